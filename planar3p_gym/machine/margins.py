"""The singularity margins of one configuration, defined once and compiled.

From the leg vectors ``u_i = C_i - B_i`` (m) and ``(cos theta, sin theta)``: the parallel margin
(``sigma_min / sigma_max`` of ``A_bar``, in ``[0, 1]``, 0 at a parallel singularity, from the
eigenvalues of ``A_bar^T A_bar`` in closed form), the serial margin (``min_i |cos alpha_i|``)
and the assembly mode (``sign det A_bar``).  The formulas, and why compiled: docs/kinematics.md,
"The singularity margins, compiled"; :func:`planar3p_gym.machine.kinematics.parallel_margin`'s
SVD is the definition they are tested against.

* :func:`leg_margins`, :func:`inverse_condition`: one configuration (every per-step user: the
  env's step, the compiled reach-step outputs);
* :func:`inverse_condition_batch`: the same definition in a compiled loop (the workspace grids).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["inverse_condition", "inverse_condition_batch", "leg_margins"]


@njit(cache=True)
def inverse_condition(
    a: float, b: float, c: float, d: float, e: float, f: float, g: float, h: float, i: float
) -> float:
    """``sigma_min / sigma_max`` of the 3x3 matrix with rows ``(a, b, c), (d, e, f),
    (g, h, i)`` (module docstring), in ``[0, 1]``."""
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    s00 = a * a + d * d + g * g
    s11 = b * b + e * e + h * h
    s22 = c * c + f * f + i * i
    s01 = a * b + d * e + g * h
    s02 = a * c + d * f + g * i
    s12 = b * c + e * f + h * i
    q = (s00 + s11 + s22) / 3.0
    p1 = s01 * s01 + s02 * s02 + s12 * s12
    p2 = (s00 - q) ** 2 + (s11 - q) ** 2 + (s22 - q) ** 2 + 2.0 * p1
    if p2 <= 1e-300:
        return 1.0 if q > 0.0 else 0.0
    p = math.sqrt(p2 / 6.0)
    b00, b11, b22 = (s00 - q) / p, (s11 - q) / p, (s22 - q) / p
    b01, b02, b12 = s01 / p, s02 / p, s12 / p
    r = 0.5 * (
        b00 * (b11 * b22 - b12 * b12)
        - b01 * (b01 * b22 - b12 * b02)
        + b02 * (b01 * b12 - b11 * b02)
    )
    phi = math.acos(max(-1.0, min(1.0, r))) / 3.0
    lam1 = q + 2.0 * p * math.cos(phi)
    if lam1 <= 0.0:
        return 0.0
    # lambda_2 + lambda_3 and lambda_2 * lambda_3 = det^2 / lambda_1 are both accurate, so the
    # smaller root of t^2 - sum t + prod (in its cancellation-free form) is too, even when
    # lambda_2 and lambda_3 are both tiny (A_bar of rank about 1).
    total = max(3.0 * q - lam1, 0.0)
    prod = det * det / lam1
    disc = math.sqrt(max(total * total - 4.0 * prod, 0.0))
    denom = total + disc
    lam3 = 2.0 * prod / denom if denom > 0.0 else 0.0
    return math.sqrt(max(lam3, 0.0) / lam1)


@njit(cache=True)
def leg_margins(
    ux1: float, uy1: float, ux2: float, uy2: float, ux3: float, uy3: float,
    c: float, s: float,
    k1: float, k2: float, k3: float, l1: float, l2: float, l3: float, ref: float,
) -> tuple[float, float, int, float, float, float]:  # fmt: skip
    """``(parallel margin, serial margin, sign det A, |u_1|, |u_2|, |u_3|)`` from the leg
    vectors ``u_i`` (m), ``cos/sin theta``, the joint offsets ``k_i`` (m), the leg lengths
    ``l_i`` (m) and the characteristic length ``ref`` (m) (module docstring)."""
    a, b, cc = ux1 / l1, uy1 / l1, k1 * (uy1 * c - ux1 * s) / (l1 * ref)
    d, e, f = ux2 / l2, uy2 / l2, k2 * (uy2 * c - ux2 * s) / (l2 * ref)
    g, h, i = ux3 / l3, uy3 / l3, k3 * (uy3 * c - ux3 * s) / (l3 * ref)
    det = a * (e * i - f * h) - b * (d * i - f * g) + cc * (d * h - e * g)
    n1 = math.sqrt(ux1 * ux1 + uy1 * uy1)
    n2 = math.sqrt(ux2 * ux2 + uy2 * uy2)
    n3 = math.sqrt(ux3 * ux3 + uy3 * uy3)
    serial = min(
        1.0,
        abs(ux1) / n1 if n1 > 0.0 else 0.0,
        abs(ux2) / n2 if n2 > 0.0 else 0.0,
        abs(ux3) / n3 if n3 > 0.0 else 0.0,
    )
    parallel = inverse_condition(a, b, cc, d, e, f, g, h, i)
    sign = (1 if det > 0.0 else 0) - (1 if det < 0.0 else 0)
    return parallel, serial, sign, n1, n2, n3


@njit(cache=True)
def _inverse_condition_flat(m: np.ndarray) -> np.ndarray:
    n = m.shape[0]
    out = np.empty(n)
    for j in range(n):
        out[j] = inverse_condition(
            m[j, 0], m[j, 1], m[j, 2], m[j, 3], m[j, 4], m[j, 5], m[j, 6], m[j, 7], m[j, 8]
        )
    return out


def inverse_condition_batch(rows: np.ndarray) -> np.ndarray:
    """:func:`inverse_condition` of matrices ``(..., 3, 3)`` (rows last but one), shape
    ``(...)``."""
    rows = np.asarray(rows, dtype=np.float64)
    if rows.shape[-2:] != (3, 3):
        raise ValueError(f"rows must have shape (..., 3, 3), got {rows.shape}")
    flat = np.ascontiguousarray(rows.reshape(-1, 9))
    return _inverse_condition_flat(flat).reshape(rows.shape[:-2])
