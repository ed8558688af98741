"""Exact kinematics of the 3-PRR manipulator (pure numpy, vectorised over leading axes).

Conventions (``MECHANISM.md``): pose ``p = (x, y, theta)`` is the gripper point ``G`` (m) and the
direction ``theta`` (rad) of ``e = (cos theta, sin theta)`` pointing from ``G`` to the joints,
``C_i = G + L_iG e``; travels ``rho`` (m) put the slider joints at ``B_i = (a_i + rho_i, 0)``;
leg vectors ``u_i = C_i - B_i`` have length ``L_i`` and angle ``alpha_i``.  The working mode is
``sigma_i = sign(cos alpha_i)``; the assembly mode is ``sign(det A)``.

Public functions:

* :func:`inverse` -- slider travels of poses in given working modes, with a reachability mask.
* :func:`forward` / :func:`forward_batch` -- every real pose for given travels (closed form:
  linear elimination, a cubic in ``cos theta``, circle intersection, Newton polish).
* :func:`jacobians` -- ``A``, ``B`` of ``A p_dot = B rho_dot``.
* :func:`simple_motion_rates` -- the paper's three simple-motion formulas superposed.
* :func:`parallel_margin`, :func:`serial_margin`, :func:`assembly_mode`,
  :func:`classify_singularity` -- singularity measures.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .design import Design

__all__ = [
    "ALL_MODES",
    "ForwardSolutions",
    "IKResult",
    "PoseSolution",
    "SingularityReport",
    "assembly_mode",
    "classify_singularity",
    "forward",
    "forward_batch",
    "inverse",
    "jacobians",
    "leg_vectors",
    "loop_residual",
    "normalised_A",
    "parallel_margin",
    "serial_margin",
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


def _as_triples(name: str, value: ArrayLike) -> FloatArray:
    """Float64 array of shape (..., 3), all finite, or ValueError naming ``name``."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric with shape (..., 3): {exc}") from exc
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (..., 3), got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def _as_modes(mode: ArrayLike) -> FloatArray:
    try:
        arr = np.asarray(mode)
    except (TypeError, ValueError) as exc:  # pragma: no cover - numpy accepts nearly anything
        raise ValueError(f"mode must be +-1 with shape (..., 3): {exc}") from exc
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ValueError(f"mode must have shape (..., 3), got shape {arr.shape}")
    if not np.issubdtype(arr.dtype, np.number) or not np.isin(arr, (1, -1)).all():
        raise ValueError("mode entries must be +1 or -1 (sign of cos alpha_i)")
    return arr.astype(np.float64)


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
    th = p[..., 2:3]
    cx = p[..., 0:1] + c.k * np.cos(th)
    cy = p[..., 1:2] + c.k * np.sin(th)
    disc = c.legs**2 - cy**2
    closable = disc >= 0.0
    rho = cx - c.origins - sigma * np.sqrt(np.where(closable, disc, np.nan))
    inside = (rho >= 0.0) & (rho <= c.stroke)  # NaN compares False
    return IKResult(rho, inside.all(axis=-1))


def leg_vectors(design: Design, pose: ArrayLike, rho: ArrayLike) -> FloatArray:
    """Leg vectors ``u_i = C_i - B_i`` (m), shape ``(..., 3, 2)``."""
    c = _consts(_check_design(design))
    p = _as_triples("pose", pose)
    r = _as_triples("rho", rho)
    return _leg_vectors(c, p, r)


def _leg_vectors(c: _Consts, p: FloatArray, r: FloatArray) -> FloatArray:
    th = p[..., 2:3]
    ux = p[..., 0:1] + c.k * np.cos(th) - (c.origins + r)
    uy = np.broadcast_to(p[..., 1:2] + c.k * np.sin(th), ux.shape)
    return np.stack([ux, uy], axis=-1)


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
    sv = np.linalg.svd(normalised_A(design, pose, rho), compute_uv=False)
    return sv[..., -1] / sv[..., 0]


def serial_margin(design: Design, pose: ArrayLike, rho: ArrayLike) -> FloatArray:
    """``min_i |cos alpha_i|`` in ``[0, 1]`` (0 at a serial singularity), shape ``(...)``."""
    u = leg_vectors(design, pose, rho)
    return np.min(np.abs(u[..., 0]) / np.hypot(u[..., 0], u[..., 1]), axis=-1)


