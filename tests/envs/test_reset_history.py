"""A seeded reset forgets the environment's history.  The simulation is kept
across episodes and moved (:meth:`planar3p_gym.sim.physics.Planar3PSim.reset`), and the
episode samplers keep pools: an environment reset with seed ``s`` after any history must be,
bit for bit, a new environment reset with seed ``s`` (observations, rewards, episode ends and
infos along the episode)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym

IDS = [row.id for row in planar3p_gym.ENV_SPECS]


def canonical(value):
    """``value`` as nested tuples of exact representations (floats in hex, arrays as bytes)."""
    if isinstance(value, dict):
        return tuple(sorted((str(k), canonical(v)) for k, v in value.items()))
    if isinstance(value, (list, tuple)):
        return tuple(canonical(v) for v in value)
    if isinstance(value, np.ndarray):
        return (value.dtype.str, value.shape, value.tobytes())
    if isinstance(value, (float, np.floating)):
        return float(value).hex()
    if isinstance(value, (bool, np.bool_, int, np.integer)):
        return int(value)
    return repr(value)


def actions(env: gym.Env, n: int, seed: int) -> list:
    space = env.action_space
    space.seed(seed)
    return [space.sample() for _ in range(n)]


def episode(env: gym.Env, seed: int | None, acts: list) -> list:
    """The canonical record of a reset and up to ``len(acts)`` steps (to the episode's end)."""
    obs, info = env.reset(seed=seed)
    out = [canonical(obs), canonical(info)]
    for a in acts:
        obs, reward, terminated, truncated, info = env.step(a)
        out.append(canonical((obs, reward, terminated, truncated, info)))
        if terminated or truncated:
            break
    return out


@pytest.mark.parametrize("env_id", IDS)
def test_a_seeded_reset_after_any_history_is_a_new_environment_s(env_id):
    used, fresh = gym.make(env_id), gym.make(env_id)
    try:
        # A history: two seeded episodes, an unseeded one, one cut short mid-episode.
        episode(used, 11, actions(used, 40, 0))
        episode(used, 12, actions(used, 40, 1))
        episode(used, None, actions(used, 30, 2))
        used.reset()
        for a in actions(used, 7, 3):
            used.step(a)
        acts = actions(fresh, 30, 4)
        for seed in (5, 6):
            assert episode(used, seed, acts) == episode(fresh, seed, acts)
            # ... and what follows the seeded reset: the unseeded episode after it.
            assert episode(used, None, acts) == episode(fresh, None, acts)
    finally:
        used.close()
        fresh.close()
