"""planar3p_gym.analysis.workspace_report / workspace_figures and scripts/workspace.py: the
regenerated table equals docs/workspace_table.*, a quick run writes every file, bad arguments write
nothing."""

from __future__ import annotations

from pathlib import Path

import pytest
from script_loader import ROOT, command

from planar3p_gym.analysis.workspace_figures import FIGURES
from planar3p_gym.analysis.workspace_report import (
    StudySettings,
    recommendation_text,
    run_study,
    tables,
)

workspace_script = command("workspace")


def _read(path: Path) -> str:
    with open(path, newline="") as fh:  # the CSV ends its lines with \r\n, as csv writes them
        return fh.read()


def test_full_study_reproduces_the_shipped_table() -> None:
    """The library regenerates docs/workspace_table.csv and .md character for character (the
    same S, usable S, dead zones and areas at 201 x 201 x 360, and the same recommendation)."""
    res = run_study(StudySettings(repeats=1))
    csv_text, md_text = tables(res)
    assert csv_text == _read(ROOT / "docs" / "workspace_table.csv")
    assert md_text == _read(ROOT / "docs" / "workspace_table.md")
    assert res["rec"]["final"] == pytest.approx(0.36)
    assert "L = 0.36 m" in recommendation_text(res["rec"])


def test_quick_run_writes_tables_and_figures(tmp_path: Path, capsys) -> None:
    out = tmp_path / "docs"
    assert workspace_script.main(["--quick", "--no-pin", "--out", str(out)]) == 0
    assert "BENCHMARK" in capsys.readouterr().out
    assert (out / "workspace_table.csv").is_file() and (out / "workspace_table.md").is_file()
    for name in FIGURES:
        assert (out / "figures" / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
    leftovers = [p.name for p in out.rglob("*") if p.name.endswith(".tmp")]
    assert leftovers == []  # atomic writes leave no temporary files
    csv_lines = _read(out / "workspace_table.csv").splitlines()
    assert csv_lines[0] == "stroke_m,S,S_usable,dead_zones,dead_zone_area_cm2,paper_range"
    assert len(csv_lines) == 1 + 21 + 10  # 0.10..0.30 m, then 0.31..0.40 m


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--repeats", "-1"], "--repeats must be >= 1"),
        (["--repeats", "0"], "--repeats must be >= 1"),
        (["--theta-plane", "nan"], "--theta-plane must be between -360 and 360 deg"),
        (["--theta-plane", "inf"], "--theta-plane must be between -360 and 360 deg"),
        (["--theta-plane", "1e9"], "--theta-plane must be between -360 and 360 deg"),
    ],
)
def test_bad_arguments_exit_2_and_write_nothing(argv, message, tmp_path: Path, capsys) -> None:
    """These raised tracebacks (some after writing into docs/) or fell back
    to defaults silently."""
    out = tmp_path / "docs"
    assert workspace_script.main([*argv, "--quick", "--no-pin", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not out.exists()


def test_out_must_be_a_directory(tmp_path: Path, capsys) -> None:
    target = tmp_path / "file.txt"
    target.write_text("keep")
    assert workspace_script.main(["--quick", "--no-pin", "--out", str(target)]) == 2
    assert "is not a directory" in capsys.readouterr().err
    assert target.read_text() == "keep"


def test_settings_validation() -> None:
    assert StudySettings.preset(quick=True) == StudySettings(61, 72, 1, quick=True)
    assert StudySettings.preset(quick=False, repeats=5).repeats == 5
    for bad in (dict(grid=1), dict(orientations=0), dict(repeats=-1), dict(ext_max=float("nan"))):
        with pytest.raises(ValueError):
            StudySettings(**bad)
