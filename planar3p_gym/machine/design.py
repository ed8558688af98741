"""The machine's parameters: geometry, masses, actuator limits, gravity.

A :class:`Design` is immutable and validated at construction; every module of the package
(kinematics, workspace, physics, environment) takes one.  All quantities are SI (m, kg, s, N).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from functools import lru_cache
from typing import Any

import numpy as np
from numba import njit

__all__ = ["Design", "closing_pose"]

Triple = tuple[float, float, float]


def _is_number(v: Any) -> bool:
    """A real number (numpy scalars included), not a bool or a string."""
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(
        v, (bool, np.bool_)
    )


def _triple(name: str, value: Any) -> Triple:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise ValueError(f"Design.{name} must be three numbers, got {value!r}")
    raw = list(value)
    if not all(_is_number(v) for v in raw):
        raise ValueError(f"Design.{name} must be three numbers, got {value!r}")
    items = tuple(float(v) for v in raw)
    if len(items) != 3:
        raise ValueError(f"Design.{name} must have exactly 3 entries, got {len(items)}: {value!r}")
    for i, v in enumerate(items):
        if not math.isfinite(v):
            raise ValueError(f"Design.{name}[{i}] must be finite, got {v!r}")
    return items  # type: ignore[return-value]


def _positive(name: str, value: Any, allow_zero: bool = False) -> float:
    if not _is_number(value):
        raise ValueError(f"Design.{name} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"Design.{name} must be finite and {bound}, got {value!r}")
    return v


@dataclass(frozen=True)
class Design:
    """Geometric and physical parameters of a 3-PRR manipulator with a collinear platform.

    The platform carries, in order, the joints ``C_1, C_2, C_3`` and the gripper point ``G``
    (see ``docs/mechanism.md``).  Rails lie on ``y = 0``; slider ``i`` travels ``rho_i in [0,
    stroke]`` from its rail origin ``(a_i, 0)``.

    Attributes:
        leg_lengths: ``(L_1, L_2, L_3)``, length of leg ``i`` from ``B_i`` to ``C_i`` (m).
        spacings: ``(d_12, d_23, d_3G)``, distances ``|C_1C_2|, |C_2C_3|, |C_3G|`` (m);
            ``d_12`` and ``d_23`` must be positive, ``d_3G`` may be zero (gripper at ``C_3``).
        stroke: ``L``, the travel range of every slider (m).
        rail_origins: ``(a_1, a_2, a_3)``, x of each rail's origin (m).
        slider_mass: mass of each slider (kg).
        leg_mass: mass of each leg, a uniform rod (kg).
        platform_mass: mass of the platform, a uniform rod from ``G`` to ``C_1`` (kg).
        max_force: the largest force an actuator can apply along its rail (N).
        max_speed: the largest slider speed an actuator can be commanded (m/s).
        gravity: magnitude ``g`` of gravity, acting along ``-y`` (m/s^2); 0 disables it.
        reference_length: characteristic length used to make angles commensurate with
            lengths (m); ``None`` means ``L_1G``, the distance from ``C_1`` to ``G``.
    """

    leg_lengths: Triple = (0.17, 0.18, 0.19)
    spacings: Triple = (0.10, 0.10, 0.10)
    stroke: float = 0.30
    rail_origins: Triple = (0.0, 0.0, 0.0)
    slider_mass: float = 0.5
    leg_mass: float = 0.3
    platform_mass: float = 0.3
    max_force: float = 40.0
    max_speed: float = 0.2
    gravity: float = 9.81
    reference_length: float | None = field(default=None)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        legs = _triple("leg_lengths", self.leg_lengths)
        for i, v in enumerate(legs):
            if v <= 0:
                raise ValueError(f"Design.leg_lengths[{i}] must be > 0, got {v!r}")
        spacings = _triple("spacings", self.spacings)
        for i, name in enumerate(("d_12", "d_23", "d_3G")):
            if spacings[i] < 0 or (i < 2 and spacings[i] == 0):
                bound = ">= 0" if i == 2 else "> 0"
                raise ValueError(
                    f"Design.spacings[{i}] ({name}) must be {bound}, got {spacings[i]!r}"
                )
        set_(self, "leg_lengths", legs)
        set_(self, "spacings", spacings)
        set_(self, "rail_origins", _triple("rail_origins", self.rail_origins))
        set_(self, "stroke", _positive("stroke", self.stroke))
        for name in ("slider_mass", "leg_mass", "platform_mass", "max_force", "max_speed"):
            set_(self, name, _positive(name, getattr(self, name)))
        set_(self, "gravity", _positive("gravity", self.gravity, allow_zero=True))
        if self.reference_length is not None:
            set_(self, "reference_length", _positive("reference_length", self.reference_length))
        # The platform must be able to close: some pose has all three travels in the stroke.
        self._check_closable()

    def _check_closable(self) -> None:
        """Raise if no pose of the platform lets all three legs close with travels in
        ``[0, stroke]`` (an empty workspace)."""
        witness = closing_pose(self)
        if witness is None:
            spread = _least_spread(
                self.leg_lengths, self.joint_offsets, self.rail_origins, self.stroke
            )[0]
            raise ValueError(
                "Design cannot close: with leg_lengths="
                f"{self.leg_lengths}, spacings={self.spacings}, stroke={self.stroke} and "
                f"rail_origins={self.rail_origins} no pose lets all three legs reach their "
                f"stroke segments (the three travels of a pose span at least about "
                f"{spread:.6g} m, more than the stroke)"
            )

    # ------------------------------------------------------------------ derived quantities
    @property
    def joint_offsets(self) -> Triple:
        """``(L_1G, L_2G, L_3G)``: distance from each platform joint ``C_i`` to ``G`` (m)."""
        d12, d23, d3g = self.spacings
        return (d12 + d23 + d3g, d23 + d3g, d3g)

    @property
    def L_iG(self) -> Triple:
        """Alias of :attr:`joint_offsets`, the paper's ``L_iG`` (m)."""
        return self.joint_offsets

    @property
    def characteristic_length(self) -> float:
        """Length that converts platform rotation to displacement (m); ``L_1G`` by default."""
        if self.reference_length is not None:
            return float(self.reference_length)
        return self.joint_offsets[0]

    @property
    def search_height(self) -> float:
        """``h = min_i (L_iG + L_i)``, the height of the workspace search rectangle (m)."""
        return min(k + l for k, l in zip(self.joint_offsets, self.leg_lengths, strict=True))

    @property
    def h(self) -> float:
        """Alias of :attr:`search_height` (m)."""
        return self.search_height

    @property
    def search_rectangle(self) -> tuple[float, float, float, float]:
        """``(x_min, x_max, y_min, y_max)`` of the paper's search rectangle above the rails (m)."""
        h = self.search_height
        return (
            min(self.rail_origins) - h,
            max(self.rail_origins) + self.stroke + h,
            0.0,
            h,
        )

    def travel_band(self, margin: float) -> tuple[float, float]:
        """The travels ``(lo, hi)`` (m) that keep ``margin`` (a fraction of the stroke, in
        ``[0, 0.5)``) free at both ends of the stroke; ``ValueError`` otherwise."""
        if not (_is_number(margin) and 0.0 <= margin < 0.5):
            raise ValueError(f"a travel margin must be in [0, 0.5), got {margin!r}")
        return margin * self.stroke, (1.0 - margin) * self.stroke

    @property
    def shortest_leg(self) -> float:
        """The smallest leg length (m)."""
        return min(self.leg_lengths)

    @property
    def platform_length(self) -> float:
        """Length of the platform from ``G`` to ``C_1`` (m)."""
        return self.joint_offsets[0]

    # ------------------------------------------------------------------ presets and helpers
    @classmethod
    def fig8(cls, stroke: float = 0.30, **overrides: Any) -> Design:
        """The paper's workspace-versus-stroke design (default design); ``stroke`` in m."""
        params: dict[str, Any] = dict(
            leg_lengths=(0.17, 0.18, 0.19), spacings=(0.10, 0.10, 0.10), stroke=stroke
        )
        params.update(overrides)
        return cls(**params)

    @classmethod
    def fig7(cls, **overrides: Any) -> Design:
        """The paper's workspace-map design: legs 2.5 m, spacings 0.5 m, stroke 1.0 m."""
        params: dict[str, Any] = dict(
            leg_lengths=(2.5, 2.5, 2.5), spacings=(0.5, 0.5, 0.5), stroke=1.0
        )
        params.update(overrides)
        return cls(**params)

    def with_(self, **changes: Any) -> Design:
        """A copy with some fields changed (validated like a new design)."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dictionary of the fields (JSON-serialisable)."""
        out: dict[str, Any] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            out[f.name] = list(v) if isinstance(v, tuple) else v
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Design:
        """Inverse of :meth:`to_dict`; unknown keys raise ``ValueError``."""
        known = {f.name for f in fields(cls)}
        unknown = set(data) - known
        if unknown:
            raise ValueError(f"unknown Design fields: {sorted(unknown)}")
        return cls(**data)


