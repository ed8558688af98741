"""The residual on the predictive on-off law end to end: trained with its command memory and a
pose correction named by file, then played by the benchmark without that file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from bench_helpers import assert_plays_one_episode
from script_loader import command

from planar3p_agents.controllers.pose_correction import FEATURES, PoseCorrection
from planar3p_agents.training import config as training

train_script = command("train")


def test_predictive_residual_trains_and_the_benchmark_plays_it(tmp_path: Path, bench) -> None:
    weights = np.zeros((len(FEATURES) + 1, 3))
    weights[-1] = (0.001, 0.0, 0.0)
    correction = tmp_path / "c.json"
    PoseCorrection(weights).save(correction)
    run = tmp_path / "run"
    recipe = training.HYPERPARAMS_DIR / "ppo_on_off_predictive.yml"
    argv = [
        *("--algo", "ppo", "--env", "Planar3PRealOnOff-v0", "--hyperparams", str(recipe)),
        *("--timesteps", "128", "--run-dir", str(run), "--n-envs", "2", "--eval-freq", "128"),
        *("--eval-episodes", "1", "--final-eval-episodes", "1", "--no-progress-bar"),
        *("--params", "n_steps=64", "batch_size=64", "n_epochs=1"),
        f"policy_kwargs=dict(base_logit=5.0, correction='{correction}', net_arch=[8])",
    ]
    assert train_script.main(argv) == 0
    correction.unlink()  # the model holds the weights
    assert_plays_one_episode(bench, run, tmp_path / "bench")
