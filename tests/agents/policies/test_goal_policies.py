"""Learned policies on the goal-conditioned ids (``Dict`` observations): SAC+HER and PPO
``MultiInputPolicy`` models load without their training env, play ``Dict`` observations with
``Dict`` normalisation statistics, and the shipped hyperparameters resolve."""

from __future__ import annotations

import pickle
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import planar3p_gym
from planar3p_agents.policies.factory import PolicyError, load_policy
from planar3p_agents.policies.goal_features import (
    ERROR_FEATURES,
    TRAVEL_FEATURES,
    GoalErrorExtractor,
    GoalTravelExtractor,
    travel_features,
)
from planar3p_agents.policies.sb3_models import load_sb3_model
from planar3p_agents.training import config as training
from planar3p_gym.envs.goal import flat_observation
from planar3p_gym.tasks.observation import SLICES

GOAL = planar3p_gym.GOAL_ENV_ID
DENSE = planar3p_gym.GOAL_DENSE_ENV_ID


def _tiny_her_model(path: Path) -> None:
    """A SAC + HER model after a few hundred steps on the sparse goal id, saved to ``path``."""
    import torch as th
    from stable_baselines3 import SAC, HerReplayBuffer

    th.set_num_threads(1)  # many threads on a shared machine are many times slower

    env = gym.make(GOAL)
    model = SAC(
        "MultiInputPolicy",
        env,
        replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs={"goal_selection_strategy": "future", "n_sampled_goal": 2},
        buffer_size=1000,
        learning_starts=100,
        batch_size=32,
        policy_kwargs={"net_arch": [16]},
        seed=0,
        device="cpu",
    )
    model.learn(200)
    model.save(path)


def test_her_model_plays_without_its_training_env(tmp_path: Path) -> None:
    """A HER model cannot be rebuilt without an env by SB3's ``load``; the loader gives it a
    one-entry plain buffer instead and plays exactly the saved actor."""
    from stable_baselines3 import SAC

    path = tmp_path / "her.zip"
    _tiny_her_model(path)
    env = gym.make(GOAL)
    policy = load_sb3_model(path, check_env=env)
    assert policy.model.replay_buffer.buffer_size == 1
    reference = SAC.load(path, env=gym.make(GOAL), buffer_size=1000)
    obs, _ = env.reset(seed=5)
    for _ in range(20):
        action, _ = policy.predict(obs, deterministic=True)
        expected, _ = reference.predict(obs, deterministic=True)
        assert action.shape == (3,)
        np.testing.assert_array_equal(action, expected)
        obs, *_ = env.step(action)
    with pytest.raises(PolicyError, match="expects observations"):
        load_sb3_model(path, check_env=gym.make("Planar3P-v0"))