# ------------------------------------------------------------------ closability
# Leg ``i`` closes with travel ``rho_i = C_ix - a_i - sigma_i w_i`` where
# ``w_i = sqrt(L_i^2 - C_iy^2)`` (it needs ``|C_iy| <= L_i``), and ``C_ix = x + k_i cos theta``.
# For a fixed ``(y, theta, sigma)`` the three conditions ``0 <= rho_i <= stroke`` are intervals
# of ``x`` of width ``stroke`` starting at ``v_i = a_i + sigma_i w_i - k_i cos theta``; they meet
# iff ``max_i v_i - min_i v_i <= stroke``.  So the design can close iff the least spread of the
# ``v_i`` over ``(y, theta, sigma)`` is at most the stroke.  The spread is continuous on the
# (compact) set of ``(y, theta)`` where all three legs reach the rail line, so a grid over
# ``theta in [0, pi]`` (the mirror ``(-y, -theta)`` gives the same spreads) and the admissible
# ``y`` interval, refined around its best local minima, finds the minimum.  (Checked against
# a 2881 x 801 grid on random designs: within 5e-5 m, i.e. only a design whose least stroke
# is that close to its stroke can be misjudged.)  The previous check only looked at the
# platform lying on the rail line and took each joint's reach as the whole hull
# ``[a_i - L_i, a_i + stroke + L_i]``, which accepted designs that cannot close.
_MODES = np.array([[s1, s2, s3] for s1 in (1.0, -1.0) for s2 in (1.0, -1.0) for s3 in (1.0, -1.0)])


