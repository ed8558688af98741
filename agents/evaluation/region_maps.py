"""Singularity maps of one working mode: kinematic fields over ``(y, theta)`` and the connected
singularity-free regions of the configuration space.

With every rail on ``y = 0`` the leg vectors do not depend on the gripper's ``x``, so the
singularity structure is a function of ``(y, theta)`` (and the working mode) alone
(:func:`ytheta_fields`).  :class:`RegionMap` labels the connected regions of a grid over
``(x, y, theta)`` that keep given margins, per assembly mode; the suites use it to keep only
start/target pairs joined by a singularity-free path (so every episode is solvable).  This is
specific to the mechanism; the component labelling is written here (not
``scipy.ndimage.label``) because ``theta`` is periodic and the grid must wrap along it.
Lengths in m, angles in rad.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_gym.analysis.workspace import merge_labels
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design

__all__ = ["RegionMap", "ytheta_fields"]


def ytheta_fields(
    design: Design, mode: ArrayLike, ys: ArrayLike, thetas: ArrayLike
) -> dict[str, np.ndarray]:
    """Kinematic fields over a ``(y, theta)`` grid, shape ``(len(ys), len(thetas))`` each.

    With every rail on ``y = 0`` the leg vectors do not depend on the gripper's ``x``, so the
    singularity structure is a function of ``(y, theta)`` (and the working mode) alone:
    ``det`` (``det A_bar``, NaN where a leg cannot close), ``parallel_margin``,
    ``serial_margin``, ``closable``, and the interval ``[x_lo, x_hi]`` of gripper ``x`` that
    keeps every travel inside ``[0, stroke]`` (empty when ``x_lo > x_hi``).
    """
    y = np.asarray(ys, dtype=np.float64)
    th = np.asarray(thetas, dtype=np.float64)
    Y, T = np.meshgrid(y, th, indexing="ij")
    poses = np.stack([np.zeros_like(Y), Y, T], axis=-1)
    rho0, _ = kinematics.inverse(design, poses, np.asarray(mode, dtype=np.float64))
    closable = np.isfinite(rho0).all(axis=-1)
    r = np.nan_to_num(rho0)
    A = kinematics.normalised_A(design, poses, r)
    det = np.where(closable, np.linalg.det(A), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        sv = np.linalg.svd(A, compute_uv=False)
        pm = np.where(closable, sv[..., -1] / sv[..., 0], np.nan)
        u = kinematics.leg_vectors(design, poses, r)
        sm = np.where(
            closable, np.min(np.abs(u[..., 0]) / np.hypot(u[..., 0], u[..., 1]), axis=-1), np.nan
        )
    # rho_i(x) = x + rho_i(0): all in [0, L] iff x in [max(-rho_i(0)), min(L - rho_i(0))].
    x_lo = np.where(closable, np.max(-r, axis=-1), np.inf)
    x_hi = np.where(closable, np.min(design.stroke - r, axis=-1), -np.inf)
    return {
        "det": det,
        "parallel_margin": pm,
        "serial_margin": sm,
        "closable": closable,
        "x_lo": x_lo,
        "x_hi": x_hi,
    }


def _label(mask: NDArray[np.bool_], wrap_last: bool) -> NDArray[np.int64]:
    """Face-connected components of an n-D mask (last axis periodic if ``wrap_last``):
    labels ``-1`` off the mask, else the smallest flat index of the component."""
    shape = mask.shape
    idx = np.arange(mask.size).reshape(shape)
    ea, eb = [], []
    for ax in range(mask.ndim):
        a = np.moveaxis(idx, ax, 0)
        m = np.moveaxis(mask, ax, 0)
        pairs = [(a[:-1], a[1:], m[:-1] & m[1:])]
        if wrap_last and ax == mask.ndim - 1 and shape[ax] > 2:
            pairs.append((a[-1:], a[:1], m[-1:] & m[:1]))
        for p, q, ok in pairs:
            ea.append(p[ok])
            eb.append(q[ok])
    lab = merge_labels(mask.size, np.concatenate(ea), np.concatenate(eb))
    out = np.where(mask.ravel(), lab, -1)
    return out.reshape(shape)


class RegionMap:
    """Connected regions of one working mode's configuration space, per assembly mode.

    A grid over ``(x, y, theta)`` (``x`` over the search rectangle, ``y`` in ``[-h, h]``,
    ``theta`` periodic) marks the cells reachable within the stroke with parallel margin at
    least ``min_parallel_margin``, serial margin at least ``min_serial_margin`` and a given
    sign of ``det A``; :meth:`region` names the connected component a pose lies in.  Two poses
    in the same region are joined by a path that keeps those margins (up to grid resolution),
    so a task between them is solvable without crossing a singularity.
    """

    def __init__(
        self,
        design: Design,
        mode: ArrayLike,
        min_parallel_margin: float = 0.015,
        min_serial_margin: float = 0.1,
        shape: tuple[int, int, int] = (72, 56, 144),
    ) -> None:
        self.design = design
        self.mode = tuple(int(m) for m in np.asarray(mode).tolist())
        nx, ny, nt = shape
        x0, x1, _, h = design.search_rectangle
        self.x = np.linspace(x0, x1, nx)
        self.y = np.linspace(-h, h, ny)
        self.theta = -math.pi + 2.0 * math.pi * np.arange(nt) / nt
        f = ytheta_fields(design, self.mode, self.y, self.theta)
        with np.errstate(invalid="ignore"):
            ok2 = (
                f["closable"]
                & (f["parallel_margin"] >= min_parallel_margin)
                & (f["serial_margin"] >= min_serial_margin)
            )
        X = self.x[:, None, None]
        inside = (X >= f["x_lo"][None]) & (X <= f["x_hi"][None])
        sign = np.sign(np.nan_to_num(f["det"]))
        self.labels = np.full((nx, ny, nt), -1, dtype=np.int64)
        for s in (1.0, -1.0):
            mask = inside & (ok2 & (sign == s))[None]
            lab = _label(mask, wrap_last=True)
            self.labels = np.where(mask, lab * 2 + (0 if s > 0 else 1), self.labels)

    def region(self, pose: ArrayLike) -> int:
        """Label of the region of the grid cells around ``pose`` (-1 if none is inside)."""
        x, y, th = (float(v) for v in np.asarray(pose, dtype=np.float64))
        best, best_d = -1, math.inf
        fx = np.interp(x, self.x, np.arange(self.x.size))
        fy = np.interp(y, self.y, np.arange(self.y.size))
        nt = self.theta.size
        ft = ((th + math.pi) / (2.0 * math.pi) * nt) % nt
        for ix in {math.floor(fx), min(math.floor(fx) + 1, self.x.size - 1)}:
            for iy in {math.floor(fy), min(math.floor(fy) + 1, self.y.size - 1)}:
                for it in {math.floor(ft) % nt, (math.floor(ft) + 1) % nt}:
                    lab = int(self.labels[ix, iy, it])
                    if lab < 0:
                        continue
                    dt = min(abs(ft - it), nt - abs(ft - it))
                    d = (fx - ix) ** 2 + (fy - iy) ** 2 + dt**2
                    if d < best_d:
                        best, best_d = lab, d
        return best
