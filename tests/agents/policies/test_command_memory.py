"""The command in flight appended to the observation: in training (a VecEnv wrapper) and in
play (from the policy's state), the same encoding."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from stable_baselines3.common.vec_env import DummyVecEnv

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_agents.policies.command_memory import (
    COMMAND_ENTRIES,
    VecCommandMemory,
    command_one_hot,
    observed_commands,
    with_command_memory,
)
from planar3p_gym.tasks.observation import OBS_SIZE

ID = "Planar3PRealOnOff-v0"
STOP = [1, 0, 0, 1, 0, 0, 1, 0, 0]


@settings(max_examples=30, deadline=None)
@given(st.lists(st.integers(0, 2), min_size=3, max_size=3))
def test_one_hot_marks_each_motors_command(command: list[int]) -> None:
    one_hot = command_one_hot(command)[0]
    assert one_hot.sum() == 3
    for motor, c in enumerate(command):
        assert one_hot[3 * motor + c] == 1.0


def test_one_hot_refuses_unknown_commands() -> None:
    with pytest.raises(ValueError, match="0, 1 or 2"):
        command_one_hot([0, 3, 1])


def test_wrapper_appends_the_last_command_and_a_stop_after_a_reset() -> None:
    venv = VecCommandMemory(DummyVecEnv([lambda: gym.make(ID, max_episode_steps=3)] * 2))
    assert venv.observation_space.shape == (OBS_SIZE + COMMAND_ENTRIES,)
    venv.seed(0)
    obs = venv.reset()
    assert obs[:, OBS_SIZE:].tolist() == [STOP, STOP]
    actions = np.array([[1, 2, 0], [0, 0, 1]])
    for step in range(3):
        obs, _, dones, infos = venv.step(actions)
        if step < 2:
            np.testing.assert_array_equal(obs[:, OBS_SIZE:], command_one_hot(actions))
    # The time limit ended both: the new episodes start with a stop in flight, the ended ones
    # keep the command sent last.
    assert dones.all() and obs[:, OBS_SIZE:].tolist() == [STOP, STOP]
    for i in range(2):
        last = infos[i]["terminal_observation"]
        np.testing.assert_array_equal(last[OBS_SIZE:], command_one_hot(actions[i])[0])
    venv.close()


def test_wrapper_refuses_other_actions() -> None:
    with pytest.raises(ValueError, match="MultiDiscrete"):
        VecCommandMemory(DummyVecEnv([lambda: gym.make("Planar3P-v0")]))


def test_play_observation_is_the_training_one() -> None:
    env = gym.make(ID)
    obs, _ = env.reset(seed=1)
    full, single = with_command_memory(obs, None, None)
    assert single and full.shape == (1, OBS_SIZE + COMMAND_ENTRIES)
    assert full[0, OBS_SIZE:].tolist() == STOP
    full, _ = with_command_memory(obs, np.array([[2, 1, 0]]), np.zeros(1, dtype=bool))
    np.testing.assert_array_equal(full[0, OBS_SIZE:], command_one_hot([2, 1, 0])[0])
    np.testing.assert_array_equal(full[0, :OBS_SIZE], obs)
    full, _ = with_command_memory(obs, np.array([[2, 1, 0]]), np.ones(1, dtype=bool))
    assert full[0, OBS_SIZE:].tolist() == STOP
    env.close()


def test_observed_commands_of_a_class_or_an_alias() -> None:
    class Observes:
        observed_commands = 1

    assert observed_commands(Observes) == 1 and observed_commands("MlpPolicy") == 0
