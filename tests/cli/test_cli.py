"""``planar3p``: one command line over the library; ``scripts/`` are one-line calls of it."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from planar3p_agents.cli import COMMANDS, main

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_has_a_help(name, capsys):
    with pytest.raises(SystemExit) as exc:
        main([name, "--help"])
    assert exc.value.code == 0
    assert f"usage: planar3p {name}" in capsys.readouterr().out


def test_the_usage_lists_every_command(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert all(name in out for name in COMMANDS)
    assert main([]) == 2  # no command: the usage, status 2


def test_an_unknown_command_exits_2_with_one_line(capsys):
    assert main(["trian"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown command 'trian'" in err[0]


def test_a_bad_flag_is_named_before_any_work(tmp_path, capsys):
    out = tmp_path / "bench"
    assert main(["benchmark", "--seed", "-1", "--out", str(out)]) == 2
    assert "--seed" in capsys.readouterr().err
    assert not out.exists()


def test_the_scripts_are_one_line_calls_of_the_cli():
    modules = {module for module, _ in COMMANDS.values()}
    scripts = {p.stem for p in (ROOT / "scripts").glob("*.py")}
    assert scripts == modules
    for path in (ROOT / "scripts").glob("*.py"):
        text = path.read_text()
        assert "sys.path" not in text, path
        calls = [
            n for n in ast.walk(ast.parse(text)) if isinstance(n, ast.Call)
        ]  # main([...]) inside SystemExit(...)
        assert any(getattr(c.func, "id", "") == "main" for c in calls), path


def test_python_dash_m_runs_the_cli():
    done = subprocess.run(
        [sys.executable, "-m", "planar3p_agents", "--help"],
        capture_output=True,
        text=True,
        cwd=ROOT / "tests",
        check=True,
    )
    assert "usage: planar3p <command>" in done.stdout


@pytest.mark.parametrize(
    "argv",
    [
        ["bench-kinematics", "--batch", "0"],
        ["bench-kinematics", "--batch", "-3"],
        ["bench-kinematics", "--repeats", "-1"],
    ],
)
def test_bench_kinematics_refuses_bad_sizes(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("planar3p bench-kinematics: error: " + argv[1])
