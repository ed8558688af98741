"""Every shell command of the documentation's pages runs, at its smallest budget.

The pages are the README, the changelog, the hand-written site pages and the generated model
cards (the study notes under ``docs/_notes`` record past runs, some on retired ids, and are
only checked for their options by ``tests/test_docs.py``). Running them all takes many minutes
(about 70 processes, each loading the stack), so the whole set runs with
``PLANAR3P_DOC_COMMANDS=1`` in the environment; by default only the pages of
:data:`ALWAYS` run (the rl-zoo3 commands among them). Each command runs as written, in a
scratch directory that links the repository's folders, with:

* its budget cut to the smallest (:data:`BUDGETS`: one episode, 64 training steps, one seed,
  ...) and, where a command has a budget knob the page does not set, that knob too
  (:data:`EXTRA`);
* what it writes moved into the scratch directory (an output under a repository folder, such
  as ``--out docs/benchmark``, goes to ``out/docs/benchmark`` there), so the repository is
  never changed;
* ``--resume`` run after the same command without it (the run it continues).

A command that cannot run in a test (it installs packages, starts servers or a cluster, or is
the test suite itself) is listed in :data:`NOT_RUN` with the reason; any other must exit 0.
"""

from __future__ import annotations

import glob
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from test_docs import PAGES, ROOT, SHELL_LANGS, _commands, _rel, fences, model_cards

#: Pages whose commands run in every test run (the others with ``PLANAR3P_DOC_COMMANDS=1``).
ALWAYS = ("docs/pretrained.md",)
#: Run every page's commands.
ALL = os.environ.get("PLANAR3P_DOC_COMMANDS") == "1"
#: Off-policy algorithms: their smallest run must pass ``learning_starts``, and hindsight
#: relabelling samples only once every environment has stored a whole episode (the goal ids:
#: 100 steps; up to 8 environments).
OFF_POLICY_SMALLEST = (
    ["--timesteps", "1100"],
    ["learning_starts=1000", "batch_size=32", "buffer_size=2000"],
)
#: Commands that cannot run in a test, by their first words, with the reason.
NOT_RUN = {
    ("make", "test"): "the test suite itself",
    ("make", "demo"): "creates .venv; its recipe `planar3p demo` runs here as `planar3p demo`",
    ("pip",): "installs packages",
    ("tensorboard",): "starts a server",
    ("ray", "start"): "starts a Ray cluster node",
}
#: A command that names a Ray cluster (``--address``) cannot run without one.
NEEDS_CLUSTER = "--address"
#: The smallest budget of each budget option (per program where they differ).
BUDGETS = {
    "--episodes": "1",
    "--eval-episodes": "1",
    "--final-eval-episodes": "1",
    "--timesteps": "64",  # PPO; off-policy runs: OFF_POLICY_SMALLEST
    "--num-samples": "1",
    "--pairs": "2",
    "--kickstart-steps": "64",
    "--kickstart-epochs": "1",
}
#: Budget options a program has that a page may not set: added, at their smallest.
EXTRA = {
    # an evaluation in the run (evaluations.npz: plot-learning reads it), of one episode
    "train": [
        "--final-eval-episodes",
        "1",
        "--eval-episodes",
        "1",
        "--eval-freq",
        "32",
        "--no-progress-bar",
    ],
    "benchmark": ["--episodes", "1", "--bootstrap", "20", "--no-progress"],
    "bench-env": [
        "--rounds",
        "1",
        "--duration",
        "0.05",
        "--resets",
        "2",
        "--steps",
        "10",
        "--ppo-steps",
        "64",
        "--ppo-rounds",
        "1",
    ],
    "bench-kinematics": ["--batch", "100", "--repeats", "1", "--no-pin"],
    "workspace": ["--quick", "--repeats", "1", "--no-pin", "--out", "out/docs"],
    "fidelity": ["--pairs", "2", "--episodes", "1"],
    "sweep": ["--num-cpus", "1", "--final-eval-episodes", "1", "--eval-episodes", "1"],
    "goal-track-baselines": ["--episodes", "1"],
    "task-baselines": ["--episodes", "1"],
    "track-gains": ["--episodes", "1"],
    "rl_zoo3.train": ["-n", "64", "--eval-freq", "-1"],
}
#: Options whose value the command writes (``-f``: rl_zoo3.train's log folder only; the other
#: rl-zoo3 scripts read it).
OUTPUTS = {"--out", "-o", "--run-dir", "--output", "--json", "--csv"}
#: Files a page's commands read that the page describes in words (a sweep's grid and space).
FIXTURES = {
    "grid.yml": "one:\n  params: {n_epochs: 1}\n",
    "space.yml": "learning_rate: {loguniform: [1.0e-5, 1.0e-3]}\n",
}
REPO_ENTRIES = ("agents", "docs", "scripts", "planar3p_gym", "tests", "Makefile", "pyproject.toml")


