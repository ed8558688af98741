"""Every registered id is frozen: its seeded episodes replay bit for bit.

For each id a random policy (seeded) plays ``STEPS`` steps from ``reset(seed=...)``, resetting
as episodes end; the observations, rewards, episode ends and the physical quantities of
``info`` are hashed.  A change to the physics, a task's sampler, its reward or its observation
fails here.  Such a change must be deliberate, and then it is a new id: register ``<Name>-vN+1``
beside the old id (which keeps its hash and stays registered), record the new id's hash
(``python tests/envs/test_episode_hashes.py`` prints every id's), and name the change in
CHANGELOG.md and in the env's Version History.  A newly registered id without a recorded hash
fails too.
"""

from __future__ import annotations

import hashlib
import re

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym

#: Steps hashed per id (episodes are reset as they end).
STEPS = 120
#: Seed of each id's first reset and of its random actions.
SEED = 3
INFO_KEYS = ("pose", "rho", "rho_dot", "actuator_forces", "closure_error", "parallel_margin")

#: sha256 of each id's stream as released (1.0.0), ``python tests/envs/test_episode_hashes.py``.
EXPECTED: dict[str, str] = {
    "Planar3P-v0": "807e69d03d68eeb7a4301ff5370efc173af79b6319eadf286bcb7cbc883ba582",
    "Planar3PGoal-v0": "8072aa2888490f26a2f565e77dd880b7b3ebf341882021b8583707efef91f74e",
    "Planar3PGoalDense-v0": "5482f9865e9a68249432319d75f5f06d21332bf2c03a925dcd1eeecc817b0899",
    "Planar3PTrack-v0": "0288ed749ecfadae8ac026bdaa9e89e53dee83de9e6ef6a2a666abeb663cf924",
    "Planar3PModeChange-v0": "5dca31433ef7b7065bcab220e49964600ef06ec30a6036f384aefc0650cfed43",
    "Planar3PAssemblyChange-v0": "718068f55b19101d14967df688724eed7d823d93dc465526f5e9f5cc78cad369",
    "Planar3PReal-v0": "a6d9ec59405c712b2ac091d3e0baff82f1eaf8793e948ac9edad1b0dd97ec21c",
    "Planar3PRealOnOff-v0": "824375ceabfc743170dbcb4b125cdf94dec7c95beee125ba926aa7edd32915bd",
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


#: What a developer does when an id's behaviour changes.
NEW_VERSION = (
    "register the changed behaviour as a new id ({next_id}) and keep {env_id} registered with "
    "its old behaviour; record {next_id}'s hash here (python tests/envs/test_episode_hashes.py) "
    "and name the change in CHANGELOG.md and in the env's Version History"
)


def next_version(env_id: str) -> str:
    """``Name-vN`` -> ``Name-v(N+1)``."""
    name, _, version = env_id.rpartition("-v")
    return f"{name}-v{int(version) + 1}"


def test_every_registered_id_has_a_recorded_hash():
    registered = {spec.id for spec in planar3p_gym.ENV_SPECS}
    missing = sorted(registered - set(EXPECTED))
    assert not missing, f"ids without a recorded episode hash: {missing}; record them here"
    gone = sorted(set(EXPECTED) - registered)
    assert not gone, (
        f"ids no longer registered: {gone}; a released id stays registered (its behaviour "
        "changes under a new -vN id)"
    )
    assert all(re.fullmatch(r"Planar3P\w*-v\d+", env_id) for env_id in registered), registered


@pytest.mark.parametrize("env_id", sorted(EXPECTED))
def test_seeded_episodes_replay_bit_for_bit(env_id):
    digest = episode_digest(env_id)
    assert digest == EXPECTED[env_id], (
        f"{env_id}'s seeded episodes changed (hash {digest}): "
        + NEW_VERSION.format(env_id=env_id, next_id=next_version(env_id))
    )


#: A stream through the constrained recovery (planar3p_gym.sim.recovery), which the streams
#: above do not reach: the assembly change's random actions of seed 4 lock the chain at a
#: parallel singularity from its first step, and 18 of these 60 steps are recovered.
RECOVERED = ("Planar3PAssemblyChange-v0", 60, 4)
RECOVERED_HASH = "74a19a58d77152c8efe3cb7e6fd3075a1b5620cf6037a0eda964f010a19ac5fa"


def test_recovered_steps_replay_bit_for_bit():
    env_id, steps, seed = RECOVERED
    env = gym.make(env_id)
    env.action_space.seed(seed)
    env.reset(seed=seed)
    recovered = 0
    for _ in range(steps):
        *_, terminated, truncated, _ = env.step(env.action_space.sample())
        recovered += env.unwrapped.sim.recovered
        if terminated or truncated:
            env.reset()
    env.close()
    assert recovered >= 10, f"the stream meant to cross the recovery recovered {recovered} steps"
    digest = episode_digest(env_id, steps, seed)
    assert digest == RECOVERED_HASH, (
        f"{env_id}'s recovered steps changed (hash {digest}): "
        + NEW_VERSION.format(env_id=env_id, next_id=next_version(env_id))
    )


def test_the_message_names_the_next_version():
    assert next_version("Planar3P-v0") == "Planar3P-v1"
    assert next_version("Planar3PGoalDense-v9") == "Planar3PGoalDense-v10"


if __name__ == "__main__":
    for spec in planar3p_gym.ENV_SPECS:
        print(f'    "{spec.id}": "{episode_digest(spec.id)}",')
