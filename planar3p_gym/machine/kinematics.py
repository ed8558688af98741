"""Exact kinematics of the 3-PRR manipulator (numpy, vectorised over leading axes; numba).

Conventions (``docs/mechanism.md``): pose ``p = (x, y, theta)`` is the gripper point ``G`` (m) and
the direction ``theta`` (rad) of ``e = (cos theta, sin theta)`` pointing from ``G`` to the joints,
``C_i = G + L_iG e``; travels ``rho`` (m) put the slider joints at ``B_i = (a_i + rho_i, 0)``;
leg vectors ``u_i = C_i - B_i`` have length ``L_i`` and angle ``alpha_i``.  The working mode is
``sigma_i = sign(cos alpha_i)``; the assembly mode is ``sign(det A)``.

Public functions:

* :func:`inverse` -- slider travels of poses in given working modes, with a reachability mask.
* :func:`forward` / :func:`forward_batch` -- every real pose for given travels (closed form:
  linear elimination, a cubic in ``cos theta``, circle intersection, Newton polish).
* :func:`jacobians` -- ``A``, ``B`` of ``A p_dot = B rho_dot``.
* :func:`simple_motion_basis` / :func:`simple_motion_rates` -- the paper's three
  simple-motion formulas, and superposed.
* :func:`parallel_margin`, :func:`serial_margin`, :func:`assembly_mode` (all three at once:
  :func:`margins`), :func:`classify_singularity` -- singularity measures.
* :func:`screen_poses` / :func:`screen_paths` -- thresholds on travels and margins, decided as
  :func:`inverse` and :func:`margins` would, but cheaply (the task sampler's filter).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.design import Design

__all__ = [
    "ALL_MODES",
    "ForwardSolutions",
    "IKResult",
    "Margins",
    "PoseSolution",
    "Screening",
    "SingularityReport",
    "assembly_mode",
    "classify_singularity",
    "forward",
    "forward_batch",
    "inverse",
    "jacobians",
    "leg_vectors",
    "loop_residual",
    "margins",
    "min_parallel_margin",
    "normalised_A",
    "parallel_margin",
    "pose_distance",
    "pose_distance_euclidean",
    "screen_paths",
    "screen_poses",
    "serial_margin",
    "simple_motion_basis",
    "simple_motion_rates",
    "simple_motion_rates_from_angles",
    "working_mode",
]

FloatArray = NDArray[np.float64]

#: The 8 working modes ``sigma = (sigma_1, sigma_2, sigma_3)``, each entry +1 or -1, shape (8, 3).
ALL_MODES: NDArray[np.int8] = np.array(
    [[s1, s2, s3] for s1 in (1, -1) for s2 in (1, -1) for s3 in (1, -1)], dtype=np.int8
)
ALL_MODES.setflags(write=False)


class _Consts(NamedTuple):
    k: FloatArray  # L_iG, (3,)
    legs: FloatArray  # L_i, (3,)
    origins: FloatArray  # a_i, (3,)
    stroke: float
    ref: float  # characteristic length
    scale: float  # max leg length, for tolerances


@lru_cache(maxsize=64)
def _consts(design: Design) -> _Consts:
    k = np.array(design.joint_offsets, dtype=np.float64)
    legs = np.array(design.leg_lengths, dtype=np.float64)
    origins = np.array(design.rail_origins, dtype=np.float64)
    for arr in (k, legs, origins):
        arr.setflags(write=False)
    return _Consts(
        k, legs, origins, float(design.stroke), design.characteristic_length, float(legs.max())
    )


# ---------------------------------------------------------------------------- validation
def _check_design(design: object) -> Design:
    if not isinstance(design, Design):
        raise ValueError(f"design must be a planar3p_gym.Design, got {type(design).__name__}")
    return design


def _as_float(name: str, value: ArrayLike) -> FloatArray:
    """Float64 array of real numbers (no strings, booleans or complex), or ValueError."""
    try:
        arr = np.asarray(value)
        if arr.dtype.kind == "O":
            arr = arr.astype(np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be an array of real numbers: {exc}") from exc
    if arr.dtype.kind not in "fiu":
        raise ValueError(f"{name} must be an array of real numbers, got dtype {arr.dtype}")
    return arr.astype(np.float64, copy=False)


def _as_triples(name: str, value: ArrayLike) -> FloatArray:
    """Float64 array of shape (..., 3), all finite, or ValueError naming ``name``."""
    arr = _as_float(name, value)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (..., 3), got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


#: The input checks and design constants above under public names, for the other modules of
#: :mod:`planar3p_gym.machine` (the same functions, not copies).
check_design, as_float, as_triples = _check_design, _as_float, _as_triples
design_constants = _consts


def _as_modes(mode: ArrayLike) -> FloatArray:
    if type(mode) is tuple and len(mode) == 3 and all(type(m) is int for m in mode):
        return _mode_of_tuple(mode)  # the usual case: a working mode's tuple of ints
    return _modes_array(mode)


@lru_cache(maxsize=64)
def _mode_of_tuple(mode: tuple) -> FloatArray:
    """:func:`_modes_array` of a tuple, kept (read-only): a reset validates a few a step."""
    arr = _modes_array(mode)
    arr.setflags(write=False)
    return arr


def _modes_array(mode: ArrayLike) -> FloatArray:
    try:
        arr = np.asarray(mode)
    except (TypeError, ValueError) as exc:  # pragma: no cover - numpy accepts nearly anything
        raise ValueError(f"mode must be +-1 with shape (..., 3): {exc}") from exc
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ValueError(f"mode must have shape (..., 3), got shape {arr.shape}")
    if arr.dtype.kind not in "fiu" or not (np.abs(arr) == 1).all():
        raise ValueError("mode entries must be +1 or -1 (sign of cos alpha_i)")
    return arr.astype(np.float64)


def _check_broadcast(name_a: str, a: NDArray, name_b: str, b: NDArray) -> None:
    """ValueError naming both arguments when their shapes do not broadcast."""
    if a.shape == b.shape or (b.ndim == 1 and a.shape[-1:] == b.shape):
        return
    try:
        np.broadcast_shapes(a.shape, b.shape)
    except ValueError:
        raise ValueError(
            f"{name_a} of shape {a.shape} and {name_b} of shape {b.shape} do not broadcast"
        ) from None


#: :func:`_check_broadcast` under a public name (for :mod:`planar3p_gym.machine.statics`).
check_broadcast = _check_broadcast


# ---------------------------------------------------------------------------- inverse kinematics
class IKResult(NamedTuple):
    """Result of :func:`inverse`.

    Attributes:
        rho: slider travels (m), shape ``(..., 3)``; NaN for a leg that cannot close
            (``|C_iy| > L_i``).
        reachable: ``(...)`` bool, all three legs close with travels inside ``[0, stroke]``.
    """

    rho: FloatArray
    reachable: NDArray[np.bool_]


def inverse(design: Design, pose: ArrayLike, mode: ArrayLike = (1, 1, 1)) -> IKResult:
    """Slider travels (m) for poses ``(..., 3)`` in working modes ``(..., 3)`` of +-1.

    ``pose`` and ``mode`` broadcast against each other, e.g. poses ``(N, 1, 3)`` with
    :data:`ALL_MODES` ``(8, 3)`` give all 8 modes of N poses.
    """
    c = _consts(_check_design(design))
    p = _as_triples("pose", pose)
    sigma = _as_modes(mode)
    _check_broadcast("pose", p, "mode", sigma)
    shape = p.shape if p.shape == sigma.shape else np.broadcast_shapes(p.shape, sigma.shape)
    if p.shape != shape:
        p = np.broadcast_to(p, shape)
    if sigma.shape != shape:
        sigma = np.broadcast_to(sigma, shape)
    rho, inside = _inverse_rows(
        np.ascontiguousarray(p.reshape(-1, 3)), np.ascontiguousarray(sigma.reshape(-1, 3)),
        c.k, c.legs, c.origins, c.stroke,
    )  # fmt: skip
    reachable = inside.reshape(shape[:-1])
    return IKResult(rho.reshape(shape), reachable if reachable.ndim else reachable[()])


@njit(cache=True)
def _leg_travel(
    x: float, y: float, cos: float, sin: float, k: float, leg: float, origin: float, sigma: float
) -> tuple[float, float, float]:
    """The inverse kinematics of one leg, defined once (:func:`inverse` and :func:`_screen_rows`
    call it): ``(rho_i, C_ix, C_iy)`` (m) of the pose ``(x, y)`` with ``cos theta, sin theta``,
    ``rho_i = ((x + k_i cos) - a_i) - sigma_i sqrt(L_i^2 - C_iy^2)`` (NaN where the leg cannot
    close).  (``planar3p_gym.analysis.workspace`` evaluates the same expression on its grids.)"""
    cx = x + k * cos
    cy = y + k * sin
    disc = leg * leg - cy * cy
    if disc < 0.0:
        return math.nan, cx, cy
    return cx - origin - sigma * math.sqrt(disc), cx, cy


@njit(cache=True)
def _inverse_rows(
    p: FloatArray, sigma: FloatArray, k: FloatArray, legs: FloatArray, origins: FloatArray,
    stroke: float,
) -> tuple[FloatArray, NDArray[np.bool_]]:  # fmt: skip
    """:func:`_leg_travel` of poses ``p`` (M, 3) in modes ``sigma`` (M, 3): the travels (M, 3)
    (m) and whether all three are within ``[0, stroke]`` (M,)."""
    m = p.shape[0]
    rho = np.empty((m, 3))
    inside = np.empty(m, dtype=np.bool_)
    for j in range(m):
        cos, sin = math.cos(p[j, 2]), math.sin(p[j, 2])
        ok = True
        for i in range(3):
            r = _leg_travel(p[j, 0], p[j, 1], cos, sin, k[i], legs[i], origins[i], sigma[j, i])[0]
            rho[j, i] = r
            if not (r >= 0.0 and r <= stroke):  # (NaN compares False)
                ok = False
        inside[j] = ok
    return rho, inside


def leg_vectors(design: Design, pose: ArrayLike, rho: ArrayLike) -> FloatArray:
    """Leg vectors ``u_i = C_i - B_i`` (m), shape ``(..., 3, 2)``."""
    c = _consts(_check_design(design))
    p = _as_triples("pose", pose)
    r = _as_triples("rho", rho)
    return _leg_vectors(c, p, r)


def _leg_vectors(c: _Consts, p: FloatArray, r: FloatArray) -> FloatArray:
    _check_broadcast("pose", p, "rho", r)
    th = p[..., 2:3]
    ux = p[..., 0:1] + c.k * np.cos(th) - (c.origins + r)
    uy = np.broadcast_to(p[..., 1:2] + c.k * np.sin(th), ux.shape)
    return np.stack([ux, uy], axis=-1)


def pose_distance(a: ArrayLike, b: ArrayLike, length: float) -> FloatArray:
    """``|dp| + length * |dtheta|`` (m) between poses ``(..., 3)`` (m, m, rad), the angle
    difference wrapped to ``[0, pi]``; ``length`` (m) weighs the rotation (the Euclidean
    distance is :func:`pose_distance_euclidean`)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    dth = np.abs(wrap_angle(b[..., 2] - a[..., 2]))
    return np.hypot(b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]) + length * dth