def program(words: list[str]) -> str:
    """The command's program: ``planar3p NAME`` and the script file of NAME give ``NAME``,
    ``python -m rl_zoo3.train`` gives ``rl_zoo3.train``."""
    if words[0] == "planar3p" and len(words) > 1:
        return words[1]
    if words[0] in ("python", "python3") and len(words) > 1:
        if words[1].startswith("scripts/"):
            name = Path(words[1]).stem
            return {"ship_policy": "ship", "docs_media": "docs-media"}.get(
                name, name.replace("_", "-")
            )
        if words[1] == "-m" and len(words) > 2:
            return words[2]
        if words[1] == "-c" and "rl_zoo3.record_video" in words[2]:
            return "rl_zoo3.record_video"
    return words[0]


def not_run(words: list[str]) -> str | None:
    """Why ``words`` is not run, or ``None``."""
    for prefix, reason in NOT_RUN.items():
        if tuple(words[: len(prefix)]) == prefix:
            return reason
    if NEEDS_CLUSTER in words:
        return "needs a Ray cluster"
    return None


def _moved(word: str) -> str:
    """An output path inside the scratch directory (``out/`` before repository folders)."""
    first = Path(word).parts[0] if word and not word.startswith("/") else ""
    if word.startswith("/"):
        return "out" + word
    return f"out/{word}" if first in REPO_ENTRIES else word


def smallest(words: list[str]) -> list[str]:
    """``words`` at the smallest budget, its outputs in the scratch directory."""
    prog = program(words)
    out: list[str] = []
    it = iter(range(len(words)))
    for i in it:
        word = words[i]
        value = words[i + 1] if i + 1 < len(words) else None
        flag = word.split("=", 1)[0]
        if flag == "-n" and prog.startswith("rl_zoo3") and value is not None:
            out += [word, "64" if prog == "rl_zoo3.train" else "20"]
            next(it)
        elif flag == "--seeds" and value is not None:
            # the sweep's seed list, bench-resets' number of resets: the first / 5
            out += [word, "5" if prog == "bench-resets" else value]
            next(it)
            while i + 2 < len(words) and not words[i + 2].startswith("-"):
                i += 1
                next(it)
        elif flag in BUDGETS and value is not None and "=" not in word:
            out += [word, BUDGETS[flag]]
            next(it)
        elif (
            (flag in OUTPUTS or (flag == "-f" and prog == "rl_zoo3.train"))
            and value is not None
            and "=" not in word
        ):
            out += [word, _moved(value)]
            next(it)
        else:
            out.append(word)
    if prog == "benchmark" and "--out" not in out:
        out += ["--out", "out/results/benchmark"]
    if prog in ("train", "sweep"):
        out = _smallest_run(out)
    return out + EXTRA.get(prog, [])


def _smallest_run(argv: list[str]) -> list[str]:
    """A training or sweep command's smallest run: 64 steps (PPO), or past ``learning_starts``
    with a small buffer (off-policy; the values join the command's own ``--params``)."""
    algo = argv[argv.index("--algo") + 1] if "--algo" in argv else "ppo"
    if "--timesteps" not in argv:
        argv = [*argv, "--timesteps", "64"]
    if algo == "ppo":
        return argv
    steps, params = OFF_POLICY_SMALLEST
    argv[argv.index("--timesteps") + 1] = steps[1]
    if "--params" in argv:
        at = argv.index("--params") + 1
        while at < len(argv) and not argv[at].startswith("--"):
            at += 1
        return argv[:at] + params + argv[at:]
    return [*argv, "--params", *params]


def shell_commands() -> list[tuple[str, list[list[str]]]]:
    """``(where, commands)`` of every shell block of the pages (a block's commands run in
    order, in one scratch directory: a later one may read what an earlier one wrote)."""
    blocks = []
    pages = [p for p in PAGES if "_notes" not in p.parts]
    for path in [*pages, *model_cards()]:
        for lang, code, line in fences(path):
            if lang in SHELL_LANGS:
                cmds = _commands(code)
                if cmds:
                    blocks.append(
                        (f"{_rel(path) if path.is_relative_to(ROOT) else path}:{line}", cmds)
                    )
    return blocks