def assembly_mode(design: Design, pose: ArrayLike, rho: ArrayLike) -> NDArray[np.int8]:
    """``sign(det A)``: +1 or -1 labels the assembly mode, 0 exactly at a parallel
    singularity; shape ``(...)``."""
    A, _ = jacobians(design, pose, rho)
    return np.sign(np.linalg.det(A)).astype(np.int8)


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
def simple_motion_rates_from_angles(
    design: Design, alpha: ArrayLike, theta: ArrayLike, twist: ArrayLike
) -> FloatArray:
    """Slider rates (m/s) from measured leg angles ``alpha`` (rad, ``(..., 3)``), platform
    angle ``theta`` (rad, ``(...)``) and twist ``(x_dot, y_dot, theta_dot)`` (m/s, m/s, rad/s).

    ``rho_dot_i = x_dot + y_dot tan(alpha_i) + theta_dot L_iG sin(alpha_i - theta)/cos(alpha_i)``;
    infinite where ``cos alpha_i = 0`` (a serial singularity) and the motion needs that leg.
    """
    c = _consts(_check_design(design))
    al = _as_triples("alpha", alpha)
    th = np.asarray(theta, dtype=np.float64)[..., None]
    tw = _as_triples("twist", twist)
    cos_a = np.cos(al)
    with np.errstate(divide="ignore", invalid="ignore"):
        vertical = tw[..., 1:2] * np.sin(al) / cos_a
        rotation = tw[..., 2:3] * c.k * np.sin(al - th) / cos_a
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

    Solutions are sorted: valid ones first; above the rails (``y >= 0``) before below; then
    ``sign det A = +1`` before ``-1``; then by ``theta``.

    Attributes:
        poses: ``(..., 4, 3)`` poses ``(x, y, theta)`` (m, m, rad; ``theta`` in ``(-pi, pi]``),
            NaN where ``valid`` is False.
        valid: ``(..., 4)`` bool.
        assembly: ``(..., 4)`` int8, ``sign(det A)`` of each solution (0 where invalid or
            exactly singular).
        side: ``(..., 4)`` int8, +1 above the rails, -1 below, 0 on the rail line or invalid.
        count: ``(...)`` number of distinct real poses (0 to 4).
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


def _cubic_candidates(a3: FloatArray, a2: FloatArray, a1: FloatArray, a0: FloatArray) -> FloatArray:
    """Candidate real roots ``(N, 3)`` of ``a3 c^3 + a2 c^2 + a1 c + a0`` (NaN when absent).

    Where only one root is real, the real part of the complex pair is also returned: near a
    double root (a parallel singularity) rounding can make a real pair look complex, and the
    caller verifies every candidate anyway.
    """
    scale = np.maximum.reduce([np.abs(a3), np.abs(a2), np.abs(a1), np.abs(a0)])
    scale = np.where(scale > 0, scale, 1.0)
    a3, a2, a1, a0 = a3 / scale, a2 / scale, a1 / scale, a0 / scale
    out = np.full(a3.shape + (3,), np.nan)
    cubic = np.abs(a3) > 1e-9
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        # -- genuine cubics: depressed form c = t - A/3
        A = a2 / a3
        B = a1 / a3
        C = a0 / a3
        p = B - A * A / 3.0
        q = 2.0 * A**3 / 27.0 - A * B / 3.0 + C
        disc = (q / 2.0) ** 2 + (p / 3.0) ** 3
        shift = -A / 3.0
        three = cubic & (disc <= 0.0)
        m = 2.0 * np.sqrt(np.maximum(-p / 3.0, 0.0))
        arg = np.where(m > 0, 3.0 * q / (np.where(p != 0, p, 1.0) * np.where(m > 0, m, 1.0)), 0.0)
        phi = np.arccos(np.clip(arg, -1.0, 1.0)) / 3.0
        for j in range(3):
            tj = m * np.cos(phi - 2.0 * np.pi * j / 3.0) + shift
            out[..., j] = np.where(three, tj, out[..., j])
        one = cubic & (disc > 0.0)
        sq = np.sqrt(np.maximum(disc, 0.0))
        w = np.cbrt(-q / 2.0 - np.copysign(sq, q))
        w_nz = np.where(w != 0, w, 1.0)
        t_real = np.where(w != 0, w - p / (3.0 * w_nz), 0.0)
        t_pair = np.where(w != 0, -(w - p / (3.0 * w_nz)) / 2.0, 0.0)
        out[..., 0] = np.where(one, t_real + shift, out[..., 0])
        out[..., 1] = np.where(one, t_pair + shift, out[..., 1])
        # -- (nearly) quadratic or linear
        quad = ~cubic & (np.abs(a2) > 1e-12)
        qd = a1 * a1 - 4.0 * a2 * a0
        qs = np.sqrt(np.maximum(qd, 0.0))
        qq = -0.5 * (a1 + np.copysign(qs, a1))
        r1 = qq / np.where(quad, a2, 1.0)
        r2 = a0 / np.where(qq != 0, qq, np.nan)
        out[..., 0] = np.where(quad, r1, out[..., 0])
        out[..., 1] = np.where(quad, r2, out[..., 1])
        lin = ~cubic & ~quad & (np.abs(a1) > 1e-12)
        out[..., 0] = np.where(lin, -a0 / np.where(lin, a1, 1.0), out[..., 0])
        # Newton polish on the cubic itself.
        for _ in range(2):
            x = out
            f = ((a3[..., None] * x + a2[..., None]) * x + a1[..., None]) * x + a0[..., None]
            df = (3.0 * a3[..., None] * x + 2.0 * a2[..., None]) * x + a1[..., None]
            step = np.where(np.abs(df) > 1e-14, f / df, 0.0)
            out = np.where(np.abs(step) < 0.1, x - step, x)
    return out



