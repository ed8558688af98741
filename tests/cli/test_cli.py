"""The ``planar3p`` command line (planar3p_agents.cli, planar3p_agents.commands): every subcommand
has a help that shows its defaults; bad arguments and impossible output locations exit 2 with one
line naming the flag, before any work, writing nothing and leaving no process behind; the
repository's tools (scripts/, not installed) parse their arguments by the same rules."""

from __future__ import annotations

import importlib.util
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from script_loader import ROOT, SCRIPTS, standalone

from planar3p_agents import cli
from planar3p_agents.commands import COMMANDS, load, summary
from planar3p_gym import atomic_files

# ------------------------------------------------------------------------------- helpers

#: The repository's tools, standalone files of scripts/: the name each had as a command ->
#: its file's stem.  They are not ``planar3p`` commands (not installed).
TOOLS = {
    "bench-env": "bench_env",
    "bench-kinematics": "bench_kinematics",
    "soak-end-stops": "soak_end_stops",
    "docs-media": "docs_media",
    "detours": "detours",
    "track-gains": "track_gains",
    "track-curves": "track_curves",
    "task-baselines": "task_baselines",
    "goal-track-baselines": "goal_track_baselines",
    "fidelity": "fidelity",
    "bench-resets": "bench_resets",
}


def _run(argv: list[str]) -> int:
    """Run ``argv`` (``[name, *options]``): a tool's script, else a ``planar3p`` command."""
    if argv[0] in TOOLS:
        return standalone(TOOLS[argv[0]]).main(argv[1:])
    return cli.main(argv)


def _prog(name: str) -> str:
    """The program name in the error line of ``name``."""
    return f"python scripts/{TOOLS[name]}.py" if name in TOOLS else f"planar3p {name}"


def _can_create_in(directory: Path) -> bool:
    try:
        atomic_files.check_output_dir(directory / "probe")
    except ValueError:
        return False
    return True


@pytest.fixture
def read_only_dir(tmp_path: Path):
    """A directory this process cannot write into: a read-only one, or (as root, whom
    permissions do not stop) /proc, where no file can be made."""
    ro = tmp_path / "read-only"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        if not _can_create_in(ro):
            yield ro
        elif Path("/proc").is_dir() and not _can_create_in(Path("/proc")):
            yield Path("/proc")
        else:
            pytest.skip("no directory here that this process cannot write into")
    finally:
        ro.chmod(0o755)


def _children() -> set[int]:
    """Process ids of this process's children (Linux), empty elsewhere."""
    pids: set[int] = set()
    for task in Path(f"/proc/{os.getpid()}/task").glob("*"):
        try:
            pids.update(int(p) for p in (task / "children").read_text().split())
        except OSError:
            pass
    return pids


