"""Domain randomisation: the machine as built, drawn per episode around the nominal design.

A :class:`DynamicsRandomization` holds the range of every randomised quantity; every range is
zero by default, and a zero range draws no random number and leaves its quantity nominal, so
the default (all zero) is the nominal machine exactly, and an environment with it replays the
nominal environment's episodes bit for bit.  :meth:`DynamicsRandomization.sample` draws one
machine from a generator (the environment's ``np_random``): the true
:class:`~planar3p_gym.machine.design.Design` (geometry, masses, servo force limit), which the
simulation and its exact loop projection use, and the
:class:`~planar3p_gym.sim.dynamics.MachineDynamics` the design lacks (friction, servo lag, base
tilt, inertia errors).  Draws are uniform and independent, in the order of the fields.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np

from planar3p_gym import checks
from planar3p_gym.machine.design import Design
from planar3p_gym.sim.dynamics import MAX_TILT, MachineDynamics, viscous_step_limits

__all__ = ["REALISTIC_RANDOMIZATION", "DynamicsRandomization", "SampledMachine"]


@dataclass(frozen=True)
class SampledMachine:
    """One machine drawn by :meth:`DynamicsRandomization.sample`.

    Attributes:
        design: the true design (geometry, masses, servo force limit).
        dynamics: its friction, servo lag, base tilt and inertia scale.
    """

    design: Design
    dynamics: MachineDynamics

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python values (JSON-serialisable)."""
        return {"design": self.design.to_dict(), "dynamics": self.dynamics.to_dict()}