def forward_batch(design: Design, rho: ArrayLike) -> ForwardSolutions:
    """Every real pose for travels ``rho`` of shape ``(..., 3)`` (m); see :class:`ForwardSolutions`.

    Method: eliminating ``|G|^2``, ``G . e`` and ``G_x`` from the three loop equations leaves a
    cubic in ``c = cos theta`` (no division by the elimination determinant, so two sliders at the
    same place are fine).  For each real root (with ``sin theta >= 0``) the gripper lies on the
    intersection of two circles; the best-separated pair is intersected, the third leg checks
    the candidates, a few Newton steps on the loop equations polish them, the mirror images
    about the rail line are added and duplicates (double roots) removed.
    """
    c = _consts(_check_design(design))
    r = _as_triples("rho", rho)
    lead = r.shape[:-1]
    b = (c.origins + r).reshape(-1, 3)
    k, L = c.k, c.legs
    scale = c.scale

    # Rows m_i = [1, 2 k_i, -2 b_i] of the elimination matrix; rhs_i = -r_i + c * (2 b_i k_i).
    m = np.stack([np.ones_like(b), np.broadcast_to(2.0 * k, b.shape), -2.0 * b], axis=-1)
    rhs0 = -(k * k + b * b - L * L)
    rhs1 = 2.0 * b * k
    m0, m1, m2 = m[:, 0], m[:, 1], m[:, 2]
    adj_cols = (np.cross(m1, m2), np.cross(m2, m0), np.cross(m0, m1))  # columns of adj(M)
    det = np.einsum("ij,ij->i", m0, adj_cols[0])
    z0 = sum(adj_cols[i] * rhs0[:, i : i + 1] for i in range(3))  # D * (u, v, X) at c = 0
    z1 = sum(adj_cols[i] * rhs1[:, i : i + 1] for i in range(3))  # D * d(u, v, X)/dc
    U0, V0, X0 = z0[:, 0], z0[:, 1], z0[:, 2]
    U1, V1, X1 = z1[:, 0], z1[:, 1], z1[:, 2]
    p0 = det * U0 - X0 * X0
    p1 = det * U1 - 2.0 * X0 * X1
    p2 = -X1 * X1
    q0, q1, q2 = V0, V1 - X0, -X1
    roots = _cubic_candidates(
        -p1 - 2.0 * q1 * q2, p2 - p0 - q1 * q1 - 2.0 * q0 * q2, p1 - 2.0 * q0 * q1, p0 - q0 * q0
    )  # (n, 3)
    # Near |c| = 1 the parametrisation by cos(theta) is ill-conditioned (roots cluster), so
    # roots slightly outside [-1, 1] are kept, clipped, and left to the Newton polish.
    roots = np.where(np.abs(roots) <= 1.05, np.clip(roots, -1.0, 1.0), np.nan)
    # A repeated root (exact elimination degeneracy) stands for two poses with the same theta:
    # the second copy takes the other circle intersection.
    dup = np.zeros(roots.shape, dtype=bool)
    dup[:, 1] = np.abs(roots[:, 1] - roots[:, 0]) < 1e-7
    dup[:, 2] = (np.abs(roots[:, 2] - roots[:, 0]) < 1e-7) | (
        np.abs(roots[:, 2] - roots[:, 1]) < 1e-7
    )
    gx, gy, th, keep = _circle_candidates(b, roots, dup, k, L, scale)
    X, Y, T, res, keep = _polish(b, gx, gy, th, keep, k, L)
    keep &= res < _ACCEPT * scale

    # Mirror images about the rail line, then de-duplicate.
    X = np.concatenate([X, X], axis=1)
    Y = np.concatenate([Y, -Y], axis=1)
    T = np.concatenate([T, np.where(T == np.pi, T, -T)], axis=1)
    res = np.concatenate([res, res], axis=1)
    keep = np.concatenate([keep, keep], axis=1)
    tol = _SAME * scale
    dth = np.abs(np.mod(T[:, :, None] - T[:, None, :] + np.pi, 2.0 * np.pi) - np.pi)
    same = (
        (np.abs(X[:, :, None] - X[:, None, :]) < tol)
        & (np.abs(Y[:, :, None] - Y[:, None, :]) < tol)
        & (dth * c.ref < tol)
        & keep[:, :, None]
        & keep[:, None, :]
    )
    ncand = X.shape[1]
    earlier = np.tril(np.ones((ncand, ncand), dtype=bool), k=-1)  # [a, b]: b < a
    keep &= ~(same & earlier).any(axis=2)

    # Labels and ordering.
    ct, st = np.cos(T)[..., None], np.sin(T)[..., None]
    bb = b[:, None, :]
    ux = X[..., None] + k * ct - bb
    uy = Y[..., None] + k * st
    detA = _det3(ux, uy, k * (uy * ct - ux * st))
    assembly = np.where(keep, np.sign(detA), 0).astype(np.int8)
    side = np.where(keep, np.sign(np.where(np.abs(Y) < tol, 0.0, Y)), 0).astype(np.int8)
    theta_key = np.where(keep, T, np.inf)
    order = np.lexsort((theta_key, -assembly, -side, ~keep), axis=-1)[:, :4]

    def sel(arr: NDArray) -> NDArray:
        return np.take_along_axis(arr, order, axis=1)

    valid = sel(keep)
    poses = np.stack([sel(X), sel(Y), sel(T)], axis=-1)
    poses = np.where(valid[..., None], poses, np.nan)
    return ForwardSolutions(
        poses.reshape(lead + (4, 3)),
        valid.reshape(lead + (4,)),
        sel(assembly).reshape(lead + (4,)),
        sel(side).reshape(lead + (4,)),
        valid.sum(axis=1).reshape(lead),
        np.where(valid, sel(res), np.nan).reshape(lead + (4,)),
    )