def pose_distance_euclidean(a: ArrayLike, b: ArrayLike, length: float) -> FloatArray:
    """``|(dx, dy, length * dtheta)|`` (m) between poses ``(..., 3)`` (m, m, rad), the angle
    difference wrapped to ``(-pi, pi]``; ``length`` (m) weighs the rotation.  The Euclidean
    twin of :func:`pose_distance` (which adds ``|dp|`` and ``length * |dtheta|``)."""
    d = np.asarray(b, dtype=np.float64) - np.asarray(a, dtype=np.float64)
    d[..., 2] = wrap_angle(d[..., 2]) * length
    return np.linalg.norm(d, axis=-1)


def loop_residual(design: Design, pose: ArrayLike, rho: ArrayLike) -> FloatArray:
    """Loop-closure residual ``|C_i - B_i| - L_i`` (m) per leg, shape ``(..., 3)``."""
    c = _consts(_check_design(design))
    u = _leg_vectors(c, _as_triples("pose", pose), _as_triples("rho", rho))
    return np.hypot(u[..., 0], u[..., 1]) - c.legs


def working_mode(design: Design, pose: ArrayLike, rho: ArrayLike) -> NDArray[np.int8]:
    """Working mode ``sign(cos alpha_i)`` of a configuration, shape ``(..., 3)`` of +-1 (0 if
    a leg is exactly perpendicular to its rail)."""
    u = leg_vectors(design, pose, rho)
    return np.sign(u[..., 0]).astype(np.int8)


# ---------------------------------------------------------------------------- Jacobians
def _jacobian_A(c: _Consts, p: FloatArray, u: FloatArray) -> FloatArray:
    th = p[..., 2:3]
    third = c.k * (u[..., 1] * np.cos(th) - u[..., 0] * np.sin(th))
    return np.stack([u[..., 0], u[..., 1], third], axis=-1)


