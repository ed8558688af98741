"""Residual mode-change policy (agents/controllers/residual.py): PPO on top of the planner
baseline on ``Planar3PModeChange-v0``, whose state the features extractor keeps."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch as th
from residual_helpers import (
    assert_round_trip,
    assert_trains_shipped_entry,
    residual_model,
    saved_with_correction,
)
from stable_baselines3 import PPO

from planar3p_agents.controllers.planner import JointPathPlanner
from planar3p_agents.controllers.residual import (
    MODE_CHANGE_OBS_SIZE,
    PlannerFeatures,
    ResidualPlannerPolicy,
)
from planar3p_agents.evaluation import episodes as ep
from planar3p_agents.evaluation import task_suites as ts
from planar3p_agents.policies.factory import load_policy
from planar3p_agents.training import config as training

ID = "Planar3PModeChange-v0"
HYPERPARAMS = training.HYPERPARAMS_DIR / "ppo_residual.yml"


def _model(scale: float = 0.3, **policy_kwargs) -> PPO:
    return residual_model(ResidualPlannerPolicy, ID, scale, -2.5, **policy_kwargs)


def _episodes(policy, seeds=(3, 4), steps: int = 60) -> tuple[np.ndarray, np.ndarray]:
    """Observations and actions of ``policy`` (SB3's ``predict``, ``episode_start`` not given)
    over the first ``steps`` steps of seeded mode-change episodes, played one after another."""
    env = gym.make(ID)
    observations, actions = [], []
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        for _ in range(steps):
            action = policy.predict(obs, deterministic=True)[0]
            observations.append(obs)
            actions.append(action)
            obs, _, term, trunc, _ = env.step(action)
            if term or trunc:
                break
    env.close()
    return np.asarray(observations), np.asarray(actions)


def _planner_actions(observations: np.ndarray, seeds=(3, 4), steps: int = 60) -> np.ndarray:
    """The planner's actions on the same episodes, told of each episode's start."""
    env = gym.make(ID)
    planner = JointPathPlanner.from_env(env)
    actions = []
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        for k in range(steps):
            action = planner.predict(obs, episode_start=[k == 0])[0]
            actions.append(action)
            obs, _, term, trunc, _ = env.step(action)
            if term or trunc:
                break
    env.close()
    return np.asarray(actions)


def test_untrained_policy_is_the_planner_across_episodes():
    """The correction starts at zero and the extractor keeps the planner's plan and clock,
    starting afresh at a new target: the untrained policy's actions over two episodes played
    back to back are the planner's, bit for bit (float32)."""
    observations, actions = _episodes(_model())
    np.testing.assert_array_equal(actions, _planner_actions(observations))
    assert np.abs(actions).max() > 0.3  # the planner moves: the comparison is not 0 == 0
    assert observations.shape[1] == MODE_CHANGE_OBS_SIZE


def test_updates_replay_the_rollout_base_actions():
    """In training mode the features of shuffled rollout observations carry the base actions
    the rollout played, and asking again in evaluation mode moves no clock."""
    model = _model()
    observations, actions = _episodes(model)
    feats = model.policy.features_extractor
    assert isinstance(feats, PlannerFeatures)
    order = np.random.default_rng(0).permutation(len(observations))
    batch = th.as_tensor(observations[order], dtype=th.float32)
    model.policy.set_training_mode(True)
    np.testing.assert_array_equal(feats(batch)[:, -3:].numpy(), actions[order])
    model.policy.set_training_mode(False)
    again = th.as_tensor(observations[-1:], dtype=th.float32)
    np.testing.assert_array_equal(feats(again)[:, -3:].numpy(), actions[-1:])
    np.testing.assert_array_equal(feats(again)[:, -3:].numpy(), actions[-1:])


def test_benchmark_plays_an_untrained_model_like_the_planner(tmp_path: Path):
    """Saved, loaded and played by the benchmark's episode runner on two episodes of the
    mode-change suite, the untrained model has the planner's outcomes and times."""
    _model().save(tmp_path / "residual.zip")
    env = ts.make_task_env("mode-change")
    suite = ts.make_task_suite("mode-change", 2, seed=0, env=env)
    learned = ep.evaluate(
        env, load_policy(f"{tmp_path / 'residual.zip'}:stats=none", env=env), suite
    )
    planner = ep.evaluate(env, load_policy("planner", env), suite)
    assert [r.success for r in learned] == [r.success for r in planner]
    assert any(r.success for r in planner)
    assert [r.time_to_success for r in learned] == [r.time_to_success for r in planner]


def test_round_trip_registry_and_wrong_arguments(tmp_path: Path):
    model = _model(0.2, net_arch={"pi": [16], "vf": [16]}, dt=0.02)
    observations, _ = _episodes(_model(), seeds=(3,), steps=10)
    loaded = assert_round_trip(model, ResidualPlannerPolicy, observations, tmp_path / "m.zip")
    assert loaded.policy.dt == 0.02
    with pytest.raises(ValueError, match=r"observation of shape \(37,\)"):
        PlannerFeatures(gym.spaces.Box(-1, 1, (36,)))
    with pytest.raises(ValueError, match="dt must be finite"):
        _model(dt=0.0)
    assert training.policy_class("ResidualPlannerPolicy") is ResidualPlannerPolicy


def test_train_script_trains_the_shipped_entry(tmp_path: Path):
    """scripts/train.py with the mode-change entry of ppo_residual.yml: a complete run whose
    model is a residual planner policy with reward-only statistics."""
    assert_trains_shipped_entry(tmp_path / "mode", ID, HYPERPARAMS, ResidualPlannerPolicy)


def test_a_correction_is_kept_as_weights_and_moves_the_planner(tmp_path: Path):
    """A correction named by its file is kept in the model as weights, and on the machine as
    built (the ``real-mode-change`` suite's environment) the untrained policy is the planner
    acting on the corrected observation, bit for bit (float32), over whole episodes; a 2 mm
    bias of the reading changes its actions once the plan's travel is done and it closes on
    the target by the observed errors."""
    from planar3p_agents.controllers.pose_correction import PoseCorrection

    bias = (0.002, -0.001, 0.001)
    loaded, weights = saved_with_correction(ResidualPlannerPolicy, ID, 0.3, tmp_path, bias)
    assert loaded.policy.dt == 0.02

    def play(act) -> np.ndarray:
        env, actions = ts.make_task_env("real-mode-change"), []
        for seed in (3, 4):
            obs, _ = env.reset(seed=seed)
            for k in range(400):
                actions.append(act(obs, k == 0))
                obs, _, term, trunc, _ = env.step(actions[-1])
                if term or trunc:
                    break
        return np.asarray(actions, dtype=np.float32)

    planners = [JointPathPlanner.from_env(gym.make(ID)) for _ in range(2)]

    def planner_on(fix):
        def act(obs, start):
            x = np.asarray(obs, np.float32)[None]
            x = PoseCorrection(weights).corrected(x) if fix else x
            return planners[fix].predict(x, episode_start=[start])[0][0]

        return act

    learned = play(lambda obs, start: loaded.predict(obs, deterministic=True)[0])
    np.testing.assert_array_equal(learned, play(planner_on(1)))
    plain = play(planner_on(0))
    n = min(len(plain), len(learned))
    assert np.abs(learned[:n] - plain[:n]).max() > 1e-3  # the correction changes the rates
