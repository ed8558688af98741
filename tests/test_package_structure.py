"""The package's shape: its layers import only downwards, nothing of the core reaches torch,
Stable-Baselines3 or the agents, the import graph has no cycle (type-only imports included),
the wheel's package list names every folder, no module of the package, the agents or the
scripts reads another module's private attributes (an attribute ``obj._name`` on anything but
``self``/``cls`` only where ``_name`` is defined, imported included, in the same module; no
``from planar3p_gym... import _name``; other libraries' privates, such as pymunk's C handles,
are not the package's seams), and the environment has
one step and never tests its task's type."""

from __future__ import annotations

import ast
import inspect
import re
import subprocess
import sys
from pathlib import Path

import pytest
import tomllib

from planar3p_gym.envs.core import Planar3PEnv

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "planar3p_gym"
FORBIDDEN = ("torch", "stable_baselines3", "sb3_contrib", "planar3p_agents", "agents", "rl_zoo3")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(path: Path) -> set[str]:
    """Every module ``path`` imports, anywhere in the file (functions and ``TYPE_CHECKING``
    blocks included), as absolute dotted names."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = _module_name(path).rsplit(".", 0 if path.name == "__init__.py" else 1)[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                module = ".".join([*base, node.module] if node.module else base)
            else:
                module = node.module or ""
            found.add(module)
            found.update(f"{module}.{alias.name}" for alias in node.names)
    return found


CORE_MODULES = {_module_name(p): p for p in sorted(CORE.rglob("*.py"))}


@pytest.mark.parametrize("name", sorted(CORE_MODULES))
def test_core_module_imports_no_learning_code(name):
    bad = sorted(m for m in _imports(CORE_MODULES[name]) if m.split(".")[0] in FORBIDDEN)
    assert not bad, f"{name} imports {bad}"


def test_importing_the_package_loads_no_learning_code():
    code = (
        "import sys, gymnasium as gym, planar3p_gym\n"
        "for spec in planar3p_gym.ENV_SPECS:\n"
        "    env = gym.make(spec.id); env.reset(seed=0); env.step(env.action_space.sample())\n"
        f"bad = [m for m in sys.modules if m.split('.')[0] in {FORBIDDEN!r}]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT / "tests")


#: Core modules that may import matplotlib (the ``plots`` extra of the core package).
PLOTTING_MODULES = {"planar3p_gym.analysis.workspace_figures"}
#: A subprocess prelude that makes matplotlib unimportable, as on an install without the extra.
_NO_MATPLOTLIB = (
    "import sys\n"
    "class _Block:\n"
    "    def find_spec(self, name, path=None, target=None):\n"
    "        if name.split('.')[0] == 'matplotlib':\n"
    "            raise ModuleNotFoundError(f'No module named {name!r}', name=name)\n"
    "sys.meta_path.insert(0, _Block())\n"
)


@pytest.mark.parametrize("name", sorted(set(CORE_MODULES) - PLOTTING_MODULES))
def test_core_module_imports_no_matplotlib(name):
    bad = sorted(m for m in _imports(CORE_MODULES[name]) if m.split(".")[0] == "matplotlib")
    assert not bad, f"{name} imports {bad}: matplotlib is the plots extra"


def test_the_core_works_without_matplotlib_and_its_figures_name_the_extra():
    code = _NO_MATPLOTLIB + (
        "import gymnasium as gym, planar3p_gym\n"
        "from planar3p_gym.analysis import workspace, workspace_report\n"
        "for spec in planar3p_gym.ENV_SPECS:\n"
        "    env = gym.make(spec.id); env.reset(seed=0); env.step(env.action_space.sample())\n"
        "try:\n"
        "    import planar3p_gym.analysis.workspace_figures\n"
        "except ModuleNotFoundError as exc:\n"
        "    assert \"pip install 'planar3p-gym[plots]'\" in str(exc), exc\n"
        "    assert exc.name == 'matplotlib', exc.name\n"
        "else:\n"
        "    raise AssertionError('workspace_figures imported without matplotlib')\n"
        "assert not [m for m in sys.modules if m.startswith('matplotlib')]\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT / "tests")


def _graph() -> dict[str, set[str]]:
    graph = {}
    for name, path in CORE_MODULES.items():
        targets = set()
        for m in _imports(path):
            # ``from pkg import submodule`` and ``from module import name``: the longest
            # prefix that is a module of the package.
            while m and m not in CORE_MODULES:
                m = m.rpartition(".")[0]
            if m and m != name and not name.startswith(m + ".") and m != "planar3p_gym":
                targets.add(m)
        graph[name] = targets
    return graph


def test_the_import_graph_has_no_cycle():
    graph = _graph()
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                cycle = [*stack[stack.index(nxt) :], nxt]
                raise AssertionError("import cycle: " + " -> ".join(cycle))
            if nxt not in state:
                visit(nxt)
        stack.pop()
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node)


#: Which layer may import which (a layer may always import itself and the package's
#: top-level helper modules).
LAYERS = {
    "machine": set(),
    "sim": {"machine"},
    "tasks": {"machine", "sim"},
    "envs": {"machine", "sim", "tasks"},
    "analysis": {"machine"},
}


def test_layers_import_only_downwards():
    problems = []
    for name, targets in _graph().items():
        parts = name.split(".")
        if len(parts) < 3 or parts[1] not in LAYERS:
            continue
        layer = parts[1]
        for t in targets:
            t_parts = t.split(".")
            if len(t_parts) >= 2 and t_parts[1] in LAYERS and t_parts[1] != layer:
                if t_parts[1] not in LAYERS[layer]:
                    problems.append(f"{name} -> {t}")
    assert not problems, problems


def test_the_wheel_lists_every_package_folder():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    mapping = config["package-dir"]
    on_disk = set()
    for top, folder in (("planar3p_gym", "planar3p_gym"), *mapping.items()):
        for init in (ROOT / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(ROOT / folder).parts
            on_disk.add(".".join((top, *rel)))
    assert listed == on_disk


#: Names of repository tooling (studies, throughput and soak measurements, documentation media),
#: which lives in scripts/ and is not installed.
TOOLING = re.compile(
    r"stud|throughput|bench_|soak|docs_media|fidelity|detours|track_gains|track_curves"
    r"|task_baselines|goal_track_baselines"
)
#: Installed modules whose names look like tooling but are what a user imports: the
#: crossing-fidelity measure of an assembly-change policy (the evaluation layer).
NOT_TOOLING = {"planar3p_agents/evaluation/crossing_fidelity.py"}
#: The ``planar3p`` commands: what a user runs.
USER_COMMANDS = {
    "train",
    "play",
    "list",
    "sweep",
    "benchmark",
    "demo",
    "seed-report",
    "plot-learning",
    "ship",
    "workspace",
}


def _installed_files() -> set[str]:
    """The files the wheel installs, as paths in site-packages: each listed package's modules
    and its package data (pyproject's ``packages``, ``package-dir`` and ``package-data``),
    read from the tree as setuptools reads them."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    mapping = config["package-dir"]
    files: set[str] = set()
    for package in config["packages"]:
        top, *rest = package.split(".")
        folder = ROOT / mapping.get(top, top) / Path(*rest)
        files.update(f"{'/'.join(package.split('.'))}/{m.name}" for m in folder.glob("*.py"))
    for package, patterns in config["package-data"].items():
        folder = ROOT / mapping.get(package, package)
        for pattern in patterns:
            files.update(
                f"{package}/{f.relative_to(folder).as_posix()}"
                for f in folder.glob(pattern)
                if f.is_file()
            )
    return files


def test_the_installed_packages_hold_no_repository_tooling():
    installed = _installed_files()
    assert "planar3p_gym/envs/core.py" in installed and "planar3p_agents/cli.py" in installed
    tooling = sorted(f for f in installed if TOOLING.search(f) and f not in NOT_TOOLING)
    assert not tooling, tooling
    assert NOT_TOOLING <= installed
    assert not any(f.startswith(("scripts/", "tooling/", "docs/")) for f in installed)
    assert not (ROOT / "scripts" / "__init__.py").exists()  # not a package of the wheel


def test_the_command_line_lists_only_user_commands():
    from planar3p_agents.commands import COMMANDS

    assert set(COMMANDS) == USER_COMMANDS


#: Attribute names of the standard library's named tuples (public API despite the underscore).
NAMEDTUPLE_API = frozenset({"_replace", "_asdict", "_fields", "_make", "_field_defaults"})


#: The trees whose modules may not read each other's privates: the package, the agents and
#: the scripts (the tests may).
SCANNED = (CORE, ROOT / "agents", ROOT / "scripts")


def _modules() -> dict[Path, ast.Module]:
    """Every module of :data:`SCANNED`, by its path relative to its tree's folder."""
    return {
        path.relative_to(root.parent): ast.parse(path.read_text())
        for root in SCANNED
        for path in sorted(root.rglob("*.py"))
    }


def _own(node: ast.AST) -> bool:
    return isinstance(node, ast.Name) and node.id in ("self", "cls")


def _defined(tree: ast.Module) -> set[str]:
    """Private names a module defines: its functions, classes, names it binds or imports, and
    the attributes it sets on ``self``/``cls`` (or through ``object.__setattr__(self, ...)``)."""
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update(a.asname or a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            if _own(node.value):
                names.add(node.attr)
        elif isinstance(node, ast.Call) and len(node.args) >= 2:
            arg = node.args[1]
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                names.add(arg.value)  # setattr(self, "_name", ...) and object.__setattr__
    return {n for n in names if n.startswith("_")}


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__") and name not in NAMEDTUPLE_API


def private_reach_ins() -> list[str]:
    """``path:line: name`` of every read or write of another package module's private (a
    private attribute defined in another module of the package and not in this one)."""
    modules = _modules()
    defined = {path: _defined(tree) for path, tree in modules.items()}
    everywhere = set().union(*defined.values())
    found = []
    for where, tree in modules.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and _private(node.attr) and not _own(node.value):
                # A private the package defines in another module, not in this one.
                if node.attr in everywhere and node.attr not in defined[where]:
                    found.append(f"{where}:{node.lineno}: .{node.attr}")
            elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith(
                "planar3p_gym"
            ):
                found += [
                    f"{where}:{node.lineno}: import {a.name}"
                    for a in node.names
                    if _private(a.name)
                ]
    return found


def test_no_module_reads_another_module_s_private_attributes():
    assert private_reach_ins() == []


def test_the_checker_finds_a_reach_in(tmp_path, monkeypatch):
    """The check is real: reads, writes and imports of another module's privates are reported,
    across trees and for privates a module imports, an object's own privates and other
    libraries' are not."""
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "a.py").write_text(
        "class A:\n    def __init__(self):\n        self._x = self._y = 1\n"
    )
    (package / "b.py").write_text(
        "from planar3p_gym.machine.kinematics import _consts\n"
        "def f(a, body):\n    body._body = a._x\n\n\n"
        "class B:\n    def g(self, a):\n        self._z = 1\n        a._y = self._z\n"
    )
    (package / "c.py").write_text("from pymunk._chipmunk_cffi import lib as _cp\n")
    tools = tmp_path / "tools"
    tools.mkdir()
    (tools / "d.py").write_text("import pkg.c as c\n\nstep = c._cp.cpSpaceStep\n")
    monkeypatch.setattr(sys.modules[__name__], "SCANNED", (package, tools))
    assert sorted(private_reach_ins()) == [
        "pkg/b.py:1: import _consts",
        "pkg/b.py:3: ._x",
        "pkg/b.py:9: ._y",
        "tools/d.py:3: ._cp",
    ]


def _type_tests(tree: ast.AST) -> list[str]:
    """The source of every ``type(...)``, ``isinstance(...)`` and ``issubclass(...)`` call."""
    return [
        ast.unparse(node)
        for node in ast.walk(tree)
        if isinstance(node, ast.Call)
        and isinstance(node.func, ast.Name)
        and node.func.id in ("type", "isinstance", "issubclass")
    ]


@pytest.mark.parametrize("method", ["__init__", "reset", "step"])
def test_the_environment_never_tests_its_task_s_type(method):
    """No ``type(...)`` or ``isinstance(...)`` of anything of the task in the environment's
    set-up, reset and step: the task picks its kernel
    (:meth:`planar3p_gym.tasks.base.Task.kernel`)."""
    source = inspect.getsource(getattr(Planar3PEnv, method))
    tree = ast.parse("\n".join(line[4:] for line in source.splitlines()))
    tests = _type_tests(tree)
    assert not [t for t in tests if "task" in t], tests


def test_the_vector_env_never_tests_its_task_s_type():
    """The native vector env chooses its batched step by the task's compiled hooks
    (:attr:`~planar3p_gym.tasks.base.Task.compiled_family`), not by the task's class: no
    ``type(...)``/``isinstance(...)`` of anything of the task, and no task class imported."""
    tree = ast.parse((CORE / "envs" / "vector.py").read_text())
    tests = _type_tests(tree)
    assert tests and not [t for t in tests if "task" in t.lower()], tests
    imported = [
        a.name
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom)
        for a in node.names
        if a.name.endswith("Task")
    ]
    assert imported == []


def test_the_environment_has_one_step():
    """One step for every id (no second step method beside ``step``)."""
    methods = [name for name, value in vars(Planar3PEnv).items() if callable(value)]
    assert [name for name in methods if "step" in name] == ["step"]


def test_the_environment_stays_small():
    """The environment owns the Gymnasium API and nothing else: ``envs/core.py`` at most 400
    lines, ``Planar3PEnv.__init__`` at most 60 and its ``step`` at most 25 (the work is in
    the actuation component, the simulation and the task's kernel)."""
    assert len((CORE / "envs" / "core.py").read_text().splitlines()) <= 400
    assert len(inspect.getsource(Planar3PEnv.__init__).splitlines()) <= 60
    assert len(inspect.getsource(Planar3PEnv.step).splitlines()) <= 25
