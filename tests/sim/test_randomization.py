"""Domain randomisation (planar3p_gym.sim.randomization): zero ranges are the nominal machine
and draw nothing; each range changes its own quantities only, within the range."""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planar3p_gym.machine.design import Design
from planar3p_gym.sim.dynamics import IDEAL
from planar3p_gym.sim.randomization import REALISTIC_RANDOMIZATION, DynamicsRandomization

NOMINAL = Design.fig8()
#: A nonzero range of each field (within its validation bounds).
RANGES = {
    "mass": 0.2,
    "inertia": 0.2,
    "leg_length": 1e-3,
    "joint_position": 1e-3,
    "rail_offset": 1e-3,
    "max_force": 0.2,
    "slider_coulomb": 2.0,
    "slider_viscous": 5.0,
    "joint_coulomb": 0.01,
    "joint_viscous": 0.002,
    "servo_lag": 0.04,
    "gravity_tilt": 0.02,
}


def _quantities(machine) -> dict[str, tuple[float, ...]]:
    """The randomised quantities of a drawn machine, by the range that draws them."""
    d, dyn = machine.design, machine.dynamics
    return {
        "mass": (d.slider_mass, d.leg_mass, d.platform_mass),
        "inertia": (dyn.inertia_scale,),
        "leg_length": d.leg_lengths,
        "joint_position": d.spacings,
        "rail_offset": d.rail_origins,
        "max_force": (d.max_force,),
        "slider_coulomb": (dyn.slider_coulomb,),
        "slider_viscous": (dyn.slider_viscous,),
        "joint_coulomb": (dyn.joint_coulomb,),
        "joint_viscous": (dyn.joint_viscous,),
        "servo_lag": (dyn.servo_lag,),
        "gravity_tilt": (dyn.gravity_tilt,),
    }


def test_every_field_has_a_test_range():
    assert set(RANGES) == {f.name for f in fields(DynamicsRandomization)}


def test_zero_ranges_are_the_nominal_machine_and_draw_nothing():
    rng = np.random.default_rng(0)
    before = rng.bit_generator.state
    machine = DynamicsRandomization().sample(NOMINAL, rng)
    assert machine.design is NOMINAL and machine.dynamics == IDEAL
    assert rng.bit_generator.state == before
    assert DynamicsRandomization().is_zero and not REALISTIC_RANDOMIZATION.is_zero


@pytest.mark.parametrize("name", sorted(RANGES))
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_each_range_changes_its_quantities_only_within_the_range(name, seed):
    r = RANGES[name]
    machine = DynamicsRandomization(**{name: r}).sample(NOMINAL, np.random.default_rng(seed))
    drawn, nominal = (
        _quantities(machine),
        _quantities(DynamicsRandomization().sample(NOMINAL, None)),
    )
    for key in drawn:
        if key != name:
            assert drawn[key] == nominal[key], key
    new, old = np.array(drawn[name]), np.array(nominal[name])
    assert (new != old).any()  # a uniform draw hits the nominal value with probability 0
    if name in ("mass", "inertia", "max_force"):
        assert (np.abs(new / old - 1.0) <= r * (1 + 1e-12)).all()
    elif name in ("leg_length", "joint_position", "rail_offset", "gravity_tilt"):
        assert (np.abs(new - old) <= r * (1 + 1e-12) + 1e-15).all()
    else:
        assert ((new >= 0.0) & (new <= r)).all()
    assert machine.design.characteristic_length == NOMINAL.characteristic_length


def test_the_same_generator_state_draws_the_same_machine():
    a = REALISTIC_RANDOMIZATION.sample(NOMINAL, np.random.default_rng(7))
    b = REALISTIC_RANDOMIZATION.sample(NOMINAL, np.random.default_rng(7))
    c = REALISTIC_RANDOMIZATION.sample(NOMINAL, np.random.default_rng(8))
    assert a == b and a != c
    assert a.to_dict()["design"]["leg_lengths"] == list(a.design.leg_lengths)


@pytest.mark.parametrize(
    "kwargs,name",
    [
        ({"mass": -0.1}, "mass"),
        ({"mass": 0.95}, "mass"),
        ({"leg_length": 0.5}, "leg_length"),
        ({"gravity_tilt": math.nan}, "gravity_tilt"),
        ({"servo_lag": "0.1"}, "servo_lag"),
        ({"joint_coulomb": False}, "joint_coulomb"),
    ],
)
def test_bad_ranges_are_refused_naming_the_field(kwargs, name):
    with pytest.raises(ValueError, match=name):
        DynamicsRandomization(**kwargs)


@settings(max_examples=200, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    mass=st.floats(0.0, 0.9),
    inertia=st.floats(0.0, 0.9),
    leg=st.floats(0.0, 0.01),
    slider=st.floats(0.0, 20.0),
    joint=st.floats(0.0, 0.01),
)
def test_no_drawn_machine_needs_a_shorter_step_than_the_longest_step(
    seed, mass, inertia, leg, slider, joint
):
    """``longest_step`` bounds the viscous limits of every machine the ranges can draw (the
    worst draw is the lightest, shortest, most damped one), so a step below it integrates them
    all; and the check refuses a step just above it and accepts one just below."""
    from planar3p_gym.sim.dynamics import viscous_step_limits

    r = DynamicsRandomization(
        mass=mass, inertia=inertia, leg_length=leg, slider_viscous=slider, joint_viscous=joint
    )
    limit = r.longest_step(NOMINAL)
    machine = r.sample(NOMINAL, np.random.default_rng(seed))
    assert min(viscous_step_limits(machine.design, machine.dynamics)) >= limit * (1 - 1e-12)
    if math.isfinite(limit):
        with pytest.raises(ValueError, match="control_frequency must exceed"):
            r.check_step(NOMINAL, 1.0 / limit * (1 - 1e-9), 1)
        r.check_step(NOMINAL, 1.0 / limit * (1 + 1e-9), 1)
        r.check_step(NOMINAL, 0.5 / limit, 3)  # (three steps of a third)
