"""Smooth reference motions (the minimum-jerk time law, open-loop slider commands along
straight pose paths), and the gap between a simulated pose and the exact direct kinematics of
its travels.

Used to measure the physics model's fidelity (``tests/sim/test_physics.py``,
``scripts/fidelity.py``): the commands follow the paper's simple-motion rates
(:func:`planar3p_gym.machine.kinematics.simple_motion_rates`) along the straight path in pose space
with the minimum-jerk time law (:func:`minimum_jerk`), so speeds and accelerations are zero at both
ends and bounded between.  The same law times the task references and baselines
(:mod:`planar3p_gym.tasks.travel_motion`, :mod:`planar3p_gym.tasks.track_references`,
:class:`planar3p_agents.controllers.planner.JointPathPlanner`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks import sampling as task

__all__ = [
    "MIN_JERK_PEAK",
    "WELL_CONDITIONED",
    "min_jerk_commands",
    "minimum_jerk",
    "nearest_dk",
    "well_conditioned_pairs",
]

#: Task margins of well-conditioned poses and paths (above the environment's defaults): the
#: domain on which the fidelity bound is stated.
WELL_CONDITIONED = task.TaskConfig(
    min_parallel_margin=0.08,
    min_serial_margin=0.3,
    path_parallel_margin=0.06,
    path_serial_margin=0.25,
    min_distance=0.08,
    travel_margin=0.05,
)

#: Peak of ``ds/du`` of the minimum-jerk law (at ``u = 1/2``): its largest rate is
#: ``MIN_JERK_PEAK / duration`` times the distance covered.
MIN_JERK_PEAK = 1.875


def minimum_jerk(t: float, duration: float) -> tuple[float, float]:
    """The minimum-jerk time law at time ``t`` (s) of a motion lasting ``duration`` (s):
    progress ``s = 10 u^3 - 15 u^4 + 6 u^5`` in ``[0, 1]`` and its rate ``ds/dt`` (1/s), with
    ``u = t / duration`` clipped to ``[0, 1]``."""
    u = min(max(t / duration, 0.0), 1.0)
    s = u**3 * (10.0 - 15.0 * u + 6.0 * u * u)
    s_dot = 30.0 * u * u * (1.0 - u) ** 2 / duration
    return s, s_dot


def min_jerk_commands(
    design: Design,
    mode: ArrayLike,
    start: ArrayLike,
    target: ArrayLike,
    dt: float,
    peak: float,
) -> NDArray[np.float64]:
    """Slider velocity commands (m/s), shape ``(n, 3)``, one per control period ``dt`` (s), that
    move the platform from ``start`` to ``target`` (poses, m, m, rad) along the straight path with
    the time law :func:`minimum_jerk`; the rates are taken at the middle of each period and the
    duration makes the largest command ``peak`` (m/s) or a little less."""
    start, target = np.asarray(start, float), np.asarray(target, float)
    delta = target - start
    delta[2] = wrap_angle(delta[2])
    if not (math.isfinite(peak) and 0.0 < peak <= design.max_speed):
        raise ValueError(f"peak must be in (0, max_speed = {design.max_speed}] m/s, got {peak!r}")

    def commands(duration: float) -> NDArray[np.float64]:
        out = []
        for k in range(int(math.ceil(duration / dt))):
            s, s_dot = minimum_jerk((k + 0.5) * dt, duration)
            p = start + s * delta
            rho = kinematics.inverse(design, p, mode).rho
            out.append(kinematics.simple_motion_rates(design, p, rho, s_dot * delta))
        return np.array(out)

    # Rates scale as 1/duration along a fixed path: one probe fixes the duration.
    probe = np.abs(commands(1.0)).max()
    return commands(max(1.02 * probe / peak, 5 * dt))


def well_conditioned_pairs(
    design: Design, mode: ArrayLike, n: int, seed: int, cfg: task.TaskConfig = WELL_CONDITIONED
) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """``n`` (start, target) pose pairs joined by straight paths with the margins of ``cfg``,
    drawn from ``np.random.default_rng(seed)``."""
    rng = np.random.default_rng(seed)
    sampler = task.PoseSampler(design, mode, cfg)
    return [task.sample_pair(design, mode, rng, cfg, sampler=sampler) for _ in range(n)]


def nearest_dk(
    design: Design, rho: ArrayLike, pose: ArrayLike
) -> tuple[NDArray[np.float64], int, float]:
    """The exact direct-kinematics solution of travels ``rho`` (m) nearest ``pose`` (m, m, rad):
    ``(its pose, its assembly mode, its distance |(dx, dy, L_ref dtheta)|)`` (m); ``ValueError``
    if the travels have no solution."""
    sol = kinematics.forward_batch(design, np.asarray(rho, dtype=np.float64))
    if int(sol.count) < 1:
        raise ValueError(f"no direct-kinematics solution for travels {rho!r}")
    p = np.asarray(pose, dtype=np.float64)
    gaps = kinematics.pose_distance_euclidean(p, sol.poses, design.characteristic_length)
    dist = np.where(sol.valid, gaps, np.inf)
    j = int(np.argmin(dist))
    return sol.poses[j], int(sol.assembly[j]), float(dist[j])
