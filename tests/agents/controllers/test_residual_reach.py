"""Residual reach policy (agents/controllers/residual.py): PPO on top of the benchmark's analytic
controller on ``Planar3P-v0``."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch as th
from residual_helpers import (
    assert_correction_bounded,
    assert_round_trip,
    assert_trains_shipped_entry,
    observation_with_errors,
    residual_model,
    saved_with_correction,
)
from stable_baselines3 import PPO

import planar3p_gym
from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.residual import (
    REACH_ERROR_SCALE,
    ReachFeatures,
    ResidualReachPolicy,
)
from planar3p_agents.training import config as training
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

ID = planar3p_gym.ENV_ID
HYPERPARAMS = training.HYPERPARAMS_DIR / "ppo_residual.yml"


def _model(scale: float = 0.5, **policy_kwargs) -> PPO:
    return residual_model(ResidualReachPolicy, ID, scale, -2.5, **policy_kwargs)


def _observations(n_steps: int = 40) -> np.ndarray:
    """Observations met by the analytic controller on two seeded reach episodes."""
    out = []
    env = gym.make(ID)
    ctrl = AnalyticController.from_env(env)
    for seed in (3, 4):
        obs, _ = env.reset(seed=seed)
        for _ in range(n_steps):
            out.append(obs)
            obs, _, term, trunc, _ = env.step(ctrl(obs))
            if term or trunc:
                break
    env.close()
    return np.asarray(out)


def test_untrained_policy_is_the_analytic_controller():
    """The correction's output layer starts at zero, so the deterministic action is the
    benchmark's analytic-simultaneous controller's, bit for bit (float32)."""
    obs = _observations()
    actions = _model().predict(obs, deterministic=True)[0]
    expected = AnalyticController().predict(obs)[0]
    np.testing.assert_array_equal(actions, expected)
    assert np.abs(expected).max() > 0.5  # the controller moves: the comparison is not 0 == 0


def test_correction_is_bounded_by_the_residual_scale():
    assert_correction_bounded(_model(0.3), AnalyticController(), _observations(20), 0.3)


def test_features_scale_a_centimetre_to_one():
    env = gym.make(ID)
    feats = ReachFeatures(env.observation_space)
    s = REACH_ERROR_SCALE
    x, tensor = observation_with_errors(env, s, -0.1 * s, s)
    f = feats(tensor)[0].numpy()
    assert f.shape == (OBS_SIZE + 3,)
    np.testing.assert_allclose(f[SLICES["position_error"]], [1.0, -0.1], rtol=1e-5)
    np.testing.assert_allclose(f[SLICES["orientation_error"]], [1.0], rtol=1e-5)
    np.testing.assert_allclose(f[OBS_SIZE:], AnalyticController().predict(x.astype(np.float32))[0])
    # an error of 20 cm is clipped at 10 (features stay of order one to ten)
    x[SLICES["position_error"]] = (0.2, 0.0)
    assert feats(th.as_tensor(x[None], dtype=th.float32))[0, SLICES["position_error"]][0] == 10


def test_round_trip_and_wrong_observation(tmp_path: Path):
    model = _model(0.2, net_arch={"pi": [16], "vf": [16]})
    assert_round_trip(model, ResidualReachPolicy, _observations(20), tmp_path / "m.zip")
    with pytest.raises(ValueError, match=r"observation of shape \(31,\)"):
        ReachFeatures(gym.spaces.Box(-1, 1, (34,)))
    assert training.policy_class("ResidualReachPolicy") is ResidualReachPolicy


def test_benchmark_plays_an_untrained_residual_model_like_the_controller(tmp_path: Path):
    """Played by the benchmark's episode runner on the fixed `standard` suite, the untrained
    residual model is the analytic controller: same outcomes, same times to success."""
    from planar3p_agents.evaluation.benchmark import build_suites
    from planar3p_agents.evaluation.episodes import evaluate
    from planar3p_agents.policies.factory import load_policy

    _model().save(tmp_path / "residual.zip")
    env = gym.make(ID)
    suite = build_suites(["standard"], 2, 0, env.unwrapped.design)["standard"]
    learned = evaluate(env, load_policy(f"{tmp_path / 'residual.zip'}:stats=none", env=env), suite)
    analytic = evaluate(env, AnalyticController.from_env(env), suite)
    assert [r.success for r in learned] == [r.success for r in analytic] == [True, True]
    assert [r.time_to_success for r in learned] == [r.time_to_success for r in analytic]


def test_train_script_trains_the_shipped_entry(tmp_path: Path):
    """scripts/train.py with agents/training/hyperparams/ppo_residual.yml: a complete run whose
    model is a residual reach policy with reward-only statistics."""
    assert_trains_shipped_entry(tmp_path / "reach", ID, HYPERPARAMS, ResidualReachPolicy)


def test_a_correction_moves_the_base_and_is_kept_as_weights(tmp_path: Path):
    """With a learned pose correction the untrained policy is the analytic controller on the
    corrected observation, bit for bit, and the saved model holds the weights, not the file."""
    from planar3p_agents.controllers.pose_correction import PoseCorrection

    bias = (-0.002, 0.001, 0.0)
    loaded, weights = saved_with_correction(ResidualReachPolicy, ID, 0.5, tmp_path, bias)
    obs = _observations()
    corrected = PoseCorrection(weights).corrected(obs.astype(np.float32))
    base = AnalyticController(planar3p_gym.Design.fig8(), "simultaneous")
    actions = loaded.predict(obs, deterministic=True)[0]
    np.testing.assert_array_equal(actions, base.predict(corrected)[0])
    assert np.abs(actions - base.predict(obs)[0]).max() > 1e-3
