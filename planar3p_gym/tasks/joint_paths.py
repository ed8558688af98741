"""Feasibility certificates in joint space: paths of the slider travels, followed by the exact
direct kinematics.

A serial singularity (a leg perpendicular to its rail) is harmless in joint space: moving the
slider under an upright leg swings the leg from one side to the other while the platform stays
put to first order (``p_dot = A^-1 B rho_dot`` stays finite; only ``B`` loses rank).  So a
change of working mode is a straight line in travel space, and what has to be checked along it
is what the direct kinematics gives: the platform pose on the branch that starts at the start
pose (followed by continuity), its parallel margin and the actuator forces that hold it at rest.

Used by :mod:`planar3p_gym.tasks.mode_change` (the sampler's feasibility test) and by
:mod:`planar3p_agents.controllers.planner` (the baseline follows the certified path).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.statics import holding_forces_at

__all__ = [
    "JointPath",
    "PathLimits",
    "certify_joint_path",
    "closing_travels",
    "find_joint_path",
    "track_segment",
    "upright_waypoints",
]

FloatArray = NDArray[np.float64]

#: A tracked branch is unambiguous when the second-nearest direct-kinematics solution is at
#: least this many times farther than the nearest (both from the previous tracked pose).
_AMBIGUITY_RATIO = 3.0
#: The tracked end of a path must be within this pose distance of the requested end (m).
_END_TOLERANCE = 1e-6


@dataclass(frozen=True)
class PathLimits:
    """What a certified joint path must respect at every checked point.

    Attributes:
        points: points checked per straight segment in travel space (>= 2).
        min_parallel_margin: smallest parallel margin allowed (dimensionless, in [0, 1)).
        max_holding_force: largest actuator force needed to hold the pose at rest, as a
            fraction of ``design.max_force`` (in (0, 1]).
        travel_margin: fraction of the stroke kept free at both ends of the waypoints (the
            segments between them stay inside by convexity).
    """

    points: int = 100
    min_parallel_margin: float = 0.02
    max_holding_force: float = 0.9
    travel_margin: float = 0.03

    def __post_init__(self) -> None:
        if not (isinstance(self.points, int) and self.points >= 2):
            raise ValueError(f"PathLimits.points must be an int >= 2, got {self.points!r}")
        if not 0.0 <= self.min_parallel_margin < 1.0:
            raise ValueError(
                "PathLimits.min_parallel_margin must be in [0, 1), got "
                f"{self.min_parallel_margin!r}"
            )
        if not 0.0 < self.max_holding_force <= 1.0:
            raise ValueError(
                f"PathLimits.max_holding_force must be in (0, 1], got {self.max_holding_force!r}"
            )
        if not 0.0 <= self.travel_margin < 0.5:
            raise ValueError(
                f"PathLimits.travel_margin must be in [0, 0.5), got {self.travel_margin!r}"
            )


@dataclass(frozen=True)
class JointPath:
    """A certified piecewise-straight path in travel space.

    Attributes:
        travels: ``(m, 3)`` waypoints of the slider travels (m), start first, end last.
        poses: ``(m, 3)`` platform poses at the waypoints (m, m, rad).
        min_parallel_margin: smallest parallel margin met along the path (dimensionless).
        max_holding_force: largest holding force met along the path (N).
    """

    travels: FloatArray
    poses: FloatArray
    min_parallel_margin: float
    max_holding_force: float


def _pose_gap(design: Design, a: FloatArray, b: FloatArray) -> FloatArray:
    """``|(dx, dy, L_ref dtheta)|`` (m) between poses ``(..., 3)``."""
    d = b - a
    d[..., 2] = ((d[..., 2] + math.pi) % (2.0 * math.pi) - math.pi) * (design.characteristic_length)
    return np.linalg.norm(d, axis=-1)


def track_segment(
    design: Design, rho_a: ArrayLike, rho_b: ArrayLike, pose_a: ArrayLike, points: int
) -> tuple[FloatArray, FloatArray] | None:
    """Follow the direct-kinematics branch through ``pose_a`` along the straight travel path
    from ``rho_a`` to ``rho_b`` (m): ``(travels (points, 3), poses (points, 3))``, or ``None``
    when the branch is lost (no solution, or two solutions too close to tell apart: the path
    comes near a parallel singularity)."""
    ra, rb = np.asarray(rho_a, dtype=np.float64), np.asarray(rho_b, dtype=np.float64)
    u = np.linspace(0.0, 1.0, points)[:, None]
    rho = ra + u * (rb - ra)
    sol = kinematics.forward_batch(design, rho)
    poses = np.empty((points, 3))
    prev = np.asarray(pose_a, dtype=np.float64)
    for j in range(points):
        dist = np.where(sol.valid[j], _pose_gap(design, prev, sol.poses[j]), np.inf)
        order = np.argsort(dist)
        near, second = dist[order[0]], dist[order[1]]
        if not math.isfinite(near) or second < _AMBIGUITY_RATIO * near:
            return None
        prev = sol.poses[j, order[0]]
        poses[j] = prev
    return rho, poses


def certify_joint_path(
    design: Design, travels: ArrayLike, start: ArrayLike, end: ArrayLike, limits: PathLimits
) -> tuple[JointPath | None, str]:
    """Check the piecewise-straight travel path through ``travels`` ``(m, 3)`` (m) from the
    pose ``start`` (on the first waypoint): the followed branch must stay unambiguous, keep the
    parallel margin and holding forces of ``limits`` and arrive at the pose ``end``.

    Returns ``(path, "ok")`` or ``(None, reason)`` with ``reason`` one of ``"stroke"``,
    ``"branch"``, ``"parallel_margin"``, ``"holding_force"``, ``"end_pose"``.
    """
    w = np.asarray(travels, dtype=np.float64)
    lo, hi = limits.travel_margin * design.stroke, (1.0 - limits.travel_margin) * design.stroke
    if not ((w >= lo - 1e-12) & (w <= hi + 1e-12)).all():
        return None, "stroke"
    pose = np.asarray(start, dtype=np.float64)
    waypoint_poses = [pose]
    min_margin, max_force = 1.0, 0.0
    for a, b in itertools.pairwise(w):
        tracked = track_segment(design, a, b, pose, limits.points)
        if tracked is None:
            return None, "branch"
        rho, poses = tracked
        margin = float(kinematics.parallel_margin(design, poses, rho).min())
        force = float(np.abs(holding_forces_at(design, poses, rho)).max())
        min_margin, max_force = min(min_margin, margin), max(max_force, force)
        if margin < limits.min_parallel_margin:
            return None, "parallel_margin"
        if not force <= limits.max_holding_force * design.max_force:
            return None, "holding_force"
        pose = poses[-1]
        waypoint_poses.append(pose)
    if _pose_gap(design, pose, np.asarray(end, dtype=np.float64)) > _END_TOLERANCE:
        return None, "end_pose"
    return JointPath(w, np.array(waypoint_poses), min_margin, max_force), "ok"


def closing_travels(design: Design, poses: ArrayLike, mode: ArrayLike) -> FloatArray:
    """:func:`planar3p_gym.machine.kinematics.inverse` travels (m) of poses ``(..., 3)`` in ``mode``,
    with a leg that is upright up to rounding (``L_i^2 - C_iy^2`` within ``-1e-12 L_i^2`` of 0)
    counted as exactly upright; NaN where a leg cannot close.  (No stroke test.)"""
    p = np.asarray(poses, dtype=np.float64)
    k = np.asarray(design.joint_offsets)
    legs = np.asarray(design.leg_lengths)
    th = p[..., 2:3]
    cx = p[..., 0:1] + k * np.cos(th)
    cy = p[..., 1:2] + k * np.sin(th)
    disc = legs**2 - cy**2
    disc = np.where((disc < 0.0) & (disc > -1e-12 * legs**2), 0.0, disc)
    with np.errstate(invalid="ignore"):
        root = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
    return cx - np.asarray(design.rail_origins) - np.asarray(mode, dtype=np.float64) * root


def upright_waypoints(
    design: Design,
    start: ArrayLike,
    target: ArrayLike,
    start_mode: ArrayLike,
    target_mode: ArrayLike,
    count: int = 12,
) -> FloatArray:
    """Candidate intermediate poses ``(n, 3)`` with every flipping leg upright (``|C_iy| =
    L_i``: perpendicular to its rail, where its two working modes meet), deterministic.

    Each flipping leg's joint ``C_i`` is put at height ``+L_i`` or ``-L_i``; one flipping leg
    leaves ``theta`` free (candidates: ``count`` angles spread between the start's and the
    target's angles, each way round), two fix ``sin theta`` (both solutions), three must be
    consistent (they are only for special designs).  ``x`` centres the travels in the stroke.
    Candidates whose travels do not fit the stroke are dropped.
    """
    s, t = np.asarray(start, dtype=np.float64), np.asarray(target, dtype=np.float64)
    ms, mt = np.asarray(start_mode), np.asarray(target_mode)
    flip = np.flatnonzero(ms != mt)
    k = np.asarray(design.joint_offsets)
    legs = np.asarray(design.leg_lengths)
    cands: list[tuple[float, float]] = []  # (y, theta)
    if flip.size == 1:
        i = int(flip[0])
        dth = (t[2] - s[2] + math.pi) % (2.0 * math.pi) - math.pi
        fractions = np.linspace(0.0, 1.0, count)
        thetas = np.concatenate(
            [s[2] + fractions * dth, s[2] + fractions * (dth - math.copysign(2 * math.pi, dth))]
        )
        for th in thetas:
            for side in (1.0, -1.0):
                cands.append((side * legs[i] - k[i] * math.sin(th), float(th)))
    elif flip.size >= 2:
        i, j = int(flip[0]), int(flip[1])
        for si in (1.0, -1.0):
            for sj in (1.0, -1.0):
                sin_th = (si * legs[i] - sj * legs[j]) / (k[i] - k[j])
                if abs(sin_th) > 1.0:
                    continue
                base = math.asin(sin_th)
                for th in (base, math.pi - base):
                    y = si * legs[i] - k[i] * sin_th
                    if flip.size == 3:
                        m = int(flip[2])
                        if abs(abs(y + k[m] * sin_th) - legs[m]) > 1e-9:
                            continue
                    cands.append((y, (th + math.pi) % (2.0 * math.pi) - math.pi))
    if not cands:
        return np.zeros((0, 3))
    yt = np.array(cands)
    # travels at x = 0 in the start mode (the flipping legs have sqrt = 0: either mode)
    poses0 = np.column_stack([np.zeros(len(yt)), yt])
    rho0 = closing_travels(design, poses0, ms)
    ok = np.isfinite(rho0).all(axis=1)
    spread_lo, spread_hi = np.nanmin(rho0, axis=1), np.nanmax(rho0, axis=1)
    x = 0.5 * design.stroke - 0.5 * (spread_lo + spread_hi)
    ok &= (spread_hi - spread_lo) <= design.stroke
    out = np.column_stack([x, yt])[ok]
    return out


def find_joint_path(
    design: Design,
    start: ArrayLike,
    start_mode: ArrayLike,
    target: ArrayLike,
    target_mode: ArrayLike,
    limits: PathLimits,
    waypoints: int = 12,
) -> tuple[JointPath | None, str]:
    """A certified travel path from ``start`` (pose in ``start_mode``) to ``target`` (pose in
    ``target_mode``): the straight travel line if it passes :func:`certify_joint_path`, else
    the first of :func:`upright_waypoints` (in their fixed order) through which both straight
    segments pass.  Deterministic.  Returns ``(path, "ok")`` or ``(None, reason of the straight
    line's failure)``."""
    s, t = np.asarray(start, dtype=np.float64), np.asarray(target, dtype=np.float64)
    ms = np.asarray(start_mode, dtype=np.float64)
    mt = np.asarray(target_mode, dtype=np.float64)
    rs = kinematics.inverse(design, s, ms).rho
    rt = kinematics.inverse(design, t, mt).rho
    if not (np.isfinite(rs).all() and np.isfinite(rt).all()):
        return None, "stroke"
    path, reason = certify_joint_path(design, np.stack([rs, rt]), s, t, limits)
    if path is not None or waypoints <= 0:
        return path, reason
    for w in upright_waypoints(design, s, t, ms, mt, waypoints):
        rw = closing_travels(design, w, ms)
        if not np.isfinite(rw).all():
            continue
        first, _ = certify_joint_path(design, np.stack([rs, rw]), s, w, limits)
        if first is None:
            continue
        second, _ = certify_joint_path(design, np.stack([rw, rt]), w, t, limits)
        if second is None:
            continue
        return (
            JointPath(
                np.stack([rs, rw, rt]),
                np.stack([s, w, t]),
                min(first.min_parallel_margin, second.min_parallel_margin),
                max(first.max_holding_force, second.max_holding_force),
            ),
            "ok",
        )
    return None, reason
