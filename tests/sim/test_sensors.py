"""The encoders and the nominal model's pose (planar3p_gym.sim.sensors)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.sim.physics import Planar3PSim
from planar3p_gym.sim.sensors import (
    REALISTIC_SENSORS,
    Encoders,
    SensorConfig,
    joint_angle_beta,
    pose_from_joints,
)
from planar3p_gym.tasks import sampling

DESIGN = Design.fig8()
MODE = (1, 1, -1)
POSES = sampling.sample_poses(DESIGN, MODE, np.random.default_rng(0), sampling.TaskConfig())[0][:50]


@settings(max_examples=30, deadline=None)
@given(i=st.integers(0, len(POSES) - 1))
def test_the_pose_from_exact_joint_readings_is_the_pose(i):
    """Leg 1 as a serial chain: exact to rounding (the lengths are ~0.3 m: 1e-15 relative)."""
    pose = POSES[i]
    rho = kinematics.inverse(DESIGN, pose, MODE).rho
    u = kinematics.leg_vectors(DESIGN, pose, rho)
    alpha_1 = math.atan2(u[0, 1], u[0, 0])
    beta = joint_angle_beta(tuple(pose), alpha_1)
    assert math.isclose(float(pose[2]), beta + alpha_1 - math.pi, abs_tol=1e-12) or math.isclose(
        abs(float(pose[2]) - (beta + alpha_1 - math.pi)), 2 * math.pi, abs_tol=1e-12
    )
    got = pose_from_joints(DESIGN, float(rho[0]), alpha_1, beta)
    assert got[:2] == pytest.approx(pose[:2], abs=1e-12)
    assert math.remainder(got[2] - pose[2], 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


def _state():
    sim = Planar3PSim(DESIGN, POSES[0], MODE, projection=True)
    for _ in range(5):
        state = sim.step((0.01, -0.01, 0.005))
    return state


def test_exact_encoders_read_the_true_state():
    state = _state()
    enc = Encoders(DESIGN, SensorConfig(), 0.02)
    seen = enc.measure(state, np.random.default_rng(0))
    assert seen.rho == state.rho and seen.leg_angles == pytest.approx(state.leg_angles, abs=1e-15)
    assert seen.pose == pytest.approx(state.pose, abs=1e-12)
    assert seen.rho_dot == (0.0, 0.0, 0.0) and seen.twist == (0.0, 0.0, 0.0)  # first reading
    assert (seen.time, seen.actuator_forces, seen.closure_error) == (
        state.time,
        state.actuator_forces,
        state.closure_error,
    )


def test_rates_are_backward_differences_of_the_readings():
    enc = Encoders(DESIGN, REALISTIC_SENSORS, 0.02)
    rng = np.random.default_rng(1)
    state = _state()
    first = enc.measure(state, rng)
    second = enc.measure(state, rng)
    assert second.rho_dot == pytest.approx(
        [(b - a) / 0.02 for a, b in zip(first.rho, second.rho, strict=True)], abs=1e-12
    )
    enc.reset()
    assert enc.measure(state, rng).rho_dot == (0.0, 0.0, 0.0)


def test_readings_are_quantised_and_noisy_within_a_few_sigma():
    cfg = SensorConfig(slider_noise=5e-6, slider_resolution=1e-5, angle_resolution=1e-3)
    state = _state()
    enc = Encoders(DESIGN, cfg, 0.02)
    rng = np.random.default_rng(2)
    for _ in range(20):
        seen = enc.measure(state, rng)
        for r, true in zip(seen.rho, state.rho, strict=True):
            assert abs(r / 1e-5 - round(r / 1e-5)) < 1e-6
            # noise of 5 um (seeded: the draws are fixed) plus half a count
            assert abs(r - true) <= 6 * 5e-6 + 0.5e-5
        for a, true in zip(seen.leg_angles, state.leg_angles, strict=True):
            assert abs(math.remainder(a - true, 2 * math.pi)) <= 0.5e-3 + 1e-12


def test_no_noise_no_draw():
    rng = np.random.default_rng(3)
    before = rng.bit_generator.state
    Encoders(DESIGN, SensorConfig(slider_resolution=1e-5), 0.02).measure(_state(), rng)
    assert rng.bit_generator.state == before


@pytest.mark.parametrize(
    "kwargs,name",
    [({"slider_noise": -1.0}, "slider_noise"), ({"angle_resolution": 1.0}, "angle_resolution")],
)
def test_bad_sensor_settings_are_refused(kwargs, name):
    with pytest.raises(ValueError, match=name):
        SensorConfig(**kwargs)
