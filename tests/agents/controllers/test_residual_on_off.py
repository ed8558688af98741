"""The residual on-off policy: untrained, it is the ``analytic-on-off`` baseline."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from hypothesis import given, settings
from hypothesis import strategies as st
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import DummyVecEnv

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.on_off import OnOffController
from planar3p_agents.controllers.pose_correction import PoseCorrection
from planar3p_agents.controllers.predictive_on_off import PredictiveOnOffController
from planar3p_agents.controllers.residual_on_off import (
    PredictiveResidualOnOffPolicy,
    ResidualOnOffPolicy,
)
from planar3p_agents.policies.command_memory import (
    COMMAND_ENTRIES,
    VecCommandMemory,
    observed_commands,
)
from planar3p_agents.policies.factory import load_policy
from planar3p_agents.policies.sb3_models import load_sb3_model
from planar3p_agents.training import config as training
from planar3p_gym.tasks.observation import OBS_SIZE

ID = "Planar3PRealOnOff-v0"
KWARGS = {"ortho_init": False, "net_arch": {"pi": [16, 16], "vf": [16, 16]}}


def _model(env: gym.Env, **policy_kwargs: float) -> PPO:
    th.set_num_threads(1)
    return PPO(
        ResidualOnOffPolicy,
        env,
        n_steps=64,
        batch_size=64,
        policy_kwargs={**KWARGS, **policy_kwargs},
        device="cpu",
        seed=0,
    )


def _visited(env: gym.Env, steps: int = 120) -> np.ndarray:
    """Observations of an episode driven by random motor commands (seeded)."""
    obs, _ = env.reset(seed=5)
    env.action_space.seed(5)
    out = [obs]
    for _ in range(steps):
        obs, _, terminated, truncated, _ = env.step(env.action_space.sample())
        out.append(obs)
        if terminated or truncated:
            obs, _ = env.reset()
    return np.stack(out)


def test_untrained_policy_plays_the_baseline() -> None:
    env = gym.make(ID)
    model = _model(env)
    base = OnOffController(AnalyticController())
    obs = _visited(env)
    actions, _ = model.predict(obs, deterministic=True)
    np.testing.assert_array_equal(actions, base.predict(obs)[0])
    env.close()


@settings(max_examples=10, deadline=None)
@given(base_logit=st.floats(0.1, 8.0))
def test_base_command_probability_is_the_softmax_of_the_bias(base_logit: float) -> None:
    """Each motor samples the base command with probability ``e^b / (e^b + 2)``."""
    env = gym.make(ID)
    model = _model(env, base_logit=base_logit)
    obs = th.as_tensor(_visited(env, 20))
    dist = model.policy.get_distribution(obs)
    expected = math.exp(base_logit) / (math.exp(base_logit) + 2.0)
    base = OnOffController(AnalyticController()).predict(obs.numpy().astype(np.float64))[0]
    for motor, categorical in enumerate(dist.distribution):
        probs = categorical.probs.detach().numpy()
        chosen = probs[np.arange(len(probs)), base[:, motor]]
        np.testing.assert_allclose(chosen, expected, rtol=1e-5)
    env.close()


def test_saved_model_keeps_its_bias(tmp_path) -> None:
    env = gym.make(ID)
    model = _model(env, base_logit=2.0)
    model.save(tmp_path / "m.zip")
    loaded = PPO.load(tmp_path / "m.zip", device="cpu")
    assert isinstance(loaded.policy, ResidualOnOffPolicy) and loaded.policy.base_logit == 2.0
    obs = _visited(env, 30)
    np.testing.assert_array_equal(
        loaded.predict(obs, deterministic=True)[0], model.predict(obs, deterministic=True)[0]
    )
    env.close()


def test_bad_arguments_are_refused() -> None:
    env = gym.make(ID)
    with pytest.raises(ValueError, match="base_logit"):
        _model(env, base_logit=0.0)
    with pytest.raises(ValueError, match="MultiDiscrete"):
        _model(gym.make(ID, action_type="on-off-discrete"))
    with pytest.raises(ValueError, match="MultiDiscrete"):
        _model(gym.make("Planar3P-v0"))
    env.close()


def test_the_recipe_names_the_policy() -> None:
    path = training.HYPERPARAMS_DIR / "ppo_on_off.yml"
    cfg = training.resolve("ppo", ID, 0, training.load_hyperparams(path, ID, "ppo"))
    assert training.policy_class(cfg.policy) is ResidualOnOffPolicy
    assert cfg.normalize == {"norm_obs": False, "norm_reward": True}


def _predictive_model(env: gym.Env) -> PPO:
    th.set_num_threads(1)
    venv = VecCommandMemory(DummyVecEnv([lambda: env]))
    return PPO(
        PredictiveResidualOnOffPolicy,
        venv,
        n_steps=64,
        batch_size=64,
        policy_kwargs=KWARGS,
        device="cpu",
        seed=0,
    )


def test_untrained_predictive_policy_plays_the_predictive_law() -> None:
    """On the environment's own observation (the command in flight rebuilt from the state) the
    untrained policy plays ``analytic-on-off-predictive`` step for step."""
    env = gym.make(ID)
    model = _predictive_model(gym.make(ID))
    assert model.observation_space.shape == (OBS_SIZE + COMMAND_ENTRIES,)
    assert model.policy.played_observation_space.shape == (OBS_SIZE,)
    base = load_policy("analytic-on-off-predictive", env)
    obs, _ = env.reset(seed=2)
    state = base_state = None
    start = np.ones(1, dtype=bool)
    for _ in range(150):
        action, state = model.predict(obs, state, start, deterministic=True)
        expected, base_state = base.predict(obs, base_state, start)
        np.testing.assert_array_equal(action, expected)
        start = np.zeros(1, dtype=bool)
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    env.close()


def test_predictive_model_loads_against_the_environment(tmp_path) -> None:
    env = gym.make(ID)
    model = _predictive_model(gym.make(ID))
    model.save(tmp_path / "m.zip")
    policy = load_sb3_model(tmp_path / "m.zip", check_env=env, vecnormalize="none")
    obs, _ = env.reset(seed=4)
    action, state = policy.predict(obs, None, np.ones(1, dtype=bool), deterministic=True)
    assert action.shape == (3,) and state.shape == (1, 3)
    env.close()


def test_the_predictive_recipe_trains_on_the_command_memory() -> None:
    path = training.HYPERPARAMS_DIR / "ppo_on_off_predictive.yml"
    cfg = training.resolve("ppo", ID, 0, training.load_hyperparams(path, ID, "ppo"))
    assert training.policy_class(cfg.policy) is PredictiveResidualOnOffPolicy
    assert observed_commands(training.policy_class(cfg.policy)) == 1
    assert cfg.normalize == {"norm_obs": False, "norm_reward": True}


def test_predictive_policy_with_a_correction_keeps_its_weights(tmp_path) -> None:
    """A correction named by its file is kept in the model as weights: the loaded model plays
    the corrected law without the file."""
    weights = np.zeros((14, 3))
    weights[-1] = (0.002, -0.001, 0.0)  # a constant bias of the pose reading
    PoseCorrection(weights).save(tmp_path / "c.json")
    th.set_num_threads(1)
    venv = VecCommandMemory(DummyVecEnv([lambda: gym.make(ID)]))
    kwargs = PredictiveResidualOnOffPolicy.resolve_policy_kwargs(
        {**KWARGS, "correction": str(tmp_path / "c.json")}
    )
    model = PPO(
        PredictiveResidualOnOffPolicy,
        venv,
        n_steps=64,
        batch_size=64,
        policy_kwargs=kwargs,
        device="cpu",
        seed=0,
    )
    model.save(tmp_path / "m.zip")
    (tmp_path / "c.json").unlink()
    loaded = PPO.load(tmp_path / "m.zip", device="cpu")
    np.testing.assert_array_equal(loaded.policy.correction, weights)
    env = gym.make(ID)
    base = PredictiveOnOffController.from_env(env, correction=PoseCorrection(weights))
    plain = PredictiveOnOffController.from_env(env)
    obs, _ = env.reset(seed=6)
    state = base_state = plain_state = None
    start = np.ones(1, dtype=bool)
    differs = False
    for _ in range(200):
        action, state = loaded.predict(obs, state, start, deterministic=True)
        expected, base_state = base.predict(obs, base_state, start)
        other, plain_state = plain.predict(obs, plain_state, start)
        np.testing.assert_array_equal(action, expected)
        differs |= bool((other != expected).any())
        start = np.zeros(1, dtype=bool)
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    assert differs  # the 2 mm correction changes where the law stops
    env.close()
