"""Batched certification of straight travel lines (planar3p_gym/tasks/joint_paths.py,
``certify_lines``) against the one-path certificate ``certify_joint_path``."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks import sampling
from planar3p_gym.tasks.joint_paths import (
    PathLimits,
    certify_joint_path,
    certify_lines,
    first_straight_path,
)

DESIGN = Design.fig8()
MODE = np.array([1.0, 1.0, -1.0])
LIMITS = PathLimits(points=24, min_parallel_margin=0.02, max_holding_force=1.0, travel_margin=0.0)


def _poses(seed: int, n: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    poses = sampling.sample_poses(DESIGN, MODE, rng, sampling.TaskConfig())[0]
    return poses[:n]


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_each_row_is_certify_joint_path(seed):
    """Row by row, the batch gives the one-path certificate's verdict (the same tracking of
    the branch, margins and forces, one solve for all rows)."""
    poses = _poses(seed, 24)
    start, ends = poses[0], poses[1:]
    rho0 = kinematics.inverse(DESIGN, start, MODE).rho
    rho = kinematics.inverse(DESIGN, ends, MODE).rho
    batch = certify_lines(DESIGN, rho0, rho, start, ends, LIMITS)
    one = [certify_joint_path(DESIGN, np.stack([rho0, r]), start, e, LIMITS)[0] is not None
           for r, e in zip(rho, ends, strict=True)]  # fmt: skip
    np.testing.assert_array_equal(batch, one)
    # per-row starts give the same verdicts as the shared start
    starts = np.broadcast_to(start, ends.shape)
    rho0s = np.broadcast_to(rho0, rho.shape)
    np.testing.assert_array_equal(certify_lines(DESIGN, rho0s, rho, starts, ends, LIMITS), batch)


def test_non_finite_and_out_of_stroke_rows_are_refused():
    poses = _poses(1, 3)
    rho = kinematics.inverse(DESIGN, poses, MODE).rho
    ok = certify_lines(DESIGN, rho[0], rho[1:], poses[0], poses[1:], LIMITS)
    bad = rho[1:].copy()
    bad[0, 1] = np.nan
    bad[1, 2] = DESIGN.stroke + 1e-3
    assert not certify_lines(DESIGN, rho[0], bad, poses[0], poses[1:], LIMITS).any()
    # a line to where it starts is certified (nothing moves)
    assert certify_lines(DESIGN, rho[0], rho[0], poses[0], poses[0], LIMITS).all()
    assert ok.shape == (2,)


def test_a_line_ending_elsewhere_is_not_certified():
    poses = _poses(2, 2)
    rho = kinematics.inverse(DESIGN, poses, MODE).rho
    wrong_end = poses[1] + np.array([0.01, 0.0, 0.0])
    assert not certify_lines(DESIGN, rho[0], rho[1], poses[0], wrong_end, LIMITS)[0]


def test_bad_shapes_are_refused_by_name():
    poses = _poses(3, 2)
    rho = kinematics.inverse(DESIGN, poses, MODE).rho
    with pytest.raises(ValueError, match=r"rho_end \(6,\)"):
        certify_lines(DESIGN, rho[0], rho.reshape(-1), poses[0], poses[1], LIMITS)
    with pytest.raises(ValueError, match=r"\(3,\) or \(N, 3\) arrays with one N"):
        certify_lines(DESIGN, rho, rho[:1], poses, poses, LIMITS)


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(1, 12))
def test_first_straight_path_is_the_first_certified_line(seed, n):
    """The first target whose straight line :func:`certify_lines` passes, with the tracked
    end pose, margin and force of certifying that line: the same answer as certifying every
    target at once, though the first is certified alone."""
    poses = _poses(seed, n + 1)
    start, targets = poses[0], poses[1:]
    rho0 = kinematics.inverse(DESIGN, start, MODE).rho
    rho = kinematics.inverse(DESIGN, targets, MODE).rho
    passed = np.flatnonzero(certify_lines(DESIGN, rho0, rho, start, targets, LIMITS))
    found = first_straight_path(DESIGN, start, MODE, targets, MODE, LIMITS)
    if not passed.size:
        assert found is None
        return
    assert found is not None
    index, path = found
    assert index == passed[0]
    one, reason = certify_joint_path(
        DESIGN, np.stack([rho0, rho[index]]), start, targets[index], LIMITS
    )
    assert reason == "ok" and one is not None
    np.testing.assert_array_equal(path.travels, one.travels)
    np.testing.assert_array_equal(path.poses, one.poses)
    assert (path.min_parallel_margin, path.max_holding_force) == (
        one.min_parallel_margin,
        one.max_holding_force,
    )
