"""Residual assembly-change policy (agents/controllers/residual.py): PPO on top of the
benchmark's analytic controller on ``Planar3PAssemblyChange-v0``."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from residual_helpers import (
    assert_correction_bounded,
    assert_round_trip,
    assert_trains_shipped_entry,
    observation_with_errors,
    residual_model,
    saved_with_correction,
)
from stable_baselines3 import PPO

from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.layout import extra_slice
from planar3p_agents.controllers.pose_correction import PoseCorrection
from planar3p_agents.controllers.residual import (
    ASSEMBLY_OBS_SIZE,
    REACH_ERROR_SCALE,
    AssemblyFeatures,
    ResidualAssemblyPolicy,
    feature_scaling,
)
from planar3p_agents.training import config as training
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

ID = "Planar3PAssemblyChange-v0"
HYPERPARAMS = training.HYPERPARAMS_DIR / "ppo_residual.yml"


def _model(scale: float = 0.3, **policy_kwargs) -> PPO:
    return residual_model(ResidualAssemblyPolicy, ID, scale, -2.5, **policy_kwargs)


def _base() -> AnalyticController:
    return AnalyticController(
        Design.fig8(gravity=0.0), "simultaneous", observation_size=ASSEMBLY_OBS_SIZE
    )


def _observations(n_steps: int = 40) -> np.ndarray:
    """Observations met by the analytic controller on a seeded assembly-change episode."""
    out = []
    env = gym.make(ID)
    ctrl = AnalyticController.from_env(env)
    obs, _ = env.reset(seed=3)
    for _ in range(n_steps):
        out.append(obs)
        obs, _, term, trunc, _ = env.step(ctrl(obs))
        if term or trunc:
            break
    env.close()
    return np.asarray(out)


@pytest.fixture(scope="module")
def observations() -> np.ndarray:
    return _observations()


def test_untrained_policy_is_the_analytic_controller(observations):
    """The correction's output layer starts at zero, so the deterministic action is the
    benchmark's analytic-simultaneous controller's on the 36-entry observation, bit for bit."""
    actions = _model().predict(observations, deterministic=True)[0]
    expected = _base().predict(observations)[0]
    np.testing.assert_array_equal(actions, expected)
    assert np.abs(expected).max() > 0.5  # the controller moves: the comparison is not 0 == 0
    assert observations.shape[1] == ASSEMBLY_OBS_SIZE == OBS_SIZE + 5


def test_correction_is_bounded_by_the_residual_scale(observations):
    assert_correction_bounded(_model(0.3), _base(), observations[:20], 0.3)


def test_features_scale_errors_and_the_target_travels():
    """A centimetre of error is a feature of 1; the target's travels are centred on mid-stroke
    over half the stroke (an end of the stroke is -1 or 1); the base action comes last."""
    env = gym.make(ID)
    feats = AssemblyFeatures(env.observation_space)
    design = env.unwrapped.design
    s = REACH_ERROR_SCALE
    x, tensor = observation_with_errors(env, s, -0.1 * s, s)
    f = feats(tensor)[0].numpy()
    assert f.shape == (ASSEMBLY_OBS_SIZE + 3,)
    np.testing.assert_allclose(f[SLICES["position_error"]], [1.0, -0.1], rtol=1e-5)
    np.testing.assert_allclose(f[SLICES["orientation_error"]], [1.0], rtol=1e-5)
    target_rho = extra_slice("assembly_change", "target_rho")
    expected = (x[target_rho] - design.stroke / 2.0) * 2.0 / design.stroke
    np.testing.assert_allclose(f[target_rho], expected, rtol=1e-5, atol=1e-6)
    for name in ("target_assembly", "signed_parallel_margin"):  # dimensionless: as they are
        k = extra_slice("assembly_change", name)
        np.testing.assert_allclose(f[k], x[k], rtol=1e-6)
    np.testing.assert_allclose(
        f[ASSEMBLY_OBS_SIZE:], _base().predict(x.astype(np.float32))[0], rtol=1e-6
    )
    offset, scale = feature_scaling(design, ASSEMBLY_OBS_SIZE, s)
    ends = (np.array([0.0, design.stroke]) - offset[target_rho][0]) * scale[target_rho][0]
    np.testing.assert_allclose(ends, [-1.0, 1.0])
    with pytest.raises(ValueError, match="size must be one of"):
        feature_scaling(design, 35, s)


def test_round_trip_registry_and_wrong_observation(tmp_path: Path, observations):
    model = _model(0.2, net_arch={"pi": [16], "vf": [16]})
    loaded = assert_round_trip(model, ResidualAssemblyPolicy, observations[:20], tmp_path / "m.zip")
    assert loaded.policy.design_dict == Design.fig8(gravity=0.0).to_dict()
    with pytest.raises(ValueError, match=r"observation of shape \(36,\)"):
        AssemblyFeatures(gym.spaces.Box(-1, 1, (31,)))
    assert training.policy_class("ResidualAssemblyPolicy") is ResidualAssemblyPolicy


def test_train_script_trains_the_shipped_entry(tmp_path: Path):
    """scripts/train.py with the assembly-change entry of ppo_residual.yml: a complete run
    whose model is a residual assembly policy with reward-only statistics."""
    assert_trains_shipped_entry(tmp_path / "assembly", ID, HYPERPARAMS, ResidualAssemblyPolicy)


def test_a_correction_is_kept_as_weights_and_moves_the_base(tmp_path: Path, observations):
    """A correction named by its file is kept in the model as weights (the saved model names no
    path), and the untrained policy is the base on the corrected observation, bit for bit."""
    bias = (0.002, -0.001, 0.001)
    loaded, weights = saved_with_correction(ResidualAssemblyPolicy, ID, 0.3, tmp_path, bias)
    actions = loaded.predict(observations, deterministic=True)[0]
    corrected = PoseCorrection(weights).corrected(observations.astype(np.float32))
    np.testing.assert_array_equal(actions, _base().predict(corrected)[0])
    plain = _base().predict(observations)[0]
    assert np.abs(actions - plain).max() > 1e-3  # a 2 mm bias changes the base's rates
    with pytest.raises(ValueError, match="weights must be finite with shape"):
        _model(correction=[[0.0] * 3] * 13)
