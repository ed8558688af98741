"""The learned correction of the pose reading: a linear least-squares model of its bias."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planar3p_agents.controllers.pose_correction import (
    FEATURES,
    PoseCorrection,
    fit_pose_correction,
    pose_bias,
)
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

SHAPE = (len(FEATURES) + 1, 3)


def _observations(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (n, OBS_SIZE))


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_fit_recovers_a_linear_bias(seed: int) -> None:
    """Noise-free samples of a linear bias give back its weights (least squares is exact when
    the features have full rank: 200 random samples of 14 features)."""
    weights = np.random.default_rng(seed + 1).normal(0.0, 1e-3, SHAPE)
    obs = _observations(200, seed)
    truth = PoseCorrection(weights)
    fitted = fit_pose_correction(obs, truth.bias(obs))
    np.testing.assert_allclose(fitted.weights, weights, atol=1e-12)


def test_corrected_changes_the_errors_only() -> None:
    weights = np.zeros(SHAPE)
    weights[-1] = (0.001, -0.002, 0.01)  # a constant bias
    obs = _observations(3, 0)
    out = PoseCorrection(weights).corrected(obs)
    np.testing.assert_allclose(out[:, SLICES["position_error"]], obs[:, 23:25] - (0.001, -0.002))
    np.testing.assert_allclose(out[:, SLICES["orientation_error"]][:, 0], obs[:, 25] - 0.01)
    others = np.ones(OBS_SIZE, dtype=bool)
    others[23:26] = False
    np.testing.assert_array_equal(out[:, others], obs[:, others])


def test_bias_is_true_minus_observed_pose_with_the_angle_wrapped() -> None:
    obs = np.zeros((1, OBS_SIZE))
    obs[0, SLICES["position"]] = (0.1, 0.2)
    th = math.pi - 0.01
    obs[0, SLICES["orientation"]] = (math.cos(th), math.sin(th))
    bias = pose_bias(obs, [(0.101, 0.199, -math.pi + 0.01)])
    np.testing.assert_allclose(bias, [[0.001, -0.001, 0.02]], atol=1e-12)


def test_saved_weights_load_from_the_file(tmp_path) -> None:
    c = PoseCorrection(np.full(SHAPE, 1e-4))
    c.save(tmp_path / "c.json", episodes=3)
    np.testing.assert_array_equal(PoseCorrection(tmp_path / "c.json").weights, c.weights)


def test_bad_input_is_refused() -> None:
    with pytest.raises(ValueError, match="shape"):
        PoseCorrection(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="finite"):
        PoseCorrection(np.full(SHAPE, np.nan))
    with pytest.raises(ValueError, match="at least"):
        PoseCorrection(np.zeros(SHAPE)).bias(np.zeros((1, 5)))
    with pytest.raises(ValueError, match="samples"):
        fit_pose_correction(_observations(5, 0), np.zeros((5, 3)))
    with pytest.raises(ValueError, match="n x 3"):
        fit_pose_correction(_observations(20, 0), np.zeros((19, 3)))
