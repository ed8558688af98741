"""Holding forces against gravity, and the task's use of them."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planar3p_gym import Design
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.statics import holding_forces, holding_forces_at
from planar3p_gym.sim.physics import Planar3PSim
from planar3p_gym.tasks import sampling as task

DESIGN = Design.fig8()
ALL_MODES = list(itertools.product((1, -1), repeat=3))


def potential_energy(design: Design, pose: np.ndarray) -> float:
    """Gravitational potential energy (J) of the platform (uniform rod from G to C_1) and the
    legs (uniform rods from B_i on the rails, y = 0, to C_i)."""
    _, y, th = pose
    k = np.asarray(design.joint_offsets)
    platform = design.platform_mass * (y + 0.5 * k[0] * math.sin(th))
    legs = design.leg_mass * float(np.sum(0.5 * (y + k * math.sin(th))))
    return design.gravity * (platform + legs)


def numerical_holding_forces(design: Design, pose: np.ndarray, mode) -> np.ndarray:
    """``F = dV/drho`` by central differences in pose space: ``dV/dp = (drho/dp)^T F``."""
    eps = 1e-6
    d_rho = np.zeros((3, 3))
    d_v = np.zeros(3)
    for j in range(3):
        step = np.zeros(3)
        step[j] = eps
        hi, lo = pose + step, pose - step
        d_rho[:, j] = (
            kinematics.inverse(design, hi, mode).rho - kinematics.inverse(design, lo, mode).rho
        ) / (2 * eps)
        d_v[j] = (potential_energy(design, hi) - potential_energy(design, lo)) / (2 * eps)
    return np.linalg.solve(d_rho.T, d_v)


def holdable_poses(mode, n: int, seed: int = 0) -> np.ndarray:
    poses, _ = task.sample_poses(DESIGN, mode, np.random.default_rng(seed), task.TaskConfig())
    return poses[:n]


@settings(max_examples=40, deadline=None)
@given(mode=st.sampled_from(ALL_MODES), seed=st.integers(0, 2**32 - 1))
def test_holding_forces_are_the_gradient_of_the_potential_energy(mode, seed):
    pose = holdable_poses(mode, 1, seed)[0]
    analytic = holding_forces(DESIGN, pose, mode)
    numeric = numerical_holding_forces(DESIGN, pose, mode)
    # Central differences: truncation O(eps^2) and round-off O(1e-16 / eps), relative to the
    # largest force (the solve through drho/dp mixes the components, so a small component
    # carries the error of the large ones: 2.7e-8 N on a 0.01 N component beside 2 N ones),
    # amplified by the conditioning of drho/dp (serial margin >= 0.2 on these poses).
    scale = float(np.abs(numeric).max())
    np.testing.assert_allclose(analytic, numeric, rtol=0.0, atol=1e-6 * scale + 1e-10)


def test_holding_forces_broadcast_and_mark_unreachable_poses():
    poses = holdable_poses((1, 1, -1), 4)
    batch = holding_forces(DESIGN, poses, (1, 1, -1))
    assert batch.shape == (4, 3)
    for p, f in zip(poses, batch, strict=True):
        np.testing.assert_array_equal(holding_forces(DESIGN, p, (1, 1, -1)), f)
    far = np.array([10.0, 10.0, 0.0])  # no leg closes
    assert np.isnan(holding_forces(DESIGN, far, (1, 1, -1))).all()


def test_holding_forces_at_given_travels_are_the_same():
    mode = (1, 1, 1)
    poses = holdable_poses(mode, 5)
    rho = kinematics.inverse(DESIGN, poses, mode).rho
    np.testing.assert_array_equal(
        holding_forces_at(DESIGN, poses, rho), holding_forces(DESIGN, poses, mode)
    )


@pytest.mark.parametrize("mode", ALL_MODES)
def test_simulated_actuators_carry_the_holding_forces_at_rest(mode):
    """The pymunk servos, holding still under gravity, carry the statics' forces (5 % or
    0.05 N: the servo force is averaged over a control step of an iterative solver)."""
    for pose in holdable_poses(mode, 2):
        sim = Planar3PSim(DESIGN, pose, mode)
        for _ in range(10):
            state = sim.step((0.0, 0.0, 0.0))
        expected = np.abs(holding_forces(DESIGN, pose, mode))
        np.testing.assert_allclose(state.actuator_forces, expected, rtol=0.05, atol=0.05)


@pytest.mark.parametrize("mode", ALL_MODES)
def test_sampled_poses_need_at_most_the_configured_holding_force(mode):
    cfg = task.TaskConfig()
    poses, _ = task.sample_poses(DESIGN, mode, np.random.default_rng(3), cfg)
    forces = np.abs(holding_forces(DESIGN, poses, mode)).max(axis=-1)
    assert (forces <= cfg.max_holding_force * DESIGN.max_force).all()


def test_a_stricter_holding_force_limit_keeps_a_subset_of_the_same_draws():
    mode = (1, 1, 1)
    loose = task.TaskConfig(max_holding_force=1.0)
    strict = task.TaskConfig(max_holding_force=0.5)
    a, _ = task.sample_poses(DESIGN, mode, np.random.default_rng(9), loose, max_batches=1)
    b, _ = task.sample_poses(DESIGN, mode, np.random.default_rng(9), strict, max_batches=1)
    assert len(b) < len(a)
    assert {tuple(p) for p in b} <= {tuple(p) for p in a}
    forces = np.abs(holding_forces(DESIGN, b, mode)).max(axis=-1)
    assert (forces <= 0.5 * DESIGN.max_force).all()


@pytest.mark.parametrize("value", [0.0, -0.1, 1.5, math.nan])
def test_task_config_rejects_bad_holding_force_fraction(value):
    with pytest.raises(ValueError, match="max_holding_force"):
        task.TaskConfig(max_holding_force=value)


def test_weak_actuators_leave_no_pose_to_sample():
    weak = DESIGN.with_(max_force=0.5)  # less than the platform's own weight per actuator
    with pytest.raises(ValueError, match="holding force"):
        task.sample_poses(
            weak, (1, 1, -1), np.random.default_rng(0), task.TaskConfig(), max_batches=3
        )


def reference_holding_forces(design: Design, poses: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """``F = g B A^-T c`` with numpy's LAPACK solve (the formula as it was before it was
    compiled)."""
    A, B = kinematics.jacobians(design, poses, rho)
    k = np.asarray(design.joint_offsets)
    c = np.zeros(poses.shape)
    c[..., 1] = design.platform_mass + 1.5 * design.leg_mass
    c[..., 2] = (0.5 * design.platform_mass * k[0] + 0.5 * design.leg_mass * k.sum()) * np.cos(
        poses[..., 2]
    )
    z = np.linalg.solve(np.swapaxes(A, -1, -2), c[..., None])[..., 0]
    return design.gravity * np.diagonal(B, axis1=-2, axis2=-1) * z


@settings(max_examples=40, deadline=None)
@given(mode=st.sampled_from(ALL_MODES), seed=st.integers(0, 2**32 - 1))
def test_compiled_holding_forces_solve_the_same_system_as_lapack(mode, seed):
    """The compiled elimination and LAPACK's solve are both backward stable: they agree to a
    small multiple of ``eps * cond(A)`` relative to the largest force."""
    poses = holdable_poses(mode, 8, seed)
    rho = kinematics.inverse(DESIGN, poses, mode).rho
    got = holding_forces_at(DESIGN, poses, rho)
    want = reference_holding_forces(DESIGN, poses, rho)
    A, _ = kinematics.jacobians(DESIGN, poses, rho)
    bound = 64 * np.finfo(float).eps * np.linalg.cond(A) * np.abs(want).max(axis=-1)
    assert (np.abs(got - want).max(axis=-1) <= bound).all()


def test_holding_forces_at_broadcasts_and_checks_its_arguments():
    mode = (1, 1, -1)
    poses = holdable_poses(mode, 3)
    rho = kinematics.inverse(DESIGN, poses, mode).rho
    one = holding_forces_at(DESIGN, poses[0], rho)  # one pose against three travels
    assert one.shape == (3, 3)
    np.testing.assert_array_equal(one[0], holding_forces_at(DESIGN, poses[0], rho[0]))
    nan_row = rho.copy()
    nan_row[1, 2] = np.nan
    forces = holding_forces_at(DESIGN, poses, nan_row)
    assert np.isnan(forces[1]).all() and np.isfinite(forces[[0, 2]]).all()
    inf_row = rho.copy()
    inf_row[0, 0] = np.inf
    assert np.isnan(holding_forces_at(DESIGN, poses, inf_row)[0]).all()
    with pytest.raises(ValueError, match=r"rho must have shape \(\.\.\., 3\)"):
        holding_forces_at(DESIGN, poses, rho[:, :2])
    with pytest.raises(ValueError, match="do not broadcast"):
        holding_forces_at(DESIGN, poses, rho[:2])
    with pytest.raises(ValueError, match="poses contains NaN"):
        holding_forces_at(DESIGN, np.full(3, np.nan), rho[0])


def test_an_exactly_singular_configuration_gives_nan_forces_not_an_error():
    """Every leg vertical (``u_ix = 0`` exactly, the rails at the origin): ``A``'s first column
    is zero, so ``A^T z = c`` has no solution; the forces are NaN, which thresholds reject."""
    assert DESIGN.rail_origins == (0.0, 0.0, 0.0)
    pose = np.array([0.2, 0.1, 0.3])
    rho = pose[0] + np.asarray(DESIGN.joint_offsets) * math.cos(pose[2])
    assert not np.isfinite(holding_forces_at(DESIGN, pose, rho)).any()
