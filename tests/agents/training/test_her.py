"""The compact HER buffer keeps the relabelling keys of ``info`` only, and relabels to the same
rewards as SB3's buffer with whole info dicts."""

from __future__ import annotations

import copy

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from stable_baselines3 import HerReplayBuffer
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv

import planar3p_gym  # noqa: F401
from planar3p_agents.training.config import _resolve_replay_buffer
from planar3p_agents.training.her import KEPT_INFO_KEYS, CompactHerReplayBuffer, KeptInfo
from planar3p_gym.tasks.goal import RELABEL_INFO_KEYS

N_ENVS = 2
STEPS = 240  # more than two 100-step episodes per env


def _buffers_filled():
    """Both buffers fed the same transitions of the dense goal id (its goal-free reward is not
    zero, so relabelled rewards depend on the kept infos)."""
    env = make_vec_env("Planar3PGoalDense-v0", n_envs=N_ENVS, seed=3, vec_env_cls=DummyVecEnv)
    kwargs = {"goal_selection_strategy": "future", "n_sampled_goal": 4, "copy_info_dict": True}
    buffers = [
        cls(1_000, env.observation_space, env.action_space, env=env, n_envs=N_ENVS, **kwargs)
        for cls in (HerReplayBuffer, CompactHerReplayBuffer)
    ]
    rng = np.random.default_rng(0)
    obs = env.reset()
    infos_seen = []
    for _ in range(STEPS):
        action = rng.uniform(-1.0, 1.0, size=(N_ENVS, 3)).astype(np.float32)
        next_obs, reward, done, infos = env.step(action)
        for buf in buffers:
            buf.add(obs, next_obs, action, reward, done, infos)
        infos_seen.append(infos)
        obs = next_obs
    return buffers, infos_seen


def test_compact_buffer_keeps_only_the_relabelling_keys():
    (_, compact), infos_seen = _buffers_filled()
    assert set(RELABEL_INFO_KEYS) <= set(KEPT_INFO_KEYS)
    for pos, infos in enumerate(infos_seen):
        for env_idx, info in enumerate(infos):
            stored = compact.infos[pos, env_idx]
            assert stored == {k: info[k] for k in KEPT_INFO_KEYS if k in info}
            assert set(RELABEL_INFO_KEYS) <= set(stored)
            assert type(stored) is KeptInfo
            assert copy.deepcopy(stored) is stored  # SB3's per-sample copy: no work
            assert all(type(v) in (bool, float) for v in stored.values())  # immutable values


def test_compact_buffer_relabels_to_the_same_rewards():
    (full, compact), _ = _buffers_filled()
    np.random.seed(11)  # noqa: NPY002 (SB3's HER samples with numpy's global generator)
    a = full.sample(256)
    np.random.seed(11)  # noqa: NPY002
    b = compact.sample(256)
    assert np.array_equal(a.rewards.numpy(), b.rewards.numpy())
    assert np.any(a.rewards.numpy() != np.round(a.rewards.numpy()))  # dense: not just 0 / -1
    for key in a.observations:
        assert np.array_equal(a.observations[key].numpy(), b.observations[key].numpy())


def test_training_config_resolves_the_compact_buffer():
    kwargs = {"replay_buffer_class": "CompactHerReplayBuffer"}
    _resolve_replay_buffer("sac", kwargs)
    assert kwargs["replay_buffer_class"] is CompactHerReplayBuffer
    with pytest.raises(ValueError, match="off-policy"):
        _resolve_replay_buffer("ppo", {"replay_buffer_class": "CompactHerReplayBuffer"})