BLOCKS = shell_commands()


def _argv(words: list[str]) -> list[str]:
    if words[0] in ("python", "python3"):
        return [sys.executable, *words[1:]]
    if words[0] == "planar3p":
        return [sys.executable, "-m", "planar3p_agents", *words[1:]]
    return words


def _scratch(tmp: Path) -> Path:
    for name in REPO_ENTRIES:
        (tmp / name).symlink_to(ROOT / name)
    for name, text in FIXTURES.items():
        (tmp / name).write_text(text)
    (tmp / "out").mkdir()
    return tmp


def _run(words: list[str], cwd: Path) -> subprocess.CompletedProcess:
    expanded = []
    for w in words:  # the shell's globs (runs/*), in the scratch directory
        hits = sorted(glob.glob(w, root_dir=cwd)) if any(c in w for c in "*?") else []
        expanded += hits or [w]
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "MPLBACKEND": "Agg", "OMP_NUM_THREADS": "1"}
    return subprocess.run(
        _argv(expanded), cwd=cwd, capture_output=True, text=True, env=env, timeout=900
    )


@pytest.mark.parametrize(("where", "commands"), BLOCKS, ids=[b[0] for b in BLOCKS])
def test_documented_commands_run(where, commands, tmp_path):
    if not ALL and not where.startswith(ALWAYS):
        pytest.skip("set PLANAR3P_DOC_COMMANDS=1 to run every page's commands (many minutes)")
    cwd = _scratch(tmp_path)
    ran = 0
    for words in commands:
        if not_run(words):
            continue
        argv = smallest(words)
        if "--resume" in argv:  # the run it continues, with a checkpoint, then a longer total
            first = _run([w for w in argv if w != "--resume"] + ["--checkpoint-freq", "32"], cwd)
            assert first.returncode == 0, f"{where}: {' '.join(argv)}\n{first.stderr[-2000:]}"
            run_dir = cwd / argv[argv.index("--run-dir") + 1]
            done = json.loads((run_dir / "metrics.json").read_text())["timesteps"]
            argv[argv.index("--timesteps") + 1] = str(done + 64)
        r = _run(argv, cwd)
        assert r.returncode == 0, (
            f"{where}: {' '.join(argv)}\n{r.stdout[-1500:]}\n{r.stderr[-2500:]}"
        )
        ran += 1
    if ran == 0:
        pytest.skip("; ".join(filter(None, (not_run(w) for w in commands))))


def test_every_command_not_run_says_why():
    """Only the listed commands are left out, and the list has no stale entry."""
    used = {p for _, cmds in BLOCKS for w in cmds for p in NOT_RUN if tuple(w[: len(p)]) == p}
    assert used == set(NOT_RUN), f"entries no page uses: {set(NOT_RUN) - used}"


def test_model_cards_commands_are_commands():
    """A model card's training command as recorded (``planar3p train ...``) is shown as it
    runs: it read ``python planar3p train``, which Python cannot open."""
    bad = [w for where, cmds in BLOCKS for w in cmds if w[:2] == ["python", "planar3p"]]
    assert not bad, bad


def test_budgets_are_cut_and_outputs_moved():
    argv = smallest(
        "python scripts/benchmark.py --out docs/benchmark --force --episodes 100".split()
    )
    assert argv[argv.index("--out") + 1] == "out/docs/benchmark"
    assert argv[argv.index("--episodes") + 1] == "1"
    argv = smallest("python scripts/sweep.py --algo ppo --seeds 0 1 2 --timesteps 1e6".split())
    assert argv[argv.index("--seeds") + 1 : argv.index("--seeds") + 3] == ["0", "--timesteps"]
    assert argv[argv.index("--timesteps") + 1] == "64"
    argv = smallest("planar3p train --algo sac --params gamma=0.9 --seed 1".split())
    assert argv[argv.index("--timesteps") + 1] == "1100"
    assert argv[argv.index("--params") + 1 : argv.index("--params") + 3] == [
        "gamma=0.9",
        "learning_starts=1000",
    ]
    argv = smallest("python -m rl_zoo3.enjoy --algo ppo -f agents/zoo/pretrained/x -n 2000".split())
    assert argv[argv.index("-f") + 1] == "agents/zoo/pretrained/x"  # read, not moved
    assert argv[argv.index("-n") + 1] == "20"
