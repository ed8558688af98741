"""The demonstration motion of an assembly change: slider travels along the straight pose path,
followed with a minimum-jerk time law (:mod:`planar3p_gym.tasks.assembly_change`).

Used by the task's sampler (:func:`planar3p_gym.tasks.crossing_checks.verify_crossing`) and by
the crossing baseline (:class:`planar3p_agents.controllers.crossing.CrossingController`).  The
time law, :func:`planar3p_gym.machine.motions.minimum_jerk`, is re-exported here under its old
name.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.motions import MIN_JERK_PEAK, minimum_jerk
from planar3p_gym.tasks import sampling as task

__all__ = [
    "TravelCurve",
    "demonstration_travels",
    "minimum_jerk",
    "pose_path_travels",
    "straight_pose_path",
]

FloatArray = NDArray[np.float64]


def straight_pose_path(start: ArrayLike, target: ArrayLike, points: int) -> FloatArray:
    """``points`` poses ``(points, 3)`` on the straight pose path from ``start`` to ``target``
    (m, m, rad; shortest rotation): :func:`planar3p_gym.tasks.sampling.interpolate` of one pair."""
    s = np.asarray(start, dtype=np.float64)
    t = np.asarray(target, dtype=np.float64)
    return task.interpolate(s, t, points)


def pose_path_travels(
    design: Design, start: ArrayLike, target: ArrayLike, mode: ArrayLike, points: int = 200
) -> FloatArray:
    """Travels (m) ``(points, 3)`` along the straight pose path from ``start`` to ``target``
    (poses, m, m, rad; shortest rotation) in working mode ``mode``; NaN where a leg cannot
    close.  Smooth through a parallel singularity (only ``A`` loses rank there)."""
    path = straight_pose_path(start, target, points)
    return kinematics.inverse(design, path, np.asarray(mode, dtype=np.float64)).rho


class TravelCurve:
    """Minimum-jerk motion along a sampled travel curve ``(n, 3)`` (m), whose peak slider rate
    is ``peak`` (m/s)."""

    def __init__(self, travels: FloatArray, peak: float) -> None:
        travels = np.asarray(travels, dtype=np.float64)
        n = len(travels)
        if travels.ndim != 2 or travels.shape[1] != 3 or n < 2:
            raise ValueError(f"travels must have shape (n >= 2, 3), got {travels.shape}")
        if not (math.isfinite(peak) and peak > 0):
            raise ValueError(f"peak must be finite and > 0 (m/s), got {peak!r}")
        self.travels = travels
        self.slopes = np.gradient(travels, 1.0 / (n - 1), axis=0)  # d rho / d s (m)
        self.duration = max(MIN_JERK_PEAK * float(np.abs(self.slopes).max()) / peak, 1e-3)
        self._n = n

    def reference(self, t: float) -> tuple[FloatArray, FloatArray]:
        """Travels (m) and rates (m/s) of the reference at time ``t`` (s)."""
        s, s_dot = minimum_jerk(t, self.duration)
        x = s * (self._n - 1)
        j = min(int(x), self._n - 2)
        w = x - j
        rho = (1.0 - w) * self.travels[j] + w * self.travels[j + 1]
        slope = (1.0 - w) * self.slopes[j] + w * self.slopes[j + 1]
        return rho, s_dot * slope

    def command(self, t: float, rho: ArrayLike, gain: float, max_speed: float) -> FloatArray:
        """Slider velocity command (m/s) at time ``t`` (s) for measured travels ``rho`` (m):
        the reference rate one control period ahead plus ``gain`` times the travel error,
        clipped to ``max_speed``."""
        ref, rate = self.reference(t)
        return np.clip(rate + gain * (ref - np.asarray(rho)), -max_speed, max_speed)


def demonstration_travels(
    design: Design, start_rho: ArrayLike, start: ArrayLike, target: ArrayLike, mode: ArrayLike
) -> FloatArray:
    """The demonstration's travel curve ``(200, 3)`` (m): the straight pose path's travels in
    ``mode``, beginning at the measured travels ``start_rho``; where a leg cannot close on the
    way, the straight travel line to the target's travels instead."""
    travels = pose_path_travels(design, start, target, mode)
    r0 = np.asarray(start_rho, dtype=np.float64)
    if not np.isfinite(travels).all():
        end = kinematics.inverse(design, target, np.asarray(mode, dtype=np.float64)).rho
        end = np.where(np.isfinite(end), end, r0)
        u = np.linspace(0.0, 1.0, len(travels))[:, None]
        travels = r0 + u * (end - r0)
    travels[0] = r0
    return travels
