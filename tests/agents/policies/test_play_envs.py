"""planar3p_agents.policies.play_envs: the environment a model is played in."""

from __future__ import annotations

import gymnasium as gym
import pytest

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_agents.policies.play_envs import PlayEnvs, play_kwargs


@pytest.fixture
def on_off():
    env = gym.make("Planar3PRealOnOff-v0")
    yield env
    env.close()


def test_an_on_off_model_gets_its_own_encoding_of_the_same_motors(on_off) -> None:
    """A DQN model (one index) on a suite of three commands, and the other way round."""
    assert play_kwargs({"action_type": "on-off-discrete"}, on_off) == {
        "action_type": "on-off-discrete"
    }
    discrete = gym.make("Planar3PRealOnOff-v0", action_type="on-off-discrete")
    try:
        assert play_kwargs({"action_type": "on-off"}, discrete) == {"action_type": "on-off"}
    finally:
        discrete.close()


def test_the_machine_itself_is_never_changed(on_off) -> None:
    """Continuous and on-off motors are different machines: the suite's stays."""
    assert play_kwargs({"action_type": "continuous"}, on_off) == {}
    reach = gym.make("Planar3PReal-v0")
    try:
        assert play_kwargs({"action_type": "on-off-discrete"}, reach) == {}
        assert play_kwargs({"travel_goal": True, "max_speed": 0.5}, reach) == {"travel_goal": True}
        assert play_kwargs(None, reach) == {}
    finally:
        reach.close()


def test_play_envs_makes_the_variant_once_with_the_suites_other_arguments(on_off) -> None:
    envs = PlayEnvs()
    try:
        assert envs.get(on_off, {"action_type": "on-off"}) is on_off  # nothing to change
        variant = envs.get(on_off, {"action_type": "on-off-discrete", "max_speed": 0.5})
        assert variant is envs.get(on_off, {"action_type": "on-off-discrete"})
        assert isinstance(variant.action_space, gym.spaces.Discrete)
        assert variant.action_space.n == 27
        assert variant.spec.id == on_off.spec.id
        # the suite's own arguments (its randomised machine, sensors and delay) are kept
        assert variant.unwrapped.randomization == on_off.unwrapped.randomization
        assert variant.unwrapped.latency == on_off.unwrapped.latency
    finally:
        envs.close()
