"""Statistics of the benchmark (agents/evaluation/intervals.py): IQM, bootstrap and Wilson
intervals, per-suite summaries.  Expected values are worked out by hand in the comments."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planar3p_agents.evaluation import episodes as ep
from planar3p_agents.evaluation import intervals as st


def test_iqm_hand_checked():
    assert st.iqm([1, 2, 3, 4, 5, 6, 7, 8]) == pytest.approx(4.5)  # mean of 3, 4, 5, 6
    assert st.iqm([4, 1, 3, 2]) == pytest.approx(2.5)  # mean of 2, 3
    assert st.iqm([0, 0, 0, 0, 100]) == pytest.approx(0.0)  # 100 trimmed
    assert st.iqm([7.0]) == pytest.approx(7.0)
    assert math.isnan(st.iqm([]))
    np.testing.assert_allclose(st.iqm(np.array([[1, 2, 3, 4], [10, 20, 30, 40]])), [2.5, 25])


def test_bootstrap_hand_checked():
    assert st.bootstrap_ci([3.0] * 10) == (3.0, 3.0)
    x = np.array([0.0, 1.0] * 50)  # mean 0.5, standard error 0.05
    lo, hi = st.bootstrap_ci(x, n_resamples=4000, seed=1)
    assert 0.38 <= lo <= 0.42 and 0.58 <= hi <= 0.62
    assert st.bootstrap_ci(x, seed=1) == st.bootstrap_ci(x, seed=1)
    lo, hi = st.bootstrap_ci(np.arange(100.0), st.iqm, seed=0)
    assert lo < 49.5 < hi
    assert all(math.isnan(v) for v in st.bootstrap_ci([]))


def _result(success, ret, cause="success", steps=50, **kw):
    base = dict(
        policy="p",
        suite="standard",
        index=0,
        success=success,
        termination_reason=cause if cause in ("success", "singularity_crossing") else "time_limit",
        cause=cause,
        steps=steps,
        duration=steps * 0.02,
        time_to_success=steps * 0.02 if success else math.nan,
        episode_return=ret,
        final_position_error=0.001,
        final_orientation_error=0.01,
        min_parallel_margin=0.05,
        min_serial_margin=0.3,
        saturation_fraction=0.0,
        energy=1.0,
        end_stop_fraction=0.0,
        max_closure_error=0.0,
        working_mode_changed=False,
        path_crosses=False,
        path_clear=True,
        sequential_path_clear=True,
        slider_line_reaches=True,
    )
    base.update(kw)
    return ep.EpisodeResult(**base)


def test_summarize_hand_checked():
    res = [
        _result(True, 10.0, steps=50, final_position_error=0.001, saturation_fraction=0.5),
        _result(True, 20.0, steps=100, final_position_error=0.003),
        _result(False, -5.0, cause="singularity_crossing", steps=10, min_parallel_margin=0.001),
        _result(False, -1.0, cause="not_converged", steps=250, final_position_error=0.01),
    ]
    s = st.summarize(res, n_resamples=500)
    assert s["episodes"] == 4 and s["successes"] == 2 and s["success_rate"] == 0.5
    assert s["return_iqm"] == pytest.approx(4.5)  # mean of -1 and 10
    assert s["median_position_error_mm"] == pytest.approx(2.0)
    assert s["median_time_to_success"] == pytest.approx(1.5)  # 1.0 s and 2.0 s
    assert s["worst_min_parallel_margin"] == pytest.approx(0.001)
    assert s["singularity_crossings"] == 1 and s["time_limits"] == 1
    assert s["saturation_fraction"] == pytest.approx(25 / 410)
    assert s["causes"]["not_converged"] == 1
    assert 0.0 <= s["success_ci"][0] <= 0.5 <= s["success_ci"][1] <= 1.0


def test_success_interval_hand_checked():
    """Wilson score interval, z = 1.959964: at 100/100 the lower end is n / (n + z^2) =
    100 / 103.8415 = 0.963007; at 0/100 the upper end is z^2 / (n + z^2) = 0.036993; at
    50/100 the centre is 0.5 and the half-width z sqrt(p q / n + z^2 / 4n^2) / (1 + z^2 / n) =
    1.959964 * 0.0509513 / 1.0384146 = 0.0961684."""
    lo, hi = st.success_interval(100, 100)
    assert lo == pytest.approx(0.963007, abs=1e-6) and hi == pytest.approx(1.0)
    lo, hi = st.success_interval(0, 100)
    assert lo == pytest.approx(0.0, abs=1e-12) and hi == pytest.approx(0.036993, abs=1e-6)
    lo, hi = st.success_interval(50, 100)
    assert lo == pytest.approx(0.5 - 0.0961684, abs=1e-6)
    assert hi == pytest.approx(0.5 + 0.0961684, abs=1e-6)
    assert all(math.isnan(v) for v in st.success_interval(0, 0))
    with pytest.raises(ValueError, match="successes"):
        st.success_interval(5, 3)
    with pytest.raises(ValueError, match="confidence"):
        st.success_interval(1, 2, confidence=1.0)


def test_bootstrap_of_one_value_and_bad_confidence():
    assert st.bootstrap_ci([4.0]) == (4.0, 4.0)
    assert st.bootstrap_ci([4.0], st.iqm) == (4.0, 4.0)
    with pytest.raises(ValueError, match="confidence"):
        st.bootstrap_ci([1.0, 2.0], confidence=0.0)


def test_success_interval_does_not_collapse_at_all_or_nothing():
    wins = st.summarize([_result(True, 1.0) for _ in range(20)], n_resamples=100)
    assert wins["success_rate"] == 1.0
    assert wins["success_ci"][0] == pytest.approx(20 / (20 + 1.959964**2), abs=1e-6)
    losses = st.summarize([_result(False, -1.0, cause="not_converged") for _ in range(20)])
    assert losses["success_ci"][0] == pytest.approx(0.0, abs=1e-12)
    assert losses["success_ci"][1] == pytest.approx(1.959964**2 / (20 + 1.959964**2), abs=1e-6)


def test_summarize_task_metrics():
    res = [
        _result(True, 1.0, task_metrics={"tracking_rms": 0.001, "tracking_max": 0.004}),
        _result(True, 1.0, task_metrics={"tracking_rms": 0.003, "tracking_max": 0.002}),
        _result(False, 1.0, cause="not_converged", task_metrics={"tracking_rms": 0.005}),
    ]
    s = st.summarize(res, n_resamples=100)
    rms = s["task_metrics"]["tracking_rms"]
    assert rms == pytest.approx({"median": 0.003, "mean": 0.003, "min": 0.001, "max": 0.005})
    assert s["task_metrics"]["tracking_max"] == pytest.approx(
        {"median": 0.003, "mean": 0.003, "min": 0.002, "max": 0.004}
    )  # the third episode did not report it
    row = res[0].row()
    assert row["tracking_rms"] == 0.001 and "task_metrics" not in row
    assert "task_metrics" not in st.summarize([_result(True, 1.0)], n_resamples=100)