@njit(cache=True)
def _reach(
    L: np.ndarray, k: np.ndarray, a: np.ndarray, s: float, c: float, u: float
) -> tuple[bool, float, tuple[float, float, float], tuple[float, float, float]]:
    """At ``sin theta = s``, ``cos theta = c`` and the parameter ``u in [0, 1]`` of the interval
    of ``y`` where all three legs reach the rail line: whether that interval is non-empty,
    ``y`` (m), and per leg ``a_i - k_i cos theta`` and ``w_i`` (m), so that ``v_i = a_i - k_i
    cos theta + sigma_i w_i`` (:func:`_mode_spread`).  ``y`` runs over the interval as
    ``(1 - cos(pi u)) / 2``, so that the ``w_i``, which behave like the square root of the
    distance to the interval's ends, vary smoothly with ``u`` there.  Compiled, as every
    search below (a design drawn per episode, ``Planar3PReal-v0``'s, is checked at every
    reset)."""
    lo = max(-L[0] - k[0] * s, max(-L[1] - k[1] * s, -L[2] - k[2] * s))
    hi = min(L[0] - k[0] * s, min(L[1] - k[1] * s, L[2] - k[2] * s))
    if not hi >= lo:
        return False, math.nan, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    y = lo + 0.5 * (1.0 - math.cos(math.pi * min(max(u, 0.0), 1.0))) * (hi - lo)
    w0 = math.sqrt(max(L[0] * L[0] - (y + k[0] * s) ** 2, 0.0))
    w1 = math.sqrt(max(L[1] * L[1] - (y + k[1] * s) ** 2, 0.0))
    w2 = math.sqrt(max(L[2] * L[2] - (y + k[2] * s) ** 2, 0.0))
    return True, y, (a[0] - k[0] * c, a[1] - k[1] * c, a[2] - k[2] * c), (w0, w1, w2)


