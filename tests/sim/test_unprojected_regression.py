"""Regression guard: the unprojected model (``projection=False``) stays bit-identical.

``Planar3P-v0`` ran this model until 0.2.0; every seeded episode of it must replay exactly as it
did when the hashes below were recorded (observations, rewards, episode ends and the physical
quantities in ``info``), so fidelity studies against it stay comparable across releases.  The
task sampler draws other episodes from a seed since its proposal region
(``planar3p_gym/tasks/pose_proposal.py``), so the episodes 0.2.0 drew are given as reset options
(``unprojected_episodes.json``, beside this file); the seeds still seed the actions.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_agents.controllers.analytic import AnalyticController

#: sha256 of the replayed streams, recorded on the released ``Planar3P-v0``; three recorded
#: again when every angle took the one wrap into ``(-pi, pi]`` (``planar3p_gym.machine.angles``:
#: wrapped angles differ from 0.2.0's in the last bits).
EXPECTED = {
    ("random", 0, "default"): "4a1b67e30dabd82a49a739e2b50c4bb4c349ed95076aa8cb9098b7faed477dce",
    ("random", 1, "random_mode"): (
        "b848441e0ca0c3de2d27836c69ab0adabfb61c496725cceb96f15df358faf381"
    ),
    ("analytic", 2, "default"): "fcce27e5dad1eeaf8b234cb4975330b84fd956ae3343d1815e1ffc9fc619651b",
    ("analytic", 3, "random_mode"): (
        "0ae56232a06653f182043f0bf5e81083b3a6a15f94b132ca6ae6c1a990f56e48"
    ),
}

INFO_KEYS = ("pose", "rho", "rho_dot", "actuator_forces", "closure_error", "parallel_margin")
#: The episodes of each stream as 0.2.0 drew them: key ``"policy/seed/variant"``.
EPISODES = json.loads((Path(__file__).parent / "unprojected_episodes.json").read_text())["episodes"]


def episode_digest(policy: str, seed: int, variant: str, steps: int = 300) -> str:
    """Hash of ``steps`` steps (resetting as episodes end, on the recorded episodes) of
    ``policy`` from ``seed``."""
    kwargs = {"working_mode": "random"} if variant == "random_mode" else {}
    env = gym.make("Planar3P-v0", projection=False, **kwargs)
    h = hashlib.sha256()
    episodes = iter(EPISODES[f"{policy}/{seed}/{variant}"])
    obs, info = env.reset(seed=seed, options=next(episodes))
    h.update(obs.tobytes())
    actions = np.random.default_rng(seed).uniform(-1.0, 1.0, size=(steps, 3)).astype(np.float32)
    ctrl = AnalyticController.from_env(env, mode="simultaneous") if policy == "analytic" else None
    start = True
    for a in actions:
        if ctrl is not None:
            a, _ = ctrl.predict(obs, episode_start=np.array([start]))
        start = False
        obs, reward, terminated, truncated, info = env.step(a)
        h.update(obs.tobytes())
        h.update(np.float64(reward).tobytes())
        h.update(bytes([terminated, truncated]))
        h.update(str(info["termination_reason"]).encode())
        for key in INFO_KEYS:
            h.update(np.asarray(info[key], dtype=np.float64).tobytes())
        if terminated or truncated:
            obs, info = env.reset(options=next(episodes))
            h.update(obs.tobytes())
            start = True
    env.close()
    return h.hexdigest()


@pytest.mark.parametrize("key", sorted(EXPECTED))
def test_planar3p_v0_episodes_are_bit_identical(key):
    policy, seed, variant = key
    assert episode_digest(policy, seed, variant) == EXPECTED[key]
