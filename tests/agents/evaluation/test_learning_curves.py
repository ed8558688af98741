"""planar3p_agents.evaluation.learning_curves.time_to_success: the first evaluation at >= 90 %
from TensorBoard logs."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("torch")
from torch.utils.tensorboard import SummaryWriter

from planar3p_agents.evaluation.learning_curves import time_to_success


def _session(run: Path, name: str, start: float, evals: list[tuple[int, float, float]]) -> None:
    """One training session's log: a first scalar at ``start`` then ``(step, success, t)``."""
    with SummaryWriter(str(run / "tb" / name)) as w:
        w.add_scalar("time/fps", 1000.0, 0, walltime=start)
        for step, value, t in evals:
            w.add_scalar("eval/success_rate", value, step, walltime=start + t)


def test_first_evaluation_at_the_level_and_its_wall_time(tmp_path):
    _session(
        tmp_path, "PPO_1", 1000.0, [(25_000, 0.5, 30.0), (50_000, 0.92, 61.5), (75_000, 1.0, 90)]
    )
    assert time_to_success(tmp_path) == (50_000, pytest.approx(61.5))
    assert time_to_success(tmp_path, level=0.95) == (75_000, pytest.approx(90.0))
    assert time_to_success(tmp_path, level=1.01) is None


def test_a_resumed_run_counts_training_time_only(tmp_path):
    """The pause between two sessions (an hour here) is not training time."""
    _session(tmp_path, "PPO_1", 1000.0, [(25_000, 0.2, 40.0)])
    _session(tmp_path, "PPO_2", 5000.0, [(50_000, 0.6, 20.0), (75_000, 0.9, 45.0)])
    assert time_to_success(tmp_path) == (75_000, pytest.approx(40.0 + 45.0))


def test_a_run_without_logs_never_got_there(tmp_path):
    assert time_to_success(tmp_path) is None
