"""The machine's actuation and sensing component (:mod:`planar3p_gym.envs.actuation`)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_gym.envs.actuation import ON_OFF_COMMANDS, BuiltMachine
from planar3p_gym.machine.design import Design
from planar3p_gym.sim.randomization import REALISTIC_RANDOMIZATION
from planar3p_gym.sim.sensors import REALISTIC_SENSORS

DESIGN = Design.fig8()
DT = 0.02
finite = st.floats(-5.0, 5.0, allow_nan=False)


@given(st.tuples(finite, finite, finite))
@settings(max_examples=50, deadline=None)
def test_the_nominal_machine_is_the_identity(action):
    """No feature on: the executed action is the policy's clipped to [-1, 1], and the
    observed state is the true one (the same object)."""
    machine = BuiltMachine(DESIGN, DT)
    assert machine.nominal
    machine.begin(np.random.default_rng(0))
    got = machine.command(np.array(action, dtype=np.float64))
    assert got == tuple(float(np.clip(a, -1.0, 1.0)) for a in action)
    assert machine.delay(obs := np.zeros(3)) is obs


def test_the_action_delay_executes_the_action_of_n_steps_before_and_a_stop_first():
    machine = BuiltMachine(DESIGN, DT, latency={"action_delay": 2})
    machine.begin(np.random.default_rng(0))
    actions = [(0.1, 0.2, 0.3), (0.4, 0.5, 0.6), (-0.1, -0.2, -0.3), (1.0, 1.0, 1.0)]
    executed = [machine.command(np.array(a)) for a in actions]
    assert executed == [(0.0, 0.0, 0.0), (0.0, 0.0, 0.0), actions[0], actions[1]]


def test_a_rejected_action_changes_no_delay_line():
    machine = BuiltMachine(DESIGN, DT, latency={"action_delay": 1})
    machine.begin(np.random.default_rng(0))
    machine.command(np.array([0.5, 0.5, 0.5]))
    with pytest.raises(ValueError, match="action"):
        machine.command(np.array([np.nan, 0.0, 0.0]))
    assert machine.command(np.array([0.0, 0.0, 0.0])) == (0.5, 0.5, 0.5)


@pytest.mark.parametrize("action_type", ["on-off", "on-off-discrete"])
def test_on_off_commands_run_at_the_rated_speed(action_type):
    machine = BuiltMachine(DESIGN, DT, action_type=action_type, on_off_speed=0.25)
    machine.begin(np.random.default_rng(0))
    for digits in [(0, 1, 2), (2, 2, 1), (1, 0, 0)]:
        action = digits if action_type == "on-off" else 9 * digits[0] + 3 * digits[1] + digits[2]
        expected = tuple(0.25 * ON_OFF_COMMANDS[d] for d in digits)
        assert machine.command(np.array(action)) == expected


def test_the_encoders_read_through_the_nominal_model_and_draw_from_the_given_generator():
    """With encoders the policy's state is a reading (noise from the generator passed, the
    same draws for the same generator state), measured through the nominal model."""
    env = gym.make("Planar3P-v0").unwrapped
    env.reset(seed=0)
    state = env.sim.state
    machine = BuiltMachine(DESIGN, DT, sensors=REALISTIC_SENSORS)
    machine.begin(np.random.default_rng(0))
    true = machine.measures(state)
    seen, seen_measures = machine.sense(state, true, np.random.default_rng(5))
    again, _ = machine.sense(state, true, np.random.default_rng(5))
    assert seen == again and seen != state
    assert seen_measures == machine.kin.measures(seen.pose, seen.rho)
    env.close()


def test_a_drawn_machine_gives_the_true_measures_and_is_in_the_snapshot():
    machine = BuiltMachine(DESIGN, DT, randomization=REALISTIC_RANDOMIZATION)
    env = gym.make("Planar3P-v0").unwrapped
    env.reset(seed=0)
    start, mode = env.episode.spec["start"], env.episode.mode
    nominal = machine.episode.machine
    drawn = machine.draw(np.random.default_rng(1), start, mode)
    assert drawn.design != DESIGN and machine.episode.machine is nominal  # (the draw alone)
    sim = machine.simulation(drawn, None, start, mode, env.settings)
    assert machine.episode.machine is drawn and machine.episode.true_kin.design == drawn.design
    assert sim.design == drawn.design
    record = machine.get_state()
    machine.simulation(
        machine.draw(np.random.default_rng(2), start, mode), sim, start, mode, env.settings
    )
    assert machine.episode.machine != drawn
    machine.set_state(record)
    assert machine.episode.machine == drawn
    sim.close()
    env.close()


def test_the_config_names_only_the_features_that_are_on():
    assert BuiltMachine(DESIGN, DT).config() == {}
    on = BuiltMachine(DESIGN, DT, latency={"action_delay": 1}, action_type="on-off").config()
    assert set(on) == {"latency", "action_type", "on_off_speed"}


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"action_type": "pwm"}, "action_type"),
        ({"on_off_speed": 0.0}, "on_off_speed"),
        ({"latency": {"action_delay": 3}}, "action_delay"),
        ({"sensors": {"nosuch": 1}}, "sensors"),
    ],
)
def test_bad_settings_are_rejected_naming_the_argument(kwargs, name):
    with pytest.raises(ValueError, match=name):
        BuiltMachine(DESIGN, DT, **kwargs)
