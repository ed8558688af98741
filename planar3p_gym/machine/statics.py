"""Statics: the actuator forces that hold the mechanism at rest against gravity.

By virtual work with ``p_dot = A^-1 B rho_dot``, the forces along the rails are
``F = g B A^-T c``, where ``c`` maps the platform twist to the rate of change of
``sum m_k y_k`` (the platform, a uniform rod from ``G`` to ``C_1``, and the legs, uniform rods
from ``B_i`` to ``C_i``; the sliders do not rise).  They grow like ``1 / parallel margin`` near
a parallel singularity: a pose whose forces exceed ``design.max_force`` cannot be held, whatever
its margin.

The formula is defined once, per configuration, in the compiled :func:`_holding_row`;
:func:`holding_forces_at` loops it over a batch.  It is compiled because the task sampler
calls it on a few poses per batch, where numpy's per-call overhead would be most of a
seeded reset's cost.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design

__all__ = ["holding_forces", "holding_forces_at", "holding_forces_of_rows"]

FloatArray = NDArray[np.float64]


def holding_forces(design: Design, poses: ArrayLike, mode: ArrayLike) -> FloatArray:
    """Actuator forces (N, signed, along the rails) that hold poses ``(..., 3)`` (m, m, rad) at
    rest in working mode ``mode``, shape ``(..., 3)``; NaN where a pose is unreachable."""
    p = np.asarray(poses, dtype=np.float64)
    rho, _ = kinematics.inverse(design, p, np.asarray(mode, dtype=np.float64))
    return holding_forces_at(design, p, rho)


def holding_forces_at(design: Design, poses: ArrayLike, rho: ArrayLike) -> FloatArray:
    """:func:`holding_forces` of configurations given by their poses ``(..., 3)`` and slider
    travels ``rho`` (m, ``(..., 3)``, broadcast against the poses; rows with a travel that is
    not finite, as :func:`kinematics.inverse` gives NaN for unreachable poses, give NaN forces,
    and so do exactly singular configurations).  ``ValueError`` for poses that are not finite
    or shapes that do not broadcast."""
    p = kinematics.as_triples("poses", poses)
    r = kinematics.as_float("rho", rho)
    if r.ndim == 0 or r.shape[-1] != 3:
        raise ValueError(f"rho must have shape (..., 3), got shape {r.shape}")
    kinematics.check_broadcast("poses", p, "rho", r)
    shape = np.broadcast_shapes(p.shape, r.shape)
    flat_p = np.broadcast_to(p, shape).reshape(-1, 3)
    flat_r = np.broadcast_to(r, shape).reshape(-1, 3)
    return holding_forces_of_rows(design, flat_p, flat_r).reshape(shape)


def holding_forces_of_rows(design: Design, poses: FloatArray, rho: FloatArray) -> FloatArray:
    """:func:`holding_forces_at` of ``(M, 3)`` float64 poses and travels that need no checks
    (as :func:`kinematics.screen_poses` gives them: the task sampler's path, where the checks
    would cost more than the forces), shape ``(M, 3)``."""
    out = np.empty((poses.shape[0], 3))
    _holding_rows(
        np.ascontiguousarray(poses), np.ascontiguousarray(rho), *_coefficients(design), out
    )
    return out


@lru_cache(maxsize=64)
def _coefficients(design: Design) -> tuple[FloatArray, FloatArray, float, float, float]:
    """The constants of :func:`_holding_row` for ``design``: joint offsets ``L_iG`` (m), rail
    origins ``a_i`` (m), ``c_y`` (kg), ``c_theta`` (kg m, times ``cos theta``), ``g`` (m/s^2)."""
    c = kinematics.design_constants(kinematics.check_design(design))
    lift = design.platform_mass + 1.5 * design.leg_mass
    turn = 0.5 * design.platform_mass * c.k[0] + 0.5 * design.leg_mass * c.k.sum()
    return c.k, c.origins, float(lift), float(turn), float(design.gravity)


@njit(cache=True)
def _holding_rows(
    p: FloatArray, rho: FloatArray, k: FloatArray, origins: FloatArray, lift: float,
    turn: float, gravity: float, out: FloatArray,
) -> None:  # fmt: skip
    """:func:`_holding_row` of each row of ``p`` and ``rho`` ((M, 3) each) into ``out``."""
    for j in range(p.shape[0]):
        _holding_row(p[j], rho[j], k, origins, lift, turn, gravity, out[j])


@njit(cache=True, error_model="numpy")
def _holding_row(
    p: FloatArray, rho: FloatArray, k: FloatArray, origins: FloatArray, lift: float,
    turn: float, gravity: float, out: FloatArray,
) -> None:  # fmt: skip
    """The holding forces of one configuration (pose ``p``, travels ``rho``) into ``out`` (N):
    ``F_i = g u_ix z_i`` with ``A^T z = c``, ``c = (0, lift, turn cos theta)``; NaN if a travel
    is not finite.

    Row ``i`` of ``A`` is ``(u_ix, u_iy, L_iG (u_iy cos theta - u_ix sin theta))``, as in
    :func:`kinematics.jacobians`.  The 3 x 3 system is solved by Gaussian elimination with
    partial pivoting, written out here: numba's ``np.linalg.solve`` needs SciPy's LAPACK at
    run time and allocates per call, for a system this small.  An exactly singular ``A`` gives
    infinite or NaN forces (numpy's error model: no exception), which every threshold rejects.
    """
    if not (math.isfinite(rho[0]) and math.isfinite(rho[1]) and math.isfinite(rho[2])):
        out[0] = out[1] = out[2] = math.nan
        return
    th = p[2]
    cos, sin = math.cos(th), math.sin(th)
    m = np.empty((3, 4))  # [A^T | c]: column i of A^T is leg i's row of A
    ux = np.empty(3)
    for i in range(3):
        x = p[0] + k[i] * cos - (origins[i] + rho[i])
        y = p[1] + k[i] * sin
        ux[i] = x
        m[0, i] = x
        m[1, i] = y
        m[2, i] = k[i] * (y * cos - x * sin)
    m[0, 3] = 0.0
    m[1, 3] = lift
    m[2, 3] = turn * cos
    for col in range(3):  # forward elimination, the largest pivot of the column first
        best = col
        for row in range(col + 1, 3):
            if abs(m[row, col]) > abs(m[best, col]):
                best = row
        if best != col:
            for q in range(4):
                m[col, q], m[best, q] = m[best, q], m[col, q]
        for row in range(col + 1, 3):
            f = m[row, col] / m[col, col]
            for q in range(col, 4):
                m[row, q] -= f * m[col, q]
    z = np.empty(3)
    for row in range(2, -1, -1):  # back substitution
        s = m[row, 3]
        for q in range(row + 1, 3):
            s -= m[row, q] * z[q]
        z[row] = s / m[row, row]
    for i in range(3):
        out[i] = gravity * ux[i] * z[i]
