"""Helpers shared by the task tests: episode loops, bit-for-bit replay and the env checkers."""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

#: Warning categories the env checkers must not emit on the task ids.
RELEVANT = (UserWarning, RuntimeWarning)


def checker_warnings(check: Callable[..., Any], *args: Any, **kwargs: Any) -> list[str]:
    """Run an env checker (``check(*args, **kwargs)``); the messages of the :data:`RELEVANT`
    warnings it emitted."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check(*args, **kwargs)
    return [str(w.message) for w in caught if issubclass(w.category, RELEVANT)]


def flat(obs: Any) -> np.ndarray:
    """Observation as one float array (Dict observations concatenated in key order)."""
    if isinstance(obs, dict):
        return np.concatenate([np.asarray(obs[k], np.float64).ravel() for k in sorted(obs)])
    return np.asarray(obs, np.float64)


def rollout(
    env: gym.Env, actions: np.ndarray, info_keys: tuple[str, ...] = (), **reset_kwargs: Any
) -> np.ndarray:
    """Reset with ``reset_kwargs``, then step ``actions`` until the episode ends: the reset
    observation and every step's observation, reward, ``terminated`` and the ``info`` entries
    ``info_keys``, as one array.  Every step's numbers must be finite."""
    obs, _ = env.reset(**reset_kwargs)
    out = [flat(obs)]
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(a)
        row = np.concatenate([flat(obs), [reward, terminated], [info[k] for k in info_keys]])
        assert np.isfinite(row).all()
        out.append(row)
        if terminated or truncated:
            break
    return np.concatenate(out)


def assert_seeded_and_replayable(
    env: gym.Env,
    actions: np.ndarray,
    seed: int,
    info_keys: tuple[str, ...] = (),
    fresh: gym.Env | None = None,
) -> None:
    """The same seed gives the same episode (again in ``env``, or in ``fresh``, a newly made
    environment of the same id), and ``reset(options=spec)`` with the seeded episode's spec
    (after a JSON round trip) replays it bit for bit (see :func:`rollout`)."""
    first = rollout(env, actions, info_keys, seed=seed)
    assert np.array_equal(first, rollout(fresh or env, actions, info_keys, seed=seed))
    _, info = env.reset(seed=seed)
    spec = json.loads(json.dumps(info["episode_spec"]))
    assert np.array_equal(first, rollout(env, actions, info_keys, options=spec))


def play_episode(env: gym.Env, policy: Any, seed: int | None = None) -> list[dict[str, Any]]:
    """Run ``policy`` (SB3-style ``predict``, ``episode_start`` set on the first step) for one
    episode from ``reset(seed=seed)``; the ``info`` of every step (the last is the episode's).
    Every action must lie in the action space."""
    obs, _ = env.reset(seed=seed)
    start = np.ones(1, dtype=bool)
    infos = []
    while True:
        action, _ = policy.predict(obs, episode_start=start)
        start = np.zeros(1, dtype=bool)
        assert env.action_space.contains(np.asarray(action, dtype=np.float32))
        obs, _, terminated, truncated, info = env.step(action)
        infos.append(info)
        if terminated or truncated:
            return infos