@dataclass(frozen=True)
class DynamicsRandomization:
    """Ranges of the per-episode randomisation of the machine (SI units; 0 = not randomised).

    Relative ranges ``r`` multiply the nominal value by a factor drawn from ``[1 - r, 1 + r]``;
    absolute ranges ``e`` add an error drawn from ``[-e, e]``; the friction coefficients and the
    servo lag are drawn from ``[0, max]``.  Viscous friction is integrated explicitly, so the
    physics step must stay below :meth:`longest_step` for every machine drawn; an environment
    refuses a control rate that would not (:meth:`check_step`).

    Attributes:
        mass: relative range of the slider, leg and platform masses (each drawn on its own;
            the design has one mass per kind of body).
        inertia: relative range of the moments of inertia of the legs and the platform (one
            factor for all, :attr:`MachineDynamics.inertia_scale`).
        leg_length: absolute range of each leg's length ``L_i`` (m), manufacturing error.
        joint_position: absolute range of each spacing ``d_12, d_23, d_3G`` of the joints on the
            platform (m); ``d_3G`` is kept ``>= 0``.
        rail_offset: absolute range of each rail origin ``a_i`` (m).
        max_force: relative range of the servos' force limit (one factor, the design's
            ``max_force``).
        slider_coulomb: largest Coulomb friction force of the sliders (N).
        slider_viscous: largest viscous friction coefficient of the sliders (N s/m).
        joint_coulomb: largest Coulomb friction torque of the revolute joints (N m).
        joint_viscous: largest viscous friction coefficient of the revolute joints (N m s/rad).
        servo_lag: largest servo time constant (s).
        gravity_tilt: absolute range of the base's tilt (rad).
    """

    mass: float = 0.0
    inertia: float = 0.0
    leg_length: float = 0.0
    joint_position: float = 0.0
    rail_offset: float = 0.0
    max_force: float = 0.0
    slider_coulomb: float = 0.0
    slider_viscous: float = 0.0
    joint_coulomb: float = 0.0
    joint_viscous: float = 0.0
    servo_lag: float = 0.0
    gravity_tilt: float = 0.0

    def __post_init__(self) -> None:
        relative = ("mass", "inertia", "max_force")
        lengths = ("leg_length", "joint_position", "rail_offset")
        for f in fields(self):
            name = f"DynamicsRandomization.{f.name}"
            if f.name in relative:
                value = checks.number(getattr(self, f.name), name, low=0.0, high=0.9)
            elif f.name in lengths:
                value = checks.number(getattr(self, f.name), name, low=0.0, high=0.1, unit="m")
            elif f.name == "gravity_tilt":
                value = checks.number(
                    getattr(self, f.name), name, low=0.0, high=MAX_TILT, unit="rad"
                )
            else:
                value = checks.number(getattr(self, f.name), name, low=0.0, high=1e6)
            object.__setattr__(self, f.name, value)

    @property
    def is_zero(self) -> bool:
        """True when nothing is randomised (the nominal machine)."""
        return all(v == 0.0 for v in asdict(self).values())

    def to_dict(self) -> dict[str, float]:
        """Plain-Python dictionary of the fields."""
        return asdict(self)

    def longest_step(self, nominal: Design) -> float:
        """The physics step (s) at and above which some machine drawn around ``nominal`` has
        viscous friction its step cannot integrate
        (:func:`~planar3p_gym.sim.dynamics.viscous_step_limits` of the worst draw: the largest
        friction coefficients on the lightest sliders and the shortest, lightest legs of the
        smallest inertia); ``inf`` without viscous friction."""
        if not (self.slider_viscous > 0.0 or self.joint_viscous > 0.0):
            return math.inf
        light = 1.0 - self.mass
        worst = nominal.with_(
            slider_mass=nominal.slider_mass * light,
            leg_mass=nominal.leg_mass * light,
            leg_lengths=tuple(v - self.leg_length for v in nominal.leg_lengths),
        )
        dyn = MachineDynamics(
            inertia_scale=1.0 - self.inertia,
            slider_viscous=self.slider_viscous,
            joint_viscous=self.joint_viscous,
        )
        return min(viscous_step_limits(worst, dyn))

    def check_step(self, nominal: Design, control_frequency: float, substeps: int) -> None:
        """``ValueError`` naming the lowest control rate accepted unless every machine drawn
        around ``nominal`` can be integrated at ``control_frequency`` (Hz) with ``substeps``
        physics steps per control step (:meth:`longest_step`)."""
        limit = self.longest_step(nominal)
        h = 1.0 / (control_frequency * substeps)
        if h >= limit:
            raise ValueError(
                f"control_frequency {control_frequency:g} Hz with {substeps} physics step(s) "
                f"per control step gives a physics step of {h:.4g} s, too long for the viscous "
                f"friction randomization draws (every step must stay below {limit:.4g} s): "
                f"control_frequency must exceed {1.0 / (limit * substeps):.4g} Hz at "
                f"substeps={substeps}, or substeps must be at least "
                f"{math.floor(1.0 / (limit * control_frequency)) + 1}"
            )

    def sample(self, nominal: Design, rng: np.random.Generator) -> SampledMachine:
        """One machine around ``nominal``, drawn from ``rng`` (no draw for a zero range).

        ``ValueError`` if the drawn geometry cannot close (ranges far beyond manufacturing
        errors); the ranges the package uses leave every design closable."""

        def factor(r: float, n: int = 1) -> np.ndarray:
            return 1.0 + rng.uniform(-r, r, size=n) if r > 0.0 else np.ones(n)

        def error(e: float, n: int = 3) -> np.ndarray:
            return rng.uniform(-e, e, size=n) if e > 0.0 else np.zeros(n)

        def upto(m: float) -> float:
            return float(rng.uniform(0.0, m)) if m > 0.0 else 0.0

        masses = factor(self.mass, 3)
        inertia = float(factor(self.inertia)[0])
        legs = np.asarray(nominal.leg_lengths) + error(self.leg_length)
        spacings = np.asarray(nominal.spacings) + error(self.joint_position)
        spacings[2] = max(spacings[2], 0.0)
        origins = np.asarray(nominal.rail_origins) + error(self.rail_offset)
        force = float(factor(self.max_force)[0])
        dynamics = MachineDynamics(
            inertia_scale=inertia,
            slider_coulomb=upto(self.slider_coulomb),
            slider_viscous=upto(self.slider_viscous),
            joint_coulomb=upto(self.joint_coulomb),
            joint_viscous=upto(self.joint_viscous),
            servo_lag=upto(self.servo_lag),
            gravity_tilt=float(error(self.gravity_tilt, 1)[0]),
        )
        if not (
            self.mass or self.leg_length or self.joint_position or self.rail_offset
            or self.max_force
        ):  # fmt: skip
            return SampledMachine(nominal, dynamics)
        design = nominal.with_(
            leg_lengths=tuple(legs.tolist()),
            spacings=tuple(spacings.tolist()),
            rail_origins=tuple(origins.tolist()),
            slider_mass=nominal.slider_mass * float(masses[0]),
            leg_mass=nominal.leg_mass * float(masses[1]),
            platform_mass=nominal.platform_mass * float(masses[2]),
            max_force=nominal.max_force * force,
            # The reference length stays the nominal one (it scales the pose distance).
            reference_length=nominal.characteristic_length,
        )
        return SampledMachine(design, dynamics)


#: The ranges of ``Planar3PReal-v0``: manufacturing errors up to a millimetre, masses and
#: inertias within 10 %, servo force within 10 %, friction and servo lag of the size of a small
#: DC-motor-driven prototype, a base tilted by up to one degree.
REALISTIC_RANDOMIZATION = DynamicsRandomization(
    mass=0.1,
    inertia=0.1,
    leg_length=1e-3,
    joint_position=1e-3,
    rail_offset=1e-3,
    max_force=0.1,
    slider_coulomb=2.0,
    slider_viscous=5.0,
    joint_coulomb=0.01,
    joint_viscous=0.002,
    servo_lag=0.04,
    gravity_tilt=math.radians(1.0),
)