@njit(cache=True)
def _mode_spread(
    base: tuple[float, float, float], w: tuple[float, float, float], im: int
) -> tuple[float, float, float]:
    """``max_i v_i - min_i v_i``, ``min_i v_i`` and ``max_i v_i`` (m) of working mode
    ``_MODES[im]`` from :func:`_reach`'s ``a_i - k_i cos theta`` and ``w_i``."""
    v0 = base[0] + _MODES[im, 0] * w[0]
    v1 = base[1] + _MODES[im, 1] * w[1]
    v2 = base[2] + _MODES[im, 2] * w[2]
    v_min, v_max = min(v0, min(v1, v2)), max(v0, max(v1, v2))
    return v_max - v_min, v_min, v_max


@njit(cache=True)
def _spread(L: np.ndarray, k: np.ndarray, a: np.ndarray, theta: float, u: float, im: int) -> float:
    """The spread (m) of working mode ``_MODES[im]`` at ``(theta, u)``; inf where the legs
    cannot all reach the rail line."""
    ok, _, base, w = _reach(L, k, a, math.sin(theta), math.cos(theta), u)
    return _mode_spread(base, w, im)[0] if ok else math.inf


@njit(cache=True)
def _grid_spreads(L: np.ndarray, k: np.ndarray, a: np.ndarray, nt: int, nu: int) -> np.ndarray:
    """The spread of every working mode on the grid ``theta = linspace(0, pi, nt)``,
    ``u = linspace(0, 1, nu)``: ``(nt, nu, 8)`` (m; inf where the legs cannot all reach)."""
    out = np.full((nt, nu, 8), math.inf)
    for jt in range(nt):
        th = math.pi * jt / (nt - 1)
        s, c = math.sin(th), math.cos(th)
        for ju in range(nu):
            ok, _, base, w = _reach(L, k, a, s, c, ju / (nu - 1))
            if ok:
                for im in range(8):
                    out[jt, ju, im] = _mode_spread(base, w, im)[0]
    return out


@njit(cache=True)
def _first_within(
    L: np.ndarray, k: np.ndarray, a: np.ndarray, stroke: float, nt: int, nu: int
) -> tuple[float, float, float, int]:
    """The first point ``(spread, theta, u, im)`` of :func:`_grid_spreads`'s grid whose spread
    is within ``stroke`` (it stops there), else the grid's least spread."""
    best = (math.inf, 0.0, 0.0, 0)
    for jt in range(nt):
        th = math.pi * jt / (nt - 1)
        s, c = math.sin(th), math.cos(th)
        for ju in range(nu):
            u = ju / (nu - 1)
            ok, _, base, w = _reach(L, k, a, s, c, u)
            if not ok:
                continue
            for im in range(8):
                sp = _mode_spread(base, w, im)[0]
                if sp < best[0]:
                    best = (sp, th, u, im)
                if sp <= stroke:
                    return best
    return best


@njit(cache=True)
def _refine(
    L: np.ndarray, k: np.ndarray, a: np.ndarray, t0: float, u0: float, dt: float, du: float,
    im: int, spread: float,
) -> tuple[float, float, float]:  # fmt: skip
    """Pattern search from ``(t0, u0)`` in working mode ``im``: a 9 x 9 local grid of steps
    ``dt, du``, moved to its best point while that improves, else shrunk fourfold, until
    ``dt < 1e-10`` or 40 rounds; ``(spread, theta, u)``."""
    for _ in range(40):
        bt, bu, bs = t0, u0, math.inf
        for it in range(9):
            t = t0 + dt * (it / 4.0 - 1.0)
            for iu in range(9):
                u = min(max(u0 + du * (iu / 4.0 - 1.0), 0.0), 1.0)
                sp = _spread(L, k, a, t, u, im)
                if sp < bs:
                    bt, bu, bs = t, u, sp
        if bs < spread:
            t0, u0, spread = bt, bu, bs
        else:
            dt, du = dt / 4.0, du / 4.0
        if dt < 1e-10:
            break
    return spread, t0, u0


