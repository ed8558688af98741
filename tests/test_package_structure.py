"""The package's shape: its layers import only downwards, nothing of the core reaches torch,
Stable-Baselines3 or the agents, the import graph has no cycle (type-only imports included),
and the wheel's package list names every folder."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest
import tomllib

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
