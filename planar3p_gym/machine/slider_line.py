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
    n = len(targets)
    rows = np.arange(n)
    pose = np.broadcast_to(start, (n, 3)).copy()
    previous = pose.copy()
    followed = np.ones(n, dtype=bool)
    length = design.characteristic_length
    for k in range(steps):
        predicted = 2.0 * pose - previous
        candidates = solutions.poses[:, k]  # (N, 4, 3)
        distance = kinematics.pose_distance(predicted[:, None, :], candidates, length)
        distance = np.where(solutions.valid[:, k], distance, np.inf)
        nearest = np.argmin(distance, axis=1)
        followed &= np.isfinite(distance[rows, nearest])
        previous, pose = pose, np.where(followed[:, None], candidates[rows, nearest], pose)
    return pose, followed


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