@lru_cache(maxsize=256)
def _least_spread(
    legs: Triple, offsets: Triple, origins: Triple, stroke: float
) -> tuple[float, tuple[float, float, float] | None, tuple[int, int, int] | None]:
    """Least spread (m) and, if it is within the stroke, a pose and working mode that close.

    A grid point within the stroke is returned at once (its spread is then only an upper bound
    of the least spread): a grid of 13 x 5 points, then one of 91 x 25 (a design drawn per
    episode, ``Planar3PReal-v0``'s, nearly always closes at the first points).  Otherwise a
    fine grid (0.25 deg x 1/160 of the height interval) is searched and its best local minima
    per working mode are refined (:func:`_refine`, a pattern search in ``(theta, u)``)."""
    L, k, a = (np.asarray(v, dtype=np.float64) for v in (legs, offsets, origins))
    best = (math.inf, 0.0, 0.0, 0)
    for nt, nu in ((13, 5), (91, 25)):
        best = min(best, _first_within(L, k, a, stroke, nt, nu))
        if best[0] <= stroke:
            break
    else:
        nt, nu = 721, 161
        grid = _grid_spreads(L, k, a, nt, nu)
        best = min(best, _grid_best(grid, nt, nu))
        # start from the best local minima of the grid (the landscape has several basins)
        pad = np.pad(grid, ((1, 1), (1, 1), (0, 0)), constant_values=np.inf)
        is_min = np.ones(grid.shape, dtype=bool)
        for di in (0, 1, 2):
            for dj in (0, 1, 2):
                if (di, dj) != (1, 1):
                    is_min &= grid <= pad[di : di + nt, dj : dj + nu]
        flat = np.where(is_min, grid, np.inf).reshape(-1, 8)
        for im in range(8):
            for j in np.argsort(flat[:, im])[:4]:
                if not np.isfinite(flat[j, im]) or best[0] <= stroke:
                    break
                t0, u0 = math.pi * (j // nu) / (nt - 1), (j % nu) / (nu - 1)
                sp, t0, u0 = _refine(
                    L, k, a, t0, u0, 2.0 * math.pi / (nt - 1), 2.0 / (nu - 1), im,
                    float(flat[j, im]),
                )  # fmt: skip
                best = min(best, (sp, t0, u0, im))
    spread_min, t0, u0, im = best
    if not spread_min <= stroke:
        return spread_min, None, None
    mode = tuple(int(m) for m in _MODES[im])
    # A pose in the middle of the common x interval.  At u = 0 or 1 a leg is exactly vertical
    # and rounding may leave it a hair short: step inside the height interval if needed.
    for nudge in (0.0, 1e-9, 1e-6, 1e-4, 1e-2):
        u1 = min(max(u0, nudge), 1.0 - nudge)
        _, y, base, w = _reach(L, k, a, math.sin(t0), math.cos(t0), u1)
        _, v_min, v_max = _mode_spread(base, w, im)
        x = 0.5 * (v_max + v_min + stroke)
        cy = y + k * math.sin(t0)
        disc = L**2 - cy**2
        if (disc >= 0.0).all():
            rho = ((x + k * math.cos(t0)) - a) - np.array(mode) * np.sqrt(disc)
            if ((rho >= 0.0) & (rho <= stroke)).all():
                break
    return spread_min, (x, y, t0), mode  # type: ignore[return-value]


def _grid_best(grid: np.ndarray, nt: int, nu: int) -> tuple[float, float, float, int]:
    """The least spread of a grid of :func:`_grid_spreads` as ``(spread, theta, u, im)``."""
    flat = grid.reshape(-1, 8)
    j = int(np.argmin(flat.min(axis=1)))
    im = int(np.argmin(flat[j]))
    return float(flat[j, im]), math.pi * (j // nu) / (nt - 1), (j % nu) / (nu - 1), im


def closing_pose(
    design: Design,
) -> tuple[tuple[float, float, float], tuple[int, int, int]] | None:
    """A pose ``(x, y, theta)`` (m, m, rad) and working mode with all three travels inside the
    stroke (a witness that the design can close), or ``None`` when there is none; every valid
    :class:`Design` has one."""
    _, pose, mode = _least_spread(
        design.leg_lengths, design.joint_offsets, design.rail_origins, design.stroke
    )
    if pose is None or mode is None:
        return None
    return pose, mode
