"""Tests of results across training seeds (planar3p_agents.evaluation.seed_statistics,
scripts/seed_report.py)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from script_loader import command

from planar3p_agents.evaluation import seed_statistics as ss

seed_report = command("seed-report")


def test_iqm_point_is_the_mean_of_the_middle_half():
    # 8 runs x 1 task: IQM drops the 2 lowest and 2 highest
    scores = [0.0, 0.1, 0.5, 0.6, 0.7, 0.8, 0.95, 1.0]
    point, lo, hi = ss.stratified_bootstrap_iqm(scores, n_resamples=500)
    assert point == pytest.approx(np.mean([0.5, 0.6, 0.7, 0.8]))
    assert 0.0 <= lo <= point <= hi <= 1.0


def test_identical_runs_and_a_single_run_give_point_intervals():
    assert ss.stratified_bootstrap_iqm([0.9] * 5) == pytest.approx((0.9, 0.9, 0.9))
    assert ss.stratified_bootstrap_iqm([[0.3, 0.7]]) == pytest.approx((0.5, 0.5, 0.5))


def test_resampling_is_stratified_by_task():
    """Every resample keeps each task's runs: with tasks scoring 0 and 1 for every run, the IQM
    over the pooled scores is exactly 0.5 in every resample (an unstratified bootstrap of the
    pooled scores would vary)."""
    scores = np.array([[0.0, 1.0]] * 6)
    point, lo, hi = ss.stratified_bootstrap_iqm(scores, n_resamples=300, seed=4)
    assert (point, lo, hi) == (0.5, 0.5, 0.5)


def test_interval_is_reproducible_and_covers_the_spread():
    rng = np.random.default_rng(0)
    scores = rng.uniform(0.6, 1.0, size=(10, 3))
    a = ss.stratified_bootstrap_iqm(scores, seed=1)
    assert a == ss.stratified_bootstrap_iqm(scores, seed=1)
    assert scores.min() < a[1] < a[0] < a[2] < scores.max()


@pytest.mark.parametrize("bad", [[], [[np.nan, 1.0]], np.zeros((2, 2, 2))])
def test_bad_scores_raise(bad):
    with pytest.raises(ValueError):
        ss.stratified_bootstrap_iqm(bad)


def test_group_label_drops_the_seed_token_only():
    assert ss.group_label("runs/ppo-v1-s3/model") == "runs/ppo-v1/model"
    assert ss.group_label("ppo-v1-s12") == "ppo-v1"
    assert ss.group_label("runs/s3-ppo/model") == "runs/s3-ppo/model"


def _write_csv(path: Path) -> None:
    rows = []
    for seed, rates in ((1, (1.0, 0.5)), (2, (0.5, 0.5)), (3, (1.0, 1.0))):
        for suite, rate in zip(("standard", "hard"), rates, strict=True):
            for i in range(4):
                rows.append(
                    {"policy": f"runs/ppo-s{seed}/model", "training_seed": seed, "suite": suite,
                     "index": i, "success": i < 4 * rate}
                )  # fmt: skip
    for i in range(4):
        rows.append(
            {"policy": "analytic-simultaneous", "training_seed": "", "suite": "standard",
             "index": i, "success": True}
        )  # fmt: skip
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def test_table_from_episodes_csv(tmp_path: Path):
    path = tmp_path / "episodes.csv"
    _write_csv(path)
    groups = ss.from_csv(path)
    assert set(groups) == {"runs/ppo/model"}  # the analytic controller has no training seed
    assert groups["runs/ppo/model"]["standard"] == {1: 1.0, 2: 0.5, 3: 1.0}
    rows = ss.seed_table(groups, n_resamples=200)
    by_suite = {r["suite"]: r for r in rows}
    assert by_suite["standard"]["seeds"] == [1, 2, 3]
    # 3 runs: trim_mean(0.25) trims nothing (floor(3/4) = 0), so the IQM is the mean
    assert by_suite["standard"]["iqm"] == pytest.approx(2.5 / 3)
    assert by_suite["all (stratified by suite)"]["iqm"] == pytest.approx(
        np.mean([1, 0.5, 1, 0.5, 0.5, 1])
    )
    assert "| runs/ppo/model | standard | 1, 2, 3 | 100 / 50 / 100 |" in ss.markdown(rows)


def test_script_writes_the_table_and_rejects_bad_input(tmp_path: Path, capsys):
    path = tmp_path / "episodes.csv"
    _write_csv(path)
    out = tmp_path / "seeds.md"
    assert seed_report.main([str(path), "--out", str(out), "--resamples", "100"]) == 0
    assert "runs/ppo/model" in out.read_text()
    for argv in (
        [str(tmp_path / "missing.csv")],
        [str(path), "--resamples", "0"],
        [str(path), "--out", str(tmp_path / "no" / "dir.md")],
    ):
        assert seed_report.main(argv) == 2
        assert ": error: " in capsys.readouterr().err
    assert not (tmp_path / "no").exists()


def test_learning_curves_show_the_iqm_over_the_seeds_at_each_step():
    from planar3p_agents.evaluation.learning_curves import _group_curves

    runs = [
        {"timesteps": np.array([10, 20]), "successes": np.array([0.2, 0.8])},
        {"timesteps": np.array([10, 20]), "successes": np.array([0.4, 1.0])},
        {"timesteps": np.array([10]), "successes": np.array([0.3])},  # stopped earlier
    ]
    steps, centre, lo, hi = _group_curves(runs, "successes")
    assert steps.tolist() == [10, 20]
    assert centre == pytest.approx([0.3, 0.9])  # 2-3 seeds: trim_mean trims nothing
    assert np.all(lo <= centre) and np.all(centre <= hi)
    assert lo[0] >= 0.2 - 1e-12 and hi[0] <= 0.4 + 1e-12  # means of resampled seeds


def test_continuous_metric_is_the_median_per_seed_in_its_unit(tmp_path: Path, capsys):
    """--metric tracking_rms_error: each seed's score is the median over the suite's
    episodes (rows without a value skipped), shown in mm."""
    rows = []
    for seed, values in ((1, (0.1e-3, 0.2e-3, 0.9e-3)), (2, (0.3e-3, 0.3e-3, 0.4e-3))):
        for i, v in enumerate(values):
            rows.append(
                {"policy": f"runs/trk-s{seed}/model", "training_seed": seed,
                 "suite": "track-segments", "index": i, "success": "",
                 "tracking_rms_error": v}
            )  # fmt: skip
    rows.append(
        {"policy": "runs/trk-s2/model", "training_seed": 2, "suite": "track-segments",
         "index": 3, "success": "", "tracking_rms_error": ""}
    )  # fmt: skip
    path = tmp_path / "episodes.csv"
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    groups = ss.from_csv(path, "tracking_rms_error")
    assert groups["runs/trk/model"]["track-segments"] == pytest.approx({1: 0.2e-3, 2: 0.3e-3})
    table = ss.markdown(ss.seed_table(groups, n_resamples=100), "tracking_rms_error")
    assert "median tracking RMS error mm per seed" in table
    assert "| 0.200 / 0.300 | 0.250 [0.200, 0.300] |" in table
    assert seed_report.main([str(path), "--metric", "tracking_rms_error"]) == 0
    assert "0.200 / 0.300" in capsys.readouterr().out
    assert seed_report.main([str(path), "--metric", "nope"]) == 2
    assert "unknown metric" in capsys.readouterr().err
    with pytest.raises(ValueError, match="unknown metric"):
        ss.read_seed_scores([], "nope")


def test_time_to_success_is_the_median_over_the_successful_episodes():
    """A failed episode's time to success is NaN in episodes.csv: it has no value and does
    not enter the median (which stays finite, so the bootstrap works)."""
    rows = [
        {"policy": "runs/r-s1/model", "training_seed": 1, "suite": "standard", "success": ok,
         "time_to_success": t}
        for ok, t in ((True, "0.6"), (True, "0.7"), (False, "nan"), (True, "0.64"))
    ]  # fmt: skip
    groups = ss.read_seed_scores(rows, "time_to_success")
    assert groups["runs/r/model"]["standard"] == {1: pytest.approx(0.64)}
    table = ss.markdown(ss.seed_table(groups, n_resamples=10), "time_to_success")
    assert "median time to success s per seed" in table
    assert "| 0.64 | 0.640 [0.640, 0.640] |" in table


def test_time_over_the_speed_bound_per_seed():
    """``time_over_bound``: each seed's median over its successful episodes, in units of the
    speed bound (``x``), three decimals."""
    rows = [
        {"policy": "runs/l-s2/model", "training_seed": 2, "suite": "hard", "success": ok,
         "time_over_bound": t}
        for ok, t in ((True, "1.05"), (True, "1.2"), (False, "nan"), (True, "1.1"))
    ]  # fmt: skip
    groups = ss.read_seed_scores(rows, "time_over_bound")
    assert groups["runs/l/model"]["hard"] == {2: pytest.approx(1.1)}
    table = ss.markdown(ss.seed_table(groups, n_resamples=10), "time_over_bound")
    assert "median time to success over the speed bound x per seed" in table
    assert "| 1.100 | 1.100 [1.100, 1.100] |" in table
