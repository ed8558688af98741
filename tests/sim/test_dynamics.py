"""The built machine's imperfections in the physics (planar3p_gym.sim.dynamics): the ideal machine
is the default model bit for bit, each imperfection changes the motion as its law says, and
snapshots replay it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planar3p_gym.machine.design import Design
from planar3p_gym.sim.dynamics import IDEAL, MachineDynamics
from planar3p_gym.sim.physics import PROJECTED_ITERATIONS, PROJECTED_SUBSTEPS, Planar3PSim

DESIGN = Design.fig8()
START = (0.08041, 0.192845, -0.276906)  # reachable in (1, 1, -1), well inside the stroke
MODE = (1, 1, -1)
COMMAND = (0.02, 0.02, 0.02)  # m/s, every slider the same way: a horizontal translation
PROJECTED = {"projection": True, "substeps": PROJECTED_SUBSTEPS, "iterations": PROJECTED_ITERATIONS}


def _run(dynamics=None, steps: int = 20, command=COMMAND, **kw):
    sim = Planar3PSim(DESIGN, START, MODE, dynamics=dynamics, **(kw or PROJECTED))
    for _ in range(steps):
        state = sim.step(command)
    return sim, state


@pytest.mark.parametrize("settings", [PROJECTED, {"projection": False}])
def test_the_ideal_machine_is_the_default_model_bit_for_bit(settings):
    _, a = _run(None, **settings)
    _, b = _run(IDEAL, **settings)
    _, c = _run({}, **settings)
    assert a == b == c
    assert Planar3PSim(DESIGN, START, MODE, dynamics=IDEAL).get_state().settings == (
        Planar3PSim(DESIGN, START, MODE).get_state().settings
    )


@pytest.mark.parametrize(
    "field,value",
    [
        ("inertia_scale", 2.0),
        ("slider_coulomb", 3.0),
        ("slider_viscous", 10.0),
        ("joint_coulomb", 0.05),
        ("joint_viscous", 0.002),
        ("servo_lag", 0.05),
        ("gravity_tilt", 0.05),
    ],
)
def test_each_imperfection_changes_the_motion_and_snapshots_replay_it(field, value):
    _, nominal = _run(None)
    sim, state = _run(MachineDynamics(**{field: value}))
    assert state != nominal
    assert state.finite and state.closure_error < 1e-9
    again = Planar3PSim.from_state(sim.get_state())
    assert again.state == state
    assert again.step(COMMAND) == sim.step(COMMAND)


def _signed_change(f0: float, f1: float, df: float) -> float:
    """How far the magnitude ``f1`` is from ``|F0 + df|`` for the signed force ``F0`` of
    magnitude ``f0`` (either sign: the servo forces are reported as magnitudes)."""
    return min(abs(abs(f0 + df) - f1), abs(abs(-f0 + df) - f1))


def test_coulomb_friction_of_a_moving_slider_adds_its_force_to_the_servo():
    """At a constant rate the servo pushes the slider through the friction: its mean force
    changes by exactly the friction force (same sign as the motion)."""
    _, nominal = _run(None)
    friction = 3.0
    _, state = _run(MachineDynamics(slider_coulomb=friction))
    # The servo force is reported as a magnitude; the sign follows from the nominal force
    # the servo applies (for sliders pushed against the motion the magnitude falls).
    for f0, f1 in zip(nominal.actuator_forces, state.actuator_forces, strict=True):
        assert _signed_change(f0, f1, friction) < 1e-9
    assert state.rho_dot == pytest.approx(nominal.rho_dot, abs=1e-12)


def test_viscous_friction_of_a_moving_slider_adds_c_v_to_the_servo():
    _, nominal = _run(None, steps=30)
    c = 10.0
    _, state = _run(MachineDynamics(slider_viscous=c), steps=30)
    for f0, f1, v in zip(
        nominal.actuator_forces, state.actuator_forces, state.rho_dot, strict=True
    ):
        # |F| changes by c v.  The force is explicit: c times the rate at the start of the
        # physics step, before the solver and the projection settle it (a change of the order of
        # 1e-5 m/s at 0.02 m/s here), hence 0.5 % of c v.
        assert _signed_change(f0, f1, c * v) < 0.005 * c * abs(v)


def test_servo_lag_is_a_first_order_lag_of_the_setpoint_velocity():
    tau, dt = 0.05, 0.02
    sim = Planar3PSim(DESIGN, START, MODE, dynamics={"servo_lag": tau}, **PROJECTED)
    for k in range(1, 6):
        sim.step(COMMAND)
        expected = COMMAND[0] * (1.0 - math.exp(-k * dt / tau))
        for drive in sim.drives:
            assert drive.velocity.x == pytest.approx(expected, rel=1e-12)


def test_a_tilted_base_tilts_gravity():
    g = MachineDynamics(gravity_tilt=0.1).gravity_vector(9.81)
    assert g == pytest.approx((9.81 * math.sin(0.1), -9.81 * math.cos(0.1)), rel=1e-15)
    sim, _ = _run(MachineDynamics(gravity_tilt=0.1), steps=1)
    assert tuple(sim.space.gravity) == pytest.approx(g, rel=1e-15)


def test_the_inertia_scale_scales_the_rods_moments_of_inertia():
    sim, _ = _run(MachineDynamics(inertia_scale=1.5), steps=1)
    k1 = DESIGN.joint_offsets[0]
    assert sim.platform.moment == pytest.approx(
        1.5 * DESIGN.platform_mass * k1 * k1 / 12, rel=1e-14
    )
    for leg, L in zip(sim.legs, DESIGN.leg_lengths, strict=True):
        assert leg.moment == pytest.approx(1.5 * DESIGN.leg_mass * L * L / 12, rel=1e-14)


def test_the_machine_holds_still_with_friction():
    _, nominal = _run(None, steps=50, command=(0.0, 0.0, 0.0))
    _, state = _run(
        MachineDynamics(slider_coulomb=2.0, joint_coulomb=0.01, slider_viscous=5.0),
        steps=50,
        command=(0.0, 0.0, 0.0),
    )
    assert state.pose == pytest.approx(nominal.pose, abs=1e-9)


@pytest.mark.parametrize(
    "kwargs,name",
    [
        ({"inertia_scale": 0.0}, "inertia_scale"),
        ({"slider_coulomb": -1.0}, "slider_coulomb"),
        ({"joint_viscous": math.nan}, "joint_viscous"),
        ({"servo_lag": True}, "servo_lag"),
        ({"gravity_tilt": 2.0}, "gravity_tilt"),
        ({"slider_viscous": 1j}, "slider_viscous"),
    ],
)
def test_bad_dynamics_are_refused_naming_the_field(kwargs, name):
    with pytest.raises(ValueError, match=name):
        MachineDynamics(**kwargs)


def test_unstable_explicit_viscous_friction_is_refused():
    with pytest.raises(ValueError, match="slider_viscous"):
        Planar3PSim(DESIGN, START, MODE, dynamics={"slider_viscous": 1e3}, **PROJECTED)
    with pytest.raises(ValueError, match="joint_viscous"):
        Planar3PSim(DESIGN, START, MODE, dynamics={"joint_viscous": 1.0}, **PROJECTED)
    with pytest.raises(ValueError, match="unknown dynamics"):
        Planar3PSim(DESIGN, START, MODE, dynamics={"viscosity": 1.0})
    assert np.isfinite(_run(MachineDynamics(slider_viscous=20.0))[1].rho).all()
