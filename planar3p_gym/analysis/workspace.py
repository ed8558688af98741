"""Workspace and singularity analysis of the 3-PRR manipulator (``docs/mechanism.md``, the workspace
study), vectorised numpy: no Python loop runs over grid points.

With all rails on ``y = 0`` the leg vectors do not depend on the gripper's ``x``, so each grid
row's reachable set is a union of exact ``x`` intervals, decided by the same floating-point
expression as :func:`planar3p_gym.machine.kinematics.inverse` (docs/workspace.md, "How the
workspace study is computed").

* :func:`orientations`, :func:`search_grid`: the paper's sampling;
* :func:`workspace`, :func:`stroke_study`: reachable (and usable) grid masks and ``S`` for one
  design, and ``S(L)`` over strokes;
* :func:`in_constant_orientation_workspace`, :func:`constant_orientation_area`,
  :func:`reachable_exact`, :func:`exact_workspace`: exact tests and areas;
* :func:`row_margins`, :func:`margin_levels`: margins of every ``(y, theta, mode)``;
* :func:`label_components`, :func:`dead_zones`, :func:`full_plane`: holes in the envelope;
* :func:`singularity_map`, :func:`parallel_singularity_points`,
  :func:`serial_singularity_points`, :func:`singularity_segments`: singularity loci.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_gym.machine.design import Design
from planar3p_gym.machine.kinematics import ALL_MODES
from planar3p_gym.machine.margins import inverse_condition_batch

__all__ = [
    "DEFAULT_MIN_PARALLEL",
    "DEFAULT_MIN_SERIAL",
    "DeadZones",
    "RowMargins",
    "SingularityMap",
    "SingularitySegment",
    "StrokeStudy",
    "Workspace",
    "constant_orientation_area",
    "dead_zones",
    "exact_workspace",
    "full_plane",
    "in_constant_orientation_workspace",
    "label_components",
    "margin_levels",
    "merge_labels",
    "orientations",
    "parallel_singularity_points",
    "reachable_exact",
    "row_margins",
    "search_grid",
    "serial_singularity_points",
    "singularity_map",
    "singularity_segments",
    "stroke_study",
    "workspace",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
IntArray = NDArray[np.int64]

#: Default threshold of the parallel margin (inverse condition number of ``A_bar``) for the
#: usable workspace.
DEFAULT_MIN_PARALLEL = 0.05
#: Default threshold of the serial margin (``min_i |cos alpha_i|``) for the usable workspace.
DEFAULT_MIN_SERIAL = 0.10


# =============================================================================== sampling
def orientations(
    n_theta: int = 360,
    theta_range: tuple[float, float] | None = None,
    theta: float | ArrayLike | None = None,
) -> FloatArray:
    """The sampled orientations (rad).

    * default: ``n_theta`` equally spaced angles ``2 pi k / n_theta`` on ``[0, 2 pi)``;
    * ``theta_range=(lo, hi)``: ``n_theta`` equally spaced angles from ``lo`` to ``hi``
      inclusive (one angle, ``lo``, if ``n_theta == 1``);
    * ``theta``: exactly these orientations (a scalar for the constant-orientation workspace).
    """
    if theta is not None:
        if theta_range is not None:
            raise ValueError("give either theta or theta_range, not both")
        out = np.atleast_1d(np.asarray(theta, dtype=np.float64)).ravel()
        if out.size == 0 or not np.isfinite(out).all():
            raise ValueError("theta must be finite and non-empty")
        return out
    n = int(n_theta)
    if n < 1:
        raise ValueError(f"n_theta must be >= 1, got {n_theta!r}")
    if theta_range is None:
        return 2.0 * np.pi * np.arange(n) / n
    lo, hi = (float(v) for v in theta_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise ValueError(f"theta_range must be finite with lo <= hi, got {theta_range!r}")
    return np.linspace(lo, hi, n) if n > 1 else np.array([lo])


def _grid_shape(n: int | tuple[int, int]) -> tuple[int, int]:
    nx, ny = (int(n), int(n)) if np.isscalar(n) else (int(n[0]), int(n[1]))  # type: ignore[index]
    if nx < 2 or ny < 2:
        raise ValueError(f"grid must have at least 2 x 2 points, got {n!r}")
    return nx, ny


def search_grid(
    design: Design, n: int | tuple[int, int] = 201, half: str = "upper"
) -> tuple[FloatArray, FloatArray]:
    """``x`` (nx,) and ``y`` (ny,) samples (m) of the paper's search rectangle.

    ``n`` is the number of points per side, or ``(nx, ny)``; edges are included.  ``half``:
    ``"upper"`` is the paper's rectangle ``y in [0, h]``; ``"full"`` adds its exact mirror
    image below the rails (``2 ny - 1`` rows, ``y in [-h, h]``).
    """
    nx, ny = _grid_shape(n)
    x0, x1, _, h = design.search_rectangle
    x = np.linspace(x0, x1, nx)
    y = np.linspace(0.0, h, ny)
    if half == "full":
        y = np.concatenate([-y[:0:-1], y])
    elif half != "upper":
        raise ValueError(f"half must be 'upper' or 'full', got {half!r}")
    return x, y


def _modes(mode: ArrayLike | None) -> NDArray[np.int8]:
    if mode is None:
        return np.asarray(ALL_MODES, dtype=np.int8)
    m = np.atleast_2d(np.asarray(mode))
    if m.ndim != 2 or m.shape[1] != 3 or not np.isin(m, (1, -1)).all():
        raise ValueError(f"mode must be +-1 triples of shape (3,) or (m, 3), got {mode!r}")
    return m.astype(np.int8)


# =============================================================================== row geometry
class _Rows(NamedTuple):
    """Stroke- and x-independent quantities of every (y, theta) and leg."""

    cy: FloatArray  # (ny, nt, 3) C_iy
    w: FloatArray  # (ny, nt, 3) sqrt(L_i^2 - C_iy^2), NaN where the leg cannot close
    kc: FloatArray  # (nt, 3) L_iG cos(theta), as in kinematics.inverse
    closable: BoolArray  # (ny, nt, 3)


def _rows(design: Design, y: FloatArray, thetas: FloatArray) -> _Rows:
    k = np.array(design.joint_offsets)
    legs = np.array(design.leg_lengths)
    th = thetas[:, None]
    kc = k * np.cos(th)  # same expression as kinematics.inverse: fl(k * fl(cos))
    ks = k * np.sin(th)
    cy = y[:, None, None] + ks[None]  # fl(y + fl(k sin))
    disc = legs**2 - cy**2
    closable = disc >= 0.0
    w = np.sqrt(np.where(closable, disc, np.nan))
    return _Rows(cy, w, kc, closable)


def _x_bounds(
    rows: _Rows, origins: FloatArray, stroke: float, x: FloatArray
) -> tuple[IntArray, IntArray]:
    """Integer ``x``-grid bounds ``(lo, hi)`` of each leg and branch, shape ``(ny, nt, 3, 2)``
    (branch 0 is ``sigma = +1``, branch 1 is ``sigma = -1``): grid point ``j`` gives a travel in
    ``[0, stroke]`` exactly when ``lo <= j <= hi``; decided by the floating-point expression of
    :func:`planar3p_gym.machine.kinematics.inverse`, ``((x + L_iG cos) - a_i) - sigma_i w_i``."""
    nx = x.size
    x0 = float(x[0])
    dx = (float(x[-1]) - x0) / (nx - 1)
    sw = np.stack([rows.w, -rows.w], axis=-1)  # sigma * w: (ny, nt, 3, 2)
    kc = rows.kc[None, :, :, None]
    a = origins[None, None, :, None]
    ok = np.isfinite(sw)
    s = np.where(ok, a - kc + sw, np.inf)  # approximate x where rho = 0

    def rho(j: IntArray) -> FloatArray:
        xj = x[np.clip(j, 0, nx - 1)]
        return ((xj + kc) - a) - sw

    # lower bound: smallest j with rho(x_j) >= 0 (monotone in j)
    with np.errstate(invalid="ignore"):
        lo = np.ceil(np.clip((s - x0) / dx, -1.0, nx + 1.0)).astype(np.int64)
        hi = np.floor(np.clip((s + stroke - x0) / dx, -2.0, nx)).astype(np.int64)
    lo = np.clip(lo, 0, nx)
    hi = np.clip(hi, -1, nx - 1)
    with np.errstate(invalid="ignore"):
        step_down = (lo > 0) & (rho(lo - 1) >= 0.0)
        lo = lo - step_down
        step_up = (lo < nx) & ~(rho(lo) >= 0.0)
        lo = lo + step_up
        hi_up = (hi < nx - 1) & (rho(hi + 1) <= stroke)
        hi = hi + hi_up
        hi_down = (hi >= 0) & ~(rho(hi) <= stroke)
        hi = hi - hi_down
    lo = np.where(ok, lo, nx)
    hi = np.where(ok, hi, -1)
    return lo, hi


def _mode_intervals(
    lo: IntArray, hi: IntArray, modes: NDArray[np.int8]
) -> tuple[IntArray, IntArray]:
    """Per working mode, the grid interval ``[lo, hi]`` of each (y, theta): (ny, nt, m)."""
    branch = (modes == -1).astype(np.intp)  # (m, 3)
    legs = np.arange(3)
    lo_m = lo[:, :, legs, branch].max(axis=-1)
    hi_m = hi[:, :, legs, branch].min(axis=-1)
    return lo_m, hi_m


def _rasterise(lo: IntArray, hi: IntArray, keep: BoolArray, nx: int, groups: int = 1) -> BoolArray:
    """Union of integer intervals per row.  ``lo, hi, keep`` have shape ``(ny, ...)``; with
    ``groups > 1`` the last axis (of that length) is kept apart.  Returns ``(ny, nx)`` or
    ``(groups, ny, nx)`` booleans."""
    ny = lo.shape[0]
    keep = keep & (lo <= hi)
    row = np.broadcast_to(np.arange(ny).reshape((ny,) + (1,) * (lo.ndim - 1)), lo.shape)
    width = nx + 1
    if groups > 1:
        grp = np.broadcast_to(np.arange(groups), lo.shape)
        base = (grp[keep] * ny + row[keep]) * width
    else:
        base = row[keep] * width
    size = groups * ny * width
    starts = np.bincount(base + lo[keep], minlength=size)
    ends = np.bincount(base + hi[keep] + 1, minlength=size)
    cover = np.cumsum((starts - ends).reshape(groups, ny, width), axis=-1)[..., :nx] > 0
    return cover if groups > 1 else cover[0]


# =============================================================================== margins
class RowMargins(NamedTuple):
    """Margins of every ``(y, theta, mode)``, each ``(ny, nt, m)`` (NaN where a leg cannot
    close).  They do not depend on ``x``.

    Attributes:
        parallel: inverse condition number of ``A_bar`` (``kinematics.parallel_margin``).
        serial: ``min_i |cos alpha_i|`` (``kinematics.serial_margin``).
        det_A: determinant of ``A_bar`` (dimensionless; its sign is the assembly mode).
        det_B: determinant of ``B`` divided by ``L_1 L_2 L_3``, i.e. ``prod_i cos alpha_i``.
    """

    parallel: FloatArray
    serial: FloatArray
    det_A: FloatArray
    det_B: FloatArray


def _margins(
    design: Design, rows: _Rows, thetas: FloatArray, modes: NDArray[np.int8]
) -> RowMargins:
    k = np.array(design.joint_offsets)
    legs = np.array(design.leg_lengths)
    ref = design.characteristic_length
    sig = modes.astype(np.float64)  # (m, 3)
    ux = rows.w[:, :, None, :] * sig  # (ny, nt, m, 3)
    uy = np.broadcast_to(rows.cy[:, :, None, :], ux.shape)
    ct = np.cos(thetas)[None, :, None, None]
    st = np.sin(thetas)[None, :, None, None]
    norm = np.hypot(ux, uy)
    serial = np.min(np.abs(ux) / norm, axis=-1)
    # A_bar rows: [ux, uy, k (uy cos - ux sin) / ref] / L_i
    c0 = ux / legs
    c1 = uy / legs
    c2 = k * (uy * ct - ux * st) / (legs * ref)
    det = (
        c0[..., 0] * (c1[..., 1] * c2[..., 2] - c1[..., 2] * c2[..., 1])
        - c0[..., 1] * (c1[..., 0] * c2[..., 2] - c1[..., 2] * c2[..., 0])
        + c0[..., 2] * (c1[..., 0] * c2[..., 1] - c1[..., 1] * c2[..., 0])
    )
    parallel = inverse_condition_batch(np.stack((c0, c1, c2), axis=-1))
    parallel[np.isnan(det)] = np.nan  # (a leg that cannot close)
    det_b = np.prod(ux / legs, axis=-1)
    return RowMargins(parallel, serial, det, det_b)


def row_margins(
    design: Design,
    y: ArrayLike,
    thetas: ArrayLike,
    mode: ArrayLike | None = None,
) -> RowMargins:
    """Parallel and serial margins and the normalised ``det A``, ``det B`` of every row ``y``
    (m), orientation ``theta`` (rad) and working mode; shape ``(ny, nt, m)``.

    They are the same at every ``x`` (and equal
    :func:`planar3p_gym.machine.kinematics.parallel_margin` and
    :func:`~planar3p_gym.machine.kinematics.serial_margin` there).
    """
    yy = np.atleast_1d(np.asarray(y, dtype=np.float64))
    th = np.atleast_1d(np.asarray(thetas, dtype=np.float64))
    modes = _modes(mode)
    return _margins(design, _rows(design, yy, th), th, modes)


# =============================================================================== workspace
@dataclass(frozen=True)
class Workspace:
    """Result of :func:`workspace`.

    Attributes:
        design: the design analysed.
        x, y: grid samples (m), shapes ``(nx,)`` and ``(ny,)``.
        thetas: sampled orientations (rad).
        modes: working modes used, ``(m, 3)``.
        reachable: ``(ny, nx)`` bool, some sampled orientation and mode puts every travel in
            ``[0, stroke]``.
        usable: ``(ny, nx)`` bool, the same with ``parallel margin >= min_parallel`` and
            ``serial margin >= min_serial`` for that orientation and mode (``None`` if not
            requested).
        per_mode: ``(m, ny, nx)`` bool, reachability in each mode (``None`` unless requested).
        min_parallel, min_serial: the thresholds of ``usable``.
        half: ``"upper"`` (the paper's rectangle) or ``"full"`` (with the part below the rails).
        theta_range: the orientation range sampled (``None``: the whole circle).
        theta_given: the orientations were given explicitly (e.g. a fixed orientation).
        exact_orientation: the mask is exact over the continuum of orientations
            (:func:`exact_workspace`) rather than over sampled ones.
    """

    design: Design
    x: FloatArray
    y: FloatArray
    thetas: FloatArray
    modes: NDArray[np.int8]
    reachable: BoolArray
    usable: BoolArray | None = None
    per_mode: BoolArray | None = None
    min_parallel: float | None = None
    min_serial: float | None = None
    half: str = "upper"
    theta_range: tuple[float, float] | None = None
    theta_given: bool = False
    exact_orientation: bool = False

    @property
    def S(self) -> float:
        """Relative workspace: reachable grid points / all grid points."""
        return float(self.reachable.mean())

    @property
    def S_usable(self) -> float | None:
        """Usable grid points / all grid points (``None`` if not computed)."""
        return None if self.usable is None else float(self.usable.mean())

    @property
    def rectangle_area(self) -> float:
        """Area (m^2) of the sampled rectangle."""
        return float((self.x[-1] - self.x[0]) * (self.y[-1] - self.y[0]))

    @property
    def area(self) -> float:
        """Grid estimate of the reachable area (m^2): the trapezoidal rule on the indicator
        of ``reachable`` (edge points weigh 1/2, corners 1/4); close to ``S`` times the
        rectangle's area, and converges to the exact area at rate ``O(1 / n)``."""
        wx = np.ones(self.x.size)
        wx[[0, -1]] = 0.5
        wy = np.ones(self.y.size)
        wy[[0, -1]] = 0.5
        cell = (self.x[-1] - self.x[0]) / (self.x.size - 1) * (self.y[-1] - self.y[0])
        cell /= self.y.size - 1
        return float(wy @ self.reachable.astype(np.float64) @ wx * cell)

    @property
    def symmetric_orientations(self) -> bool:
        """True when the orientation set is closed under ``theta -> -theta`` (mod 2 pi), so
        the part below the rails is the mirror image of the part above."""
        if self.exact_orientation:
            return self.theta_range is None
        t = np.mod(self.thetas, 2.0 * np.pi)
        m = np.mod(-self.thetas, 2.0 * np.pi)
        d = np.abs(t[:, None] - m[None, :])
        d = np.minimum(d, 2.0 * np.pi - d)
        return bool((d.min(axis=1) < 1e-9).all())


def workspace(
    design: Design,
    n: int | tuple[int, int] = 201,
    n_theta: int = 360,
    theta_range: tuple[float, float] | None = None,
    theta: float | ArrayLike | None = None,
    mode: ArrayLike | None = None,
    usable: bool = False,
    min_parallel: float = DEFAULT_MIN_PARALLEL,
    min_serial: float = DEFAULT_MIN_SERIAL,
    per_mode: bool = False,
    half: str = "upper",
) -> Workspace:
    """The paper's workspace grid test, exact for the sampled orientations.

    Args:
        design: the machine (its ``stroke`` is the stroke limit).
        n: grid points per side of the search rectangle, or ``(nx, ny)``.
        n_theta: number of sampled orientations (over ``[0, 2 pi)`` or ``theta_range``).
        theta_range: ``(lo, hi)`` (rad), sampled inclusively.
        theta: a fixed orientation (or explicit list of orientations), rad.
        mode: a fixed working mode ``(s1, s2, s3)`` of +-1 (or several, ``(m, 3)``); default all 8.
        usable: also compute the usable workspace (margins above the thresholds).
        min_parallel, min_serial: thresholds of the usable workspace.
        per_mode: also return the reachable mask of each working mode.
        half: ``"upper"`` (the paper's ``y in [0, h]``) or ``"full"`` (``y in [-h, h]``).
    """
    if not isinstance(design, Design):
        raise ValueError(f"design must be a planar3p_gym.Design, got {type(design).__name__}")
    x, y = search_grid(design, n, half)
    thetas = orientations(n_theta, theta_range, theta)
    modes = _modes(mode)
    rows = _rows(design, y, thetas)
    masks = _masks(
        design,
        rows,
        thetas,
        modes,
        x,
        design.stroke,
        usable,
        min_parallel,
        min_serial,
        per_mode,
        None,
    )
    return Workspace(
        design,
        x,
        y,
        thetas,
        modes,
        masks[0],
        masks[1],
        masks[2],
        min_parallel if usable else None,
        min_serial if usable else None,
        half,
        None if theta is not None else theta_range,
        theta is not None,
    )


def _masks(
    design: Design,
    rows: _Rows,
    thetas: FloatArray,
    modes: NDArray[np.int8],
    x: FloatArray,
    stroke: float,
    usable: bool,
    min_parallel: float,
    min_serial: float,
    per_mode: bool,
    good: BoolArray | None,
) -> tuple[BoolArray, BoolArray | None, BoolArray | None]:
    origins = np.array(design.rail_origins)
    lo, hi = _x_bounds(rows, origins, stroke, x)
    lo_m, hi_m = _mode_intervals(lo, hi, modes)
    nx = x.size
    keep = np.ones(lo_m.shape, dtype=bool)
    if per_mode:
        pm = _rasterise(lo_m, hi_m, keep, nx, groups=modes.shape[0])
        if modes.shape[0] == 1:
            pm = pm[None]
        reach = pm.any(axis=0)
    else:
        pm = None
        reach = _rasterise(lo_m, hi_m, keep, nx)
    use = None
    if usable:
        if good is None:
            mg = _margins(design, rows, thetas, modes)
            with np.errstate(invalid="ignore"):
                good = (mg.parallel >= min_parallel) & (mg.serial >= min_serial)
        use = _rasterise(lo_m, hi_m, good, nx)
    return reach, use, pm


def margin_levels(
    design: Design,
    levels: ArrayLike = (0.0, 0.01, 0.02, 0.05, 0.1, 0.2),
    n: int | tuple[int, int] = 201,
    n_theta: int = 360,
    mode: ArrayLike | None = None,
    min_serial: float = DEFAULT_MIN_SERIAL,
    half: str = "upper",
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The best parallel margin a grid point can be reached with, quantised to ``levels``.

    Returns ``(x, y, best)``: ``best[j, i]`` is the largest level ``t`` of ``levels`` such that
    the point is in the usable workspace with ``min_parallel = t`` and ``min_serial``
    (``NaN`` where no level is attained).  One rasterisation per level.
    """
    lv = np.sort(np.atleast_1d(np.asarray(levels, dtype=np.float64)))
    x, y = search_grid(design, n, half)
    thetas = orientations(n_theta)
    modes = _modes(mode)
    rows = _rows(design, y, thetas)
    lo, hi = _x_bounds(rows, np.array(design.rail_origins), design.stroke, x)
    lo_m, hi_m = _mode_intervals(lo, hi, modes)
    mg = _margins(design, rows, thetas, modes)
    best = np.full((y.size, x.size), np.nan)
    with np.errstate(invalid="ignore"):
        ser_ok = mg.serial >= min_serial
        for t in lv:
            cover = _rasterise(lo_m, hi_m, ser_ok & (mg.parallel >= t), x.size)
            best[cover] = t
    return x, y, best


# =============================================================================== dead zones
def merge_labels(n: int, edges_a: IntArray, edges_b: IntArray) -> IntArray:
    """Connected components of a graph on nodes ``0 .. n-1`` with edges ``(edges_a[k],
    edges_b[k])``: each node's label is the smallest node index of its component.

    Vectorised min-label propagation (hooking) with pointer jumping: a handful of sweeps,
    no per-node Python loop.
    """
    lab = np.arange(n)  # every label points at a node of the same component, never higher
    while True:
        la, lb = lab[edges_a], lab[edges_b]
        differ = la != lb
        if not differ.any():
            return lab
        la, lb = la[differ], lb[differ]
        low = np.minimum(la, lb)
        # hook: each (root) label adopts the smallest label it is joined to
        np.minimum.at(lab, la, low)
        np.minimum.at(lab, lb, low)
        # pointer jumping until every node points at a root
        while True:
            nxt = lab[lab]
            if np.array_equal(nxt, lab):
                break
            lab = nxt


def label_components(mask: ArrayLike) -> tuple[IntArray, int]:
    """4-connected components of the True cells of a 2-D mask.

    Returns ``(labels, count)``: ``labels`` is ``-1`` off the mask and ``0 .. count-1`` on it
    (numbered in raster order of each component's first cell).  Vectorised min-label
    propagation with pointer jumping (a handful of sweeps, no per-cell Python loop).
    """
    m = np.asarray(mask, dtype=bool)
    if m.ndim != 2:
        raise ValueError(f"mask must be 2-D, got shape {m.shape}")
    ny, nx = m.shape
    n = m.size
    flat = m.ravel()
    # edges between horizontally and vertically adjacent mask cells
    h_a = (np.arange(ny)[:, None] * nx + np.arange(nx - 1)[None, :]).ravel()
    h_a = h_a[(m[:, :-1] & m[:, 1:]).ravel()]
    v_a = np.arange((ny - 1) * nx)[(m[:-1, :] & m[1:, :]).ravel()]
    ea = np.concatenate([h_a, v_a])
    eb = np.concatenate([h_a + 1, v_a + nx])
    lab = merge_labels(n, ea, eb)
    roots, labels = np.unique(lab[flat], return_inverse=True)
    out = np.full(n, -1, dtype=np.int64)
    out[flat] = labels
    return out.reshape(ny, nx), int(roots.size)


@dataclass(frozen=True)
class DeadZones:
    """Holes inside the workspace envelope (:func:`dead_zones`).

    Attributes:
        count: number of holes.
        labels: ``(ny_full, nx)`` int, hole number ``0 .. count-1`` or ``-1``.
        cells: number of grid points of each hole, ``(count,)``.
        areas: approximate area (m^2) of each hole (cells times the cell area).
        y: the rows (m) of ``labels`` (the whole plane, both sides of the rails).
        x: the columns (m).
        exact: the grid points were decided over the continuum of orientations.
    """

    count: int
    labels: IntArray
    cells: IntArray
    areas: FloatArray
    x: FloatArray
    y: FloatArray = field(repr=False)
    exact: bool = False

    @property
    def total_area(self) -> float:
        return float(self.areas.sum())


def full_plane(ws: Workspace) -> tuple[FloatArray, BoolArray]:
    """The reachable mask of the whole plane, ``(y_full, mask)`` with ``y in [-h, h]``.

    For the paper's upper-half grid with an orientation set closed under ``theta -> -theta``
    this is the mask with its mirror image (the pose ``(x, -y, -theta)`` mirrors
    ``(x, y, theta)`` in the same working mode).  Otherwise the lower half is computed.
    """
    if ws.half == "full":
        return ws.y, ws.reachable
    if ws.symmetric_orientations:
        return np.concatenate([-ws.y[:0:-1], ws.y]), np.concatenate(
            [ws.reachable[:0:-1], ws.reachable]
        )
    if ws.exact_orientation:
        lower = reachable_exact(
            ws.design, ws.x[None, :], -ws.y[:0:-1, None], ws.modes, ws.theta_range
        )
    else:
        lower = workspace(
            ws.design, (ws.x.size, ws.y.size), theta=-ws.thetas, mode=ws.modes
        ).reachable[:0:-1]
    return np.concatenate([-ws.y[:0:-1], ws.y]), np.concatenate([lower, ws.reachable])


def dead_zones(ws: Workspace | BoolArray, min_cells: int = 1, refine: bool = True) -> DeadZones:
    """Dead zones: connected sets of unreachable grid points that do not touch the outer
    boundary of the search rectangle, judged on the whole plane (the rail line is a symmetry
    axis, not a boundary).

    With orientations sampled, a grid point reachable only in a window of orientations
    narrower than the sampling step looks unreachable, and such points show up as spurious
    one-point "holes".  With ``refine`` (the default, for a :class:`Workspace` whose
    orientations are a range or the whole circle), every unreachable grid point is decided
    again by :func:`reachable_exact`, so the holes are those of the exact workspace.

    Args:
        ws: a :class:`Workspace`, or a reachable mask already covering the whole plane.
        min_cells: ignore holes of fewer grid points (1 keeps every hole).
        refine: re-test unreachable grid points over the continuum of orientations.
    """
    refined = False
    if isinstance(ws, Workspace):
        x = ws.x
        if refine and not ws.exact_orientation and not ws.theta_given:
            if ws.half == "upper" and ws.symmetric_orientations:
                base = Workspace(
                    ws.design,
                    ws.x,
                    ws.y,
                    ws.thetas,
                    ws.modes,
                    _refine(ws, ws.x, ws.y, ws.reachable),
                    theta_range=ws.theta_range,
                )
                y, mask = full_plane(base)
            else:
                y, mask = full_plane(ws)
                mask = _refine(ws, x, y, mask)
            refined = True
        else:
            y, mask = full_plane(ws)
    else:
        mask = np.asarray(ws, dtype=bool)
        y = np.arange(mask.shape[0], dtype=np.float64)
        x = np.arange(mask.shape[1], dtype=np.float64)
    labels, count = label_components(~mask)
    border = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    border = border[border >= 0]
    cells = np.bincount(labels[labels >= 0], minlength=count)
    is_hole = np.ones(count, dtype=bool)
    is_hole[border] = False
    is_hole &= cells >= min_cells
    new_id = np.full(count + 1, -1, dtype=np.int64)
    new_id[:-1][is_hole] = np.arange(int(is_hole.sum()))
    out = new_id[labels]  # labels == -1 picks the last entry, -1
    hole_cells = cells[is_hole]
    dx = float(x[1] - x[0]) if x.size > 1 else 0.0
    dy = float(y[1] - y[0]) if y.size > 1 else 0.0
    return DeadZones(
        int(is_hole.sum()),
        out,
        hole_cells,
        hole_cells * dx * dy,
        x,
        y,
        refined or (isinstance(ws, Workspace) and ws.exact_orientation),
    )


# =============================================================================== stroke study
def _refine(ws: Workspace, x: FloatArray, y: FloatArray, mask: BoolArray) -> BoolArray:
    """``mask`` with its unreachable grid points decided again over continuous orientations."""
    out = mask.copy()
    iy, ix = np.nonzero(~mask)
    out[iy, ix] = reachable_exact(ws.design, x[ix], y[iy], ws.modes, ws.theta_range)
    return out


@dataclass(frozen=True)
class StrokeStudy:
    """Result of :func:`stroke_study` (arrays indexed like ``strokes``).

    Attributes:
        design: the design (its own stroke is ignored).
        strokes: stroke lengths ``L`` (m).
        S: relative workspace.
        S_usable: relative usable workspace (``None`` if not computed).
        dead_zones: number of dead zones of the reachable workspace (whole plane; unreachable
            grid points re-tested over the continuum of orientations, see :func:`dead_zones`).
        dead_zone_area: their total area (m^2, grid estimate).
        n, n_theta, modes, min_parallel, min_serial: the settings.
        masks: the reachable masks ``(len(strokes), ny, nx)`` if requested, else ``None``.
        usable_masks: likewise for the usable workspace.
    """

    design: Design
    strokes: FloatArray
    S: FloatArray
    S_usable: FloatArray | None
    dead_zones: IntArray
    dead_zone_area: FloatArray
    n: tuple[int, int]
    n_theta: int
    modes: NDArray[np.int8]
    min_parallel: float | None
    min_serial: float | None
    masks: BoolArray | None = field(default=None, repr=False)
    usable_masks: BoolArray | None = field(default=None, repr=False)

    def recommended_stroke(self) -> float | None:
        """The paper's choice: the shortest stroke from which on (for every longer stroke of
        the study as well) the workspace has no dead zone; ``None`` if there is none."""
        ok = self.dead_zones == 0
        tail = np.logical_and.accumulate(ok[::-1])[::-1]
        idx = np.flatnonzero(tail)
        return float(self.strokes[idx[0]]) if idx.size else None


def stroke_study(
    design: Design,
    strokes: ArrayLike,
    n: int | tuple[int, int] = 201,
    n_theta: int = 360,
    mode: ArrayLike | None = None,
    usable: bool = True,
    min_parallel: float = DEFAULT_MIN_PARALLEL,
    min_serial: float = DEFAULT_MIN_SERIAL,
    count_dead_zones: bool = True,
    keep_masks: bool = False,
) -> StrokeStudy:
    """``S(L)`` of the paper's study: the workspace of ``design`` for every stroke in
    ``strokes`` (m), with the usable workspace and dead zones.

    Everything that does not depend on the stroke (leg geometry of every row and orientation,
    margins) is computed once; per stroke only the interval bounds on that stroke's grid are
    rasterised.
    """
    Ls = np.atleast_1d(np.asarray(strokes, dtype=np.float64))
    if Ls.ndim != 1 or Ls.size == 0 or not (np.isfinite(Ls).all() and (Ls > 0).all()):
        raise ValueError("strokes must be a non-empty list of positive lengths")
    nx, ny = _grid_shape(n)
    thetas = orientations(n_theta)
    modes = _modes(mode)
    _, y = search_grid(design, (nx, ny))  # y does not depend on the stroke
    rows = _rows(design, y, thetas)
    good = None
    if usable:
        mg = _margins(design, rows, thetas, modes)
        with np.errstate(invalid="ignore"):
            good = (mg.parallel >= min_parallel) & (mg.serial >= min_serial)
    S = np.empty(Ls.size)
    Su = np.empty(Ls.size) if usable else None
    dz = np.zeros(Ls.size, dtype=np.int64)
    dza = np.zeros(Ls.size)
    masks = np.empty((Ls.size, ny, nx), dtype=bool) if keep_masks else None
    umasks = np.empty((Ls.size, ny, nx), dtype=bool) if keep_masks and usable else None
    for s_idx, L in enumerate(Ls):
        d = design.with_(stroke=float(L))
        x, _ = search_grid(d, (nx, ny))
        reach, use, _ = _masks(
            d, rows, thetas, modes, x, float(L), usable, min_parallel, min_serial, False, good
        )
        S[s_idx] = reach.mean()
        ws = Workspace(d, x, y, thetas, modes, reach, use)
        if count_dead_zones:
            z = dead_zones(ws)
            dz[s_idx], dza[s_idx] = z.count, z.total_area
        if usable:
            Su[s_idx] = use.mean()  # type: ignore[index, union-attr]
        if masks is not None:
            masks[s_idx] = reach
        if umasks is not None:
            umasks[s_idx] = use
    return StrokeStudy(
        design,
        Ls,
        S,
        Su,
        dz,
        dza,
        (nx, ny),
        int(n_theta),
        modes,
        min_parallel if usable else None,
        min_serial if usable else None,
        masks,
        umasks,
    )


# =============================================================================== exact test
def in_constant_orientation_workspace(
    design: Design, x: ArrayLike, y: ArrayLike, theta: ArrayLike, mode: ArrayLike | None = None
) -> BoolArray:
    """Exact test for the constant-orientation workspace (broadcasting ``x, y, theta``).

    Leg ``i`` can be assembled with its travel in ``[0, L]`` iff ``C_i`` lies within ``L_i`` of
    the stroke segment ``[(a_i, 0), (a_i + L, 0)]`` and at least ``L_i`` from one of its ends
    (the distance from ``C_i`` to a point of the segment takes every value between those two
    extremes).  With ``mode`` given (one triple or several, fewer than all 8), the travel of
    leg ``i`` in branch ``sigma_i`` is tested instead: the point
    ``(C_ix - sigma_i sqrt(L_i^2 - C_iy^2), 0)`` lies on the segment (in one of the modes).
    """
    xx, yy, th = np.broadcast_arrays(
        np.asarray(x, dtype=np.float64),
        np.asarray(y, dtype=np.float64),
        np.asarray(theta, dtype=np.float64),
    )
    k = np.array(design.joint_offsets)
    legs = np.array(design.leg_lengths)
    a = np.array(design.rail_origins)
    L = design.stroke
    cx = xx[..., None] + k * np.cos(th)[..., None] - a  # relative to the rail origin
    cy = yy[..., None] + k * np.sin(th)[..., None]
    modes = None if mode is None else _modes(mode)
    if modes is not None and np.unique(modes, axis=0).shape[0] < 8:
        with np.errstate(invalid="ignore"):
            w = np.sqrt(legs**2 - cy**2)
            out = np.zeros(xx.shape, dtype=bool)
            for sig in modes.astype(np.float64):
                foot = cx - sig * w
                out |= ((foot >= 0.0) & (foot <= L)).all(axis=-1)
        return out
    nearest = np.clip(cx, 0.0, L)
    d_seg = np.hypot(cx - nearest, cy)
    d_far = np.hypot(np.maximum(np.abs(cx), np.abs(cx - L)), cy)
    return ((d_seg <= legs) & (d_far >= legs)).all(axis=-1)


def _candidate_angles(design: Design, x: FloatArray, y: FloatArray) -> FloatArray:
    """Orientations (rad) at which some leg of a gripper at ``(x, y)`` meets the boundary of
    its swept circle, ``(..., 24)`` (NaN where absent): ``C_i`` on the lines ``y = +-L_i``
    (a leg perpendicular to its rail) or on the circles of radius ``L_i`` about the stroke
    ends (a travel at ``0`` or ``L``).  Between two consecutive ones the feasibility of every
    leg, in every working mode, is constant."""
    k = np.array(design.joint_offsets)
    legs = np.array(design.leg_lengths)
    a = np.array(design.rail_origins)
    xx = x[..., None]
    yy = y[..., None]
    out = []
    with np.errstate(invalid="ignore"):
        for sgn in (1.0, -1.0):  # y + k sin(theta) = +-L_i
            v = (sgn * legs - yy) / k
            s = np.arcsin(v)  # NaN when |v| > 1
            out += [s, np.pi - s]
        for end in (0.0, float(design.stroke)):  # |G + k e - P| = L_i, P = (a_i + end, 0)
            dx = xx - (a + end)
            dy = np.broadcast_to(yy, dx.shape)
            R = np.hypot(dx, dy)
            q = (legs**2 - k**2 - R**2) / (2.0 * k)
            phi = np.arctan2(dy, dx)
            c = np.arccos(q / R)  # NaN when |q| > R
            out += [phi + c, phi - c]
    return np.concatenate(out, axis=-1)


def reachable_exact(
    design: Design,
    x: ArrayLike,
    y: ArrayLike,
    mode: ArrayLike | None = None,
    theta_range: tuple[float, float] | None = None,
) -> BoolArray:
    """Exact reachability over the *continuum* of orientations (no orientation sampling).

    ``G = (x, y)`` (m, broadcast) is reachable iff some ``theta`` (in ``theta_range`` if
    given, else any) passes :func:`in_constant_orientation_workspace` (in working mode
    ``mode`` if given, else in any).  As ``theta`` turns, ``C_i`` runs on the circle of radius
    ``L_iG`` about ``G``; the feasibility of leg ``i`` changes only where that circle crosses the
    lines ``y = +-L_i`` or the circles of radius ``L_i`` about the stroke ends, which are
    closed-form angles.  Testing every such angle and the midpoint of every arc between
    consecutive ones decides the question exactly (up to rounding on the boundary, and a
    point reachable at isolated orientations only, on the boundary, may be missed).
    """
    xx, yy = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    cand = _candidate_angles(design, xx, yy)
    two_pi = 2.0 * np.pi
    if theta_range is None or theta_range[1] - theta_range[0] >= two_pi:
        lo, span = 0.0, two_pi
        extra = np.zeros(xx.shape + (1,))
    else:
        lo, hi = (float(v) for v in theta_range)
        if not lo <= hi:
            raise ValueError(f"theta_range must have lo <= hi, got {theta_range!r}")
        span = hi - lo
        extra = np.broadcast_to(np.array([lo, hi]), xx.shape + (2,))
    # angles as offsets from lo in [0, 2 pi); those beyond the range are dropped
    t = np.concatenate([cand, extra], axis=-1)
    with np.errstate(invalid="ignore"):
        off = np.mod(t - lo, two_pi)
        off = np.where(off <= span + 1e-15, np.minimum(off, span), np.nan)
    off = np.sort(off, axis=-1)  # NaN last
    count = np.isfinite(off).sum(axis=-1)
    nxt = np.roll(off, -1, axis=-1)
    last = np.clip(count - 1, 0, None)[..., None]
    first = off[..., :1]
    full = span >= two_pi
    wrap = first + two_pi if full else np.full_like(first, np.nan)
    np.put_along_axis(nxt, last, wrap, axis=-1)
    mids = 0.5 * (off + nxt) + lo  # NaN past the last angle: tests False
    modes = None if mode is None else _modes(mode)
    if modes is not None and np.unique(modes, axis=0).shape[0] == 8:
        modes = None
    return _any_feasible(design, xx, yy, mids, modes)


def _any_feasible(
    design: Design, x: FloatArray, y: FloatArray, th: FloatArray, modes: NDArray[np.int8] | None
) -> BoolArray:
    """``any_j`` of the swept-circle test at ``(x, y, th[..., j])`` (squared distances)."""
    k = np.array(design.joint_offsets)
    legs2 = np.array(design.leg_lengths) ** 2
    a = np.array(design.rail_origins)
    L = float(design.stroke)
    ct, st = np.cos(th), np.sin(th)
    ok = np.isfinite(th)
    if modes is None:
        for i in range(3):
            cx = x[..., None] + (k[i] * ct - a[i])
            cy2 = (y[..., None] + k[i] * st) ** 2
            out_x = np.maximum(np.maximum(-cx, cx - L), 0.0)
            far = np.maximum(np.abs(cx), np.abs(cx - L))
            ok &= (out_x * out_x + cy2 <= legs2[i]) & (far * far + cy2 >= legs2[i])
        return ok.any(axis=-1)
    res = np.zeros(x.shape, dtype=bool)
    with np.errstate(invalid="ignore"):
        cxs = [x[..., None] + (k[i] * ct - a[i]) for i in range(3)]
        ws_ = [np.sqrt(legs2[i] - (y[..., None] + k[i] * st) ** 2) for i in range(3)]
        for sig in modes.astype(np.float64):
            okm = ok.copy()
            for i in range(3):
                foot = cxs[i] - sig[i] * ws_[i]
                okm &= (foot >= 0.0) & (foot <= L)
            res |= okm.any(axis=-1)
    return res


def exact_workspace(
    design: Design,
    n: int | tuple[int, int] = 201,
    mode: ArrayLike | None = None,
    theta_range: tuple[float, float] | None = None,
    half: str = "upper",
) -> Workspace:
    """The grid workspace with exact orientations: :func:`reachable_exact` at every grid point
    (slower than :func:`workspace`; ``thetas`` of the result is empty)."""
    x, y = search_grid(design, n, half)
    reach = reachable_exact(design, x[None, :], y[:, None], mode, theta_range)
    return Workspace(
        design,
        x,
        y,
        np.zeros(0),
        _modes(mode),
        reach,
        half=half,
        theta_range=theta_range,
        exact_orientation=True,
    )


# --------------------------------------------------------------------- exact area (Green)
class _Prim(NamedTuple):
    """A boundary piece: a segment ``p -> q`` (``r == 0``) or an arc of centre ``c`` and
    radius ``r`` from angle ``t0`` to ``t1`` (counter-clockwise if ``t1 > t0``)."""

    owner: int
    p: tuple[float, float]
    q: tuple[float, float]
    c: tuple[float, float]
    r: float
    t0: float
    t1: float

    @property
    def is_arc(self) -> bool:
        return self.r > 0

    def point(self, u: float) -> tuple[float, float]:
        if self.is_arc:
            t = self.t0 + u * (self.t1 - self.t0)
            return (self.c[0] + self.r * math.cos(t), self.c[1] + self.r * math.sin(t))
        return (self.p[0] + u * (self.q[0] - self.p[0]), self.p[1] + u * (self.q[1] - self.p[1]))

    def left_normal(self, u: float) -> tuple[float, float]:
        if self.is_arc:
            t = self.t0 + u * (self.t1 - self.t0)
            s = -1.0 if self.t1 > self.t0 else 1.0  # CCW: the centre is on the left
            return (s * math.cos(t), s * math.sin(t))
        dx, dy = self.q[0] - self.p[0], self.q[1] - self.p[1]
        n = math.hypot(dx, dy)
        return (-dy / n, dx / n)

    def green(self, u0: float, u1: float) -> float:
        """``1/2 int (x dy - y dx)`` from parameter ``u0`` to ``u1``."""
        if self.is_arc:
            a0 = self.t0 + u0 * (self.t1 - self.t0)
            a1 = self.t0 + u1 * (self.t1 - self.t0)
            cx, cy, r = self.c[0], self.c[1], self.r
            return 0.5 * (
                r * r * (a1 - a0)
                + r * cx * (math.sin(a1) - math.sin(a0))
                - r * cy * (math.cos(a1) - math.cos(a0))
            )
        p, q = self.point(u0), self.point(u1)
        return 0.5 * (p[0] * q[1] - p[1] * q[0])

    def param_of(self, pt: tuple[float, float]) -> float:
        """Parameter of a point on the underlying curve (may fall outside ``[0, 1]``)."""
        if self.is_arc:
            ang = math.atan2(pt[1] - self.c[1], pt[0] - self.c[0])
            span = self.t1 - self.t0
            if span > 0:
                return ((ang - self.t0) % (2.0 * math.pi)) / span
            return ((self.t0 - ang) % (2.0 * math.pi)) / (-span)
        dx, dy = self.q[0] - self.p[0], self.q[1] - self.p[1]
        return ((pt[0] - self.p[0]) * dx + (pt[1] - self.p[1]) * dy) / (dx * dx + dy * dy)


def _leg_boundary(owner: int, ox: float, oy: float, L: float, r: float) -> list[_Prim]:
    """Positively oriented boundary of ``{P : dist(P, seg) <= r, max end distance >= r}``
    for the segment ``(ox, oy) -> (ox + L, oy)``."""
    pi = math.pi
    z = (0.0, 0.0)
    a, b = (ox, oy), (ox + L, oy)
    prims = [
        _Prim(owner, (ox, oy - r), (ox + L, oy - r), z, 0.0, 0.0, 0.0),
        _Prim(owner, z, z, b, r, -pi / 2, pi / 2),
        _Prim(owner, (ox + L, oy + r), (ox, oy + r), z, 0.0, 0.0, 0.0),
        _Prim(owner, z, z, a, r, pi / 2, 3 * pi / 2),
    ]
    if L < 2.0 * r:  # the lens of points closer than r to both ends is a hole (clockwise)
        phi = math.acos(L / (2.0 * r))
        prims += [
            _Prim(owner, z, z, a, r, phi, -phi),
            _Prim(owner, z, z, b, r, pi + phi, pi - phi),
        ]
    return prims


def _curve_intersections(P: _Prim, Q: _Prim, tol: float) -> list[tuple[float, float]]:
    """Intersection points of the underlying full curves of ``P`` and ``Q``; for coincident
    curves, the end points of ``Q`` (splitting there is all that is needed)."""
    if not P.is_arc and not Q.is_arc:
        (px, py), (qx, qy) = P.p, P.q
        (rx, ry), (sx, sy) = Q.p, Q.q
        d1 = (qx - px, qy - py)
        d2 = (sx - rx, sy - ry)
        cr = d1[0] * d2[1] - d1[1] * d2[0]
        n1 = math.hypot(*d1)
        n2 = math.hypot(*d2)
        if abs(cr) <= 1e-14 * n1 * n2:
            off = (rx - px) * d1[1] - (ry - py) * d1[0]
            return [Q.p, Q.q] if abs(off) <= tol * n1 else []
        t = ((rx - px) * d2[1] - (ry - py) * d2[0]) / cr
        return [(px + t * d1[0], py + t * d1[1])]
    if P.is_arc and Q.is_arc:
        (ax, ay), (bx, by) = P.c, Q.c
        d = math.hypot(bx - ax, by - ay)
        if d <= tol and abs(P.r - Q.r) <= tol:
            return [Q.point(0.0), Q.point(1.0)]
        if d <= tol or d > P.r + Q.r + tol or d < abs(P.r - Q.r) - tol:
            return []
        along = (d * d + P.r * P.r - Q.r * Q.r) / (2.0 * d)
        h = math.sqrt(max(P.r * P.r - along * along, 0.0))
        ex, ey = (bx - ax) / d, (by - ay) / d
        mx, my = ax + along * ex, ay + along * ey
        return [(mx - h * ey, my + h * ex), (mx + h * ey, my - h * ex)]
    seg, arc = (P, Q) if not P.is_arc else (Q, P)
    (px, py), (qx, qy) = seg.p, seg.q
    dx, dy = qx - px, qy - py
    n = math.hypot(dx, dy)
    dx, dy = dx / n, dy / n
    fx, fy = px - arc.c[0], py - arc.c[1]
    b = fx * dx + fy * dy
    disc = b * b - (fx * fx + fy * fy - arc.r * arc.r)
    if disc < -tol * arc.r:
        return []
    s = math.sqrt(max(disc, 0.0))
    return [(px + (-b + s) * dx, py + (-b + s) * dy), (px + (-b - s) * dx, py + (-b - s) * dy)]


def constant_orientation_area(
    design: Design, theta: float, rectangle: tuple[float, float, float, float] | None = None
) -> float:
    """Exact area (m^2) of the constant-orientation workspace at ``theta`` (rad) inside
    ``rectangle = (x_min, x_max, y_min, y_max)`` (default: the search rectangle above the
    rails).

    The region of leg ``i`` in the gripper plane is the swept circle of
    :func:`in_constant_orientation_workspace` moved by ``-L_iG e``: a stadium (segment and
    radius ``L_i``) minus the lens of points closer than ``L_i`` to both stroke ends, bounded
    by segments and circular arcs.  The boundaries of the three regions and the rectangle are
    split at all their mutual intersections; a piece bounds the intersection when a point just
    to its left lies in every other region (coincident pieces are counted once), and Green's
    theorem sums the pieces in closed form.
    """
    k = design.joint_offsets
    legs = design.leg_lengths
    a = design.rail_origins
    L = float(design.stroke)
    x0, x1, y0, y1 = design.search_rectangle if rectangle is None else rectangle
    ct, st = math.cos(theta), math.sin(theta)
    segs = [(a[i] - k[i] * ct, -k[i] * st) for i in range(3)]
    prims: list[_Prim] = []
    for i in range(3):
        prims += _leg_boundary(i, segs[i][0], segs[i][1], L, legs[i])
    z = (0.0, 0.0)
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    for j in range(4):
        prims.append(_Prim(3, corners[j], corners[(j + 1) % 4], z, 0.0, 0.0, 0.0))
    scale = max(max(legs) + max(k) + L, x1 - x0, y1 - y0)
    tol = 1e-12 * scale
    eps = 1e-9 * scale

    def inside(owner: int, px: float, py: float) -> bool:
        if owner == 3:
            return x0 <= px <= x1 and y0 <= py <= y1
        ox, oy = segs[owner]
        r = legs[owner]
        rx = px - ox
        ry = py - oy
        near = min(max(rx, 0.0), L)
        if math.hypot(rx - near, ry) > r:
            return False
        return math.hypot(max(abs(rx), abs(rx - L)), ry) >= r

    total = 0.0
    for P in prims:
        cuts = [0.0, 1.0]
        for Q in prims:
            if Q.owner == P.owner:
                continue
            for pt in _curve_intersections(P, Q, tol):
                u = P.param_of(pt)
                if 0.0 < u < 1.0:
                    cuts.append(u)
        cuts.sort()
        for u0, u1 in itertools.pairwise(cuts):
            if u1 - u0 <= 1e-14:
                continue
            um = 0.5 * (u0 + u1)
            mx, my = P.point(um)
            nx_, ny_ = P.left_normal(um)
            lx, ly = mx + eps * nx_, my + eps * ny_
            rx, ry = mx - eps * nx_, my - eps * ny_
            take = True
            for j in range(4):
                if j == P.owner:
                    continue
                if not inside(j, lx, ly):
                    take = False
                    break
                if j < P.owner and not inside(j, rx, ry):  # coincident: counted by owner j
                    take = False
                    break
            if take:
                total += P.green(u0, u1)
    return total


# =============================================================================== singularities
class SingularityMap(NamedTuple):
    """Singularity functions over ``(y, theta)`` for each working mode (:func:`singularity_map`).

    Attributes:
        y: rows (m), ``(ny,)``.
        thetas: orientations (rad), ``(nt,)``.
        modes: ``(m, 3)``.
        det_A: normalised ``det A`` (``det A_bar``), ``(m, ny, nt)``, NaN where a leg cannot
            close; its zero set is the parallel-singularity locus.
        det_B: ``prod_i cos alpha_i``, ``(m, ny, nt)``; zero on the serial-singularity locus.
        feasible: ``(m, ny, nt)`` bool, some ``x`` puts every travel inside the stroke (the
            projection of the workspace of that mode onto ``(y, theta)``).
        parallel_margin, serial_margin: ``(m, ny, nt)``.
    """

    y: FloatArray
    thetas: FloatArray
    modes: NDArray[np.int8]
    det_A: FloatArray
    det_B: FloatArray
    feasible: BoolArray
    parallel_margin: FloatArray
    serial_margin: FloatArray


def _spread(design: Design, rows: _Rows, modes: NDArray[np.int8]) -> FloatArray:
    """``max_i s_i - min_i s_i`` per (y, theta, mode): the stroke needed for the row to
    contain a reachable ``x`` (NaN where a leg cannot close)."""
    a = np.array(design.rail_origins)
    s = (a - rows.kc)[None, :, None, :] + rows.w[:, :, None, :] * modes.astype(np.float64)
    return s.max(axis=-1) - s.min(axis=-1)


def singularity_map(
    design: Design,
    n_y: int = 401,
    n_theta: int = 721,
    mode: ArrayLike | None = None,
    y_range: tuple[float, float] | None = None,
    theta_range: tuple[float, float] = (-math.pi, math.pi),
) -> SingularityMap:
    """``det A`` and ``det B`` (normalised) over a ``(y, theta)`` grid for each working mode.

    The kinematics do not depend on ``x`` (only the stroke limits do), so these maps hold
    the whole singularity structure; ``feasible`` marks where the stroke admits some ``x``.
    ``y_range`` defaults to ``[-h, h]``.
    """
    h = design.search_height
    y0, y1 = (-h, h) if y_range is None else y_range
    y = np.linspace(y0, y1, int(n_y))
    th = np.linspace(theta_range[0], theta_range[1], int(n_theta))
    modes = _modes(mode)
    rows = _rows(design, y, th)
    mg = _margins(design, rows, th, modes)
    with np.errstate(invalid="ignore"):
        feasible = _spread(design, rows, modes) <= design.stroke

    def t(arr: NDArray) -> NDArray:
        return np.moveaxis(arr, -1, 0)

    return SingularityMap(
        y, th, modes, t(mg.det_A), t(mg.det_B), t(feasible), t(mg.parallel), t(mg.serial)
    )


def parallel_singularity_points(
    design: Design,
    thetas: ArrayLike,
    mode: ArrayLike,
    n_y: int = 2001,
    y_range: tuple[float, float] | None = None,
    iterations: int = 100,
) -> tuple[FloatArray, FloatArray]:
    """Points ``(y, theta)`` of the parallel-singularity locus ``det A = 0`` of one working
    mode: for every orientation, each sign change of ``det A`` along ``y`` (sampled with
    ``n_y`` rows over ``y_range``, default ``[-h, h]``) refined by bisection to machine
    precision, and every sample where ``det A`` is exactly zero.  Returns two flat arrays
    ``(y, theta)``, sorted by ``theta`` then ``y``.  Double roots (tangencies) that fall
    between samples are missed.
    """
    h = design.search_height
    y0, y1 = (-h, h) if y_range is None else y_range
    th = np.atleast_1d(np.asarray(thetas, dtype=np.float64))
    modes = _modes(mode)[:1]
    y = np.linspace(y0, y1, int(n_y))
    det = row_margins(design, y, th, modes).det_A[..., 0]  # (ny, nt)
    with np.errstate(invalid="ignore"):
        change = np.isfinite(det[:-1]) & np.isfinite(det[1:]) & (det[:-1] * det[1:] < 0.0)
    zy, zt = np.nonzero(det == 0.0)  # exact zeros on a sample (e.g. y = 0 at theta = 0)
    iy, it = np.nonzero(change)
    lo, hi = y[iy], y[iy + 1]
    tt = th[it]
    f_lo = det[iy, it]

    def f(yy: FloatArray) -> FloatArray:
        return _det_a_points(design, yy, tt, modes[0])

    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if not np.any((mid != lo) & (mid != hi)):
            break
        fm = f(mid)
        same = np.sign(fm) == np.sign(f_lo)
        lo = np.where(same, mid, lo)
        f_lo = np.where(same, fm, f_lo)
        hi = np.where(same, hi, mid)
    fl, fh = np.abs(f(lo)), np.abs(f(hi))
    ys = np.concatenate([np.where(fl <= fh, lo, hi), y[zy]])
    ts = np.concatenate([tt, th[zt]])
    order = np.lexsort((ys, ts))
    return ys[order], ts[order]


def _det_a_points(
    design: Design, y: FloatArray, th: FloatArray, mode: NDArray[np.int8]
) -> FloatArray:
    """``det A_bar`` at paired arrays ``y``, ``theta`` (flat) for one mode."""
    k = np.array(design.joint_offsets)
    legs = np.array(design.leg_lengths)
    ref = design.characteristic_length
    cy = y[:, None] + k * np.sin(th)[:, None]
    with np.errstate(invalid="ignore"):
        w = np.sqrt(legs**2 - cy**2)
    ux = mode.astype(np.float64) * w
    ct, st = np.cos(th)[:, None], np.sin(th)[:, None]
    c0, c1 = ux / legs, cy / legs
    c2 = k * (cy * ct - ux * st) / (legs * ref)
    return (
        c0[:, 0] * (c1[:, 1] * c2[:, 2] - c1[:, 2] * c2[:, 1])
        - c0[:, 1] * (c1[:, 0] * c2[:, 2] - c1[:, 2] * c2[:, 0])
        + c0[:, 2] * (c1[:, 0] * c2[:, 1] - c1[:, 1] * c2[:, 0])
    )


def serial_singularity_points(
    design: Design, thetas: ArrayLike
) -> tuple[FloatArray, FloatArray, IntArray]:
    """The serial-singularity locus ``det B = 0`` over ``(y, theta)``: leg ``i`` is
    perpendicular to its rail iff ``C_iy = +-L_i``, i.e. ``y = +-L_i - L_iG sin(theta)``.

    Returns flat arrays ``(y, theta, leg)`` (leg 0-based), six points per orientation.
    """
    th = np.atleast_1d(np.asarray(thetas, dtype=np.float64))
    k = np.array(design.joint_offsets)
    legs = np.array(design.leg_lengths)
    ys = np.stack([legs - k * np.sin(th)[:, None], -legs - k * np.sin(th)[:, None]], axis=1)
    leg = np.broadcast_to(np.arange(3), ys.shape)
    tt = np.broadcast_to(th[:, None, None], ys.shape)
    return ys.ravel(), tt.ravel(), leg.ravel().astype(np.int64)


class SingularitySegment(NamedTuple):
    """A piece of a singularity locus in the plane at a fixed orientation: the horizontal
    segment ``y`` for ``x in [x0, x1]`` (m) where the mechanism in working mode ``mode`` is
    singular and every travel lies inside the stroke."""

    kind: str  # "parallel" or "serial"
    mode: tuple[int, int, int]
    y: float
    x0: float
    x1: float
    leg: int | None


def singularity_segments(
    design: Design,
    theta: float,
    mode: ArrayLike | None = None,
    n_y: int = 4001,
    y_range: tuple[float, float] | None = None,
) -> list[SingularitySegment]:
    """Singularity loci at a fixed orientation ``theta`` over the plane, within the stroke.

    At fixed ``theta`` and working mode the kinematics depend on ``y`` only, so ``det A = 0``
    and ``det B = 0`` are horizontal lines; each is clipped to the exact ``x`` interval
    ``[max_i s_i, min_i s_i + L]`` where every travel lies in ``[0, L]`` (none if empty).
    """
    modes = _modes(mode)
    a = np.array(design.rail_origins)
    k = np.array(design.joint_offsets)
    legs = np.array(design.leg_lengths)
    L = design.stroke
    kc = k * math.cos(theta)
    out: list[SingularitySegment] = []

    def interval(yv: float, sig: NDArray[np.int8]) -> tuple[float, float] | None:
        cy = yv + k * math.sin(theta)
        w = np.sqrt(np.maximum(legs**2 - cy**2, 0.0))
        if np.any(np.abs(cy) > legs * (1 + 1e-12)):
            return None
        s = a - kc + sig * w
        lo, hi = float(s.max()), float(s.min() + L)
        return (lo, hi) if lo <= hi else None

    for sig in modes:
        ys, _ = parallel_singularity_points(design, [theta], sig, n_y=n_y, y_range=y_range)
        for yv in ys:
            iv = interval(float(yv), sig)
            if iv is not None:
                out.append(
                    SingularitySegment(
                        "parallel", tuple(int(v) for v in sig), float(yv), iv[0], iv[1], None
                    )
                )
        yser, _, leg = serial_singularity_points(design, [theta])
        for yv, li in zip(yser, leg, strict=True):
            iv = interval(float(yv), sig)
            if iv is not None:
                out.append(
                    SingularitySegment(
                        "serial", tuple(int(v) for v in sig), float(yv), iv[0], iv[1], int(li)
                    )
                )
    return out
