"""The ``certified-line`` baseline (agents/controllers/certified_line.py) and the residual policy
on top of it (``ResidualLinePolicy`` in agents/controllers/residual.py)."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from reach_helpers import HARD, STANDARD

pytest.importorskip("stable_baselines3")

from residual_helpers import (
    TINY_RUN_ARGS,
    assert_correction_bounded,
    assert_round_trip,
    residual_model,
)
from script_loader import command
from stable_baselines3 import PPO

import planar3p_gym
from planar3p_agents.controllers import residual
from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.certified import DEFAULT_CARTESIAN_GAIN, CertifiedPlanner
from planar3p_agents.controllers.certified_line import CertifiedLineController
from planar3p_agents.controllers.residual import LineFeatures, ResidualLinePolicy
from planar3p_agents.controllers.slider_line import SliderLineController, line_rates
from planar3p_agents.evaluation.episodes import run_episode
from planar3p_agents.policies.factory import load_policy
from planar3p_agents.training import config as training
from planar3p_gym import Design
from planar3p_gym.tasks.observation import SLICES

ID = planar3p_gym.ENV_ID


@pytest.fixture(scope="module")
def env():
    e = gym.make(ID)
    yield e
    e.close()


@pytest.fixture(scope="module")
def observations(env) -> np.ndarray:
    """Observations met by the baseline on the two episodes above (line and simple motions)."""
    out = []
    policy = CertifiedLineController()
    for spec in (STANDARD, HARD):
        obs, _ = env.reset(seed=spec.index, options=spec.reset_options())
        for _ in range(30):
            out.append(obs)
            obs, _, term, trunc, _ = env.step(policy.predict(obs)[0])
            if term or trunc:
                break
    return np.asarray(out)


def test_line_where_certified_else_the_simple_motions(env, observations):
    policy = CertifiedLineController.from_env(env)
    assert policy.dt == 0.02 and policy.gain == 50.0  # deadbeat: 1 / dt
    line, rho_target = policy.certified(observations.astype(np.float64))
    assert line.any() and not line.all()  # both branches are exercised
    actions = policy.predict(observations)[0]
    # where certified: the slider line on the travel error one control period ahead
    x = observations.astype(np.float64)
    ahead = x[:, SLICES["rho"]] + 0.02 * x[:, SLICES["rho_dot"]]
    vmax = env.unwrapped.design.max_speed
    line_action = line_rates(rho_target - ahead, 50.0, vmax) / vmax
    np.testing.assert_allclose(actions[line], line_action[line], rtol=0, atol=1e-6)
    cartesian = AnalyticController(
        position_gain=DEFAULT_CARTESIAN_GAIN, orientation_gain=DEFAULT_CARTESIAN_GAIN
    ).predict(observations)[0]
    np.testing.assert_array_equal(actions[~line], cartesian[~line])
    assert policy.line_steps == int(line.sum()) and policy.steps == len(line)


def test_prediction_commands_nothing_when_the_observed_rates_arrive(env, observations):
    """Deadbeat on the predicted error: rates that will carry the travels onto the target's
    within the period get a zero command; the same travels at rest get the whole error over
    one period (below the speed limit)."""
    policy = CertifiedLineController()
    x = observations.astype(np.float64)
    line, rho_target = policy.certified(x)
    i = int(np.flatnonzero(line)[-1])  # near the end of the standard episode
    row = x[i].copy()
    error = rho_target[i] - row[SLICES["rho"]]
    assert 0 < np.abs(error).max() < 0.004  # within one period at full speed
    row[SLICES["rho_dot"]] = error / 0.02
    np.testing.assert_allclose(policy.predict(row)[0], 0.0, atol=1e-6)
    row[SLICES["rho_dot"]] = 0.0
    expected = error / 0.02 / policy.design.max_speed
    np.testing.assert_allclose(policy.predict(row)[0], expected, rtol=1e-5, atol=1e-7)


def test_stateless_each_row_on_its_own(observations):
    policy = CertifiedLineController()
    batch = policy.predict(observations)[0]
    order = np.random.default_rng(0).permutation(len(observations))
    np.testing.assert_array_equal(policy.predict(observations[order])[0], batch[order])
    for i in (0, len(observations) - 1):
        np.testing.assert_array_equal(policy.predict(observations[i])[0], batch[i])


def test_solves_both_episodes_switching_to_the_line_on_the_hard_one(env):
    policy = load_policy("certified-line", env)
    assert isinstance(policy, CertifiedLineController)
    res = run_episode(env, policy, STANDARD, policy_name="certified-line")
    assert res.success and policy.line_steps == policy.steps
    policy = load_policy("certified-line", env)
    res = run_episode(env, policy, HARD, policy_name="certified-line")
    assert res.success and not res.working_mode_changed
    assert 0 < policy.line_steps < policy.steps  # simple motions first, then the line


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"gain": 0.0}, "gain must be finite and > 0"),
        ({"dt": -0.02}, "dt must be finite and > 0"),
        ({"cartesian_gain": float("nan")}, "cartesian_gain must be finite"),
        ({"limits": {"points": 3}}, "limits must be a PathLimits"),
        ({"observation_size": 30}, "observation_size must be an int >= 31"),
        ({"design": "fig8"}, "design must be a planar3p_gym.Design"),
    ],
)
def test_bad_arguments_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        CertifiedLineController(**kwargs)


# ---------------------------------------------------------------- the residual policy on it
def _model(scale: float = 0.3, **policy_kwargs) -> PPO:
    return residual_model(ResidualLinePolicy, ID, scale, -3.0, **policy_kwargs)


def test_untrained_policy_is_the_baseline(observations):
    """The correction's output layer starts at zero: the deterministic action is the
    ``certified-line`` baseline's, bit for bit, on both of its branches."""
    actions = _model().predict(observations, deterministic=True)[0]
    np.testing.assert_array_equal(actions, CertifiedLineController().predict(observations)[0])


