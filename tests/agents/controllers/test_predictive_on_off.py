"""The delay-aware on-off law: travel still to go after the commands in flight and the servo's
coasting, rounded to one step of the motors."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_agents.controllers.predictive_on_off import (
    PredictiveOnOffController,
    digits_of,
    signs_of,
)
from planar3p_agents.policies.factory import load_policy
from planar3p_gym.envs.actuation import on_off_action
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

GAIN = 6.0


class Fixed:
    """A stand-in for the simple motions returning given rates (fractions of ``max_speed``)."""

    position_gain = GAIN

    def __init__(self, rates):
        self.rates = np.asarray(rates, dtype=np.float64)

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return np.tile(self.rates, (len(np.atleast_2d(observation)), 1)), state


def _controller(rates, **kwargs) -> PredictiveOnOffController:
    c = PredictiveOnOffController(**kwargs)
    c.inner = Fixed(rates)
    return c


def _obs(dx: float = 0.01, rho_dot=(0.0, 0.0, 0.0)) -> np.ndarray:
    obs = np.zeros(OBS_SIZE)
    obs[SLICES["position_error"]] = (dx, 0.0)
    obs[SLICES["rho_dot"]] = rho_dot
    return obs


def _rate_of_travel(c: PredictiveOnOffController, travel: float) -> float:
    """The rate (fraction of ``max_speed``) whose travel to go is ``travel`` (m)."""
    return travel * GAIN / c.design.max_speed


def test_quantum_is_one_step_at_the_rated_speed() -> None:
    c = PredictiveOnOffController()
    assert c.quantum == pytest.approx(0.1 * c.design.max_speed * 0.02)


@settings(max_examples=30, deadline=None)
@given(steps=st.floats(-3.0, 3.0), flight=st.sampled_from([-1, 0, 1]))
def test_a_motor_runs_while_more_than_half_a_step_is_left(steps: float, flight: int) -> None:
    """With ``d`` steps to go and ``f`` in flight the motor runs towards ``d - f`` exactly when
    ``|d - f| > 1/2`` (no coasting: the slider is at rest)."""
    c = PredictiveOnOffController()
    c.inner = Fixed([_rate_of_travel(c, steps * c.quantum), 0.0, 0.0])
    signed = c.signed_commands(_obs()[None], np.array([[flight, 0, 0]]))[0]
    rest = steps - flight
    expected = 0 if abs(rest) <= 0.5 + 1e-9 else int(np.sign(rest))
    if abs(abs(rest) - 0.5) > 1e-6:  # away from the rounding tie
        assert signed.tolist() == [expected, 0, 0]


def test_the_servos_coasting_counts_as_travel() -> None:
    c = PredictiveOnOffController(servo_lag=0.02)
    # 0.5 mm to go, the slider moving at 0.02 m/s: 0.4 mm of coasting leaves 0.1 mm, < q / 2.
    c.inner = Fixed([_rate_of_travel(c, 0.0005), 0.0, 0.0])
    assert c.signed_commands(_obs(rho_dot=(0.02, 0, 0))[None], np.zeros((1, 3)))[0, 0] == 0
    assert c.signed_commands(_obs()[None], np.zeros((1, 3)))[0, 0] == 1


def test_every_motor_stops_inside_the_task_space_band() -> None:
    c = _controller([0.5, -0.5, 0.5])
    inside = _obs(0.0009)
    inside[SLICES["orientation_error"]] = math.radians(0.4)
    assert c.predict(inside)[0].tolist() == [0, 0, 0]
    assert c.predict(_obs(0.0011))[0].tolist() == [1, 2, 1]


def test_the_state_is_the_commands_in_flight() -> None:
    c = _controller([0.5, -0.5, 0.0], delay=1)
    action, state = c.predict(_obs(), episode_start=np.ones(1, dtype=bool))
    assert action.tolist() == [1, 2, 0] and state.tolist() == [[[1, -1, 0]]]
    c2 = _controller([0.5, -0.5, 0.0], delay=2)
    _, state = c2.predict(_obs())
    _, state = c2.predict(_obs(), state=state)
    assert state.tolist() == [[[1, -1, 0], [1, -1, 0]]]
    # An episode start empties the line; a plain loop that drops the state is remembered.
    _, fresh = c2.predict(_obs(), state=state, episode_start=np.ones(1, dtype=bool))
    assert fresh.tolist() == [[[0, 0, 0], [1, -1, 0]]]
    c2.reset()
    assert c2.predict(_obs())[1].tolist() == [[[0, 0, 0], [1, -1, 0]]]


def test_discrete_indices_and_batches() -> None:
    c = _controller([0.5, -0.5, 0.0], discrete=True)
    assert int(c.predict(_obs())[0]) == 1 * 9 + 2 * 3
    assert c.predict(np.stack([_obs(), _obs(0.0)]))[0].tolist() == [15, 0]


def test_bad_arguments_are_refused() -> None:
    for kwargs, name in (
        ({"delay": 3}, "delay"),
        ({"servo_lag": -0.01}, "servo_lag"),
        ({"dt": 0.0}, "dt"),
        ({"relative": 1.5}, "relative"),
        ({"discrete": 1}, "discrete"),
    ):
        with pytest.raises(ValueError, match=name):
            PredictiveOnOffController(**kwargs)
    with pytest.raises(ValueError, match="state"):
        PredictiveOnOffController().predict(_obs(), state=np.zeros((1, 3)))


def test_baseline_reads_the_environment() -> None:
    env = gym.make("Planar3PRealOnOff-v0")
    policy = load_policy("analytic-on-off-predictive", env)
    assert isinstance(policy, PredictiveOnOffController)
    assert policy.delay == 1 and policy.dt == env.unwrapped.dt and not policy.discrete
    discrete_env = gym.make("Planar3PRealOnOff-v0", action_type="on-off-discrete")
    discrete = load_policy("analytic-on-off-predictive", discrete_env)
    assert discrete.discrete
    env.close()


def test_it_brings_a_built_machine_to_rest_at_the_target() -> None:
    """A seeded episode of the built machine (deterministic): success, and no motor runs at
    the end."""
    env = gym.make("Planar3PRealOnOff-v0")
    policy = load_policy("analytic-on-off-predictive", env)
    obs, _ = env.reset(seed=3)
    state, start = None, np.ones(1, dtype=bool)
    for _ in range(1000):
        action, state = policy.predict(obs, state=state, episode_start=start)
        start = np.zeros(1, dtype=bool)
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    assert info["is_success"] and action.tolist() == [0, 0, 0]
    env.close()


@given(st.lists(st.integers(0, 2), min_size=3, max_size=3))
def test_motor_commands_and_signs_are_the_environments_encoding(digits):
    """A motor command's sign is the slider direction the environment runs it in, and
    ``digits_of`` inverts ``signs_of``."""
    signs = signs_of(digits)
    assert signs.tolist() == [int(c) for c in on_off_action(np.array(digits), "on-off")]
    assert digits_of(signs).tolist() == digits
