"""Where the straight line in slider space takes the gripper.

A feedback that moves every slider at a constant rate from the start's travels to the
target's (the straight line in joint space, which is what a policy that learns a direct map
from pose error to slider velocities tends to do) follows one continuous branch of the direct
kinematics.  That branch need not end at the target: from a start near the rail line it can
carry the platform through it and end at the target's mirror image ``(x, -y, -theta)``, and
near a parallel singularity it can end where two branches meet.  :func:`slider_line_reaches`
tells which start/target pairs the straight slider line solves; the others need a detour in
slider space (the analytic controller makes one implicitly by following the straight line in
pose space).  ``TaskConfig.detour_fraction`` uses it to train on such pairs more often.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design

__all__ = ["DEFAULT_STEPS", "END_TOLERANCE", "slider_line_end", "slider_line_reaches"]

#: Steps along the line: about 3 mm of travel per step for the largest slider motions of a
#: 0.30 m stroke, fine enough that the branch is never lost between two steps away from a
#: parallel singularity.
DEFAULT_STEPS = 64

#: Pose distance ``|dp| + L_ref |dtheta|`` (m) within which the line's end is the target.
END_TOLERANCE = 1e-6


def slider_line_end(
    design: Design,
    start: ArrayLike,
    targets: ArrayLike,
    mode: ArrayLike,
    steps: int = DEFAULT_STEPS,
) -> tuple[np.ndarray, np.ndarray]:
    """End poses ``(N, 3)`` of the slider-space straight lines from ``start`` (3,) to each of
    ``targets`` (N, 3), both reachable in working mode ``mode``, and a mask ``(N,)`` that is
    False where the branch was lost (no real pose at some step: the travels left the
    reachable set, or a parallel singularity made the branch vanish).

    The branch is followed by direct kinematics at ``steps`` equal travel steps, taking at
    each the real pose nearest to the linear prediction from the two previous poses (pose
    distance ``|dp| + L_ref |dtheta|``).  Poses in m and rad.
    """
    start = np.asarray(start, dtype=np.float64)
    targets = np.atleast_2d(np.asarray(targets, dtype=np.float64))
    m = np.asarray(mode, dtype=np.float64)
    r0 = kinematics.inverse(design, start, m).rho
    r1 = kinematics.inverse(design, targets, m).rho
    if not (np.isfinite(r0).all() and np.isfinite(r1).all()):
        raise ValueError("slider_line_end: start and targets must be reachable in the mode")
    t = np.linspace(0.0, 1.0, steps + 1)[1:, None]
    solutions = kinematics.forward_batch(design, r0 + t[None] * (r1 - r0)[:, None, :])
    return _follow(
        start,
        np.ascontiguousarray(solutions.poses),
        np.ascontiguousarray(solutions.valid),
        float(design.characteristic_length),
    )


#: :func:`planar3p_gym.machine.kinematics.pose_distance`, compiled for :func:`_follow`.
_pose_distance = njit(cache=True)(kinematics.pose_distance)


@njit(cache=True)
def _follow(
    start: np.ndarray, poses: np.ndarray, valid: np.ndarray, length: float
) -> tuple[np.ndarray, np.ndarray]:
    """The branch following of :func:`slider_line_end`, compiled (a Python loop over the steps
    cost some 2 ms a call): for each line ``j`` and step ``k``, the valid solution
    ``poses[j, k]`` (S, 3) nearest to the linear prediction (the first of equals); the line is
    lost, and its pose kept, at the first step without a valid solution."""
    n, steps = poses.shape[0], poses.shape[1]
    end = np.empty((n, 3))
    followed = np.ones(n, dtype=np.bool_)
    for j in range(n):
        pose = start.copy()
        previous = start.copy()
        for k in range(steps):
            predicted = 2.0 * pose - previous
            distance = _pose_distance(predicted.reshape(1, 3), poses[j, k], length)
            best = -1
            best_distance = np.inf
            for c in range(distance.shape[0]):
                if valid[j, k, c] and distance[c] < best_distance:
                    best, best_distance = c, distance[c]
            if best < 0:
                followed[j] = False
                break
            previous, pose = pose, poses[j, k, best].copy()
        end[j] = pose
    return end, followed


def slider_line_reaches(
    design: Design,
    start: ArrayLike,
    targets: ArrayLike,
    mode: ArrayLike,
    steps: int = DEFAULT_STEPS,
) -> np.ndarray:
    """Mask ``(N,)``: the slider-space straight line from ``start`` brings the gripper to
    each of ``targets`` (within :data:`END_TOLERANCE`); see :func:`slider_line_end`."""
    targets = np.atleast_2d(np.asarray(targets, dtype=np.float64))
    end, followed = slider_line_end(design, start, targets, mode, steps)
    distance = kinematics.pose_distance(end, targets, design.characteristic_length)
    return followed & (distance < END_TOLERANCE)