def test_kept_base_actions_are_the_computed_ones(observations, monkeypatch):
    """The features extractor's cache of base actions returns what the base computes, also
    after it overflows and is cleared."""
    import torch as th

    feats = LineFeatures(gym.spaces.Box(-np.inf, np.inf, (31,)))
    x = th.as_tensor(observations, dtype=th.float32)
    expected = CertifiedLineController().predict(observations.astype(np.float32))[0]
    first = feats.base_action(x).numpy()
    assert len(feats._cache) == len(np.unique(observations.astype(np.float32), axis=0))
    np.testing.assert_array_equal(first, expected)
    monkeypatch.setattr(residual, "BASE_CACHE_ROWS", 5)
    small = LineFeatures(gym.spaces.Box(-np.inf, np.inf, (31,)))
    np.testing.assert_array_equal(small.base_action(x[:3]).numpy(), expected[:3])
    np.testing.assert_array_equal(small.base_action(x[3:9]).numpy(), expected[3:9])
    assert len(small._cache) == 6  # 3 + 6 rows overflow 5: cleared, then the 6 new ones
    np.testing.assert_array_equal(small.base_action(x[:3]).numpy(), expected[:3])


def test_correction_bounded_and_round_trip(observations, tmp_path: Path):
    assert_correction_bounded(_model(0.3), CertifiedLineController(), observations, 0.3)
    model = _model(0.2, gain=12.0, net_arch={"pi": [16], "vf": [16]})
    loaded = assert_round_trip(model, ResidualLinePolicy, observations, tmp_path / "m.zip")
    assert loaded.policy.gain == 12.0
    assert loaded.policy.features_extractor.base.gain == 12.0
    assert training.policy_class("ResidualLinePolicy") is ResidualLinePolicy


def test_train_script_trains_the_recipe(tmp_path: Path):
    """`planar3p train` with agents/training/hyperparams/ppo_residual_line.yml: a complete run
    whose model is a residual policy on the certified line, with reward-only statistics."""
    run = tmp_path / "line"
    argv = [
        "--algo", "ppo", "--env", ID,
        "--hyperparams", str(training.HYPERPARAMS_DIR / "ppo_residual_line.yml"),
        "--vec-env", "native", "--run-dir", str(run), *TINY_RUN_ARGS,
    ]  # fmt: skip
    assert command("train").main(argv) == 0
    config = json.loads((run / "config.json").read_text())["config"]
    assert config["policy"] == "ResidualLinePolicy"
    loaded = load_policy(f"{run / 'model.zip'}:stats={run / 'vecnormalize.pkl'}", env=gym.make(ID))
    assert isinstance(loaded.model.policy, ResidualLinePolicy)
    assert not loaded.vecnormalize.norm_obs


@pytest.mark.parametrize(
    "controller",
    [AnalyticController, SliderLineController, CertifiedPlanner, CertifiedLineController],
)
def test_observation_size_is_checked_alike(controller):
    """One check for every flat-observation controller: an int of at least the 31 entries
    read (not a bool, not a float); a rejected size raises before anything is built."""
    for bad in (30, True, 31.0, "31"):
        with pytest.raises(ValueError, match=r"observation_size must be an int >= 31, got"):
            controller(observation_size=bad)
    assert controller().obs_size == 31
    assert controller(observation_size=np.int64(40)).obs_size == 40


@pytest.mark.parametrize(
    "controller",
    [AnalyticController, SliderLineController, CertifiedPlanner, CertifiedLineController],
)
def test_design_is_checked_alike(controller):
    """One check for every flat-observation controller: a Design, the paper's by default."""
    for bad in ("fig8", {"stroke": 0.3}, 1):
        with pytest.raises(ValueError, match=r"design must be a planar3p_gym.Design, got"):
            controller(bad)
    assert controller().design == Design.fig8()
    short = Design.fig8(stroke=0.2)
    assert controller(short).design is short
