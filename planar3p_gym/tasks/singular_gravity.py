"""Gravity at the parallel singularities of a working mode: can a singular pose be held at rest?
(The reason ``Planar3PAssemblyChange-v0`` runs without gravity; see
:mod:`planar3p_gym.tasks.assembly_change`.)
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_gym.machine.design import Design

__all__ = ["gravity_alignment"]

FloatArray = NDArray[np.float64]


def gravity_alignment(
    design: Design,
    mode: ArrayLike,
    min_serial: float = 0.1,
    thetas: int = 721,
    heights: int = 1201,
) -> tuple[float, tuple[float, float]]:
    """How much gravity pushes along the free motion at the parallel singularities of a
    working mode: ``(min cos, (y, theta))``.

    At a parallel singularity the platform has a free motion ``n`` (``A n = 0``: no slider
    moves); the weight's generalised force along it is ``n . c`` (``c`` as in
    :mod:`planar3p_gym.machine.statics`, ``g c`` is the gradient of the potential energy).  The
    returned value is the smallest ``|cos|`` between ``n`` and ``c`` over the singular set
    (with the angle scaled by the characteristic length, so the cosine is dimensionless), and
    where it occurs (m, rad).  ``det A`` and ``n . c`` do not depend on ``x``, so the singular
    set is a curve in ``(y, theta)``: found on a grid of ``thetas`` angles and ``heights``
    heights (``|y| <= max_i (L_i + L_iG)``), refined by bisection; singular poses with a serial
    margin below ``min_serial`` are left out (where a leg is also upright the free motion can
    be a horizontal translation, which gravity does not push).  If the minimum is not 0,
    no singular pose can be held at rest: a quasi-static crossing does not exist and the
    actuators must let the platform accelerate along ``n`` (they cannot resist it there).
    """
    sigma = np.asarray(mode, dtype=np.float64)
    k = np.asarray(design.joint_offsets)
    legs = np.asarray(design.leg_lengths)
    ref = design.characteristic_length
    reach = float((legs + k).max())
    th = np.linspace(-math.pi, math.pi, thetas, endpoint=False)[:, None]
    y = np.linspace(-reach, reach, heights)[None, :]

    def det_and_n(yy: FloatArray, tt: FloatArray) -> tuple[FloatArray, FloatArray]:
        cy = yy[..., None] + k * np.sin(tt)[..., None]
        disc = legs**2 - cy**2
        with np.errstate(invalid="ignore"):
            ux = sigma * np.sqrt(np.where(disc >= 0.0, disc, np.nan))
        third = k * (cy * np.cos(tt)[..., None] - ux * np.sin(tt)[..., None])
        rows = np.stack([ux, cy, third], axis=-1)  # (..., 3 legs, 3)
        det = np.linalg.det(np.nan_to_num(rows))
        det = np.where(np.isfinite(ux).all(axis=-1), det, np.nan)
        crosses = np.stack(
            [np.cross(rows[..., a, :], rows[..., b, :]) for a, b in ((0, 1), (0, 2), (1, 2))]
        )
        best = np.argmax(np.linalg.norm(crosses, axis=-1), axis=0)
        n = np.take_along_axis(crosses, best[None, ..., None], axis=0)[0]
        return det, n

    tt = np.broadcast_to(th, (thetas, heights))
    det, _ = det_and_n(np.broadcast_to(y, (thetas, heights)), tt)
    a, b = det[:, :-1], det[:, 1:]
    rows_, cols = np.nonzero(np.isfinite(a) & np.isfinite(b) & (np.sign(a) != np.sign(b)))
    if rows_.size == 0:
        return math.nan, (math.nan, math.nan)
    lo, hi = y[0, cols].copy(), y[0, cols + 1].copy()
    t_root = th[rows_, 0]
    d_lo = det[rows_, cols]
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        d_mid, _ = det_and_n(mid, t_root)
        same = np.sign(d_mid) == np.sign(d_lo)
        lo = np.where(same, mid, lo)
        hi = np.where(same, hi, mid)
    y_root = 0.5 * (lo + hi)
    _, n = det_and_n(y_root, t_root)
    cy_root = y_root[:, None] + k * np.sin(t_root)[:, None]
    with np.errstate(invalid="ignore"):
        serial = np.sqrt(np.clip(1.0 - (cy_root / legs) ** 2, 0.0, 1.0)).min(axis=1)
    keep = serial >= min_serial
    if not keep.any():
        return math.nan, (math.nan, math.nan)
    y_root, t_root, n = y_root[keep], t_root[keep], n[keep]
    c_y = design.platform_mass + 1.5 * design.leg_mass
    c_t = (0.5 * design.platform_mass * k[0] + 0.5 * design.leg_mass * k.sum()) * np.cos(t_root)
    # dimensionless: angle components scaled by the characteristic length
    n_s = np.stack([n[:, 0], n[:, 1], ref * n[:, 2]], axis=-1)
    c_s = np.stack([np.zeros_like(c_t), np.full_like(c_t, c_y), c_t / ref], axis=-1)
    cos = np.abs((n_s * c_s).sum(-1)) / (
        np.linalg.norm(n_s, axis=-1) * np.linalg.norm(c_s, axis=-1)
    )
    j = int(np.nanargmin(cos))
    return float(cos[j]), (float(y_root[j]), float(t_root[j]))