_NEWTON_STEPS = 8
_ACCEPT = 1e-11  # accepted loop residual, relative to the longest leg
_SAME = 1e-7  # poses closer than this (relative to the longest leg) are one solution
_PAIR_I = np.array([0, 0, 1])
_PAIR_J = np.array([1, 2, 2])
_THIRD = np.array([2, 1, 0])


def _circle_candidates(
    b: FloatArray,
    roots: FloatArray,
    dup: NDArray[np.bool_],
    k: FloatArray,
    L: FloatArray,
    scale: float,
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """One starting pose per root ``c`` (with ``sin theta >= 0``): ``G`` on the circles
    ``|G - O_i| = L_i``, ``O_i = (b_i - k_i c, -k_i s)``, of the best-separated pair, taking
    the intersection point the third circle agrees with best (the other one for ``dup``)."""
    cr = roots[:, :, None]
    sr = np.sqrt(np.maximum(1.0 - cr * cr, 0.0))
    ox = b[:, None, :] - k * cr  # (n, roots, legs)
    oy = -k * sr
    sep2 = (ox[..., _PAIR_J] - ox[..., _PAIR_I]) ** 2 + (oy[..., _PAIR_J] - oy[..., _PAIR_I]) ** 2
    best = np.nan_to_num(sep2, nan=-1.0).argmax(axis=-1)[..., None]
    ii, jj, mm = _PAIR_I[best], _PAIR_J[best], _THIRD[best]

    def pick(arr: FloatArray, idx: NDArray[np.int64]) -> FloatArray:
        return np.take_along_axis(arr, idx, axis=-1)[..., 0]

    xi, yi = pick(ox, ii), pick(oy, ii)
    dx, dy = pick(ox, jj) - xi, pick(oy, jj) - yi
    li, lj, lm = L[ii[..., 0]], L[jj[..., 0]], L[mm[..., 0]]
    d = np.sqrt(pick(sep2, best))
    with np.errstate(divide="ignore", invalid="ignore"):
        along = (d * d + li * li - lj * lj) / (2.0 * d)
        h2 = li * li - along * along
        ok = (d > 1e-12 * scale) & (h2 > -1e-4 * scale * scale)
        h = np.sqrt(np.maximum(h2, 0.0))
        ex, ey = dx / d, dy / d
    mx, my = xi + along * ex, yi + along * ey
    xm, ym = pick(ox, mm), pick(oy, mm)
    res_a = np.abs(np.hypot(mx - h * ey - xm, my + h * ex - ym) - lm)
    res_b = np.abs(np.hypot(mx + h * ey - xm, my - h * ex - ym) - lm)
    use_b = (res_b < res_a) ^ dup
    sign = np.where(use_b, 1.0, -1.0)
    gx = mx + sign * h * ey
    gy = my - sign * h * ex
    res = np.where(use_b, res_b, res_a)
    keep = ok & (res < 2e-2 * scale) & np.isfinite(gx)
    th = np.arctan2(sr[..., 0], roots)
    return gx, gy, th, keep


def _polish(
    b: FloatArray,
    gx: FloatArray,
    gy: FloatArray,
    th: FloatArray,
    keep: NDArray[np.bool_],
    k: FloatArray,
    L: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """Newton steps on ``F_i = (|C_i - B_i|^2 - L_i^2) / 2`` (Jacobian ``A``) for the kept
    candidates only; returns the polished poses (theta in ``(-pi, pi]``) and residuals (m)."""
    rows, cols = np.nonzero(keep)
    X, Y, T = gx[rows, cols], gy[rows, cols], th[rows, cols]
    bb = b[rows]
    scale = float(L.max())
    tiny = 1e-15 * scale**3 * float(k.max())  # det A is of order L^3 * L_1G
    for _ in range(_NEWTON_STEPS):
        ct, st = np.cos(T)[:, None], np.sin(T)[:, None]
        ux = X[:, None] + k * ct - bb
        uy = Y[:, None] + k * st
        F = 0.5 * (ux * ux + uy * uy - L * L)
        dX, dY, dT = _solve3(ux, uy, k * (uy * ct - ux * st), -F, tiny)
        X, Y, T = X + dX, Y + dY, T + dT
        if dX.size == 0 or max(np.abs(dX).max(), np.abs(dY).max()) < 1e-16 * scale:
            break
    T = np.pi - np.mod(np.pi - T, 2.0 * np.pi)  # (-pi, pi]
    ux = X[:, None] + k * np.cos(T)[:, None] - bb
    uy = Y[:, None] + k * np.sin(T)[:, None]
    r = np.abs(np.hypot(ux, uy) - L).max(axis=-1)
    shape = keep.shape
    outX, outY, outT = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    outR = np.full(shape, np.inf)
    outX[rows, cols], outY[rows, cols], outT[rows, cols], outR[rows, cols] = X, Y, T, r
    return outX, outY, outT, outR, keep & np.isfinite(outR)


def _det3(c0: FloatArray, c1: FloatArray, c2: FloatArray) -> FloatArray:
    """Determinant of 3x3 matrices given by their columns ``(..., 3)``."""
    return (
        c0[..., 0] * (c1[..., 1] * c2[..., 2] - c1[..., 2] * c2[..., 1])
        - c0[..., 1] * (c1[..., 0] * c2[..., 2] - c1[..., 2] * c2[..., 0])
        + c0[..., 2] * (c1[..., 0] * c2[..., 1] - c1[..., 1] * c2[..., 0])
    )


def _solve3(
    c0: FloatArray, c1: FloatArray, c2: FloatArray, rhs: FloatArray, tiny: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Cramer solve of 3x3 systems given by columns; zero step where ``|det| <= tiny``."""
    det = _det3(c0, c1, c2)
    good = np.abs(det) > tiny
    inv = np.where(good, 1.0 / np.where(good, det, 1.0), 0.0)
    return (_det3(rhs, c1, c2) * inv, _det3(c0, rhs, c2) * inv, _det3(c0, c1, rhs) * inv)
