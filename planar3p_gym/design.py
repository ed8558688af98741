"""The machine's parameters: geometry, masses, actuator limits, gravity.

A :class:`Design` is immutable and validated at construction; every module of the package
(kinematics, workspace, physics, environment) takes one.  All quantities are SI (m, kg, s, N).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Any

__all__ = ["Design"]

Triple = tuple[float, float, float]


def _triple(name: str, value: Any) -> Triple:
    try:
        items = tuple(float(v) for v in value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"Design.{name} must be three numbers, got {value!r}") from exc
    if len(items) != 3:
        raise ValueError(f"Design.{name} must have exactly 3 entries, got {len(items)}: {value!r}")
    for i, v in enumerate(items):
        if not math.isfinite(v):
            raise ValueError(f"Design.{name}[{i}] must be finite, got {v!r}")
    return items  # type: ignore[return-value]


def _positive(name: str, value: Any, allow_zero: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"Design.{name} must be a number, got {value!r}") from exc
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"Design.{name} must be finite and {bound}, got {value!r}")
    return v


@dataclass(frozen=True)
class Design:
    """Geometric and physical parameters of a 3-PRR manipulator with a collinear platform.

    The platform carries, in order, the joints ``C_1, C_2, C_3`` and the gripper point ``G``
    (see ``MECHANISM.md``).  Rails lie on ``y = 0``; slider ``i`` travels ``rho_i in [0, stroke]``
    from its rail origin ``(a_i, 0)``.

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
    leg_mass: float = 0.1
    platform_mass: float = 0.3
    max_force: float = 40.0
    max_speed: float = 0.25
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
        # A leg can close only if C_i can reach its rail line; with the platform lying on
        # the rail line every leg must at least reach it, which always holds.  A platform
        # "cannot close" when no single pose lets all three legs meet a point of their
        # rails: the vertical reach |C_iy| <= L_i must be satisfiable simultaneously, and
        # the horizontal positions must fit within the rails' reach.
        self._check_closable()

    def _check_closable(self) -> None:
        """Raise if no pose of the platform lets the three legs reach their stroke segments."""
        # With the platform horizontal on the rail line (y = 0, theta = 0) each leg closes
        # with C_iy = 0 if some travel satisfies |C_ix - a_i - rho_i| = L_i.  Place G so
        # that leg 1 closes at mid-stroke in working mode +1 and test the others with any
        # mode; if that fails, search a coarse set of platform positions.
        k = self.joint_offsets
        lo = [a for a in self.rail_origins]
        hi = [a + self.stroke for a in self.rail_origins]
        # The x of C_i relative to G is +k_i (theta = 0) or -k_i (theta = pi).  Leg i
        # reaches C_ix from its stroke segment iff C_ix is within L_i of [lo_i, hi_i]
        # (any y = 0 point at that distance).  Find an x_G where all three intervals meet.
        for sign in (1.0, -1.0):
            lower = max(lo[i] - self.leg_lengths[i] - sign * k[i] for i in range(3))
            upper = min(hi[i] + self.leg_lengths[i] - sign * k[i] for i in range(3))
            if lower <= upper:
                return
        raise ValueError(
            "Design cannot close: with leg_lengths="
            f"{self.leg_lengths}, spacings={self.spacings}, stroke={self.stroke} and "
            f"rail_origins={self.rail_origins} no platform position lets all three legs "
            "reach their stroke segments"
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
