"""The task architecture (:mod:`planar3p_gym.tasks`): the contract of episode specs, reset
options and metrics, checked generically on every id built on it."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
from task_helpers import assert_seeded_and_replayable, checker_warnings, flat, rollout

import planar3p_gym
from planar3p_gym.envs.core import Planar3PEnv
from planar3p_gym.tasks import ReachTask, Task
from planar3p_gym.tasks.base import pose_list
from planar3p_gym.tasks.observation import OBS_SIZE

#: (id, make kwargs) of the ids built on the task interface by this module's author.
CASES = [
    ("Planar3P-v0", {}),
    ("Planar3P-v0", {"working_mode": "random"}),
    (planar3p_gym.GOAL_ENV_ID, {"working_mode": "random"}),
    (planar3p_gym.GOAL_DENSE_ENV_ID, {}),
    (planar3p_gym.TRACK_ENV_ID, {"working_mode": "random"}),
    (planar3p_gym.TRACK_ENV_ID, {"reference": "figure_eight"}),
]


@pytest.mark.parametrize(("env_id", "kwargs"), CASES)
def test_episode_spec_is_json_and_replays_the_episode(env_id, kwargs):
    env = gym.make(env_id, **kwargs)
    actions = np.random.default_rng(1).uniform(-1, 1, (60, 3)).astype(np.float32)
    env.reset(seed=21)
    for _ in range(3):  # specs of unseeded episodes replay too
        first = rollout(env, actions)
        spec = env.unwrapped.episode_spec
        assert spec["task"] == env.unwrapped.task.name
        assert len(spec["working_mode"]) == 3 and len(spec["start"]) == 3
        text = json.dumps(spec)
        again = rollout(env, actions, options=json.loads(text))
        assert np.array_equal(first, again)
        assert env.unwrapped.episode_spec == spec


#: (id, make kwargs, seed, steps) of the seeded-episode check: every task id.
SEEDED = [
    (planar3p_gym.GOAL_ENV_ID, {}, 11, 120),
    (planar3p_gym.GOAL_DENSE_ENV_ID, {}, 11, 120),
    (planar3p_gym.TRACK_ENV_ID, {"reference": "segments"}, 7, 150),
    (planar3p_gym.TRACK_ENV_ID, {"reference": "figure_eight"}, 7, 150),
    (planar3p_gym.MODE_CHANGE_ENV_ID, {}, 11, 15),
    (planar3p_gym.ASSEMBLY_CHANGE_ENV_ID, {}, 5, 15),
]


@pytest.mark.parametrize(("env_id", "kwargs", "seed", "steps"), SEEDED)
def test_seeded_episodes_repeat_and_replay(env_id, kwargs, seed, steps):
    """Same seed -> same episode, also in a newly made environment; finite numbers under
    random actions; ``reset(options=spec)`` (after a JSON round trip) replays it bit for bit
    (tracking: with its rms error)."""
    actions = np.random.default_rng(seed).uniform(-1, 1, (steps, 3)).astype(np.float32)
    keys = ("tracking_rms_error",) if env_id == planar3p_gym.TRACK_ENV_ID else ()
    env, fresh = gym.make(env_id, **kwargs), gym.make(env_id, **kwargs)
    assert_seeded_and_replayable(env, actions, seed, info_keys=keys, fresh=fresh)


@pytest.mark.parametrize(("env_id", "kwargs"), CASES)
def test_spec_in_info_at_reset_and_options_checked(env_id, kwargs):
    env = gym.make(env_id, **kwargs)
    _, info = env.reset(seed=0)
    spec = info["episode_spec"]
    assert spec == env.unwrapped.episode_spec
    spec["start"] = [1e9, 0.0, 0.0]  # the info's copy is the caller's to change
    assert env.unwrapped.episode_spec["start"] != spec["start"]
    with pytest.raises(ValueError, match="task"):
        env.reset(options={"task": "no-such-task"})
    with pytest.raises(ValueError, match="unknown reset options"):
        env.reset(options={"no_such_option": 1})
    with pytest.raises(ValueError):
        env.reset(options={"start": [10.0, 10.0, 0.0], "working_mode": (1, 1, -1)})
    extra = env.unwrapped.task.observation_bounds()[0].size
    if isinstance(env.observation_space, gym.spaces.Box):
        assert env.observation_space.shape == (OBS_SIZE + extra,)


@pytest.mark.parametrize(("env_id", "kwargs"), CASES)
def test_metric_keys_in_every_info(env_id, kwargs):
    env = gym.make(env_id, **kwargs)
    keys = env.unwrapped.task.metric_keys
    _, info = env.reset(seed=3)
    assert set(keys) <= set(info)
    for _ in range(5):
        *_, info = env.step(env.action_space.sample())
        assert set(keys) <= set(info)
        assert info["termination_reason"] in (None, *env.unwrapped.task.termination_reasons)


def test_reach_spec_has_the_v0_reset_options():
    env = gym.make("Planar3P-v0")
    _, info = env.reset(seed=5)
    spec = info["episode_spec"]
    # ("pair", the kind of pair, is in the spec only with a share of special pairs)
    assert set(spec) == {"task", *ReachTask.option_keys} - {"pair"}
    _, info2 = env.reset(options={k: spec[k] for k in set(spec) - {"task"}})
    assert info2["episode_spec"] == spec


#: The task ids with a flat (Box) observation, with the make arguments that select a variant.
FLAT_TASK_IDS = [
    ("Planar3PModeChange-v0", {}),
    ("Planar3PAssemblyChange-v0", {}),
    (planar3p_gym.TRACK_ENV_ID, {"reference": "segments"}),
    (planar3p_gym.TRACK_ENV_ID, {"reference": "figure_eight"}),
]


@pytest.mark.parametrize(("env_id", "kwargs"), FLAT_TASK_IDS, ids=lambda v: str(v or ""))
def test_env_checkers_pass_without_warnings(env_id, kwargs):
    """Gymnasium's and SB3's env checkers on every flat-observation task id (the goal ids:
    tests/envs/test_goal_env.py)."""
    from gymnasium.utils.env_checker import check_env

    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    assert not checker_warnings(check_env, gym.make(env_id, **kwargs).unwrapped)
    assert not checker_warnings(sb3_checker.check_env, gym.make(env_id, **kwargs), warn=True)


class _HoldTask(ReachTask):
    """A task written against the interface alone: hold the start pose (target = start)."""

    name = "hold"

    def episode_spec(self, rng, options):
        spec = super().episode_spec(rng, options)
        return {**spec, "task": self.name, "target": spec["start"]}


def test_a_new_task_is_a_small_subclass():
    env = Planar3PEnv(task=_HoldTask())
    _obs, info = env.reset(seed=0)
    assert info["episode_spec"]["task"] == "hold"
    assert info["episode_spec"]["target"] == info["episode_spec"]["start"]
    assert env.target == tuple(info["episode_spec"]["start"])
    _, _, terminated, _, info = env.step(np.zeros(3, np.float32))
    assert terminated and info["termination_reason"] == "success"


def test_env_rejects_a_non_task():
    with pytest.raises(ValueError, match="task"):
        Planar3PEnv(task="reach")


def test_base_task_hooks_must_be_implemented():
    class Empty(Task):
        name = "empty"

    with pytest.raises(NotImplementedError):
        Planar3PEnv(task=Empty()).reset(seed=0)


def test_pose_list_is_exact_and_plain():
    pose = np.array([0.1, -0.2, 3.0]) / 3.0
    out = pose_list(pose)
    assert all(type(v) is float for v in out)
    assert np.array_equal(np.array(json.loads(json.dumps(out))), pose)


def test_config_records_the_task():
    assert gym.make("Planar3P-v0").unwrapped.config()["task"] == "reach"
    cfg = gym.make(planar3p_gym.TRACK_ENV_ID, reference="figure_eight").unwrapped.config()
    assert cfg["task"] == "track" and cfg["task_arguments"]["reference"] == "figure_eight"
    assert cfg["projection"] is True
    cfg = gym.make(planar3p_gym.GOAL_DENSE_ENV_ID).unwrapped.config()
    assert cfg["task_arguments"] == {"reward_type": "dense"}
    json.dumps(cfg)


@pytest.mark.parametrize(("env_id", "kwargs"), CASES)
def test_snapshots_continue_bit_for_bit(env_id, kwargs):
    """``get_state``/``set_state`` (the physics owner's snapshots) carry the task's episode
    state too: a restored env continues exactly, metrics included."""
    env = gym.make(env_id, **kwargs)
    u = env.unwrapped
    actions = np.random.default_rng(2).uniform(-1, 1, (40, 3)).astype(np.float32)
    env.reset(seed=9)
    for a in actions[:15]:
        env.step(a)
    snap = u.get_state()

    def tail():
        out = []
        for a in actions[15:]:
            obs, reward, terminated, truncated, info = env.step(a)
            metrics = [info[k] for k in u.task.metric_keys]
            out.append(np.concatenate([flat(obs), [reward, terminated, *metrics]]))
            if terminated or truncated:
                break
        return np.concatenate(out)

    first = tail()
    u.set_state(snap)
    assert np.array_equal(first, tail())
