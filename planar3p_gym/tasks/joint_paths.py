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
from numba import njit
from numpy.typing import ArrayLike, NDArray

from planar3p_gym import checks
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.statics import holding_forces_at

__all__ = [
    "JointPath",
    "PathLimits",
    "certify_joint_path",
    "certify_lines",
    "closing_travels",
    "find_joint_path",
    "first_straight_path",
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
        set_ = object.__setattr__
        set_(self, "points", checks.integer(self.points, "PathLimits.points", low=2, high=10_000))
        set_(
            self,
            "min_parallel_margin",
            checks.number(
                self.min_parallel_margin,
                "PathLimits.min_parallel_margin",
                low=0.0,
                high=1.0,
                high_open=True,
            ),
        )
        set_(
            self,
            "max_holding_force",
            checks.number(
                self.max_holding_force,
                "PathLimits.max_holding_force",
                low=0.0,
                high=1.0,
                low_open=True,
            ),
        )
        set_(
            self,
            "travel_margin",
            checks.number(
                self.travel_margin, "PathLimits.travel_margin", low=0.0, high=0.5, high_open=True
            ),
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


@dataclass(frozen=True)
class _Tracked:
    """Direct-kinematics branches followed along ``S`` straight travel segments at once.

    Attributes:
        rho: ``(S, P, 3)`` travels at the checked points (m).
        poses: ``(S, P, 3)`` followed poses (m, m, rad; meaningless where ``alive`` is False).
        alive: ``(S,)`` the branch stayed unambiguous over the whole segment.
    """

    rho: FloatArray
    poses: FloatArray
    alive: NDArray[np.bool_]


def _track(
    design: Design, rho_a: FloatArray, rho_b: FloatArray, pose_a: FloatArray, points: int
) -> _Tracked:
    """Follow the branch through ``pose_a[s]`` along the straight travel path from ``rho_a[s]``
    to ``rho_b[s]`` (all ``(S, 3)``), for every ``s`` at once: one direct-kinematics solve of
    the ``S * points`` travels, then the walk over the points (:func:`_walk`): at each point
    the nearest solution to the previous followed pose, unambiguous when the second-nearest is
    at least :data:`_AMBIGUITY_RATIO` times farther."""
    u = np.linspace(0.0, 1.0, points)[:, None]
    rho = rho_a[:, None, :] + u * (rho_b - rho_a)[:, None, :]  # (S, P, 3)
    sol = kinematics.forward_batch(design, rho)
    cand = np.ascontiguousarray(sol.poses)  # (S, P, 4, 3)
    start = np.ascontiguousarray(np.broadcast_to(pose_a, (rho.shape[0], 3)), dtype=np.float64)
    index, alive = _walk(
        cand, np.ascontiguousarray(sol.valid), start, design.characteristic_length, _AMBIGUITY_RATIO
    )
    poses = np.take_along_axis(cand, index[:, :, None, None], axis=2)[:, :, 0, :]
    return _Tracked(rho, poses, alive)


@njit(cache=True)
def _walk(
    cand: FloatArray, valid: NDArray[np.bool_], start: FloatArray, length: float, ratio: float
) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """The branch walk of :func:`_track`: for each segment ``s``, from ``start[s]`` through the
    solutions ``cand[s, j]`` ``(4, 3)`` (``valid[s, j]`` marks the real ones) point after point,
    the index of the followed solution at every point and whether the branch stayed unambiguous
    (the gaps ``|(dx, dy, length * dtheta)|`` in m of
    :func:`~planar3p_gym.machine.kinematics.pose_distance_euclidean`, with ``dtheta`` wrapped by
    :func:`~planar3p_gym.tasks.observation.wrap_angle`; ties go to the lower index). Written as
    loops and compiled with numba because it only ever compares the followed solution with the
    next point's four, where an array formulation computes all sixteen gaps per point and sorts
    them; past the point where a branch is lost its indices stay 0."""
    n, points = cand.shape[0], cand.shape[1]
    index = np.zeros((n, points), dtype=np.intp)
    alive = np.zeros(n, dtype=np.bool_)
    for s in range(n):
        px, py, pt = start[s, 0], start[s, 1], start[s, 2]
        ok = True
        for j in range(points):
            best, second, k = math.inf, math.inf, 0
            for m in range(cand.shape[2]):
                if not valid[s, j, m]:
                    continue
                dx = cand[s, j, m, 0] - px
                dy = cand[s, j, m, 1] - py
                dt = wrap_angle(cand[s, j, m, 2] - pt) * length
                gap = math.sqrt(dx * dx + dy * dy + dt * dt)
                if gap < best:
                    second, best, k = best, gap, m
                elif gap < second:
                    second = gap
            if not best < math.inf or second < ratio * best:
                ok = False
                break
            index[s, j] = k
            px, py, pt = cand[s, j, k, 0], cand[s, j, k, 1], cand[s, j, k, 2]
        alive[s] = ok
    return index, alive


def track_segment(
    design: Design, rho_a: ArrayLike, rho_b: ArrayLike, pose_a: ArrayLike, points: int
) -> tuple[FloatArray, FloatArray] | None:
    """Follow the direct-kinematics branch through ``pose_a`` along the straight travel path
    from ``rho_a`` to ``rho_b`` (m): ``(travels (points, 3), poses (points, 3))``, or ``None``
    when the branch is lost (no solution, or two solutions too close to tell apart: the path
    comes near a parallel singularity)."""
    tracked = _track(
        design,
        np.asarray(rho_a, dtype=np.float64).reshape(1, 3),
        np.asarray(rho_b, dtype=np.float64).reshape(1, 3),
        np.asarray(pose_a, dtype=np.float64).reshape(1, 3),
        points,
    )
    if not tracked.alive[0]:
        return None
    return tracked.rho[0], tracked.poses[0]


def _segment_figures(
    design: Design, tracked: _Tracked, rows: NDArray[np.intp]
) -> tuple[FloatArray, FloatArray]:
    """Smallest parallel margin and largest holding force (N) along each of the followed
    segments ``rows`` (every point of a segment; margins and forces per pose are independent
    of the batch they are computed in).  A pose exactly at a parallel singularity has no
    holding forces: its segment's force is NaN or infinite, which the force limit rejects."""
    poses, rho = tracked.poses[rows], tracked.rho[rows]
    margin = kinematics.min_parallel_margin(design, poses, rho)
    force = np.abs(holding_forces_at(design, poses, rho)).max(axis=(-2, -1))
    return margin, force


def _in_stroke(design: Design, travels: FloatArray, limits: PathLimits) -> NDArray[np.bool_]:
    """Whether travels ``(..., 3)`` keep ``limits.travel_margin`` of the stroke free (per row)."""
    lo, hi = design.travel_band(limits.travel_margin)
    return ((travels >= lo - 1e-12) & (travels <= hi + 1e-12)).all(axis=-1)


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
    if not _in_stroke(design, w, limits).all():
        return None, "stroke"
    pose = np.asarray(start, dtype=np.float64)
    waypoint_poses = [pose]
    min_margin, max_force = 1.0, 0.0
    for a, b in itertools.pairwise(w):
        tracked = _track(design, a[None, :], b[None, :], pose[None, :], limits.points)
        if not tracked.alive[0]:
            return None, "branch"
        margins, forces = _segment_figures(design, tracked, np.zeros(1, dtype=np.intp))
        margin, force = float(margins[0]), float(forces[0])
        min_margin, max_force = min(min_margin, margin), max(max_force, force)
        if margin < limits.min_parallel_margin:
            return None, "parallel_margin"
        if not force <= limits.max_holding_force * design.max_force:
            return None, "holding_force"
        pose = tracked.poses[0, -1]
        waypoint_poses.append(pose)
    if kinematics.pose_distance_euclidean(pose, end, design.characteristic_length) > _END_TOLERANCE:
        return None, "end_pose"
    return JointPath(w, np.array(waypoint_poses), min_margin, max_force), "ok"


def certify_lines(
    design: Design,
    rho_start: ArrayLike,
    rho_end: ArrayLike,
    pose_start: ArrayLike,
    pose_end: ArrayLike,
    limits: PathLimits,
) -> NDArray[np.bool_]:
    """:func:`certify_joint_path` of ``N`` straight travel lines at once: mask ``(N,)``, True
    where the line from travels ``rho_start`` (m, on the pose ``pose_start``) to ``rho_end``
    stays in the stroke of ``limits``, keeps its branch unambiguous, its parallel margin and
    holding forces, and arrives at the pose ``pose_end`` (m, m, rad).  Rows of ``(N, 3)``
    arrays, or one ``(3,)`` row shared by every line; False where a travel is not finite.
    ``ValueError`` unless every argument is ``(3,)`` or ``(N, 3)`` with one ``N``."""
    names = ("rho_start", "rho_end", "pose_start", "pose_end")
    arrays = [np.asarray(a, dtype=np.float64) for a in (rho_start, rho_end, pose_start, pose_end)]
    rows_of = {a.shape[0] for a in arrays if a.ndim == 2}
    if any(a.ndim not in (1, 2) or a.shape[-1] != 3 for a in arrays) or len(rows_of) > 1:
        shapes = ", ".join(f"{n} {a.shape}" for n, a in zip(names, arrays, strict=True))
        raise ValueError(f"certify_lines needs (3,) or (N, 3) arrays with one N, got {shapes}")
    shape = np.broadcast_shapes(*(a.shape for a in arrays))
    rows = [np.broadcast_to(a, shape).reshape(-1, 3) for a in arrays]
    ok = np.zeros(rows[0].shape[0], dtype=np.bool_)
    finite = np.isfinite(rows[0]).all(axis=1) & np.isfinite(rows[1]).all(axis=1)
    cand = np.flatnonzero(
        finite & _in_stroke(design, rows[0], limits) & _in_stroke(design, rows[1], limits)
    )
    if cand.size:
        ok[cand] = _certify_segments(design, *(r[cand] for r in rows), limits)[0]
    return ok


def _certify_segments(
    design: Design,
    rho_a: FloatArray,
    rho_b: FloatArray,
    pose_a: FloatArray,
    pose_b: FloatArray,
    limits: PathLimits,
) -> tuple[NDArray[np.bool_], FloatArray, FloatArray, FloatArray]:
    """:func:`certify_joint_path` of ``S`` one-segment paths at once (rows of ``(S, 3)``
    arrays, or one ``(3,)`` row shared by every segment, e.g. a common start; travels already
    checked against the stroke): ``(ok, margins, forces, ends)`` per row (``ends``: the
    followed poses at ``rho_b``), the figures meaningful where ``ok``.  The cheap tests
    (branch, end pose) come first, so the margins and forces are computed only for the
    segments that pass them."""
    shape = np.broadcast_shapes(rho_a.shape, rho_b.shape, pose_a.shape, pose_b.shape)
    rows = (-1, 3) if len(shape) == 2 else (1, 3)
    rho_a, rho_b, pose_a, pose_b = (
        np.broadcast_to(a, shape).reshape(rows).copy() for a in (rho_a, rho_b, pose_a, pose_b)
    )
    n = rho_a.shape[0]
    ok = np.zeros(n, dtype=np.bool_)
    margins, forces = np.ones(n), np.zeros(n)
    if not n:
        return ok, margins, forces, np.zeros((0, 3))
    tracked = _track(design, rho_a, rho_b, pose_a, limits.points)
    end_gap = kinematics.pose_distance_euclidean(
        tracked.poses[:, -1], pose_b, design.characteristic_length
    )
    rows = np.flatnonzero(tracked.alive & (end_gap <= _END_TOLERANCE))
    if rows.size:
        m, f = _segment_figures(design, tracked, rows)
        margins[rows], forces[rows] = np.minimum(1.0, m), np.maximum(0.0, f)
        ok[rows] = ~(m < limits.min_parallel_margin) & (
            f <= limits.max_holding_force * design.max_force
        )
    return ok, margins, forces, tracked.poses[:, -1]


def closing_travels(design: Design, poses: ArrayLike, mode: ArrayLike) -> FloatArray:
    """:func:`planar3p_gym.machine.kinematics.inverse` travels (m) of poses ``(..., 3)`` in
    ``mode``, with a leg that is upright up to rounding (``L_i^2 - C_iy^2`` within ``-1e-12 L_i^2``
    of 0) counted as exactly upright; NaN where a leg cannot close.  (No stroke test.)"""
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
        dth = wrap_angle(t[2] - s[2])
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
                    cands.append((y, wrap_angle(th)))
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
    line's failure)``.

    The waypoints are checked together (:func:`_certify_segments`: one direct-kinematics solve
    for all first segments, one for the second segments of those that passed), with the result
    of checking them one after the other."""
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
    path = _waypoint_path(design, s, rs, ms, t, rt, mt, limits, waypoints)
    return (path, "ok") if path is not None else (None, reason)


def first_straight_path(
    design: Design,
    start: ArrayLike,
    start_mode: ArrayLike,
    targets: ArrayLike,
    target_mode: ArrayLike,
    limits: PathLimits,
) -> tuple[int, JointPath] | None:
    """The first of ``targets`` ``(N, 3)`` (poses in ``target_mode``) joined to ``start`` (a pose
    in ``start_mode``) by a straight travel line that passes :func:`certify_joint_path`, as
    ``(index, path)``, or ``None``: the straight line of :func:`find_joint_path` for every
    target at once, without its waypoint search.  What the mode-change sampler certifies its
    pairs with.

    The first candidate is certified alone, then the others together (one direct-kinematics
    solve): the first usually passes, and a row's direct kinematics does not depend on the
    rows solved with it, so the answer is the one of certifying them all at once."""
    s = np.asarray(start, dtype=np.float64)
    t = np.asarray(targets, dtype=np.float64).reshape(-1, 3)
    rs = kinematics.inverse(design, s, np.asarray(start_mode, dtype=np.float64)).rho
    rt = kinematics.inverse(design, t, np.asarray(target_mode, dtype=np.float64)).rho
    if not (np.isfinite(rs).all() and _in_stroke(design, rs, limits)):
        return None
    cand = np.flatnonzero(np.isfinite(rt).all(axis=1) & _in_stroke(design, rt, limits))
    if not cand.size:
        return None
    for rows in (cand[:1], cand[1:]):
        ok, margins, forces, ends = _certify_segments(design, rs, rt[rows], s, t[rows], limits)
        passed = np.flatnonzero(ok)
        if passed.size:
            i = int(passed[0])
            j = int(rows[i])
            path = JointPath(
                np.stack([rs, rt[j]]), np.stack([s, ends[i]]), float(margins[i]), float(forces[i])
            )
            return j, path
    return None


def _waypoint_path(
    design: Design,
    s: FloatArray,
    rs: FloatArray,
    ms: FloatArray,
    t: FloatArray,
    rt: FloatArray,
    mt: FloatArray,
    limits: PathLimits,
    waypoints: int,
) -> JointPath | None:
    """The path through the first upright waypoint (in the order of
    :func:`upright_waypoints`) whose two straight segments both pass, or ``None``."""
    if not (_in_stroke(design, rs, limits) and _in_stroke(design, rt, limits)):
        return None  # every segment would start or end outside the stroke
    way = upright_waypoints(design, s, t, ms, mt, waypoints)
    if not len(way):
        return None
    rw = closing_travels(design, way, ms)
    cand = np.flatnonzero(np.isfinite(rw).all(axis=1) & _in_stroke(design, rw, limits))
    if not cand.size:
        return None
    ok1, m1, f1, _ = _certify_segments(design, rs, rw[cand], s, way[cand], limits)
    cand = cand[ok1]
    m1, f1 = m1[ok1], f1[ok1]
    if not cand.size:
        return None
    ok2, m2, f2, _ = _certify_segments(design, rw[cand], rt, way[cand], t, limits)
    passed = np.flatnonzero(ok2)
    if not passed.size:
        return None
    i = int(passed[0])
    w = way[cand[i]]
    return JointPath(
        np.stack([rs, rw[cand[i]], rt]),
        np.stack([s, w, t]),
        min(float(m1[i]), float(m2[i])),
        max(float(f1[i]), float(f2[i])),
    )
