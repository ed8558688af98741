"""The physical imperfections of a built machine that :class:`~planar3p_gym.machine.design.Design`
does not describe: joint friction, servo lag, a tilted base, inertia errors.

A :class:`MachineDynamics` is immutable and validated at construction; the default is the ideal
machine (no friction, instantaneous servos, level base, nominal inertias), with which
:class:`~planar3p_gym.sim.physics.Planar3PSim` builds exactly the model it builds without one.
How each quantity enters the pymunk model is said in :class:`MachineDynamics`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numba import njit

from planar3p_gym import checks
from planar3p_gym.machine.design import Design

__all__ = [
    "IDEAL",
    "MachineDynamics",
    "servo_lag",
    "smallest_leg_inertia",
    "viscous_step_limits",
]


@njit(cache=True)
def servo_lag(
    lagged: np.ndarray, f: float, v0: float, v1: float, v2: float
) -> tuple[float, float, float]:
    """The servo setpoint velocities (m/s) of one control step of a first-order lag: each of
    ``lagged`` (3, the last step's, updated here) moved the share ``f``
    (:meth:`MachineDynamics.lag_factor`) of the way to the commands ``v0, v1, v2`` (m/s)."""
    lagged[0] = lagged[0] + f * (v0 - lagged[0])
    lagged[1] = lagged[1] + f * (v1 - lagged[1])
    lagged[2] = lagged[2] + f * (v2 - lagged[2])
    return lagged[0], lagged[1], lagged[2]


#: Largest tilt of the base accepted (rad): beyond a quarter turn "down" is no longer ``-y``.
MAX_TILT = 0.5 * math.pi


@dataclass(frozen=True)
class MachineDynamics:
    """Friction, servo lag, base tilt and inertia errors of one machine (SI units).

    The servo force limit and the masses are the design's own (``max_force``, ``*_mass``),
    randomised through the design (:mod:`planar3p_gym.sim.randomization`).

    Attributes:
        inertia_scale: factor on the moments of inertia of the legs and the platform about
            their centres of mass (1 for uniform rods).
        slider_coulomb: Coulomb (dry) friction force of each slider on its rail (N): a
            constraint holding the slider's rail velocity at zero with at most this force
            (pymunk's idiom for friction: a zero-rate motor of bounded force).
        slider_viscous: viscous friction coefficient of each slider on its rail (N s/m): a
            force ``-c v`` along the rail, explicit over each physics step ``h`` (the
            simulation refuses ``c h`` at or above the slider's mass, where it would not be
            stable).
        joint_coulomb: Coulomb friction torque of every revolute joint ``B_i`` and ``C_i``
            (N m): a :class:`pymunk.SimpleMotor` of rate 0 whose torque is bounded by it.
        joint_viscous: viscous friction coefficient of every revolute joint (N m s/rad):
            torques ``-c (w_a - w_b)`` and its opposite on the joint's two bodies, explicit like
            the sliders' (``c h`` below a leg's moment of inertia).
        servo_lag: time constant ``tau`` of a first-order lag between the commanded slider
            velocity and the servo's setpoint velocity (s): per control step ``dt`` the setpoint
            moves by ``1 - exp(-dt / tau)`` of its distance to the command (the exact
            discretisation of ``tau v' = u - v`` for a command held over the step); 0 is an
            instantaneous servo.
        gravity_tilt: angle of the base from level (rad): gravity acts along
            ``(sin tilt, -cos tilt)`` with the design's magnitude.
    """

    inertia_scale: float = 1.0
    slider_coulomb: float = 0.0
    slider_viscous: float = 0.0
    joint_coulomb: float = 0.0
    joint_viscous: float = 0.0
    servo_lag: float = 0.0
    gravity_tilt: float = 0.0

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(
            self,
            "inertia_scale",
            checks.number(
                self.inertia_scale, "MachineDynamics.inertia_scale", low=0.0, high=1e3,
                low_open=True,
            ),
        )  # fmt: skip
        units = {
            "slider_coulomb": "N",
            "slider_viscous": "N s/m",
            "joint_coulomb": "N m",
            "joint_viscous": "N m s/rad",
            "servo_lag": "s",
        }
        for name, unit in units.items():
            value = checks.number(
                getattr(self, name), f"MachineDynamics.{name}", low=0.0, high=1e6, unit=unit
            )
            set_(self, name, value)
        set_(
            self,
            "gravity_tilt",
            checks.number(
                self.gravity_tilt, "MachineDynamics.gravity_tilt", low=-MAX_TILT, high=MAX_TILT,
                unit="rad",
            ),
        )  # fmt: skip

    @property
    def is_ideal(self) -> bool:
        """True for the ideal machine (every field at its default)."""
        return self == IDEAL

    def gravity_vector(self, magnitude: float) -> tuple[float, float]:
        """Gravity of ``magnitude`` (m/s^2) on the tilted base, ``(gx, gy)`` (m/s^2)."""
        return (magnitude * math.sin(self.gravity_tilt), -magnitude * math.cos(self.gravity_tilt))

    def lag_factor(self, dt: float) -> float:
        """Share of the distance to the command the servo setpoint moves per control step
        ``dt`` (s): ``1 - exp(-dt / tau)``, 1 without lag."""
        if self.servo_lag == 0.0:
            return 1.0
        return -math.expm1(-dt / self.servo_lag)

    def to_dict(self) -> dict[str, float]:
        """Plain-Python dictionary of the fields (``asdict``'s, without its deep copy of the
        floats: a reset of a machine drawn per episode asks for it twice)."""
        return {name: getattr(self, name) for name in _FIELDS}

    @classmethod
    def from_value(cls, value: Any, name: str = "dynamics") -> MachineDynamics:
        """A :class:`MachineDynamics` from ``None`` (ideal), an instance or a dict of its
        fields; ``ValueError`` naming ``name`` otherwise."""
        return checks.config_from(value, cls, name)


def smallest_leg_inertia(design: Design, dyn: MachineDynamics) -> float:
    """The moment of inertia (kg m^2) of the shortest leg of ``design`` about its centre of
    mass: a uniform rod, times ``dyn.inertia_scale``."""
    return dyn.inertia_scale * design.leg_mass * min(design.leg_lengths) ** 2 / 12


def viscous_step_limits(design: Design, dyn: MachineDynamics) -> tuple[float, float]:
    """The physics steps (s) at and above which the explicit viscous forces of ``dyn`` on
    ``design`` are no longer integrated stably: the sliders' (the slider mass over
    ``slider_viscous``) and the revolute joints' (:func:`smallest_leg_inertia` over
    ``joint_viscous``); ``inf`` without that friction.  An explicit viscous force is stable for
    ``c h / m < 2``; half that is asked for."""
    slider = design.slider_mass / dyn.slider_viscous if dyn.slider_viscous > 0.0 else math.inf
    joint = (
        smallest_leg_inertia(design, dyn) / dyn.joint_viscous
        if dyn.joint_viscous > 0.0
        else math.inf
    )
    return slider, joint


#: The ideal machine.
IDEAL = MachineDynamics()
#: The field names of :class:`MachineDynamics`, in order.
_FIELDS = tuple(f.name for f in fields(MachineDynamics))
