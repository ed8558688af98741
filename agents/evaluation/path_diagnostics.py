"""Diagnostics of the path between a start and a target pose: what a suite records per episode.

:func:`path_profiles` checks the straight line in pose space (the path of the simultaneous
simple motions); :func:`profile` of :func:`sequential_path` checks the
rotation-vertical-horizontal path of the sequential simple motions.  Both are vectorised over
pairs and report reachability within the stroke, the smallest parallel and serial margins met,
whether ``sign det A`` changes (a parallel singularity crossed), and whether the path passes
the environment's clear-path test; :func:`with_slider_line` adds whether the straight line in
slider space solves the pair.
Lengths in m, angles in rad, margins dimensionless.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.slider_line import slider_line_reaches
from planar3p_gym.tasks import sampling as task

__all__ = [
    "path_dict",
    "path_profiles",
    "profile",
    "sequential_path",
    "with_sequential",
    "with_slider_line",
]

FloatArray = NDArray[np.float64]


def path_profiles(
    design: Design,
    starts: ArrayLike,
    targets: ArrayLike,
    mode: ArrayLike,
    n_points: int = 64,
    cfg: task.TaskConfig | None = None,
) -> dict[str, np.ndarray]:
    """Diagnostics of the straight paths in pose space ``starts[k] -> targets[k]``.

    Returns arrays of shape ``(N,)``: ``distance`` (pose distance, m), ``reachable`` (every
    one of ``n_points`` poses reachable within the stroke in ``mode``),
    ``min_parallel_margin`` / ``min_serial_margin`` over the poses where every leg can close
    (NaN if none), ``crosses`` (``sign det A`` differs from the start's somewhere), and
    ``clear`` (reachable, no crossing, margins at least the task's path margins).
    """
    s = np.atleast_2d(np.asarray(starts, dtype=np.float64))
    t = np.atleast_2d(np.asarray(targets, dtype=np.float64))
    out = {"distance": task.pose_distance(s, t, design.characteristic_length)}
    out.update(profile(design, task.interpolate(s, t, n_points), mode, cfg))
    return out


def sequential_path(starts: ArrayLike, targets: ArrayLike, n_points: int = 64) -> FloatArray:
    """Poses ``(N, 3 n_points, 3)`` along the path of the sequential simple motions: rotation
    about ``G`` to the target angle, then vertical, then horizontal translation."""
    s = np.atleast_2d(np.asarray(starts, dtype=np.float64))
    t = np.atleast_2d(np.asarray(targets, dtype=np.float64))
    dth = wrap_angle(t[:, 2] - s[:, 2])
    w1 = s.copy()
    w1[:, 2] = s[:, 2] + dth
    w2 = w1.copy()
    w2[:, 1] = t[:, 1]
    w3 = t.copy()
    w3[:, 2] = w1[:, 2]
    return np.concatenate(
        [task.interpolate(a, b, n_points) for a, b in ((s, w1), (w1, w2), (w2, w3))], axis=-2
    )


def profile(
    design: Design, path: FloatArray, mode: ArrayLike, cfg: task.TaskConfig | None
) -> dict[str, np.ndarray]:
    """Diagnostics of sampled paths ``path`` of shape ``(N, points, 3)`` (see
    :func:`path_profiles`, without ``distance``)."""
    cfg = cfg or task.TaskConfig()
    rho, reach = kinematics.inverse(design, path, np.asarray(mode, dtype=np.float64))
    closable = np.isfinite(rho).all(axis=-1)
    r = np.nan_to_num(rho)
    A = kinematics.normalised_A(design, path, r)
    with np.errstate(invalid="ignore", divide="ignore"):
        sv = np.linalg.svd(A, compute_uv=False)
        pm = sv[..., -1] / sv[..., 0]
        u = kinematics.leg_vectors(design, path, r)
        sm = np.min(np.abs(u[..., 0]) / np.hypot(u[..., 0], u[..., 1]), axis=-1)
    det = np.sign(np.linalg.det(A))
    min_pm = np.where(closable, pm, np.inf).min(axis=-1)
    min_sm = np.where(closable, sm, np.inf).min(axis=-1)
    min_pm = np.where(np.isinf(min_pm), np.nan, min_pm)
    min_sm = np.where(np.isinf(min_sm), np.nan, min_sm)
    crosses = (closable & (det != det[:, :1])).any(axis=-1)
    reachable = reach.all(axis=-1)
    with np.errstate(invalid="ignore"):
        clear = (
            reachable
            & ~crosses
            & (min_pm >= cfg.path_parallel_margin)
            & (min_sm >= cfg.path_serial_margin)
        )
    return {
        "reachable": reachable,
        "min_parallel_margin": min_pm,
        "min_serial_margin": min_sm,
        "crosses": crosses,
        "clear": clear,
    }


def path_dict(prof: dict[str, np.ndarray], k: int) -> dict[str, Any]:
    """Pair ``k`` of a profile as plain JSON values (floats rounded to 1e-6)."""
    out: dict[str, Any] = {}
    for key, arr in prof.items():
        v = arr[k].item()
        out[key] = bool(v) if isinstance(v, (bool, np.bool_)) else round(float(v), 6)
    return out


def with_sequential(
    design: Design,
    s: FloatArray,
    t: FloatArray,
    mode: ArrayLike,
    cfg: task.TaskConfig,
    path: dict[str, Any],
) -> dict[str, Any]:
    """``path`` plus the sequential path's diagnostics under ``sequential_<key>``."""
    seq = profile(design, sequential_path(s, t), mode, cfg)
    out = dict(path)
    out.update({f"sequential_{k}": v for k, v in path_dict(seq, 0).items()})
    return out


def with_slider_line(
    design: Design, s: FloatArray, t: FloatArray, mode: ArrayLike, path: dict[str, Any]
) -> dict[str, Any]:
    """``path`` plus ``slider_line_reaches``: the straight line in slider space from ``s`` to
    ``t`` brings the gripper to ``t`` (:mod:`planar3p_gym.machine.slider_line`; False when an end is
    not reachable in ``mode``)."""
    out = dict(path)
    try:
        out["slider_line_reaches"] = bool(slider_line_reaches(design, s, t, mode)[0])
    except ValueError:
        out["slider_line_reaches"] = False
    return out
