"""The survey of certified slider paths at the speed bound (tooling.detours)."""

from __future__ import annotations

import csv
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from script_loader import load_script

from planar3p_agents.evaluation import reach_suites as su
from planar3p_gym import Design
from tooling.detours import (
    PairDetours,
    pair_detours,
    suite_summary,
    time_ratios,
    waypoint_fractions,
)

DESIGN = Design.fig8()
travel = st.floats(0.0, 0.3)
triple = st.tuples(travel, travel, travel)


@settings(max_examples=200, deadline=None)
@given(rs=triple, rt=triple, w=triple, f=st.floats(0.0, 1.0))
def test_a_path_through_a_waypoint_is_never_faster_than_the_bound(rs, rt, w, f):
    """The max norm's triangle inequality: ratio >= 1; a waypoint on the straight line costs
    nothing (ratio 1, to rounding)."""
    rs, rt, w = np.array(rs), np.array(rt), np.array(w)
    if np.abs(rt - rs).max() < 1e-6:
        return
    on_line = rs + f * (rt - rs)
    r = time_ratios(rs, np.stack([w, on_line]), rt)
    assert r[0] >= 1.0 - 1e-12
    assert r[1] == pytest.approx(1.0, abs=1e-12)


def test_time_ratios_by_hand():
    rs, rt = np.zeros(3), np.array([0.1, 0.05, 0.0])
    w = np.array([[0.05, 0.05, 0.0], [0.0, 0.1, 0.0], [0.1, -0.05, 0.0]])
    # the leading slider moves monotonically in both: 1; then (0.1 + 0.1) / 0.1; (0.1 + 0.1) / 0.1
    np.testing.assert_allclose(time_ratios(rs, w, rt), [1.0, 2.0, 2.0])
    with pytest.raises(ValueError, match="speed bound is 0"):
        time_ratios(rs, w, rs)


def test_waypoint_fractions():
    grid = waypoint_fractions([0.0, 0.5, 1.0])
    assert grid.shape == (27, 3)
    assert {tuple(r) for r in grid} == {
        (a, b, c) for a in (0.0, 0.5, 1.0) for b in (0.0, 0.5, 1.0) for c in (0.0, 0.5, 1.0)
    }
    for bad in ([], [0.0, math.nan], [[0.0]]):
        with pytest.raises(ValueError, match="fractions"):
            waypoint_fractions(bad)


def test_a_standard_pair_is_reached_on_the_straight_line():
    episode = su.make_suite("standard", 1, 0).episodes[0]
    row = pair_detours(DESIGN, episode, fractions=(0.0, 0.5, 1.0))
    assert row.straight == "ok" and row.best_ratio == 1.0
    assert row.end_gap < 1e-9  # the followed branch ends at the target itself
    assert row.tried == row.certified == 0  # no waypoint needed


def test_a_hard_pair_ends_on_another_solution_on_the_straight_line():
    """The ``hard`` suite's pairs defeat the slider line: followed from the start pose, the
    branch arrives at another pose of the target's travels (the same assembly mode, far from
    the target); the paths through the box between the travels end there too."""
    episode = su.make_suite("hard", 1, 0).episodes[0]
    row = pair_detours(DESIGN, episode, fractions=(0.0, 0.5, 1.0))
    assert row.straight == "end_pose"
    assert row.end_gap > 0.05
    assert row.tried > 0
    assert row.certified == 0 and row.best_ratio == math.inf
    with pytest.raises(ValueError, match="has no target pose"):
        pair_detours(DESIGN, replace(episode, target=None))


def test_suite_summary_counts():
    rows = [
        PairDetours(0, "ok", 0.0, 0, 0, 1.0),
        PairDetours(1, "end_pose", 0.3, 300, 2, 3.0),
        PairDetours(2, "end_pose", 0.2, 300, 0, math.inf),
        PairDetours(3, "branch", math.nan, 300, 1, 2.0),
    ]
    s = suite_summary(rows)
    assert (s["pairs"], s["straight"], s["other_solution"], s["reachable"]) == (4, 1, 2, 3)
    assert s["ratio_median"] == 2.0
    assert math.isnan(suite_summary(rows[2:3])["ratio_median"])


def test_the_detours_script_prints_a_row_per_suite_and_writes_a_row_per_pair(tmp_path, capsys):
    """``scripts/detours.py`` end to end on the committed suite file: one summary row per suite
    and, with --csv, one row per pair (here the first pair of each suite, on a 2-value grid)."""
    out = tmp_path / "out" / "pairs.csv"
    suites = Path(__file__).parents[2] / "docs" / "benchmark" / "strongest-baselines"
    argv = ["--suite-file", str(suites / "suites.json"), "--episodes", "1", "--fractions", "0,1"]
    argv += ["--csv", str(out)]
    assert load_script("detours").main(argv) == 0
    text = capsys.readouterr().out
    assert "| standard | 1 | 1 | 0 | 1 | 1.00 / 1.00 / 1.00 |" in text
    assert "| hard | 1 | 0 | 1 |" in text
    rows = list(csv.DictReader(out.open()))
    assert [(r["suite"], r["straight"]) for r in rows] == [("standard", "ok"), ("hard", "end_pose")]
    assert float(rows[1]["end_gap"]) > 0.05 and int(rows[1]["tried"]) > 0