def test_ppo_dict_policy_uses_its_dict_statistics(tmp_path: Path) -> None:
    """PPO ``MultiInputPolicy`` with ``Dict`` VecNormalize statistics: the loaded policy acts
    on the normalised observation, exactly as the model on ``normalize_obs``."""
    import torch as th
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    th.set_num_threads(1)
    venv = VecNormalize(make_vec_env(DENSE, n_envs=2, seed=0), norm_reward=False)
    model = PPO("MultiInputPolicy", venv, n_steps=32, batch_size=32, n_epochs=1, seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.learn(64)
    model.save(tmp_path / "ppo.zip")
    venv.save(tmp_path / "vn.pkl")
    assert set(venv.obs_rms) == {"observation", "achieved_goal", "desired_goal"}

    env = gym.make(DENSE)
    policy = load_policy(f"{tmp_path / 'ppo.zip'}:stats={tmp_path / 'vn.pkl'}", env=env)
    with (tmp_path / "vn.pkl").open("rb") as f:
        stats = pickle.load(f)
    obs, _ = env.reset(seed=2)
    action, _ = policy.predict(obs, deterministic=True)
    expected, _ = model.predict(stats.normalize_obs(obs), deterministic=True)
    np.testing.assert_allclose(action, expected, rtol=0, atol=1e-6)
    # The statistics changed what the policy sees (the raw observation gives another action).
    raw, _ = model.predict(obs, deterministic=True)
    assert not np.allclose(raw, expected)
    # Statistics of the robot key only (norm_obs_keys, as the shipped recipe) fit the env.
    only = VecNormalize(make_vec_env(DENSE, n_envs=1, seed=0), norm_obs_keys=["observation"])
    only.save(tmp_path / "only.pkl")
    load_policy(f"{tmp_path / 'ppo.zip'}:stats={tmp_path / 'only.pkl'}", env=env)
    # Flat statistics of another id are refused for the Dict env.
    flat = VecNormalize(make_vec_env("Planar3P-v0", n_envs=1, seed=0))
    flat.save(tmp_path / "flat.pkl")
    with pytest.raises(PolicyError, match="statistics"):
        load_policy(f"{tmp_path / 'ppo.zip'}:stats={tmp_path / 'flat.pkl'}", env=env)


def test_shipped_goal_hyperparameters_resolve() -> None:
    """The goal entries of ppo.yml and sac.yml: Dict policies, HER with the relabelling keys of
    the info dicts kept (exact failure penalties), SAC trained once per 8 transitions on the
    goal-error features, the tolerance curriculum ending at the id's own tolerances."""
    from planar3p_agents.training.her import CompactHerReplayBuffer
    from planar3p_gym.tasks.sampling import TaskConfig

    ppo = training.resolve(
        "ppo",
        DENSE,
        0,
        training.load_hyperparams(training.HYPERPARAMS_DIR / "ppo.yml", DENSE, "ppo"),
    )
    assert ppo.policy == "MultiInputPolicy" and ppo.n_envs == 16
    # Only the robot entries are normalised: the extractor needs the goals in m.
    assert ppo.normalize == {"norm_obs_keys": ["observation"]}
    assert ppo.algo_kwargs["policy_kwargs"]["features_extractor_class"] is GoalErrorExtractor
    sac = training.resolve(
        "sac", GOAL, 0, training.load_hyperparams(training.HYPERPARAMS_DIR / "sac.yml", GOAL, "sac")
    )
    assert sac.algo_kwargs["replay_buffer_class"] is CompactHerReplayBuffer
    assert sac.algo_kwargs["replay_buffer_kwargs"]["copy_info_dict"] is True
    assert sac.n_envs * sac.algo_kwargs["train_freq"] / sac.algo_kwargs["gradient_steps"] == 8
    assert sac.normalize == {"norm_obs_keys": ["observation"], "norm_reward": False}
    assert sac.algo_kwargs["policy_kwargs"]["features_extractor_class"] is GoalTravelExtractor
    # The extractor reads the working mode, which the recipe's environment argument adds.
    assert sac.env_kwargs == {"observe_working_mode": True}
    overridden = training.resolve(
        "sac", GOAL, 0, sac.entry, env_kwargs={"observe_working_mode": False, "max_speed": 0.2}
    )
    assert overridden.env_kwargs == {"observe_working_mode": False, "max_speed": 0.2}
    last = sac.task_schedule[max(sac.task_schedule)]
    own = TaskConfig()
    assert last["position_tolerance"] == own.position_tolerance
    assert last["rest_speed"] == own.rest_speed
    assert last["orientation_tolerance"] == own.orientation_tolerance


def test_goal_error_features_match_the_flat_observation() -> None:
    """The extractor's error entries are the flat observation's ``position_error``,
    ``orientation_error`` and ``fine_error`` blocks (float32 rounding), on states along real
    episodes and on goals with angle errors across +-pi."""
    import torch as th

    env = gym.make(DENSE)
    extractor = GoalErrorExtractor(env.observation_space)
    length = env.unwrapped.design.characteristic_length
    assert extractor.length == pytest.approx(length)
    obs, _ = env.reset(seed=3)
    batch = []
    rng = np.random.default_rng(0)
    for _ in range(40):
        batch.append(obs)
        obs, *_ = env.step(rng.uniform(-1.0, 1.0, 3))
    stacked = {k: np.stack([o[k] for o in batch]) for k in obs}
    angles = rng.uniform(-np.pi, np.pi, len(batch))  # desired angles all around the circle
    stacked["desired_goal"][:, 2], stacked["desired_goal"][:, 3] = np.cos(angles), np.sin(angles)
    with th.no_grad():
        feats = extractor({k: th.as_tensor(v) for k, v in stacked.items()}).numpy()
    assert feats.shape == (len(batch), 21 + 5 + 5 + ERROR_FEATURES)
    flat = flat_observation(stacked, length)
    np.testing.assert_array_equal(feats[:, :21], stacked["observation"])
    np.testing.assert_allclose(feats[:, -6:-4], flat[:, SLICES["position_error"]], atol=1e-6)
    np.testing.assert_allclose(feats[:, -4], flat[:, SLICES["orientation_error"]][:, 0], atol=1e-5)
    np.testing.assert_allclose(feats[:, -3:], flat[:, SLICES["fine_error"]], atol=1e-4)
    with pytest.raises(ValueError, match="Dict space"):
        GoalErrorExtractor(gym.make("Planar3P-v0").observation_space)


def test_yaml_names_only_known_feature_extractors() -> None:
    kwargs = training._literal("dict(features_extractor_class=GoalErrorExtractor)", "t")
    assert kwargs["features_extractor_class"] is GoalErrorExtractor
    with pytest.raises(ValueError, match="unsupported"):
        training._literal("dict(features_extractor_class=NatureCNN)", "t")


def test_travel_features_are_the_slider_travels_of_both_goals() -> None:
    """Along real episodes (relabelled goals are achieved ones) the extractor's joint-space
    block is the machine's own travels: the achieved goal's inverse kinematics in the observed
    working mode gives the observed ``rho`` (the loop is closed; float32 goals, so to a few
    micrometres), and a desired goal on another state of the episode gives that state's
    travels; the errors and their ``tanh`` follow."""
    import torch as th

    env = gym.make(GOAL, observe_working_mode=True)
    extractor = GoalTravelExtractor(env.observation_space)
    obs, _ = env.reset(seed=5)
    batch, rhos = [], []
    rng = np.random.default_rng(1)
    for _ in range(30):
        batch.append(obs)
        rhos.append(obs["observation"][SLICES["rho"]])
        obs, *_ = env.step(rng.uniform(-0.5, 0.5, 3))
    stacked = {k: np.stack([o[k] for o in batch]) for k in obs}
    rho = np.array(rhos, dtype=np.float64)
    later = np.roll(np.arange(len(batch)), -7)  # each state's goal: the state 7 steps on
    stacked["desired_goal"] = stacked["achieved_goal"][later]
    with th.no_grad():
        feats = extractor({k: th.as_tensor(v) for k, v in stacked.items()}).numpy()
    base = 21 + 5 + 5 + ERROR_FEATURES
    assert feats.shape == (len(batch), base + TRAVEL_FEATURES)
    travel = feats[:, base:]
    np.testing.assert_allclose(travel[:, :3], rho[later], atol=2e-5)  # target travels (m)
    np.testing.assert_allclose(travel[:, 6:9], rho[later] - rho, atol=4e-5)  # errors (m)
    np.testing.assert_allclose(travel[:, 3:6], np.tanh((rho[later] - rho) / 0.01), atol=4e-3)
    assert (travel[:, 9] == 1.0).all()
    assert set(np.unique(stacked["working_mode"])) <= {-1.0, 1.0}
    with pytest.raises(ValueError, match="observe_working_mode=True"):
        GoalTravelExtractor(gym.make(GOAL).observation_space)


def test_travel_features_zero_a_goal_that_does_not_close_in_the_mode() -> None:
    """A goal the legs cannot reach in the working mode (its IK is NaN) gives a zero block
    and flag 0, never NaN; the other rows are unaffected."""
    design = gym.make(GOAL).unwrapped.design
    achieved = np.array([[0.15, 0.0, 1.0, 0.0, 0.0]] * 2)
    desired = achieved.copy()
    desired[1, 1] = 5.0  # far above every leg's reach
    out = travel_features(achieved, desired, np.array([[1.0, 1.0, -1.0]] * 2), design)
    assert np.isfinite(out).all()
    assert out[0, -1] == 1.0 and out[1, -1] == 0.0
    np.testing.assert_array_equal(out[1], np.zeros(TRAVEL_FEATURES))
    np.testing.assert_allclose(out[0, 3:9], 0.0, atol=1e-7)  # at its own goal: no error
