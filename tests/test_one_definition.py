"""One definition of each shared formula: a search of the installed packages' sources finds
the angle wrap, the simple-motion rates, the reward terms and the observation layout each
defined once, no inline copy of the angle wrap, and no renaming alias of the input checks; and
each task's prose is written once (its env class docstring and its task module's share no run
of words).

The search is the documented ``grep`` of each pattern below over ``planar3p_gym/`` and
``agents/``; :data:`PENDING` names the files another change still takes a copy out of."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted([*(ROOT / "planar3p_gym").rglob("*.py"), *(ROOT / "agents").rglob("*.py")])

#: Files with an inline angle wrap that another change removes (its copy is listed there).
PENDING: set[str] = set()

#: ``(formula, pattern of its definition, the one file that defines it)``.
DEFINITIONS = [
    ("angle wrap", r"^def wrap_angle\(", "planar3p_gym/machine/angles.py"),
    ("simple-motion basis", r"^def simple_motion_basis\(", "planar3p_gym/machine/kinematics.py"),
    ("reward terms", r"^def weighted_terms\(", "planar3p_gym/tasks/rewards.py"),
    ("observation layout", r"^def write_reach_values\(", "planar3p_gym/tasks/observation.py"),
]

#: Inline forms of a wrap into a turn around 0: ``(a + pi) % (2 pi) - pi``, ``pi - (pi - a) %
#: (2 pi)`` and their ``np.mod`` / ``remainder`` spellings.
INLINE_WRAP = re.compile(
    r"[+-]\s*(math|np)\.pi\s*\)\s*%|(math|np)\.pi\s*-\s*\(\s*(math|np)\.pi\s*-|"
    r"(mod|remainder)\([^,]*[+-]\s*(math|np)\.pi\s*,|(math|np)\.pi\s*-\s*(np|th)\.(mod|remainder)\("
)
#: The one torch twin of the wrap (tested against it in ``tests/machine/test_angles.py``).
TWINS = {"agents/policies/goal_features.py", "planar3p_gym/machine/angles.py"}


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


@pytest.mark.parametrize(("formula", "pattern", "home"), DEFINITIONS)
def test_each_formula_is_defined_once(formula: str, pattern: str, home: str) -> None:
    where = [
        _rel(p) for p in SOURCES for line in p.read_text().splitlines() if re.match(pattern, line)
    ]
    assert where == [home], f"{formula} defined in {where}, expected only in {home}"


def test_no_inline_angle_wrap() -> None:
    found = [
        f"{_rel(p)}:{n}"
        for p in SOURCES
        if _rel(p) not in TWINS | PENDING
        for n, line in enumerate(p.read_text().splitlines(), 1)
        if INLINE_WRAP.search(line)
    ]
    assert not found, f"inline angle wraps (use planar3p_gym.machine.angles.wrap_angle): {found}"


def test_the_pattern_finds_the_known_forms() -> None:
    for copy in (
        "d = (a + math.pi) % (2.0 * math.pi) - math.pi",
        "return math.pi - (math.pi - angle) % (2.0 * math.pi)",
        "T = np.pi - np.mod(np.pi - T, 2.0 * np.pi)",
        "d = th.remainder(d + math.pi, 2.0 * math.pi) - math.pi",
    ):
        assert INLINE_WRAP.search(copy), copy
    assert not INLINE_WRAP.search("off = np.mod(t - lo, two_pi)")  # a reduction to [0, 2 pi)


def test_no_renaming_alias_of_the_checks() -> None:
    """No function only hands its own parameters on, unchanged, to a ``checks`` function."""
    found = []
    for p in SOURCES:
        for node in ast.walk(ast.parse(p.read_text())):
            if not isinstance(node, ast.FunctionDef):
                continue
            body = [b for b in node.body if not isinstance(b, ast.Expr)]  # without a docstring
            if len(body) != 1 or not isinstance(body[0], ast.Return):
                continue
            call = body[0].value
            params = [a.arg for a in node.args.args]
            if (
                isinstance(call, ast.Call)
                and isinstance(call.func, ast.Attribute)
                and isinstance(call.func.value, ast.Name)
                and call.func.value.id == "checks"
                and [a.id for a in call.args if isinstance(a, ast.Name)] == params
                and len(call.args) == len(params)
                and not call.keywords
            ):
                found.append(f"{_rel(p)}: {node.name}")
    assert not found, f"renaming aliases of planar3p_gym.checks: {found}"


#: Words in a run that, shared by two docstrings, counts as prose written twice.
SHARED_RUN = 8


def _runs(text: str, n: int = SHARED_RUN) -> set[tuple[str, ...]]:
    """Every run of ``n`` consecutive words of ``text`` (lower case, punctuation dropped)."""
    words = re.findall(r"[a-z0-9_]+", text.lower())
    return {tuple(words[i : i + n]) for i in range(len(words) - n + 1)}


def _task_prose() -> list[tuple[str, str, str]]:
    """``(id, env class docstring, task module docstring)`` of every registered id."""
    import importlib

    from planar3p_gym.envs.registry import ENV_SPECS

    out = []
    for row in ENV_SPECS:
        module, _, name = row.entry_point.partition(":")
        cls = getattr(importlib.import_module(module), name)
        task = importlib.import_module(f"planar3p_gym.tasks.{row.task}")
        out.append((row.id, cls.__doc__ or "", task.__doc__ or ""))
    return out


PROSE = _task_prose()


@pytest.mark.parametrize(("env_id", "env_doc", "task_doc"), PROSE, ids=[p[0] for p in PROSE])
def test_each_task_s_prose_is_written_once(env_id: str, env_doc: str, task_doc: str) -> None:
    """The env class docstring (the id's page) says what the id does; its task module's
    docstring says what the module holds: no run of :data:`SHARED_RUN` words is in both."""
    shared = sorted(" ".join(run) for run in _runs(env_doc) & _runs(task_doc))
    assert not shared, f"{env_id}: the env docstring and its task module repeat {shared[:3]}"


def test_the_prose_check_finds_a_repeated_sentence() -> None:
    sentence = "the start is drawn in the working mode of the environment with margins"
    assert _runs(f"A task. {sentence}.") & _runs(f"{sentence.capitalize()}; another one.")
    assert not _runs("a b c d e f g") and len(_runs("a b c d e f g h i")) == 2