def _tree(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


#: The work each command would start: replaced in the tests of bad input, which must never get
#: there (module, attribute).
WORK = [
    ("tooling.throughput", "single_env_rates"),
    ("tooling.throughput", "interleave"),
    ("tooling.throughput", "startup_times"),
    ("tooling.kinematics_throughput", "reachable_poses"),
    ("tooling.physics_fidelity", "fidelity_report"),
    ("tooling.goal_track_baselines", "goal_baseline"),
    ("tooling.goal_track_baselines", "tracking_baselines"),
    ("tooling.track_curves", "SuitePlayer"),
    ("planar3p_agents.training.sweep", "run_sweep"),
    ("planar3p_agents.training.run", "plan_run"),
    ("planar3p_agents.training.run", "execute"),
    ("planar3p_agents.commands.benchmark", "prepare"),
    ("planar3p_agents.commands.demo", "parts"),
    ("planar3p_agents.evaluation.play", "play"),
    ("planar3p_gym.analysis.workspace_report", "run_study"),
    ("planar3p_gym.analysis.workspace_report", "time_study"),
    ("ray", "init"),
]


@pytest.fixture
def no_work(monkeypatch):
    import importlib

    def refuse(*args, **kwargs):
        raise AssertionError("work started despite bad input")

    for module, name in WORK:
        try:
            monkeypatch.setattr(importlib.import_module(module), name, refuse)
        except ImportError:  # an optional extra (ray) not installed: nothing to start
            pass


# ------------------------------------------------------------------------------- help


def test_every_script_is_a_thin_call_of_its_subcommand_or_a_standalone_tool() -> None:
    """One command line: a shim of scripts/ calls it, with no sys.path edits; a tool is a
    standalone script with its own parser, run only as the main module; the installed package
    edits no sys.path and names no tool as a command."""
    # (scripts/soak_physics.py is a measurement of the repository with its own argparse)
    files = sorted(p.stem for p in (ROOT / "scripts").glob("*.py"))
    assert files == sorted([*SCRIPTS, *TOOLS.values(), "soak_physics"])
    assert sorted(SCRIPTS.values()) == sorted(COMMANDS)
    assert not set(TOOLS) & set(COMMANDS)
    for name, command in SCRIPTS.items():
        text = (ROOT / "scripts" / f"{name}.py").read_text()
        assert "sys.path" not in text and "spec_from_file_location" not in text, name
        assert "from planar3p_agents.cli import main" in text, name
        assert f'main(["{command}", *sys.argv[1:]])' in text, name
        # SubprocVecEnv's workers import the main module again: it must not run the command
        assert 'if __name__ == "__main__":' in text, name
    for stem in TOOLS.values():
        text = (ROOT / "scripts" / f"{stem}.py").read_text()
        assert "sys.path" not in text, stem
        assert "return script.main(__name__, argv)" in text, stem
        assert 'if __name__ == "__main__":\n    raise SystemExit(main())' in text, stem
    for path in (ROOT / "agents").rglob("*.py"):
        assert "sys.path" not in path.read_text(), path


@pytest.mark.parametrize("name", list(TOOLS))
def test_every_tool_has_a_help_with_its_defaults(name: str, capsys) -> None:
    assert _run([name, "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: python scripts/{TOOLS[name]}.py ")
    assert (standalone(TOOLS[name]).__doc__ or "").strip().splitlines()[0] in out
    flat = " ".join(out.split())
    assert "(default: None)" not in flat and "(default: False)" not in flat
    assert not re.search(r"\(default[^()]*\)\s*\(default", flat), flat


def test_console_script_is_declared() -> None:
    text = (ROOT / "pyproject.toml").read_text()
    assert re.search(r'^planar3p = "planar3p_agents\.cli:main"$', text, re.M)
    assert '"planar3p_agents.commands",' in text  # installed with the package


def test_top_level_help_lists_every_command(capsys) -> None:
    assert cli.main(["--help"]) == 0
    out = capsys.readouterr().out
    for name in COMMANDS:
        assert f"\n  {name} " in out
    assert cli.main([]) == 2  # no command: the help, on stderr
    assert "commands:" in capsys.readouterr().err


def test_top_level_help_gives_each_summary_whole(capsys) -> None:
    """Each command's summary is its docstring's first paragraph, a whole sentence, shown
    whole (not cut at the docstring's first line break), and names no internal issue."""
    assert cli.main(["--help"]) == 0
    flat = " ".join(capsys.readouterr().out.split())
    for name in COMMANDS:
        text = summary(load(name))
        assert text.endswith((".", ".)")), f"{name}: {text!r}"
        assert f"{name} {text}" in flat, name
        assert not re.search(r"\bissues? \d", load(name).__doc__ or ""), name


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_subcommand_has_a_help_with_its_defaults(name: str, capsys) -> None:
    """Item 9: each --help works, says what the command does and shows the defaults, never
    "(default: None)" (and never a default twice)."""
    assert cli.main([name, "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: planar3p {name} ")
    assert (load(name).__doc__ or "").strip().splitlines()[0] in out
    flat = " ".join(out.split())
    assert "(default: None)" not in flat and "(default: False)" not in flat
    assert "(default: )" not in flat and "(default: [])" not in flat
    assert not re.search(r"\(default[^()]*\)\s*\(default", flat), flat


def test_train_help_says_what_the_code_does(capsys) -> None:
    """Item 9: the help named PPO, SAC or TD3 but accepted tqc, and hid --env's default and
    what --vec-env auto picks."""
    from planar3p_agents.training.config import ALGORITHMS

    assert cli.main(["train", "--help"]) == 0
    flat = " ".join(capsys.readouterr().out.split())
    assert all(a.upper() in flat and a in flat for a in ALGORITHMS)
    assert "--env ENV registered environment id (default: Planar3P-v0)" in flat
    assert "auto = native where the id has a native vector env, else SubprocVecEnv" in flat


def test_benchmark_help_states_each_default_once(capsys) -> None:
    """Item 9: it printed "(default 100, 20 with --quick) (default: None)"."""
    assert cli.main(["benchmark", "--help"]) == 0
    flat = " ".join(capsys.readouterr().out.split())
    assert "episodes per suite (default: 100, 20 with --quick)" in flat
    assert "bootstrap resamples (default: 2000, 500 with --quick)" in flat


# ----------------------------------------------------------------------- bad input, exit 2

#: Each reported defect: (argv, the flag the one line must name).  ``{ro}``
#: is a directory that cannot be written, ``{file}`` an existing file, ``{tmp}`` a fresh
#: directory.
SWEEP = ["sweep", "--algo", "ppo", "--seeds", "0"]
DEFECTS = [
    (["bench-env", "--quick", "--json", "{ro}/bench.json"], "--json"),
    (["bench-env", "--quick", "--json", "{file}/bench.json"], "--json"),
    (["fidelity", "--pairs", "1", "--episodes", "1", "--json", "{ro}/f.json"], "--json"),
    (["fidelity", "--pairs", "1", "--episodes", "1", "--json", "{file}/f.json"], "--json"),
    (["goal-track-baselines", "--episodes", "1", "--json", "{ro}/g.json"], "--json"),
    (["goal-track-baselines", "--episodes", "1", "--json", "{file}/g.json"], "--json"),
    ([*SWEEP, "--out", "{ro}/sweep"], "--out"),
    ([*SWEEP, "--out", "{file}/sweep"], "--out"),
    ([*SWEEP, "--out", "{file}"], "--out"),
    (["workspace", "--quick", "--no-pin", "--out", "{ro}/docs"], "--out"),
    (["workspace", "--quick", "--no-pin", "--out", "{file}/docs"], "--out"),
    (["train", "--algo", "ppo", "--timesteps", "64", "--run-dir", "{ro}/run"], "--run-dir"),
    (["train", "--algo", "ppo", "--timesteps", "64", "--run-dir", "{file}/run"], "--run-dir"),
    (["train", "--algo", "ppo", "--timesteps", "64", "--run-dir", "{file}"], "--run-dir"),
    (["demo", "--out", "{ro}/demo"], "--out"),
    (["demo", "--out", "{file}/demo"], "--out"),
    (["demo", "--out", "{file}"], "--out"),
    (["bench-kinematics", "--batch", "0"], "--batch"),
    (["bench-kinematics", "--batch", "-3"], "--batch"),
    (["bench-kinematics", "--repeats", "-1"], "--repeats"),
    (["demo", "--seed", "-1", "--out", "{tmp}/demo"], "--seed"),
    ([*SWEEP, "--num-samples", "-1", "--out", "{tmp}/s"], "--num-samples"),
    (["benchmark", "--seed", "-1", "--out", "{tmp}/bench"], "--seed"),
    # the same rules on the other commands and flags
    (["benchmark", "--episodes", "0", "--out", "{tmp}/bench"], "--episodes"),
    (["benchmark", "--out", "{file}/bench"], "--out"),
    (["benchmark", "--hold-force-fraction", "nan"], "--hold-force-fraction"),
    (["bench-env", "--sizes", "0"], "--sizes"),
    (["bench-env", "--ids", "Planar3P-v9"], "--ids"),
    (["bench-env", "--sections", "blocks"], "--sections"),
    (["soak-end-stops", "--ids", "Planar3P-v9"], "--ids"),
    (["soak-end-stops", "--steps-per-id", "0"], "--steps-per-id"),
    (["seed-report", "{file}", "--out", "{ro}/seeds.md"], "--out"),
    (["seed-report", "{file}", "--seed", "-1"], "--seed"),
    (["plot-learning", "{tmp}", "--out", "{ro}/curves.png"], "--out"),
    (["plot-learning", "{tmp}", "--out", "{tmp}"], "--out"),
    (["track-curves", "{tmp}", "--out", "{file}/curves.png"], "--out"),
    (["track-curves", "{tmp}", "--episodes", "0"], "--episodes"),
    (["detours", "--episodes", "0"], "--episodes"),
    (["detours", "--fractions", "0,a"], "--fractions"),
    (["detours", "--fractions", "0,nan"], "--fractions"),
    (["detours", "--suites", "standard,goal"], "--suites"),
    (["detours", "--suite-file", "{file}"], "--suite-file"),
    (["detours", "--csv", "{ro}/pairs.csv"], "--csv"),
    (["track-gains", "--gains", "6,0"], "--gains"),
    (["track-gains", "--seed", "-2"], "--seed"),
    (["task-baselines", "--episodes", "0"], "--episodes"),
    (["task-baselines", "--gravity", "-1"], "--gravity"),
    (["ship", "{tmp}", "--name", "x", "--out", "{file}"], "--out"),
    ([*SWEEP, "0", "--out", "{tmp}/s"], "--seeds"),
    ([*SWEEP, "--num-cpus", "0", "--out", "{tmp}/s"], "--num-cpus"),
    (["train", "--algo", "ppo", "--seed", "-1", "--run-dir", "{tmp}/run"], "--seed"),
    (["fidelity", "--suites", "standard,easy"], "--suites"),
    (["workspace", "--theta-plane", "inf", "--out", "{tmp}/docs"], "--theta-plane"),
    # settings accepted until they were found to fail
    (["docs-media", "--out", "{file}/media"], "--out"),
    (["fidelity", "--episodes", "0"], "--episodes"),
    (["bench-resets", "--seeds", "1", "--json", "{file}/x.json"], "--json"),
    (["play", "zero", "--episodes", "0"], "--episodes"),
    (["play", "zero", "--seed", "-1"], "--seed"),
    (["play", "zero", "--frame-every", "0"], "--frame-every"),
    (["play", "zero", "--env", "Planar3P-v9"], "--env"),
    (["play", "zero", "--env-kwargs", "no_equals_sign"], "--env-kwargs"),
    (["play", "zero", "--gif", "{file}/x.gif"], "--gif"),
    (["play", "zero", "--gif", "{ro}/x.gif"], "--gif"),
    (["play", "zero", "--gif", "{tmp}/x.gif", "--render", "human"], "--gif"),
    (["play", "zero", "--json", "{file}/x.json"], "--json"),
    (["play", "zero", "--render", "window"], "argument --render"),
    (["list", "models"], "argument what"),
]  # fmt: skip


@pytest.mark.parametrize(("argv", "flag"), DEFECTS, ids=[" ".join(a) for a, _ in DEFECTS])
def test_bad_input_exits_2_naming_the_flag_before_any_work(
    argv: list[str], flag: str, tmp_path: Path, read_only_dir: Path, capsys, no_work
) -> None:
    work = tmp_path / "work"
    work.mkdir()
    a_file = work / "a_file.csv"
    a_file.write_text("keep")
    argv = [a.format(ro=read_only_dir, file=a_file, tmp=work) for a in argv]
    before, children = _tree(tmp_path), _children()
    assert _run(argv) == 2
    captured = capsys.readouterr()
    err = captured.err
    assert err.count("\n") == 1, err  # one line
    assert err.startswith(f"{_prog(argv[0])}: error: {flag}"), err
    assert captured.out == ""
    assert _tree(tmp_path) == before and a_file.read_text() == "keep"  # nothing written
    assert _children() <= children  # no process left behind


def test_workspace_figures_without_matplotlib_exit_2_naming_the_extra(
    tmp_path: Path, monkeypatch, capsys, no_work
) -> None:
    """Without the plots extra the figures are refused before any work, in one line that
    names the flag that leaves them out and the extra that installs matplotlib."""
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name.split(".")[0] == "matplotlib" else real(name, *a),
    )
    out = tmp_path / "docs"
    assert cli.main(["workspace", "--quick", "--no-pin", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith("planar3p workspace: error: --no-figures: "), err
    assert "pip install 'planar3p-gym[plots]'" in err
    assert not out.exists()


def test_sweep_refuses_bad_samples_without_starting_ray(tmp_path: Path, capsys, no_work) -> None:
    """`sweep --num-samples -1` started Ray and trained."""
    ray = pytest.importorskip("ray")
    argv = ["sweep", "--algo", "ppo", "--seeds", "0", "--num-samples", "-1"]
    assert cli.main([*argv, "--out", str(tmp_path / "s")]) == 2
    assert "--num-samples must be between 1 and 10000, got -1" in capsys.readouterr().err
    assert not ray.is_initialized() and not (tmp_path / "s").exists()


def test_sweep_without_its_extra_names_the_extra(
    tmp_path: Path, monkeypatch, capsys, no_work
) -> None:
    """Without Ray or Optuna (the ``sweep`` extra) the sweep ended in a ModuleNotFoundError
    traceback; now one line naming the extra, exit 2, nothing written."""
    import sys

    for module in ("ray", "optuna"):
        monkeypatch.setitem(sys.modules, module, None)  # as if not installed
        assert cli.main([*SWEEP, "--out", str(tmp_path / "s")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1, err
        assert err.startswith(f"planar3p sweep: error: {module} not installed"), err
        assert "'sweep' extra (pip install 'planar3p-gym[sweep]')" in err
        monkeypatch.delitem(sys.modules, module)
    assert not (tmp_path / "s").exists()


def test_a_json_path_under_a_file_is_named_as_such(tmp_path: Path, capsys) -> None:
    """`bench-resets --json <file>/x.json` said "directory <file> does not exist"."""
    a_file = tmp_path / "a_file"
    a_file.write_text("keep")
    assert _run(["bench-resets", "--seeds", "1", "--json", f"{a_file}/x.json"]) == 2
    err = capsys.readouterr().err
    assert f"is under {a_file}, which is not a directory" in err, err
    assert "does not exist" not in err


def test_detours_finds_its_default_suite_file_from_any_directory(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    """The default --suite-file was relative to the working directory: from anywhere but the
    repository's root the command refused its own default."""
    monkeypatch.chdir(tmp_path)
    assert _run(["detours", "--episodes", "1", "--suites", "standard"]) == 0
    assert "| standard | 1 |" in capsys.readouterr().out


def test_sweep_stops_ray_on_sigterm(tmp_path: Path, monkeypatch, capsys) -> None:
    """A SIGTERM during the sweep raises KeyboardInterrupt, so the sweep's cleanup (which shuts
    down the Ray it started) runs; the command shuts Ray down too and exits 130."""
    ray = pytest.importorskip("ray")
    from planar3p_agents.training import sweep

    events: list[str] = []

    def fake_run_sweep(*args, **kwargs):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(30)  # interrupted at once
            events.append("not interrupted")
        finally:
            events.append("cleanup")

    monkeypatch.setattr(sweep, "run_sweep", fake_run_sweep)
    monkeypatch.setattr(ray, "shutdown", lambda: events.append("ray.shutdown"))
    previous = signal.getsignal(signal.SIGTERM)
    argv = ["sweep", "--algo", "ppo", "--seeds", "0", "--timesteps", "64"]
    argv += ["--params", "n_steps=64", "batch_size=64", "n_epochs=1"]
    t0 = time.perf_counter()
    assert cli.main([*argv, "--out", str(tmp_path / "s")]) == 130
    assert time.perf_counter() - t0 < 25
    assert events == ["cleanup", "ray.shutdown"]
    assert "interrupted" in capsys.readouterr().err
    assert signal.getsignal(signal.SIGTERM) == previous  # restored


def test_track_curves_names_a_config_that_is_not_json(tmp_path: Path, capsys, no_work) -> None:
    """It said only "Expecting value: line 1 column 1"."""
    run = tmp_path / "T-track-s1"
    run.mkdir()
    (run / "config.json").write_text("seed: 1\n")
    out = tmp_path / "curves.png"
    assert _run(["track-curves", str(run), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"{run / 'config.json'} is not JSON (Expecting value: line 1 column 1" in err
    assert not out.exists()


def test_benchmark_seed_is_named(tmp_path: Path, capsys) -> None:
    """`benchmark --seed -1` exited 2 without naming the flag."""
    assert cli.main(["benchmark", "--seed", "-1", "--out", str(tmp_path / "b")]) == 2
    assert capsys.readouterr().err == "planar3p benchmark: error: --seed must be >= 0, got -1\n"


def test_unknown_command_and_flags_are_one_line(capsys) -> None:
    assert cli.main(["bench-kinematics"]) == 2  # a tool of the repository, not a command
    err = capsys.readouterr().err
    assert (
        err.startswith("planar3p: error: unknown command 'bench-kinematics'")
        and err.count("\n") == 1
    )
    assert _run(["bench-kinematics", "--batches", "3"]) == 2  # no abbreviations either
    err = capsys.readouterr().err
    assert err.startswith(
        "python scripts/bench_kinematics.py: error: unrecognized arguments: --batches"
    )
    assert _run(["bench-kinematics", "--batch", "x"]) == 2
    assert "argument --batch: invalid int value: 'x'" in capsys.readouterr().err
    assert cli.main(["benchmark", "--episode", "3"]) == 2
    assert "unrecognized arguments: --episode" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("command", "expected"),
    [
        (
            [sys.executable, "-m", "planar3p_agents", "benchmark", "--seed", "-1"],
            "planar3p benchmark: error: --seed must be >= 0, got -1\n",
        ),
        (
            [sys.executable, str(ROOT / "scripts" / "bench_kinematics.py"), "--batch", "-3"],
            "python scripts/bench_kinematics.py: error: --batch must be between 1 and 1000000,"
            " got -3\n",
        ),
    ],
    ids=["python -m planar3p_agents", "scripts/bench_kinematics.py"],
)
def test_entry_points_exit_2_in_a_process(command: list[str], expected: str, tmp_path) -> None:
    # from another directory: a tool finds its helpers beside it, not in the working directory
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr == expected
    assert done.stdout == ""


# ---------------------------------------------------------------- output-location checks


def test_output_location_checks(tmp_path: Path, read_only_dir: Path) -> None:
    """planar3p_gym.atomic_files.check_output_dir / check_output_file: what can be written,
    with the reason when not; nothing is created."""
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    ok_dirs = [tmp_path, tmp_path / "new", tmp_path / "new" / "deeper"]
    for path in ok_dirs:
        assert atomic_files.check_output_dir(path) == path
    for path, reason in (
        (a_file, "exists and is not a directory"),
        (a_file / "sub", "which is not a directory"),
        (a_file / "sub" / "deeper", "which is not a directory"),
        (read_only_dir / "out", "cannot create a file in"),
    ):
        with pytest.raises(ValueError, match=reason):
            atomic_files.check_output_dir(path)
    assert atomic_files.check_output_file(a_file) == a_file  # replaced atomically
    assert atomic_files.check_output_file(tmp_path / "new.json") == tmp_path / "new.json"
    assert atomic_files.check_output_file(tmp_path / "new" / "x.png", parents=True)
    for path, reason in (
        (tmp_path, "is a directory"),
        (tmp_path / "new" / "x.json", "does not exist"),
        (a_file / "x.json", "which is not a directory"),
        (read_only_dir / "x.json", "cannot create a file in"),
    ):
        with pytest.raises(ValueError, match=reason):
            atomic_files.check_output_file(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["a_file", "read-only"])


def test_numeric_checks_name_the_flag() -> None:
    from planar3p_agents.commands import checks
    from planar3p_agents.commands.parser import UsageError

    checks.at_least("--n", 0, 0)
    checks.in_range("--x", 0.5, 0, 1, low_open=True)
    for call, message in (
        (lambda: checks.at_least("--seed", -1, 0), "--seed must be >= 0, got -1"),
        (lambda: checks.at_least("--d", float("nan"), 0), "--d must be >= 0, got nan"),
        (lambda: checks.in_range("--k", 5, 1, 3), "--k must be between 1 and 3, got 5"),
        (lambda: checks.in_range("--g", -1.5, 0, 9, high_open=True), "--g must be >= 0 and < 9"),
        (lambda: checks.in_range("--t", float("inf"), 0, 9), "--t must be between 0 and 9"),
        (lambda: checks.split_list("--ids", " , "), "--ids is empty"),
    ):
        with pytest.raises(UsageError) as exc:
            call()
        assert str(exc.value).startswith(message)