def jacobians(design: Design, pose: ArrayLike, rho: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """``A`` and ``B`` of ``A p_dot = B rho_dot``, each ``(..., 3, 3)``.

    Row ``i`` of ``A`` is ``[u_ix, u_iy, u_i . E (C_i - G)]`` (units m, m, m^2) and
    ``B = diag(u_ix)`` (m), with ``E`` the rotation by +90 degrees.
    """
    c = _consts(_check_design(design))
    p = _as_triples("pose", pose)
    u = _leg_vectors(c, p, _as_triples("rho", rho))
    A = _jacobian_A(c, p, u)
    B = np.zeros(A.shape)
    idx = np.arange(3)
    B[..., idx, idx] = u[..., 0]
    return A, B


def normalised_A(design: Design, pose: ArrayLike, rho: ArrayLike) -> FloatArray:
    """Dimensionless ``A_bar``: rows of ``A`` divided by ``L_i``, third column by the design's
    characteristic length; shape ``(..., 3, 3)``."""
    c = _consts(_check_design(design))
    p = _as_triples("pose", pose)
    u = _leg_vectors(c, p, _as_triples("rho", rho))
    return _normalised_A(c, p, u)


def _normalised_A(c: _Consts, p: FloatArray, u: FloatArray) -> FloatArray:
    A = _jacobian_A(c, p, u) / c.legs[:, None]
    A[..., 2] /= c.ref
    return A


# ---------------------------------------------------------------------------- singularities
def parallel_margin(design: Design, pose: ArrayLike, rho: ArrayLike) -> FloatArray:
    """Inverse condition number ``sigma_min / sigma_max`` of ``A_bar``, in ``[0, 1]``
    (0 at a parallel singularity), shape ``(...)``."""
    return _svd_margin(normalised_A(design, pose, rho))


def _svd_margin(a_bar: FloatArray) -> FloatArray:
    """``sigma_min / sigma_max`` of matrices ``(..., 3, 3)`` by numpy's SVD, which works
    matrix by matrix (so a matrix's margin does not depend on the batch it is in): the one
    definition behind :func:`parallel_margin`, :func:`margins`, :func:`min_parallel_margin`
    and the screen's undecided poses."""
    sv = np.linalg.svd(a_bar, compute_uv=False)
    return sv[..., -1] / sv[..., 0]


def min_parallel_margin(design: Design, poses: ArrayLike, rho: ArrayLike) -> FloatArray:
    """The smallest :func:`parallel_margin` along each path of poses and travels ``(..., P,
    3)``, shape ``(...)``: ``parallel_margin(design, poses, rho).min(axis=-1)`` bit for bit,
    with the SVD only where it can matter.

    Per path, the SVD of the pose with the smallest ``|det A_bar| / |A_bar|_F^3`` gives a
    margin ``m``; the closed-form bounds of the screen (:func:`_bound_test`) then prove most
    other poses' margins at least ``m`` (they cannot be the minimum), and the SVD runs on the
    rest.  Each pose's margin is the SVD of the same matrix as :func:`parallel_margin` takes
    (numpy's SVD works matrix by matrix), so the minimum is the same number; on the mode
    change's certified paths about a third of the poses need the SVD.
    """
    c = _consts(_check_design(design))
    p, r = _as_triples("poses", poses), _as_triples("rho", rho)
    if p.ndim < 2:
        raise ValueError(f"poses must have shape (..., P, 3), got shape {p.shape}")
    if not p.shape[-2]:
        raise ValueError("min_parallel_margin needs at least one pose per path (P >= 1)")
    a_bar = _normalised_A(c, p, _leg_vectors(c, p, r))
    shape, points = a_bar.shape[:-3], a_bar.shape[-3]
    flat = np.ascontiguousarray(a_bar.reshape(-1, points, 3, 3))
    n = flat.shape[0]
    if not n:
        return np.empty(shape)
    proxy = np.abs(np.linalg.det(flat)) / np.sqrt((flat * flat).sum(axis=(-2, -1))) ** 3
    first = np.argmin(proxy, axis=1)
    best = _svd_margin(flat[np.arange(n), first])
    rows, cols = np.nonzero(_not_above(flat, best))
    if rows.size:
        np.minimum.at(best, rows, _svd_margin(flat[rows, cols]))
    return best.reshape(shape)


@njit(cache=True)
def _not_above(a_bar: FloatArray, floor: FloatArray) -> NDArray[np.bool_]:
    """``(n, P)``: the poses of paths ``a_bar`` ``(n, P, 3, 3)`` whose parallel margin the
    bounds (:func:`_bound_test`) do not prove at least ``floor[i]`` of their path."""
    out = np.empty(a_bar.shape[:2], dtype=np.bool_)
    for i in range(a_bar.shape[0]):
        for j in range(a_bar.shape[1]):
            above, _, _ = _bound_test(a_bar[i, j], floor[i])
            out[i, j] = not above
    return out


def serial_margin(design: Design, pose: ArrayLike, rho: ArrayLike) -> FloatArray:
    """``min_i |cos alpha_i|`` in ``[0, 1]`` (0 at a serial singularity), shape ``(...)``."""
    u = leg_vectors(design, pose, rho)
    return np.min(np.abs(u[..., 0]) / np.hypot(u[..., 0], u[..., 1]), axis=-1)


def assembly_mode(design: Design, pose: ArrayLike, rho: ArrayLike) -> NDArray[np.int8]:
    """``sign(det A)``: +1 or -1 labels the assembly mode, 0 exactly at a parallel
    singularity; shape ``(...)``."""
    A, _ = jacobians(design, pose, rho)
    return np.sign(np.linalg.det(A)).astype(np.int8)


class Margins(NamedTuple):
    """The singularity measures of :func:`margins`, each of shape ``(...)``.

    Attributes:
        parallel: inverse condition number of ``A_bar`` in ``[0, 1]`` (:func:`parallel_margin`).
        serial: ``min_i |cos alpha_i|`` in ``[0, 1]`` (:func:`serial_margin`).
        assembly: ``sign(det A)``, int8 (:func:`assembly_mode`).
    """

    parallel: FloatArray
    serial: FloatArray
    assembly: NDArray[np.int8]


def margins(design: Design, pose: ArrayLike, rho: ArrayLike) -> Margins:
    """Parallel margin, serial margin and ``sign(det A)`` together, from one evaluation of the
    leg vectors (the same values as the three separate functions)."""
    # NB: _screen reproduces these floating-point values bit for bit (and so _leg_vectors and
    # _jacobian_A); keep them in step.
    c = _consts(_check_design(design))
    p = _as_triples("pose", pose)
    u = _leg_vectors(c, p, _as_triples("rho", rho))
    A = _jacobian_A(c, p, u)
    A_bar = A / c.legs[:, None]
    A_bar[..., 2] /= c.ref
    serial = np.min(np.abs(u[..., 0]) / np.hypot(u[..., 0], u[..., 1]), axis=-1)
    return Margins(_svd_margin(A_bar), serial, np.sign(np.linalg.det(A)).astype(np.int8))


# ---------------------------------------------------------------------------- screening
#: A margin bound decides a threshold test only when it clears the threshold by this much (the
#: bounds and the SVD's margin are both within ~1e-11 of the exact values where they are used).
_BOUND_SLACK = 1e-8
#: ... and only where ``|cof A_bar|_F > _BOUND_TRUST |A_bar|_F^2`` (``s_2 / s_1`` not tiny), so
#: that rounding in ``det`` and the cofactors cannot make the bounds wrong by more than ~1e-11.
_BOUND_TRUST = 1e-4


@njit(cache=True)
def _bound_test(x: FloatArray, threshold: float) -> tuple[bool, bool, float]:
    """What closed-form bounds prove about the inverse condition number of the 3x3 matrix
    ``x`` against ``threshold``: ``(above, below, det)``, where ``above`` (``below``) means the
    SVD's ratio is certainly ``>=`` (``<``) the threshold.

    With singular values ``s1 >= s2 >= s3``: ``|det| = s1 s2 s3``, the squared cofactors sum to
    ``s1^2 s2^2 + s1^2 s3^2 + s2^2 s3^2`` (between ``s1^2 s2^2`` and ``3 s1^2 s2^2``) and
    ``s1^2 <= |x|_F^2 <= 3 s1^2``, so ``|det| / (|cof|_F |x|_F) <= s3 / s1`` and
    ``s3 / s1 <= 3 |det| / (|cof|_F |x|_F)``.  The bounds are used where
    ``|cof|_F > _BOUND_TRUST |x|_F^2``, and only when they clear the threshold by
    ``_BOUND_SLACK``, far more than their rounding error and the SVD's.
    """
    det = 0.0
    f2 = 0.0
    g2 = 0.0
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            cof = x[i1, j1] * x[i2, j2] - x[i1, j2] * x[i2, j1]
            if i == 0:
                det += x[0, j] * cof
            f2 += x[i, j] * x[i, j]
            g2 += cof * cof
    gf = math.sqrt(g2 * f2)
    ad = abs(det)
    trusted = g2 > _BOUND_TRUST**2 * (f2 * f2)
    above = trusted and ad >= (threshold + _BOUND_SLACK) * gf
    below = trusted and 3.0 * ad <= (threshold - _BOUND_SLACK) * gf
    return above, below, det


class Screening(NamedTuple):
    """Result of :func:`screen_poses`.

    Attributes:
        ok: ``(...)`` bool, the pose passes every test.
        rho: slider travels (m), shape ``(..., 3)``, as :func:`inverse` gives them.
        assembly: ``sign(det A)`` (int8) where ``ok``, else 0; shape ``(...)``.
    """

    ok: NDArray[np.bool_]
    rho: FloatArray
    assembly: NDArray[np.int8]


def _screen(
    c: _Consts,
    p: FloatArray,
    sigma: FloatArray,
    row: int,
    travel: tuple[float, float] | None,
    min_parallel: float,
    min_serial: float,
    assembly: float | None,
) -> tuple[NDArray[np.bool_], FloatArray, NDArray[np.int8]]:
    """Screen poses ``p`` (M, 3) in modes ``sigma`` ((3,) or (M, 3)), grouped in rows of ``row``
    consecutive poses: per-pose ``ok`` (M,), False on the whole of a row as soon as one pose of
    it fails (the rest of a failed row is not examined), travels (3, M) (legs first; NaN where
    not examined) and assembly modes (M,) (0 where not ok).

    Every decision is the one :func:`inverse` and :func:`margins` lead to: the values compared
    are computed by the same floating-point operations, and the parallel margin's SVD is
    skipped only where rigorous bounds (:func:`_bound_test`) clear the threshold by
    ``_BOUND_SLACK``.  The tests run cheapest first, pose by pose, in one compiled loop
    (:func:`_screen_rows`); the SVD of the poses the bounds leave undecided is numpy's, as in
    :func:`margins`.
    """
    lo, hi = (0.0, c.stroke) if travel is None else (float(travel[0]), float(travel[1]))
    m = p.shape[0]
    ok = np.zeros(m, dtype=np.bool_)
    rho = np.full((3, m), np.nan)
    asm = np.zeros(m, dtype=np.int8)
    pending = np.zeros(m, dtype=np.bool_)
    if m == 0:
        return ok, rho, asm
    a = np.empty((m, 3, 3))
    a_bar = np.empty((m, 3, 3))
    _screen_rows(
        np.ascontiguousarray(p, dtype=np.float64),
        np.ascontiguousarray(sigma.reshape(-1, 3), dtype=np.float64),
        row, lo, hi, c.k, c.legs, c.origins, c.ref, float(min_parallel), float(min_serial),
        0.0 if assembly is None else float(assembly), assembly is not None,
        ok, rho, asm, pending, a, a_bar,
    )  # fmt: skip
    todo = np.flatnonzero(pending)
    if todo.size:
        sign = np.sign(np.linalg.det(a[todo])).astype(np.int8)
        good = _svd_margin(a_bar[todo]) >= min_parallel
        if assembly is not None:
            good &= sign == assembly
        asm[todo] = np.where(good, sign, 0)
        failed = np.unique(todo[~good] // row)
        if failed.size:
            ok.reshape(-1, row)[failed] = False
            asm.reshape(-1, row)[failed] = 0
    return ok, rho, asm


@njit(cache=True)
def _screen_rows(
    p: FloatArray, sigma: FloatArray, row: int, lo: float, hi: float, k: FloatArray,
    legs: FloatArray, origins: FloatArray, ref: float, min_parallel: float, min_serial: float,
    assembly: float, check_assembly: bool, ok: NDArray[np.bool_], rho: FloatArray,
    asm: NDArray[np.int8], pending: NDArray[np.bool_], a: FloatArray, a_bar: FloatArray,
) -> None:  # fmt: skip
    """The compiled loop of :func:`_screen`: for each row of poses, each pose in turn (inverse,
    travels, serial margin, the parallel margin's bounds and the assembly mode) until one
    fails.  Writes ``ok`` (True for every pose of a row that did not fail), ``rho`` (3, M),
    ``asm`` (where the bounds decided), and ``pending``, with ``a`` and ``a_bar`` (``A`` and
    ``A_bar``, (M, 3, 3)), for the poses whose parallel margin the bounds leave undecided."""
    m = p.shape[0]
    per_pose = sigma.shape[0] > 1
    ux = np.empty(3)
    uy = np.empty(3)
    x_bar = np.empty((3, 3))  # A_bar transposed: components by legs
    for first in range(0, m, row):
        alive = True
        for j in range(first, first + row):
            s = sigma[j] if per_pose else sigma[0]
            th = p[j, 2]
            cos, sin = math.cos(th), math.sin(th)
            inside = True
            for i in range(3):  # inverse
                r, cx, cy = _leg_travel(p[j, 0], p[j, 1], cos, sin, k[i], legs[i], origins[i], s[i])
                rho[i, j] = r
                if not (r >= lo and r <= hi):  # (NaN compares False)
                    inside = False
                ux[i] = cx - (origins[i] + r)
                uy[i] = cy
            if not inside:
                alive = False
                break
            fail = False
            for i in range(3):  # serial margin: min |cos alpha_i| (NaN fails)
                if not (abs(ux[i]) / math.hypot(ux[i], uy[i]) >= min_serial):
                    fail = True
            for i in range(3):  # A_bar's rows (u_ix, u_iy, k_i (u_iy cos - u_ix sin) / ref) / L_i
                third = k[i] * (uy[i] * cos - ux[i] * sin)
                x_bar[0, i] = ux[i] / legs[i]
                x_bar[1, i] = uy[i] / legs[i]
                x_bar[2, i] = third / legs[i] / ref
                a[j, i, 0], a[j, i, 1], a[j, i, 2] = ux[i], uy[i], third
            above, below, det = _bound_test(x_bar, min_parallel)
            sign = 1 if det > 0.0 else (-1 if det < 0.0 else 0)
            if below or (check_assembly and above and sign != assembly):
                fail = True
            if fail:
                alive = False
                break
            if above:  # |det| far above its rounding error: the sign is exact
                asm[j] = sign
            else:
                pending[j] = True
                for i in range(3):
                    for q in range(3):
                        a_bar[j, i, q] = x_bar[q, i]
        for j in range(first, first + row):
            ok[j] = alive
            if not alive:
                pending[j] = False
                asm[j] = 0


def screen_poses(
    design: Design,
    pose: ArrayLike,
    mode: ArrayLike = (1, 1, 1),
    travel: tuple[float, float] | None = None,
    min_parallel: float = 0.0,
    min_serial: float = 0.0,
    assembly: float | None = None,
) -> Screening:
    """Which poses ``(..., 3)`` (m, m, rad) are reachable in working modes ``mode`` (``(..., 3)``
    of +-1, broadcast against the poses) with every travel in ``travel = (lo, hi)`` (m, default
    ``(0, stroke)``), a parallel margin of at least ``min_parallel``, a serial margin of at least
    ``min_serial`` and, if ``assembly`` is given, ``sign(det A) == assembly``.

    The same decisions as :func:`inverse` followed by :func:`margins` (bit for bit: the same
    floating-point values are compared), at a fraction of the cost: the tests run cheapest
    first, and the SVD behind the parallel margin only where closed-form bounds on it do not
    decide the test.
    """
    c = _consts(_check_design(design))
    shape, p, sigma = _flat_poses("pose", _as_triples("pose", pose), _as_modes(mode))
    ok, rho, asm = _screen(c, p, sigma, 1, travel, min_parallel, min_serial, assembly)
    return Screening(ok.reshape(shape[:-1]), rho.T.reshape(shape), asm.reshape(shape[:-1]))


def screen_paths(
    design: Design,
    paths: ArrayLike,
    mode: ArrayLike = (1, 1, 1),
    travel: tuple[float, float] | None = None,
    min_parallel: float = 0.0,
    min_serial: float = 0.0,
    assembly: float | None = None,
) -> NDArray[np.bool_]:
    """Mask ``(...)``: every pose of each path ``(..., P, 3)`` passes the tests of
    :func:`screen_poses` (same arguments; ``mode`` broadcasts against ``paths``).  A path is
    dropped at its first failing test, so this is cheaper than screening all its poses."""
    c = _consts(_check_design(design))
    p = _as_triples("paths", paths)
    if p.ndim < 2:
        raise ValueError(f"paths must have shape (..., P, 3), got shape {p.shape}")
    shape, p, sigma = _flat_poses("paths", p, _as_modes(mode))
    ok, _, _ = _screen(c, p, sigma, shape[-2], travel, min_parallel, min_serial, assembly)
    return ok.reshape(shape[:-1]).all(axis=-1)


def _flat_poses(
    name: str, p: FloatArray, sigma: FloatArray
) -> tuple[tuple[int, ...], FloatArray, FloatArray]:
    """Validated poses and modes broadcast together: the common shape ``(..., 3)``, the poses
    flattened to (M, 3) and the modes, (3,) if one mode, else flattened to (M, 3)."""
    if sigma.ndim == 1:
        return p.shape, p.reshape(-1, 3), sigma
    _check_broadcast(name, p, "mode", sigma)
    shape = np.broadcast_shapes(p.shape, sigma.shape)
    flat = np.broadcast_to(p, shape).reshape(-1, 3)
    return shape, flat, np.broadcast_to(sigma, shape).reshape(-1, 3)


@dataclass(frozen=True)
class SingularityReport:
    """What :func:`classify_singularity` says of one configuration.

    Attributes:
        kind: ``"serial"`` or ``"parallel"``: the singularity the configuration is at, or the
            nearest one (the one whose margin is smaller).
        detail: for serial, ``"leg i"`` (1-based); for parallel, ``"parallel legs"`` or
            ``"concurrent legs"``.
        at_singularity: the governing margin is below the tolerance.
        leg: 0-based index of the leg for a serial singularity, else ``None``.
        parallel_margin: inverse condition number of ``A_bar``.
        serial_margin: ``min_i |cos alpha_i|``.
        meeting_point: for concurrent legs, the point (m) nearest to the three leg lines.
    """

    kind: str
    detail: str
    at_singularity: bool
    leg: int | None
    parallel_margin: float
    serial_margin: float
    meeting_point: tuple[float, float] | None


def classify_singularity(
    design: Design, pose: ArrayLike, rho: ArrayLike, tol: float = 1e-6
) -> SingularityReport:
    """Which singularity a single configuration is at (margin < ``tol``) or nearest."""
    p = _as_triples("pose", pose)
    r = _as_triples("rho", rho)
    if p.shape != (3,) or r.shape != (3,):
        raise ValueError("classify_singularity takes one configuration: pose and rho of shape (3,)")
    if not (math.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be finite and > 0, got {tol!r}")
    u = leg_vectors(design, p, r)
    cos_alpha = np.abs(u[:, 0]) / np.hypot(u[:, 0], u[:, 1])
    s_margin = float(cos_alpha.min())
    p_margin = float(parallel_margin(design, p, r))
    if s_margin <= p_margin:
        leg = int(np.argmin(cos_alpha))
        return SingularityReport(
            "serial", f"leg {leg + 1}", s_margin < tol, leg, p_margin, s_margin, None
        )
    dirs = u / np.hypot(u[:, 0], u[:, 1])[:, None]
    # The leg lines are (nearly) parallel when every pair of directions is (nearly) parallel.
    cross = [abs(dirs[i, 0] * dirs[j, 1] - dirs[i, 1] * dirs[j, 0]) for i, j in _PAIRS]
    b = _consts(design).origins + r
    if max(cross) < 10 * max(p_margin, tol):
        return SingularityReport(
            "parallel", "parallel legs", p_margin < tol, None, p_margin, s_margin, None
        )
    # Least-squares point of the three lines n_i . X = n_i . B_i.
    normals = np.stack([-dirs[:, 1], dirs[:, 0]], axis=1)
    rhs = normals[:, 0] * b
    point, *_ = np.linalg.lstsq(normals, rhs, rcond=None)
    return SingularityReport(
        "parallel",
        "concurrent legs",
        p_margin < tol,
        None,
        p_margin,
        s_margin,
        (float(point[0]), float(point[1])),
    )


_PAIRS = ((0, 1), (0, 2), (1, 2))


# ---------------------------------------------------------------------------- simple motions
def simple_motion_basis(
    design: Design,
    legs_cos: ArrayLike,
    legs_sin: ArrayLike,
    cos_theta: ArrayLike,
    sin_theta: ArrayLike,
    epsilon: float = 0.0,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Slider rates of the three unit simple motions, each of shape ``(..., 3)``: the one
    definition of the paper's simple-motion formulas.

    Returns ``(horizontal, vertical, rotation)``: the rates (m/s) for a gripper velocity of
    1 m/s along ``x``, 1 m/s along ``y`` and an angular velocity of 1 rad/s about ``G``, so that
    ``rho_dot = x_dot * horizontal + y_dot * vertical + theta_dot * rotation``, with
    ``vertical_i = tan(alpha_i)`` and ``rotation_i = L_iG sin(alpha_i - theta) / cos(alpha_i)``.
    ``legs_cos``, ``legs_sin`` are ``cos/sin alpha_i`` ``(..., 3)``; ``cos_theta``,
    ``sin_theta`` are ``(...)``.  ``1 / cos alpha_i`` is ``sign(cos) / max(|cos|, epsilon)``:
    exact wherever ``|cos alpha_i| >= epsilon``; with ``epsilon > 0`` bounded by ``1 / epsilon``
    at a serial singularity, with ``epsilon = 0`` infinite there.
    """
    if not (math.isfinite(epsilon) and epsilon >= 0.0):
        raise ValueError(f"epsilon must be a finite number >= 0, got {epsilon!r}")
    c = np.asarray(legs_cos, dtype=np.float64)
    s = np.asarray(legs_sin, dtype=np.float64)
    ct = np.asarray(cos_theta, dtype=np.float64)[..., None]
    st = np.asarray(sin_theta, dtype=np.float64)[..., None]
    k = np.asarray(design.joint_offsets, dtype=np.float64)
    # 1 / cos alpha_i with |cos alpha_i| floored at ``epsilon`` (sign kept; +1 at exactly 0).
    with np.errstate(divide="ignore"):
        inv_c = np.where(c < 0.0, -1.0, 1.0) / np.maximum(np.abs(c), epsilon)
    horizontal = np.ones(np.broadcast_shapes(c.shape, ct.shape))
    vertical = s * inv_c
    with np.errstate(invalid="ignore"):
        rotation = k * (s * ct - c * st) * inv_c  # L_iG sin(alpha_i - theta) / cos(alpha_i)
    return horizontal, np.broadcast_to(vertical, horizontal.shape), rotation


def simple_motion_rates_from_angles(
    design: Design, alpha: ArrayLike, theta: ArrayLike, twist: ArrayLike
) -> FloatArray:
    """Slider rates (m/s) from measured leg angles ``alpha`` (rad, ``(..., 3)``), platform
    angle ``theta`` (rad, ``(...)``) and twist ``(x_dot, y_dot, theta_dot)`` (m/s, m/s, rad/s):
    :func:`simple_motion_basis` superposed, exact (``epsilon = 0``); infinite where
    ``cos alpha_i = 0`` (a serial singularity) and the motion needs that leg.
    """
    _check_design(design)
    al = _as_triples("alpha", alpha)
    th = _as_float("theta", theta)[..., None]
    if not np.isfinite(th).all():
        raise ValueError("theta contains NaN or infinite values")
    tw = _as_triples("twist", twist)
    _check_broadcast("alpha", al, "theta[..., None]", th)
    _check_broadcast("alpha", al, "twist", tw)
    _, ver, rot = simple_motion_basis(
        design, np.cos(al), np.sin(al), np.cos(th[..., 0]), np.sin(th[..., 0])
    )
    with np.errstate(invalid="ignore"):
        vertical = tw[..., 1:2] * ver
        rotation = tw[..., 2:3] * rot
    vertical = np.where(tw[..., 1:2] == 0.0, 0.0, vertical)
    rotation = np.where(tw[..., 2:3] == 0.0, 0.0, rotation)
    return tw[..., 0:1] + vertical + rotation


def simple_motion_rates(
    design: Design, pose: ArrayLike, rho: ArrayLike, twist: ArrayLike
) -> FloatArray:
    """The paper's simple motions superposed: slider rates (m/s) for a platform twist
    ``(x_dot, y_dot, theta_dot)`` (m/s, m/s, rad/s) at configuration ``(pose, rho)``.

    Equal to ``B^-1 A p_dot`` wherever no leg is perpendicular to its rail.
    """
    p = _as_triples("pose", pose)
    u = leg_vectors(design, p, rho)
    alpha = np.arctan2(u[..., 1], u[..., 0])
    return simple_motion_rates_from_angles(design, alpha, p[..., 2], twist)


# ---------------------------------------------------------------------------- direct kinematics
class ForwardSolutions(NamedTuple):
    """All real poses for a batch of travels, from :func:`forward_batch`.

    Solutions are sorted: valid ones first; above the rails (``side`` +1), then on the rail
    line (0), then below (-1); then ``sign det A = +1`` before ``-1``; then by ``theta``.  The
    mirror image ``(x, -y, -theta)`` of a solution is a solution with the same ``det A``, so
    away from singularities the answer is two mirror pairs (or none), and the two poses above
    the rails have opposite ``sign det A``.

    Attributes:
        poses: ``(..., 4, 3)`` poses ``(x, y, theta)`` (m, m, rad; ``theta`` in ``(-pi, pi]``),
            NaN where ``valid`` is False.
        valid: ``(..., 4)`` bool.
        assembly: ``(..., 4)`` int8, ``sign(det A)`` of each solution (0 where invalid or
            exactly singular).
        side: ``(..., 4)`` int8, +1 above the rails, -1 below, 0 on the rail line or invalid.
        count: ``(...)`` number of distinct real poses (0 to 4).  At (or within rounding of)
            a parallel singularity two coalescing poses may be reported once or twice.
        residual: ``(..., 4)`` largest loop residual ``| |C_i - B_i| - L_i |`` (m).
    """

    poses: FloatArray
    valid: NDArray[np.bool_]
    assembly: NDArray[np.int8]
    side: NDArray[np.int8]
    count: NDArray[np.int64]
    residual: FloatArray


@dataclass(frozen=True)
class PoseSolution:
    """One real pose of :func:`forward` with its labels.

    Attributes:
        pose: ``(x, y, theta)`` (m, m, rad).
        assembly: ``sign(det A)``, +1 or -1 (0 exactly at a parallel singularity).
        side: +1 above the rails, -1 below, 0 on the rail line.
        working_mode: ``sign(cos alpha_i)`` per leg.
        residual: largest loop-closure residual (m).
    """

    pose: tuple[float, float, float]
    assembly: int
    side: int
    working_mode: tuple[int, int, int]
    residual: float


def forward(design: Design, rho: ArrayLike) -> list[PoseSolution]:
    """Every real pose (at most 4) for one set of slider travels ``rho`` (m, shape (3,)).

    Travels outside ``[0, stroke]`` are allowed (the geometry does not care); see
    :func:`forward_batch` for the vectorised form and the ordering of the solutions.
    """
    r = _as_triples("rho", rho)
    if r.shape != (3,):
        raise ValueError(f"forward takes one rho of shape (3,), got {r.shape}; use forward_batch")
    sol = forward_batch(design, r)
    out = []
    for j in range(int(sol.count)):
        pose = sol.poses[j]
        modes = working_mode(design, pose, r)
        out.append(
            PoseSolution(
                (float(pose[0]), float(pose[1]), float(pose[2])),
                int(sol.assembly[j]),
                int(sol.side[j]),
                (int(modes[0]), int(modes[1]), int(modes[2])),
                float(sol.residual[j]),
            )
        )
    return out


# ---------------------------------------------------------------------------- DK internals
#
# The solver works on flat 1-D arrays, one per leg, with the slider positions taken relative
# to slider 2 (``beta_i = b_i - b_2``; the problem is invariant under a shift along the rails,
# and the shift removes most of the cancellation from the polynomial coefficients).
#
# 1. Elimination.  Row i of the loop equations, ``u + 2 k_i v - 2 b_i X = e_i + g_i c`` with
#    ``u = |G|^2``, ``v = G . e``, ``X = G_x``, ``e_i = L_i^2 - k_i^2 - b_i^2`` and
#    ``g_i = 2 k_i b_i``, is solved by Cramer's rule without dividing by its determinant
#    ``Delta``; ``4 Delta^2 [(u - X^2) (1 - c^2) - (v - X c)^2] = 0`` is a cubic
#    ``f(c) = P(c) (1 - c^2) - Q(c)^2`` (the ``c^4`` terms cancel).  Its leading coefficient is
#    ``8 (k_3 - k_2)(k_2 - k_1)(k_1 - k_3) beta_1 beta_3 (beta_3 - beta_1)``: with two sliders
#    at the same place the cubic degenerates to a quadratic (handled below); ``Delta = 0``
#    (the ``b_i`` affine in the ``k_i``) makes a root double, with two poses at one ``theta``.
# 2. Roots.  ``f(+-1) = -Q(+-1)^2 <= 0``, so ``[-1, 1]`` holds an even number of roots: none or
#    the pair on either side of the local maximum ``c_max`` of ``f`` (the third root is outside,
#    hence at most 4 poses).  The pair is bracketed by ``c_max`` and the other critical point
#    (or +-1) and found by safeguarded Newton.  A pair that rounding may have turned complex
#    (``f(c_max) <= 0`` with a half-gap below ``_NEAR_DOUBLE``) or a triple root marks the row
#    *hard*.  (Coefficient rounding limits a near-double pair to ~sqrt(eps) accuracy; near
#    ``|c| = 1``, where ``dc = -sin(theta) dtheta``, poses far apart can share ``c`` to 1e-8.)
# 3. Poses.  For a root ``c`` (``sin theta >= 0``) the gripper lies on the circles
#    ``|G - O_i| = L_i``, ``O_i = B_i - L_iG e``; the best-separated pair is intersected and the
#    third circle picks the branch (both are kept when it cannot tell them apart).
# 4. Newton on the three loop equations polishes every candidate (compressed active set, early
#    exit); poses are folded to ``sin theta >= 0`` (the mirror ``(x, -y, -theta)`` of a solution
#    is a solution, with the same ``det A``) and de-duplicated.  A row where some root gave no
#    pose of its own (failed polish, or two roots converging to one pose) is marked hard too.
# 5. Hard rows (well under 1% of random reachable poses) are re-solved in the pose space, where
#    the floating-point accuracy is not limited by the polynomial: the residual of the third
#    leg along both intersection branches of the best pair is sampled on a grid of ``theta``
#    around every root estimate; sign changes are refined by the Illinois method, touching
#    zeros (a double root, or the tangent circles of three parallel legs) by a golden-section
#    search on the miss; a guarded Gauss-Newton polishes both.  The results are merged with the
#    fast path's, poses that agree to ``_MERGE`` being one (the limit of a near-double root).

_ACCEPT = 1e-11  # accepted loop residual, relative to the longest leg
_SAME = 1e-7  # poses closer than this (relative to the longest leg) are one solution
_MERGE = 1e-6  # the same in rows re-solved by the scan (near-double roots)
_EDGE = 1e-3  # roots in cos(theta) accepted this far outside [-1, 1], then clipped
_NEAR_DOUBLE = 1e-5  # half-gap of the root pair in cos(theta) that makes a row hard
_BOTH_BRANCHES = 1e-6  # third-circle residual (relative) below which the other branch is kept
_FAST_NEWTON = 6  # Newton steps of the fast path
_SCAN_POINTS = 49  # theta samples per scan window of a hard row
_SCAN_HALF_WIDTH = 2.5e-3  # rad, least half-width of a scan window
_ILLINOIS_STEPS = 40
_GUARDED_STEPS = 40
_GOLDEN_STEPS = 60
_SUB_POINTS = 65  # samples of a cell with a touching zero, searched for a second zero


class _DK(NamedTuple):
    k: tuple[float, float, float]
    L: tuple[float, float, float]
    Lsq: tuple[float, float, float]
    E: tuple[float, float, float]  # L_i^2 - k_i^2
    kap: tuple[float, float, float]  # (k3 - k2, k1 - k3, k2 - k1)
    scale: float  # longest leg
    ref: float  # characteristic length (theta -> length)
    accept: float  # accepted residual (m)
    same: float  # de-duplication distance (m)
    merge: float  # de-duplication distance in hard rows (m)
    tol_f: float  # Newton stops when |F_i| = | |u_i|^2 - L_i^2 | / 2 is below this (m^2)


@lru_cache(maxsize=64)
def _dk_consts(design: Design) -> _DK:
    k = tuple(float(v) for v in design.joint_offsets)
    L = tuple(float(v) for v in design.leg_lengths)
    scale = max(L)
    return _DK(
        k,  # type: ignore[arg-type]
        L,  # type: ignore[arg-type]
        tuple(v * v for v in L),  # type: ignore[arg-type]
        tuple(L[i] * L[i] - k[i] * k[i] for i in range(3)),  # type: ignore[arg-type]
        (k[2] - k[1], k[0] - k[2], k[1] - k[0]),
        scale,
        float(design.characteristic_length),
        _ACCEPT * scale,
        _SAME * scale,
        _MERGE * scale,
        1e-14 * scale * scale,
    )


def _cubic_coefficients(
    d: _DK, be1: FloatArray, be3: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Coefficients ``(a3, a2, a1, a0)`` of ``f(c)`` for slider offsets ``beta_1, beta_3``."""
    k1, k2, k3 = d.k
    kap1, kap2, kap3 = d.kap
    e1 = d.E[0] - be1 * be1
    e2 = d.E[1]
    e3 = d.E[2] - be3 * be3
    b13 = be1 * be3
    delta4 = 4.0 * (kap1 * be1 + kap3 * be3)  # 4 Delta
    U0 = (k2 * be3) * e1 + (k3 * be1 - k1 * be3) * e2 - (k2 * be1) * e3
    V1 = (-2.0 * (k1 - k3)) * b13
    U1 = -k2 * V1
    X0 = -(kap1 * e1 + kap2 * e2 + kap3 * e3)
    X1 = (-2.0 * kap1 * k1) * be1 - (2.0 * kap3 * k3) * be3
    V0 = -(be3 * e1 + (be1 - be3) * e2 - be1 * e3)
    q1 = V1 - X0
    dU0 = delta4 * U0
    dU1 = delta4 * U1
    a3 = 2.0 * V1 * X1 - dU1
    a2 = X0 * X0 - X1 * X1 - dU0 - q1 * q1 + 2.0 * V0 * X1
    a1 = dU1 - 2.0 * X0 * X1 - 2.0 * V0 * q1
    a0 = dU0 - X0 * X0 - V0 * V0
    return a3, a2, a1, a0


def _inner_roots(
    a3: FloatArray, a2: FloatArray, a1: FloatArray, a0: FloatArray
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """The roots of ``f`` in ``[-1, 1]`` (left, right; NaN when absent) and a near-double flag.

    A near-double pair (half-gap below ``_NEAR_DOUBLE``) is reported as its two roots when
    ``f(c_max) > 0`` and as ``c_max`` alone (left slot) when rounding made it complex.
    """
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        s = np.maximum(np.maximum(np.abs(a3), np.abs(a2)), np.maximum(np.abs(a1), np.abs(a0)))
        inv = np.where(s > 0.0, 1.0 / s, 0.0)
        a3, a2, a1, a0 = a3 * inv, a2 * inv, a1 * inv, a0 * inv
        A = 3.0 * a3
        B = 2.0 * a2
        disc = B * B - 4.0 * A * a1
        sq = np.sqrt(disc)  # NaN where there is no critical point
        sgn = np.where(B >= 0.0, 1.0, -1.0)
        q = -0.5 * (B + sgn * sq)
        r1 = q / A
        r2 = a1 / q
        c_max = np.where(sgn > 0.0, r1, r2)
        c_min = np.where(sgn > 0.0, r2, r1)
        f_max = ((a3 * c_max + a2) * c_max + a1) * c_max + a0
        half = np.sqrt(2.0 * np.abs(f_max) / sq)  # half-gap of the pair (quadratic model)
        exists = (sq > 0.0) & (np.abs(c_max) <= 1.0 + _EDGE)
        # a pair that rounding may have made complex; a real near-double pair is left to the
        # fast path, whose self-check (every root must give its own pose) catches failures
        near = exists & (f_max <= 0.0) & (half < _NEAR_DOUBLE)
        # (nearly) coincident critical points: a triple root, e.g. theta = 0 with three equal
        # legs (the architecture singularity of the fig7 design); report the inflection point
        c_infl = -B / (2.0 * A)
        triple = (
            ~exists
            & (np.abs(disc) <= 1e-10 * (B * B + np.abs(4.0 * A * a1)))
            & (np.abs(c_infl) <= 1.0 + _EDGE)
        )
        two = exists & (f_max > 0.0)
        lo_l = np.maximum(np.where(c_min < c_max, c_min, -np.inf), -1.0 - _EDGE)
        hi_r = np.minimum(np.where(c_min > c_max, c_min, np.inf), 1.0 + _EDGE)
    n = a3.shape[0]
    left = np.full(n, np.nan)
    right = np.full(n, np.nan)
    idx = np.nonzero(two)[0]
    if idx.size:
        cm, hf = c_max[idx], half[idx]
        lo = np.concatenate([lo_l[idx], cm])
        hi = np.concatenate([cm, hi_r[idx]])
        x0 = np.concatenate([cm - hf, cm + hf])
        direction = np.concatenate([np.ones(idx.size), -np.ones(idx.size)])
        ii = np.concatenate([idx, idx])
        roots = _bracketed_newton(a3[ii], a2[ii], a1[ii], a0[ii], x0, lo, hi, direction)
        left[idx] = roots[: idx.size]
        right[idx] = roots[idx.size :]
    left[near] = c_max[near]
    left[triple] = c_infl[triple]
    return left, right, near | triple


@njit(cache=True)
def _clip(x: float, lo: float, hi: float) -> float:
    """``np.clip(x, lo, hi)`` of one number, NaN as numpy treats it (a NaN ``x`` or bound
    gives NaN)."""
    m = x if math.isnan(x) else (x if x > lo else lo)
    return m if math.isnan(m) else (m if m < hi else hi)


@njit(cache=True, error_model="numpy")
def _bracketed_newton(
    a3: FloatArray,
    a2: FloatArray,
    a1: FloatArray,
    a0: FloatArray,
    x: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    direction: FloatArray,
) -> FloatArray:
    """Newton on the cubic, falling back to bisection whenever a step leaves ``(lo, hi)``;
    ``direction`` is +1 where ``f`` increases through the root, -1 where it decreases.
    Compiled, one root after the other: a root's iterations depend on its own numbers only,
    and a loop of scalars saves the array formulation's dozens of numpy calls per iteration
    on arrays of a few hundred roots (``f / f'`` by numpy's rules: inf or NaN, no error)."""
    out = np.empty(x.size)
    for i in range(x.size):
        c3, c2, c1, c0, sense = a3[i], a2[i], a1[i], a0[i], direction[i]
        low, high = lo[i], hi[i]
        xi = _clip(x[i], low, high)
        out[i] = xi
        for _ in range(60):
            f = ((c3 * xi + c2) * xi + c1) * xi + c0
            fp = (3.0 * c3 * xi + 2.0 * c2) * xi + c1
            if sense * f > 0.0:  # right of the root
                high = xi
            else:
                low = xi
            step = f / fp
            xn = xi - step
            inside = xn >= low and xn <= high
            tiny = abs(step) <= 1e-14 * (1.0 + abs(xi))
            ax = abs(xi)
            noise = 4e-16 * (((abs(c3) * ax + abs(c2)) * ax + abs(c1)) * ax + abs(c0))
            at_root = abs(f) <= noise
            done = at_root or (tiny and inside) or (high - low <= 1e-14 * (1.0 + ax))
            xn = xi if at_root else (xn if inside else 0.5 * (low + high))
            out[i] = xn
            if done:
                break
            xi = xn
    return out


def _legs_F(
    d: _DK, X: FloatArray, Y: FloatArray, T: FloatArray, be1: FloatArray, be3: FloatArray
) -> tuple[FloatArray, ...]:
    """Leg vectors and ``F_i = (|u_i|^2 - L_i^2) / 2`` in slider-2-relative coordinates."""
    k1, k2, k3 = d.k
    ct, st = np.cos(T), np.sin(T)
    ux1 = X + k1 * ct - be1
    ux2 = X + k2 * ct
    ux3 = X + k3 * ct - be3
    uy1 = Y + k1 * st
    uy2 = Y + k2 * st
    uy3 = Y + k3 * st
    F1 = 0.5 * (ux1 * ux1 + uy1 * uy1 - d.Lsq[0])
    F2 = 0.5 * (ux2 * ux2 + uy2 * uy2 - d.Lsq[1])
    F3 = 0.5 * (ux3 * ux3 + uy3 * uy3 - d.Lsq[2])
    return ct, st, ux1, ux2, ux3, uy1, uy2, uy3, F1, F2, F3


def _newton_step(
    d: _DK,
    X: FloatArray,
    Y: FloatArray,
    be1: FloatArray,
    be3: FloatArray,
    legs: tuple[FloatArray, ...],
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Newton step ``A dp = -F`` (Cramer) and ``det A``; zero step where ``A`` is singular."""
    k1, k2, k3 = d.k
    ct, st, ux1, ux2, ux3, uy1, uy2, uy3, F1, F2, F3 = legs
    base = Y * ct - X * st  # w_i = k_i (Y c - (X - beta_i) s)
    w1 = k1 * (base + be1 * st)
    w2 = k2 * base
    w3 = k3 * (base + be3 * st)
    m1 = uy2 * w3 - uy3 * w2
    m2 = uy3 * w1 - uy1 * w3
    m3 = uy1 * w2 - uy2 * w1
    det = ux1 * m1 + ux2 * m2 + ux3 * m3
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(det != 0.0, -1.0 / det, 0.0)
    dX = (F1 * m1 + F2 * m2 + F3 * m3) * inv
    # columns 2 and 3 by Cramer with the rhs in place of a column
    n1 = F2 * w3 - F3 * w2
    n2 = F3 * w1 - F1 * w3
    n3 = F1 * w2 - F2 * w1
    dY = (ux1 * n1 + ux2 * n2 + ux3 * n3) * inv
    o1 = uy2 * F3 - uy3 * F2
    o2 = uy3 * F1 - uy1 * F3
    o3 = uy1 * F2 - uy2 * F1
    dT = (ux1 * o1 + ux2 * o2 + ux3 * o3) * inv
    return dX, dY, dT, det


def _det_from_legs(
    d: _DK, X: FloatArray, Y: FloatArray, be1: FloatArray, be3: FloatArray, legs: tuple
) -> FloatArray:
    """``det A`` from :func:`_legs_F` output."""
    k1, k2, k3 = d.k
    ct, st, ux1, ux2, ux3, uy1, uy2, uy3 = legs[:8]
    base = Y * ct - X * st
    w1 = k1 * (base + be1 * st)
    w2 = k2 * base
    w3 = k3 * (base + be3 * st)
    return ux1 * (uy2 * w3 - uy3 * w2) + ux2 * (uy3 * w1 - uy1 * w3) + ux3 * (uy1 * w2 - uy2 * w1)


def _fast_newton(
    d: _DK, X: FloatArray, Y: FloatArray, T: FloatArray, be1: FloatArray, be3: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Plain Newton with early exit on the active set.  Returns the final iterates, their
    residual ``max_i | |u_i| - L_i |`` (m) and ``det A`` (NaN propagates to both)."""
    n = X.size
    outX, outY, outT, outR, outD = (np.empty(n) for _ in range(5))
    act = np.arange(n)
    L1, L2, L3 = d.L
    for it in range(_FAST_NEWTON + 1):
        legs = _legs_F(d, X, Y, T, be1, be3)
        F1, F2, F3 = legs[8:]
        err = np.maximum(np.maximum(np.abs(F1), np.abs(F2)), np.abs(F3))
        done = ~(err > d.tol_f)  # NaN counts as done (and fails the acceptance test)
        if it == _FAST_NEWTON:
            done[:] = True
        if done.any():
            idx = act[done] if not done.all() else act
            sub = legs if done.all() else tuple(a[done] for a in legs)
            Xd, Yd = (X, Y) if done.all() else (X[done], Y[done])
            b1d, b3d = (be1, be3) if done.all() else (be1[done], be3[done])
            ux1, ux2, ux3, uy1, uy2, uy3 = sub[2:8]
            outR[idx] = np.maximum(
                np.maximum(np.abs(np.hypot(ux1, uy1) - L1), np.abs(np.hypot(ux2, uy2) - L2)),
                np.abs(np.hypot(ux3, uy3) - L3),
            )
            outD[idx] = _det_from_legs(d, Xd, Yd, b1d, b3d, sub)
            outX[idx], outY[idx] = Xd, Yd
            outT[idx] = T if done.all() else T[done]
            if done.all():
                break
            keep = ~done
            act, X, Y, T, be1, be3 = act[keep], X[keep], Y[keep], T[keep], be1[keep], be3[keep]
            legs = tuple(a[keep] for a in legs)
        dX, dY, dT, _ = _newton_step(d, X, Y, be1, be3, legs)
        X, Y, T = X + dX, Y + dY, T + dT
    return outX, outY, outT, outR, outD


def _residual(
    d: _DK, X: FloatArray, Y: FloatArray, T: FloatArray, be1: FloatArray, be3: FloatArray
) -> FloatArray:
    """Largest ``| |C_i - B_i| - L_i |`` (m); NaN propagates."""
    k1, k2, k3 = d.k
    ct, st = np.cos(T), np.sin(T)
    r1 = np.abs(np.hypot(X + k1 * ct - be1, Y + k1 * st) - d.L[0])
    r2 = np.abs(np.hypot(X + k2 * ct, Y + k2 * st) - d.L[1])
    r3 = np.abs(np.hypot(X + k3 * ct - be3, Y + k3 * st) - d.L[2])
    return np.maximum(np.maximum(r1, r2), r3)


def _pair_geometry(
    d: _DK, be1: FloatArray, be3: FloatArray, c: FloatArray, s: FloatArray, pair: NDArray | None
) -> tuple[FloatArray, ...]:
    """Circle centres ``O_i = B_i - k_i e`` of the pair (i, j) and the third leg m.

    ``pair`` (0: legs 1-2, 1: legs 1-3, 2: legs 2-3) is chosen here as the best-separated pair
    when None.  Returns ``(pair, xi, yi, xj, yj, xm, ym, Li, Lj, Lm)``."""
    k1, k2, k3 = d.k
    ox1, ox2, ox3 = be1 - k1 * c, -k2 * c, be3 - k3 * c
    oy1, oy2, oy3 = -k1 * s, -k2 * s, -k3 * s
    if pair is None:
        d12 = (ox2 - ox1) ** 2 + ((k1 - k2) * s) ** 2
        d13 = (ox3 - ox1) ** 2 + ((k1 - k3) * s) ** 2
        d23 = (ox3 - ox2) ** 2 + ((k2 - k3) * s) ** 2
        pair = np.where(d13 >= d12, np.where(d13 >= d23, 1, 2), np.where(d12 >= d23, 0, 2))
    p0, p2 = pair == 0, pair == 2
    xi = np.where(p2, ox2, ox1)
    yi = np.where(p2, oy2, oy1)
    xj = np.where(p0, ox2, ox3)
    yj = np.where(p0, oy2, oy3)
    xm = np.where(p0, ox3, np.where(p2, ox1, ox2))
    ym = np.where(p0, oy3, np.where(p2, oy1, oy2))
    L1, L2, L3 = d.L
    Li = np.where(p2, L2, L1)
    Lj = np.where(p0, L2, L3)
    Lm = np.where(p0, L3, np.where(p2, L1, L2))
    return pair, xi, yi, xj, yj, xm, ym, Li, Lj, Lm


def _intersections(
    geo: tuple[FloatArray, ...],
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Both intersections of circles i, j and the third leg's residual at each:
    ``(xa, ya, ra, xb, yb, rb, h2)`` (``h2 < 0``: the circles do not meet)."""
    _, xi, yi, xj, yj, xm, ym, Li, Lj, Lm = geo
    dx, dy = xj - xi, yj - yi
    dd = dx * dx + dy * dy
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / np.sqrt(dd)
        along = 0.5 * (dd + Li * Li - Lj * Lj) * inv
        h2 = Li * Li - along * along
        h = np.sqrt(np.maximum(h2, 0.0))
        ex, ey = dx * inv, dy * inv
    mx, my = xi + along * ex, yi + along * ey
    xa, ya = mx - h * ey, my + h * ex
    xb, yb = mx + h * ey, my - h * ex
    ra = np.hypot(xa - xm, ya - ym) - Lm
    rb = np.hypot(xb - xm, yb - ym) - Lm
    return xa, ya, ra, xb, yb, rb, h2


def _canonical(
    X: FloatArray, Y: FloatArray, T: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Fold poses to ``theta in [0, pi]`` by the rail-line mirror ``(x, -y, -theta)``."""
    T = wrap_angle(T)
    flip = T < 0.0
    return X, np.where(flip, -Y, Y), np.where(flip, -T, T)


def _forward_flat(d: _DK, b: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
    """DK of ``n`` rows of slider positions ``b`` (n, 3).  Returns canonical poses
    ``Q (5, n, 2)`` = ``X, Y, T, residual, det A`` (X relative to slider 2) and ``V (n, 2)``."""
    n = b.shape[0]
    be1 = b[:, 0] - b[:, 1]
    be3 = b[:, 2] - b[:, 1]
    left, right, hard = _inner_roots(*_cubic_coefficients(d, be1, be3))

    # ---- candidate poses: 2 roots x (best branch, other branch) = 4 slots per row
    roots = np.stack([left, right], axis=1).ravel()  # row-major: row r -> 2r, 2r + 1
    rid = np.nonzero(~np.isnan(roots))[0]
    rows = rid >> 1
    c = np.clip(roots[rid], -1.0, 1.0)
    s = np.sqrt((1.0 - c) * (1.0 + c))
    geo = _pair_geometry(d, be1[rows], be3[rows], c, s, None)
    xa, ya, ra, xb, yb, rb, h2 = _intersections(geo)
    ra, rb = np.abs(ra), np.abs(rb)
    a_best = ~(rb < ra)
    r_best = np.where(a_best, ra, rb)
    r_other = np.where(a_best, rb, ra)
    ok = (h2 > -1e-4 * d.scale * d.scale) & (r_best < 2e-2 * d.scale)
    other = ok & (r_other < _BOTH_BRANCHES * d.scale + 10.0 * r_best)
    th = np.arctan2(s, c)
    if other.any():
        cand_slot = np.concatenate([2 * rid[ok], 2 * rid[other] + 1])
        cX = np.concatenate([np.where(a_best, xa, xb)[ok], np.where(a_best, xb, xa)[other]])
        cY = np.concatenate([np.where(a_best, ya, yb)[ok], np.where(a_best, yb, ya)[other]])
        cT = np.concatenate([th[ok], th[other]])
    else:
        cand_slot = 2 * rid[ok]
        cX = np.where(a_best, xa, xb)[ok]
        cY = np.where(a_best, ya, yb)[ok]
        cT = th[ok]
    crow = cand_slot >> 2
    cX, cY, cT, cR, cD = _fast_newton(d, cX, cY, cT, be1[crow], be3[crow])
    good = cR < d.accept
    cX, cY, cT = _canonical(cX, cY, cT)  # det A is the same for a pose and its mirror

    Q = np.zeros((5, 4 * n))
    Q[3] = np.inf
    V = np.zeros(4 * n, dtype=bool)
    gs = cand_slot[good]
    Q[:, gs] = np.stack([cX, cY, cT, cR, cD])[:, good]
    V[gs] = True
    Q = Q.reshape(5, n, 4)
    V = _dedupe(d, Q, V.reshape(n, 4), d.same)
    n_roots = (~np.isnan(left)).astype(np.int64) + (~np.isnan(right))
    hard |= V.sum(axis=1) < n_roots  # a root without its own pose: re-solve the row

    hidx = np.nonzero(hard)[0]
    Q2, V2 = _first_two(d, Q, V)
    if hidx.size:
        sQ, sV = _scan_rows(d, be1[hidx], be3[hidx], left[hidx], right[hidx])
        mQ = np.concatenate([Q[:, hidx], sQ], axis=2)
        # a hard row is ill-conditioned: poses that agree to the precision a near-double root
        # allows (about sqrt(residual x leg)) are one solution
        mV = _dedupe(d, mQ, np.concatenate([V[hidx], sV], axis=1), d.merge)
        Q2[:, hidx], V2[hidx] = _first_two(d, mQ, mV)
    return Q2, V2


def _dedupe(d: _DK, Q: FloatArray, V: NDArray[np.bool_], tol: float) -> NDArray[np.bool_]:
    """Drop duplicates (closer than ``tol``, m) among canonical (``sin theta >= 0``) slots
    ``Q (5, m, S)``; two poses are the same if they agree directly or as mirror images
    (possible near theta = 0, pi).  Of two duplicates the one with the smaller residual
    survives."""
    V = V.copy()
    S = V.shape[1]
    tol_t = tol / d.ref
    for a in range(S):
        for b in range(a + 1, S):
            idx = np.nonzero(V[:, a] & V[:, b])[0]
            if not idx.size:
                continue
            Xa, Ya, Ta, Ra = Q[:4, idx, a]
            Xb, Yb, Tb, Rb = Q[:4, idx, b]
            direct = (np.abs(Ya - Yb) < tol) & (np.abs(Ta - Tb) < tol_t)
            mirror = (np.abs(Ya + Yb) < tol) & (np.minimum(Ta + Tb, 2.0 * np.pi - Ta - Tb) < tol_t)
            dup = (np.abs(Xa - Xb) < tol) & (direct | mirror)
            if dup.any():
                b_better = Rb < Ra
                V[idx[dup & b_better], a] = False
                V[idx[dup & ~b_better], b] = False
    return V


def _first_two(d: _DK, Q: FloatArray, V: NDArray[np.bool_]) -> tuple[FloatArray, NDArray]:
    """Compact valid slots ``(m, S)`` to two.  More than two distinct canonical poses cannot
    be (the cubic has at most two roots in [-1, 1]); near a double root polishing may leave a
    cluster of nearly equal poses, which is merged closest pair first."""
    m, S = V.shape
    many = np.nonzero(V.sum(axis=1) > 2)[0]
    if many.size:
        V = V.copy()
        for r in many:
            while V[r].sum() > 2:
                idx = np.nonzero(V[r])[0]
                best = (np.inf, -1, -1)
                for ia, a in enumerate(idx):
                    for b in idx[ia + 1 :]:
                        Xa, Ya, Ta = Q[:3, r, a]
                        Xb, Yb, Tb = Q[:3, r, b]
                        dist = max(
                            abs(Xa - Xb),
                            min(abs(Ya - Yb), abs(Ya + Yb)),
                            d.ref * min(abs(Ta - Tb), abs(Ta + Tb)),
                        )
                        if dist < best[0]:
                            best = (dist, a, b)
                _, a, b = best
                V[r, b if Q[3, r, b] >= Q[3, r, a] else a] = False
    i0 = np.argmax(V, axis=1)
    base = np.arange(m) * S
    V1 = V.copy()
    V1.ravel()[base + i0] = False
    i1 = np.argmax(V1, axis=1)
    flat = np.stack([base + i0, base + i1], axis=1)
    return Q.reshape(5, -1)[:, flat], np.stack([V.any(axis=1), V1.any(axis=1)], axis=1)


class _Branch(NamedTuple):
    """Per-start constants of one intersection branch: circle pair (i, j), third leg m."""

    bi: FloatArray
    bj: FloatArray
    bm: FloatArray
    ki: FloatArray
    kj: FloatArray
    km: FloatArray
    Li: FloatArray
    dL: FloatArray  # L_i^2 - L_j^2
    Lm: FloatArray
    sgn: FloatArray  # +1: branch a, -1: branch b

    def take(self, idx: NDArray) -> _Branch:
        return _Branch(*(a[idx] for a in self))


def _make_branch(
    d: _DK, be1: FloatArray, be3: FloatArray, pair: NDArray, sgn: FloatArray
) -> _Branch:
    k1, k2, k3 = d.k
    L1, L2, L3 = d.L
    zero = np.zeros_like(be1)
    p0, p2 = pair == 0, pair == 2
    bi = np.where(p2, zero, be1)
    bj = np.where(p0, zero, be3)
    bm = np.where(p0, be3, np.where(p2, be1, zero))
    ki = np.where(p2, k2, k1)
    kj = np.where(p0, k2, k3)
    km = np.where(p0, k3, np.where(p2, k1, k2))
    Li = np.where(p2, L2, L1)
    Lj = np.where(p0, L2, L3)
    Lm = np.where(p0, L3, np.where(p2, L1, L2))
    return _Branch(bi, bj, bm, ki, kj, km, Li, Li * Li - Lj * Lj, Lm, sgn)


def _branch_eval(
    g: _Branch, th: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Gripper on the branch at ``th`` (the point of closest approach where the circles miss),
    the third leg's residual there, the pair's miss ``max(-h^2, 0) / (2 L_i)`` and ``h^2``."""
    c, s = np.cos(th), np.sin(th)
    xi = g.bi - g.ki * c
    yi = -g.ki * s
    dx = (g.bj - g.bi) - (g.kj - g.ki) * c
    dy = (g.ki - g.kj) * s
    dd = dx * dx + dy * dy
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / np.sqrt(dd)
    along = 0.5 * (dd + g.dL) * inv
    h2 = g.Li * g.Li - along * along
    sh = g.sgn * np.sqrt(np.maximum(h2, 0.0)) * inv
    gx = xi + along * dx * inv - sh * dy
    gy = yi + along * dy * inv + sh * dx
    r = np.hypot(gx - (g.bm - g.km * c), gy + g.km * s) - g.Lm
    gap = np.maximum(-h2, 0.0) / (2.0 * g.Li)
    return gx, gy, r, gap, h2


def _scan_rows(
    d: _DK, be1: FloatArray, be3: FloatArray, left: FloatArray, right: FloatArray
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Slow, robust path for hard rows: scan the third leg's residual along both intersection
    branches of the best pair over a window of ``theta`` around each root estimate.

    Returns canonical slots ``Q (5, h, S)`` and ``V (h, S)`` as :func:`_forward_flat`."""
    h = be1.size
    centres = np.stack([left, right], axis=1)  # (h, 2)
    valid_c = ~np.isnan(centres)
    th_c = np.arccos(np.clip(np.where(valid_c, centres, 1.0), -1.0, 1.0))
    # both estimates of a row share a window wide enough to cover the pair (and then some)
    spread = np.where(valid_c.all(axis=1), np.abs(th_c[:, 0] - th_c[:, 1]), 0.0)
    half = np.maximum(_SCAN_HALF_WIDTH, 2.0 * spread)
    wrow, wslot = np.nonzero(valid_c)
    if not wrow.size:
        return np.zeros((5, h, 1)), np.zeros((h, 1), dtype=bool)
    w_th = th_c[wrow, wslot]
    # windows x branches: both branches of the pair that is best separated at the centre
    pair = _pair_geometry(d, be1[wrow], be3[wrow], np.cos(w_th), np.sin(w_th), None)[0]
    nw = wrow.size
    srow = np.concatenate([wrow, wrow])
    sgn = np.concatenate([np.ones(nw), -np.ones(nw)])
    g = _make_branch(d, be1[srow], be3[srow], np.concatenate([pair, pair]), sgn)
    M = _SCAN_POINTS
    centre = np.concatenate([w_th, w_th])[:, None]
    width = np.concatenate([half[wrow], half[wrow]])[:, None]
    grid = centre + width * np.linspace(-1.0, 1.0, M)
    _, _, r, gap, h2 = _branch_eval(_Branch(*(a[:, None] for a in g)), grid)
    # Where the two circles miss each other (h2 < 0) the branches merge at the point of closest
    # approach; at a parallel singularity with parallel legs the circles are tangent at the
    # solution, so a zero of the miss without a sign change of r counts too.
    meets = h2 >= 0.0
    r0, r1 = r[:, :-1], r[:, 1:]
    change = (np.sign(r0) != np.sign(r1)) & meets[:, :-1] & meets[:, 1:]
    miss = np.maximum(np.abs(r), gap)
    mid = miss[:, 1:-1]
    touch = (
        (mid <= miss[:, :-2])
        & (mid <= miss[:, 2:])
        & (mid < 1e-3 * d.scale)
        & ~change[:, :-1]
        & ~change[:, 1:]
    )
    parts = []
    wi, ti = np.nonzero(change)
    if wi.size:
        tX, tY, tT = _illinois(g.take(wi), grid[wi, ti], grid[wi, ti + 1], r0[wi, ti], r1[wi, ti])
        parts.append((tX, tY, tT, srow[wi]))
    wi, ti = np.nonzero(touch)
    if wi.size:
        gt = g.take(wi)
        lo, hi = grid[wi, ti], grid[wi, ti + 2]
        tX, tY, tT, m = _golden(gt, lo, hi)
        near_root = m < 1e-8 * d.scale
        parts.append((tX[near_root], tY[near_root], tT[near_root], srow[wi][near_root]))
        # Two zeros closer than the grid spacing hide in one cell (near a fold, and along the
        # default design's parallel-leg singularities poses some 1e-5 m apart differ in theta
        # by less than that).  Deflate the zero just found: r / (theta - theta_a) changes sign
        # at the other one.
        sub = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, _SUB_POINTS)
        rs = _branch_eval(_Branch(*(a[:, None] for a in gt)), sub)[2]
        q = rs / (sub - tT[:, None])
        q0, q1 = q[:, :-1], q[:, 1:]
        sj, sk = np.nonzero((np.sign(q0) != np.sign(q1)) & np.isfinite(q0) & np.isfinite(q1))
        if sj.size:
            fX, fY, fT = _illinois(
                gt.take(sj), sub[sj, sk], sub[sj, sk + 1], q0[sj, sk], q1[sj, sk], tT[sj]
            )
            parts.append((fX, fY, fT, srow[wi][sj]))
    if not parts:
        return np.zeros((5, h, 1)), np.zeros((h, 1), dtype=bool)
    cX, cY, cT, crow = (np.concatenate(a) for a in zip(*parts, strict=True))
    cb1, cb3 = be1[crow], be3[crow]
    cX, cY, cT = _guarded_newton(d, cX, cY, cT, cb1, cb3)
    legs = _legs_F(d, cX, cY, cT, cb1, cb3)
    cR = _residual(d, cX, cY, cT, cb1, cb3)
    cD = _det_from_legs(d, cX, cY, cb1, cb3, legs)
    good = cR < d.accept
    cX, cY, cT = _canonical(cX[good], cY[good], cT[good])
    cR, cD, crow = cR[good], cD[good], crow[good]
    # scatter into (h, S) slots, S = most poses of one row
    order = np.argsort(crow, kind="stable")
    crow = crow[order]
    counts = np.bincount(crow, minlength=h)
    S = max(int(counts.max()) if counts.size else 0, 1)
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])
    rank = np.arange(crow.size) - first[crow]
    Q = np.zeros((5, h, S))
    Q[3] = np.inf
    Q[:, crow, rank] = np.stack([cX, cY, cT, cR, cD])[:, order]
    V = np.zeros((h, S), dtype=bool)
    V[crow, rank] = True
    return Q, V


def _golden(
    g: _Branch, a: FloatArray, b: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Golden-section minimum of the miss ``max(|r|, gap)`` over ``theta in [a, b]``: a double
    root of the branch (it touches zero without a sign change).  Returns the gripper, theta
    and the miss there."""
    gr = 0.5 * (math.sqrt(5.0) - 1.0)

    def merit(t: FloatArray) -> FloatArray:
        _, _, r, gap, _ = _branch_eval(g, t)
        return np.maximum(np.abs(r), gap)

    c = b - gr * (b - a)
    e = a + gr * (b - a)
    fc, fe = merit(c), merit(e)
    for _ in range(_GOLDEN_STEPS):
        left = fc < fe  # the minimum is in [a, e]
        b = np.where(left, e, b)
        a = np.where(left, a, c)
        x = np.where(left, b - gr * (b - a), a + gr * (b - a))
        fx = merit(x)
        e, fe, c, fc = (
            np.where(left, c, x),
            np.where(left, fc, fx),
            np.where(left, x, e),
            np.where(left, fx, fe),
        )
        if (b - a).max(initial=0.0) <= 1e-13:
            break
    th = np.where(fc < fe, c, e)
    gx, gy, _, _, _ = _branch_eval(g, th)
    return gx, gy, th, np.minimum(fc, fe)


def _illinois(
    g: _Branch,
    lo: FloatArray,
    hi: FloatArray,
    flo: FloatArray,
    fhi: FloatArray,
    pole: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Regula falsi (Illinois variant) on a branch's third-leg residual in ``theta`` (divided
    by ``theta - pole`` when a deflation pole is given); converged brackets leave the active
    set.  Returns the gripper and ``theta`` of the better end of each final bracket."""
    g_all = g
    th = np.empty(lo.shape)
    act = np.arange(lo.size)
    side = np.zeros(lo.shape)
    for it in range(_ILLINOIS_STEPS):
        with np.errstate(divide="ignore", invalid="ignore"):
            x = (lo * fhi - hi * flo) / (fhi - flo)
        bad = ~((x > lo) & (x < hi))
        x = np.where(bad, 0.5 * (lo + hi), x)
        fx = _branch_eval(g, x)[2]
        if pole is not None:
            fx = fx / (x - pole)
        same_lo = np.sign(fx) == np.sign(flo)
        # Illinois: halve the retained end's value when the same end is kept twice
        fhi = np.where(same_lo & (side == -1), 0.5 * fhi, fhi)
        flo = np.where(~same_lo & (side == 1), 0.5 * flo, flo)
        lo, flo = np.where(same_lo, x, lo), np.where(same_lo, fx, flo)
        hi, fhi = np.where(same_lo, hi, x), np.where(same_lo, fhi, fx)
        side = np.where(same_lo, -1.0, 1.0)
        # the guarded Newton that follows polishes to full accuracy
        done = (hi - lo <= 1e-12) | (fx == 0.0) | (it == _ILLINOIS_STEPS - 1)
        if done.any():
            th[act[done]] = np.where(np.abs(flo) <= np.abs(fhi), lo, hi)[done]
            keep = ~done
            if not keep.any():
                break
            act, lo, hi, flo, fhi, side = (a[keep] for a in (act, lo, hi, flo, fhi, side))
            g = g.take(keep)
            if pole is not None:
                pole = pole[keep]
    gx, gy, _, _, _ = _branch_eval(g_all, th)
    return gx, gy, th


def _guarded_newton(
    d: _DK, X: FloatArray, Y: FloatArray, T: FloatArray, be1: FloatArray, be3: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Damped Gauss-Newton (Levenberg-Marquardt flavoured) that only takes steps reducing
    ``max |F_i|``; for the few starts of the slow path, near singular Jacobians included."""
    k = np.array(d.k)
    bb = np.stack([be1, np.zeros_like(be1), be3], axis=1)
    Lsq = np.array(d.Lsq)
    P = np.stack([X, Y, T], axis=1)

    def evaluate(P: FloatArray, bb: FloatArray) -> tuple[FloatArray, FloatArray]:
        ct, st = np.cos(P[:, 2:3]), np.sin(P[:, 2:3])
        ux = P[:, 0:1] + k * ct - bb
        uy = P[:, 1:2] + k * st
        F = 0.5 * (ux * ux + uy * uy - Lsq)
        J = np.stack([ux, uy, k * (uy * ct - ux * st)], axis=-1)
        return F, J

    F, J = evaluate(P, bb)
    err = np.abs(F).max(axis=1)
    lam = np.full(P.shape[0], 1e-12)
    eye = np.eye(3)
    stalled = np.zeros(P.shape[0], dtype=bool)
    for _ in range(_GUARDED_STEPS):
        act = (err > d.tol_f) & ~stalled
        if not act.any():
            break
        Ja, Fa = J[act], F[act]
        JtJ = np.einsum("nki,nkj->nij", Ja, Ja)
        g = np.einsum("nki,nk->ni", Ja, Fa)
        tr = np.trace(JtJ, axis1=1, axis2=2)
        reg = (lam[act] * tr + 1e-300)[:, None, None] * eye
        step = -np.linalg.solve(JtJ + reg, g[..., None])[..., 0]
        Pn = P[act] + step
        Fn, Jn = evaluate(Pn, bb[act])
        en = np.abs(Fn).max(axis=1)
        better = en < err[act]
        ia = np.nonzero(act)[0]
        ib = ia[better]
        P[ib], F[ib], J[ib], err[ib] = Pn[better], Fn[better], Jn[better], en[better]
        lam[ib] = np.maximum(lam[ib] * 0.1, 1e-16)
        iw = ia[~better]
        lam[iw] *= 100.0
        stalled[iw[lam[iw] > 1e2]] = True
    return P[:, 0], P[:, 1], P[:, 2]


def forward_batch(design: Design, rho: ArrayLike) -> ForwardSolutions:
    """Every real pose for travels ``rho`` of shape ``(..., 3)`` (m); see :class:`ForwardSolutions`.

    Method (details in the comments above): a cubic in ``c = cos theta`` from a division-free
    linear elimination, its (at most two) roots in ``[-1, 1]`` by bracketed Newton, the gripper
    from the intersection of two leg circles, Newton polish on the three loop equations, the
    mirror images about the rail line, and a direct scan in ``theta`` for the rows where the
    polynomial is ill-conditioned (near-double roots, ``theta`` near 0 or pi, two sliders at the
    same place).  Every returned pose has a loop residual below ``1e-11`` times the longest leg.

    Accuracy: poses are exact to rounding (~1e-12 m) where the parallel margin is not small;
    near a parallel singularity the problem itself is ill-conditioned (pose error about the
    residual divided by the margin, and at a double root set by the square root of the
    residual).  With three equal legs (``Design.fig7``) the platform parallel to the rails and
    the legs parallel has a self-motion (infinitely many poses); there the answer may be
    empty or hold any of them.
    """
    d = _dk_consts(_check_design(design))
    r = _as_triples("rho", rho)
    lead = r.shape[:-1]
    b = (_consts(design).origins + r).reshape(-1, 3)
    n = b.shape[0]
    with np.errstate(all="ignore"):  # NaN and inf are handled explicitly inside
        Q, V = _forward_flat(d, b)  # canonical (5, n, 2), X relative to slider 2
    X, Y, T, R, D = Q
    X = X + b[:, 1:2]
    asm = np.where(V, np.sign(D), 0.0)
    # each canonical pose and its mirror (x, -y, -theta); the mirror has the same det A
    tol = d.same
    self_mirror = (np.abs(Y) < tol) & (np.minimum(T, np.pi - T) * d.ref < tol)
    O = np.stack(
        [
            np.concatenate([X, X], axis=1),
            np.concatenate([Y, -Y], axis=1),
            np.concatenate([T, np.where(T == np.pi, T, -T)], axis=1),
            np.concatenate([R, R], axis=1),
            np.concatenate([asm, asm], axis=1),
        ]
    )
    oV = np.concatenate([V, V & ~self_mirror], axis=1)
    O[4] = np.where(oV, O[4], 0.0)
    oY, oT, oA = O[1], O[2], O[4]
    oS = np.where(oV, np.where(np.abs(oY) < tol, 0.0, np.sign(oY)), 0.0)
    # order: valid, side desc, assembly desc, theta asc -- one float key, 4-element network
    key = np.where(oV, (1.0 - oS) * 64.0 + (1.0 - oA) * 16.0 + (oT + np.pi), np.inf)
    ks = list(key.T)
    ix = [np.full(n, j) for j in range(4)]
    for i, j in ((0, 1), (2, 3), (0, 2), (1, 3), (1, 2)):  # a sorting network for 4 keys
        sw = ks[j] < ks[i]
        ks[i], ks[j] = np.where(sw, ks[j], ks[i]), np.where(sw, ks[i], ks[j])
        ix[i], ix[j] = np.where(sw, ix[j], ix[i]), np.where(sw, ix[i], ix[j])
    flat = np.stack(ix, axis=1) + 4 * np.arange(n)[:, None]
    Os = O.reshape(5, -1)[:, flat]  # (5, n, 4)
    valid = oV.ravel()[flat]
    side = oS.ravel()[flat]
    poses = np.stack([Os[0], Os[1], Os[2]], axis=-1)
    poses[~valid] = np.nan
    return ForwardSolutions(
        poses.reshape(lead + (4, 3)),
        valid.reshape(lead + (4,)),
        Os[4].astype(np.int8).reshape(lead + (4,)),
        side.astype(np.int8).reshape(lead + (4,)),
        valid.sum(axis=1).reshape(lead),
        np.where(valid, Os[3], np.nan).reshape(lead + (4,)),
    )
