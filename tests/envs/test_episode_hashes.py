"""Regression guard: seeded episodes of every registered id replay bit for bit.

For each id a random policy (seeded) plays ``STEPS`` steps from ``reset(seed=...)``, resetting
as episodes end; the observations, rewards, episode ends and the physical quantities of
``info`` are hashed.  A change to the physics, a task's sampler, its reward or its observation
fails here: such a change must be deliberate, and then the hashes below are regenerated once
(``python tests/envs/test_episode_hashes.py`` prints them) and the change is named in CHANGELOG.md.
"""

from __future__ import annotations

import hashlib

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym

#: Steps hashed per id (episodes are reset as they end).
STEPS = 120
#: Seed of each id's first reset and of its random actions.
SEED = 3
INFO_KEYS = ("pose", "rho", "rho_dot", "actuator_forces", "closure_error", "parallel_margin")

#: sha256 of each id's stream, recorded with ``python tests/envs/test_episode_hashes.py``.
EXPECTED: dict[str, str] = {
    "Planar3P-v0": "2aa76a18c9deb65dd0f4138a9747d656b455e4b9cc01a04f1f0c117c4136a500",
    "Planar3PGoal-v0": "482ff604fabbd055671962ac4b88bb6691935452937bb838da0b4ce7ded20f42",
    "Planar3PGoalDense-v0": "a6dfe884b12a07870d09149008a660c0ca9d09404ee375aa825e875c08374af0",
    "Planar3PTrack-v0": "875bf20df3926ab8228d4c23b1a2c75f09dfe01c5040572582fd6464786cb309",
    "Planar3PModeChange-v0": "09a70f8bc3296ded248c200f0ff16359c75f485bb963fcea7c351a134814a000",
    "Planar3PAssemblyChange-v0": "b5442c63a7b263943099dd55e58dd460a172a194a818a204443c489820a545b0",
    "Planar3PReal-v0": "a7a122c6e655de31288f054a8d50ce6374ce64878552ec2ea248c698c8fea6c4",
    "Planar3PRealOnOff-v0": "a7c99696c25266e93958770cdeef6af96f17bb6b08271153f95704ffa4b2a1df",
}


def _update(h: hashlib._Hash, value: object) -> None:
    if isinstance(value, dict):
        for key in sorted(value):
            h.update(key.encode())
            _update(h, value[key])
    else:
        h.update(np.ascontiguousarray(np.asarray(value, dtype=np.float64)).tobytes())


def episode_digest(env_id: str, steps: int = STEPS, seed: int = SEED) -> str:
    """Hash of ``steps`` steps of a seeded random policy on ``env_id`` (module docstring)."""
    env = gym.make(env_id)
    env.action_space.seed(seed)
    h = hashlib.sha256()
    obs, info = env.reset(seed=seed)
    _update(h, obs)
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        _update(h, obs)
        _update(h, [reward, float(terminated), float(truncated)])
        for key in INFO_KEYS:
            _update(h, info[key])
        if terminated or truncated:
            obs, info = env.reset()
            _update(h, obs)
    env.close()
    return h.hexdigest()


def test_every_registered_id_has_a_recorded_hash():
    assert sorted(EXPECTED) == sorted(spec.id for spec in planar3p_gym.ENV_SPECS)


@pytest.mark.parametrize("env_id", sorted(EXPECTED))
def test_seeded_episodes_replay_bit_for_bit(env_id):
    assert episode_digest(env_id) == EXPECTED[env_id]


if __name__ == "__main__":
    for spec in planar3p_gym.ENV_SPECS:
        print(f'    "{spec.id}": "{episode_digest(spec.id)}",')
