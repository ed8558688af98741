"""The shipped pretrained policies load by name, act in the environment, say how they were made."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import planar3p_gym  # noqa: F401
from agents.policies import PRETRAINED_DIR, list_pretrained, load_policy

SHIPPED = list_pretrained()


def test_a_policy_is_shipped_small_with_its_statistics_and_provenance() -> None:
    assert SHIPPED, "agents/pretrained/ holds no policy"
    for name in SHIPPED:
        model = PRETRAINED_DIR / f"{name}.zip"
        assert model.stat().st_size < 5 * 2**20  # a few MB at most
        assert (PRETRAINED_DIR / f"{name}_vecnormalize.pkl").is_file()
        record = json.loads((PRETRAINED_DIR / f"{name}.json").read_text())
        assert "train.py" in record["run"]["command"]  # the command that reproduces it


@pytest.mark.parametrize("name", SHIPPED)
def test_pretrained_policy_loads_and_acts(name: str) -> None:
    env = gym.make("Planar3P-v0")
    policy = load_policy(f"pretrained:{name}", env=env)
    obs, info = env.reset(seed=11)
    start_error = info["position_error"]
    actions = []
    for _ in range(250):
        action, _ = policy.predict(obs, deterministic=True)
        action = np.asarray(action)
        assert action.shape == (3,) and np.isfinite(action).all()
        actions.append(action)
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    # Deterministic: the same observation gives the same action.
    np.testing.assert_array_equal(
        policy.predict(obs, deterministic=True)[0], policy.predict(obs, deterministic=True)[0]
    )
    # It acts, and brings the gripper much closer to the target (random actions do not).
    assert np.abs(np.array(actions)).max() > 0.05
    assert info["position_error"] < 0.2 * start_error
