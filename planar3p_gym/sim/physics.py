"""pymunk rigid-body model of the closed chain (no Gymnasium here).

Three sliders on grooves (the stroke's hard stops), three legs and the platform joined by
pivots, gravity along ``-y``, no collision shapes; each slider driven by a force-limited
velocity servo.  The solver settings, the projection's details and the snapshots are explained
in docs/physics.md ("How the simulation modules work").

* :class:`Planar3PSim`: the model, built from a pose and working mode by the exact inverse
  kinematics; :meth:`Planar3PSim.reset` moves it to a new episode bit for bit as a new build;
  ``projection=True`` (every id) projects each control step onto the constraint manifold
  (:mod:`planar3p_gym.sim.projection`);
* ``dynamics=`` (:class:`~planar3p_gym.sim.dynamics.MachineDynamics`): the machine as built
  (friction, servo lag, tilted gravity, inertia); the default adds nothing;
* :meth:`Planar3PSim.get_state` / :meth:`Planar3PSim.set_state`: snapshots, restored bit for
  bit by rebuilding and replaying the commands.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import numpy as np
import pymunk
from numba import njit
from numpy.typing import ArrayLike

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.design import Design
from planar3p_gym.sim import chipmunk, recovery
from planar3p_gym.sim.dynamics import (
    IDEAL,
    MachineDynamics,
    servo_lag,
    smallest_leg_inertia,
    viscous_step_limits,
)
from planar3p_gym.sim.projection import LoopProjector

__all__ = [
    "BATCH_STEP",
    "DEFAULT_ITERATIONS",
    "DEFAULT_SUBSTEPS",
    "PROJECTED_ITERATIONS",
    "PROJECTED_SUBSTEPS",
    "BatchLink",
    "CompiledStep",
    "FastPath",
    "Planar3PSim",
    "SimSnapshot",
    "SimState",
    "state_finite",
]

try:  # Direct Chipmunk calls skip pymunk's per-call Python bookkeeping (the hot loop's cost).
    from pymunk._chipmunk_cffi import ffi as _ffi
    from pymunk._chipmunk_cffi import lib as _cp

    _FAST = chipmunk.AVAILABLE and all(
        hasattr(_cp, name)
        for name in (
            "cpSpaceStep",
            "cpSpaceEachBody",
            "cpConstraintGetImpulse",
            "cpBodySetVelocity",
            "pmSpaceBodyGetIteratorFuncBatched",
            "pmIntArrayNew",
        )
    )
    #: Whether :meth:`Planar3PSim.close` can clear the Chipmunk user data (pymunk's bindings).
    _RELEASE = hasattr(_cp, "cpBodySetUserData") and hasattr(_cp, "cpConstraintSetUserData")
    #: Whether :meth:`Planar3PSim.reset` can move the bodies through Chipmunk's C API (else it
    #: rebuilds the model).
    _MOVE = _FAST and all(
        hasattr(_cp, name)
        for name in (
            "cpBodySetPosition",
            "cpBodyGetPosition",
            "cpBodySetAngle",
            "cpBodySetAngularVelocity",
            "cpBodySetForce",
            "cpBodySetTorque",
            "cpBodyWorldToLocal",
            "cpBodyLocalToWorld",
            "cpPivotJointSetAnchorA",
            "cpPivotJointSetAnchorB",
            "cpPinJointSetAnchorA",
            "cpPinJointSetDist",
            "cpBodySetVelocity",
            "cpConstraintGetMaxForce",
            "cpConstraintSetMaxForce",
            "cpSpaceSetIterations",
            # a new machine's numbers (Planar3PSim._set_numbers)
            "cpSpaceSetGravity",
            "cpBodySetMass",
            "cpBodySetMoment",
            "cpGrooveJointSetGrooveA",
            "cpGrooveJointSetGrooveB",
            "cpSlideJointSetAnchorA",
            "cpSlideJointSetMax",
        )
    )
except ImportError:  # pragma: no cover - other pymunk builds
    _FAST = _RELEASE = _MOVE = False

#: Whether this pymunk build gives the Chipmunk C API the compiled and batched steps call.
BATCH_STEP: bool = bool(_FAST)

#: Numbers per body in a readout: ``x, y, angle, vx, vy, angular velocity`` (pymunk's batch
#: layout for these fields).
_BODY_FIELDS = 6

#: Physics substeps per control step used by the environment by default (2.5 ms at 50 Hz).
DEFAULT_SUBSTEPS = 8
#: Constraint-solver iterations per substep used by default.
DEFAULT_ITERATIONS = 18
#: Physics substeps per control step with ``projection=True`` (``Planar3P-v0``).
PROJECTED_SUBSTEPS = 1
#: Constraint-solver iterations per substep with ``projection=True``: 3 is the fewest with which
#: every physics and projection test passes (with 1 the servos miss the static holding forces,
#: with 2 the random soak fails); 4 keeps a margin.
PROJECTED_ITERATIONS = 4
#: Solver iterations of the warm-start step at construction.
WARM_START_ITERATIONS = 500
#: pymunk's ``error_bias`` of the rails, the servos and the pivots ``B_i``: fraction of a joint
#: error left after one second.
DEFAULT_ERROR_BIAS = 1e-15
#: ``error_bias`` of the platform's pivots ``C_i``.
DEFAULT_PLATFORM_ERROR_BIAS = 1e-25
#: Length of the pin joint by which a drive body pulls its slider along the rail (m).
SERVO_ARM = 1.0
#: Servo arm with ``projection=True`` (m).  A slider's velocity off its rail (what the few
#: solver iterations leave) tilts the arm by ``y / arm`` and leaks into the servo's direction:
#: a long arm keeps servo-held sliders still to well below a nanometre per step.
PROJECTED_SERVO_ARM = 1000.0
#: With ``projection=True`` the grooves run this far past the stroke (m): the end stops are
#: separate limits (see :meth:`Planar3PSim._build`).
PROJECTED_RAIL_OVERRUN = 1.0
#: Largest speed at which a servo removes a following error (m/s).
SERVO_CORRECTION_SPEED = 0.02
#: Largest following error a servo keeps (m); beyond it the setpoint is pulled along.
FOLLOWING_ERROR_LIMIT = 0.001


@njit(cache=True)
def state_finite(
    r1: float, r2: float, r3: float, d1: float, d2: float, d3: float, x: float, y: float,
    th: float, vx: float, vy: float, w: float, a1: float, a2: float, a3: float, closure: float,
) -> bool:  # fmt: skip
    """Whether every number of a state (:class:`SimState`'s travels, rates, pose, twist, leg
    angles and closure error, in that order) is finite: the one test, for a state and for a
    batch of them."""
    # A NaN or inf anywhere makes the sum non-finite (inf - inf is NaN).
    return math.isfinite(
        r1 + r2 + r3 + d1 + d2 + d3 + x + y + th + vx + vy + w + a1 + a2 + a3 + closure
    )


class SimState(NamedTuple):
    """A readout of the full simulated state (SI units).

    Attributes:
        time: simulated time since the model was built (s).
        rho: slider travels ``rho_i`` (m).
        rho_dot: slider travel rates (m/s).
        pose: platform pose ``(x, y, theta)`` of the gripper ``G`` (m, m, rad in ``(-pi, pi]``).
        twist: ``(x_dot, y_dot, theta_dot)`` of ``G`` (m/s, m/s, rad/s).
        leg_angles: ``alpha_i``, angle of each leg ``B_i -> C_i`` from the x axis (rad).
        actuator_forces: magnitude of each servo's force along its rail, averaged over the
            last control step (N).
        saturated: whether each servo hit ``max_force`` during the last control step.
        closure_error: largest joint separation of the loop (m): pivots at ``B_i``, ``C_i``
            and the sliders' distance from their rail line (with projection: the largest
            leg-length error, ``inf`` where the projection failed).
    """

    time: float
    rho: tuple[float, float, float]
    rho_dot: tuple[float, float, float]
    pose: tuple[float, float, float]
    twist: tuple[float, float, float]
    leg_angles: tuple[float, float, float]
    actuator_forces: tuple[float, float, float]
    saturated: tuple[bool, bool, bool]
    closure_error: float

    @property
    def finite(self) -> bool:
        """True when every number of the state is finite."""
        (r1, r2, r3), (d1, d2, d3), (x, y, th) = self.rho, self.rho_dot, self.pose
        (vx, vy, w), (a1, a2, a3) = self.twist, self.leg_angles
        return state_finite(
            r1, r2, r3, d1, d2, d3, x, y, th, vx, vy, w, a1, a2, a3, self.closure_error
        )


@dataclass(frozen=True)
class SimSnapshot:
    """Everything needed to restore a :class:`Planar3PSim` bit for bit (plain data, picklable).

    Attributes:
        design: the machine, as :meth:`Design.to_dict`.
        pose: the pose the model was built at (m, m, rad).
        working_mode: its working mode.
        settings: the constructor's keyword arguments (``dt``, ``substeps``, ...).
        commands: the velocity commands of every step since the build, flattened (m/s).
    """

    design: dict
    pose: tuple[float, float, float]
    working_mode: tuple[int, int, int]
    settings: dict
    commands: tuple[float, ...]

    @property
    def steps(self) -> int:
        """Control steps since the build."""
        return len(self.commands) // 3


def _start(design: Design, pose: ArrayLike, working_mode: ArrayLike) -> tuple[np.ndarray, Any]:
    """``pose`` as a float array and its travels in ``working_mode``; ``ValueError`` unless it
    is 3 finite numbers reachable within the stroke."""
    p = np.asarray(pose, dtype=np.float64)
    if p.shape != (3,) or not np.isfinite(p).all():
        raise ValueError(f"pose must be 3 finite numbers (x, y, theta), got {pose!r}")
    rho, reachable = kinematics.inverse(design, p, working_mode)
    if not bool(reachable):
        raise ValueError(
            f"pose {tuple(p)} is not reachable in working mode {tuple(working_mode)} "
            f"within the stroke [0, {design.stroke}] m (travels {rho})"
        )
    return p, rho


def _check_viscous(design: Design, dyn: MachineDynamics, h: float) -> None:
    """``ValueError`` unless the explicit viscous forces of ``dyn`` are stable on ``design`` at
    the physics step ``h`` (s)."""
    if not (dyn.slider_viscous > 0.0 or dyn.joint_viscous > 0.0):
        return
    slider_limit, joint_limit = viscous_step_limits(design, dyn)
    if h >= slider_limit:
        raise ValueError(
            f"dynamics.slider_viscous ({dyn.slider_viscous} N s/m) times the physics "
            f"step ({h} s) must stay below the slider mass ({design.slider_mass} kg)"
        )
    if h >= joint_limit:
        raise ValueError(
            f"dynamics.joint_viscous ({dyn.joint_viscous} N m s/rad) times the physics "
            f"step ({h} s) must stay below a leg's moment of inertia "
            f"({smallest_leg_inertia(design, dyn)} kg m^2)"
        )


def _constraint_kinds(dyn: MachineDynamics | None) -> tuple[bool, bool]:
    """Which friction constraints a model of ``dyn`` has (:func:`_friction`): the sliders'
    and the revolute joints'.  Two machines with the same kinds have models of the same
    bodies and constraints, in the same order, and differ only in their numbers."""
    if dyn is None:
        return False, False
    return dyn.slider_coulomb > 0.0, dyn.joint_coulomb > 0.0


class ModelNumbers(NamedTuple):
    """The numbers of a pymunk model that depend on the machine (:meth:`Planar3PSim._numbers`),
    defined once for the build (constructors) and for a reset onto another machine (setters).

    Attributes:
        gravity: ``(gx, gy)`` (m/s^2).
        platform: the platform's mass (kg) and moment of inertia about its centre (kg m^2).
        slider_mass: each slider's mass (kg); sliders do not rotate (infinite moment).
        legs: per leg, its mass (kg) and moment of inertia (kg m^2).
        grooves: per rail, the ends of the slider's groove (m).
        stops: per rail, the end stops' anchor on the ground (m) and half stroke (m) (the
            projected model's unilateral limit).
        servo_force: the servos' force limit (N).
        slider_coulomb: the sliders' dry friction force (N); 0 without.
        joint_coulomb: the revolute joints' dry friction torque (N m); 0 without.
    """

    gravity: tuple[float, float]
    platform: tuple[float, float]
    slider_mass: float
    legs: tuple[tuple[float, float], ...]
    grooves: tuple[tuple[tuple[float, float], tuple[float, float]], ...]
    stops: tuple[tuple[tuple[float, float], float], ...]
    servo_force: float
    slider_coulomb: float
    joint_coulomb: float


#: Distance along its rail of the static anchor of a slider's friction constraints (m): so far
#: that the constraint's direction is the rail's (as the servo's long arm).
FRICTION_ARM = 1000.0


def _friction(
    dyn: MachineDynamics,
    ground: pymunk.Body,
    sliders: list[pymunk.Body],
    legs: list[pymunk.Body],
    platform: pymunk.Body,
) -> list[pymunk.Constraint]:
    """The Coulomb friction constraints of :class:`MachineDynamics` (only those with a nonzero
    coefficient): per slider along its rail, per revolute joint ``B_i`` (slider-leg) and
    ``C_i`` (leg-platform).  Each is a velocity constraint of bounded force without position
    correction (``max_bias = 0``): pymunk's idiom for dry friction, which the iterative solver
    handles like any joint (sticking included, which a force law would not give).  Viscous
    friction is a force, :meth:`Planar3PSim._apply_viscous` (pymunk's damped springs damp
    implicitly towards the velocity the other constraints leave, which under a servo is not a
    force proportional to the rate)."""
    out: list[pymunk.Constraint] = []
    for slider, leg in zip(sliders, legs, strict=True):
        x = slider.position.x
        if dyn.slider_coulomb > 0.0:
            pin = pymunk.PinJoint(ground, slider, (x - FRICTION_ARM, 0.0), (0.0, 0.0))
            pin.max_bias = 0.0
            pin.max_force = dyn.slider_coulomb
            out.append(pin)
        for a, b in ((slider, leg), (leg, platform)):
            if dyn.joint_coulomb > 0.0:
                motor = pymunk.SimpleMotor(a, b, 0.0)
                motor.max_force = dyn.joint_coulomb
                out.append(motor)
    return out


class FastPath(NamedTuple):
    """A simulation's handles for calling Chipmunk directly (:meth:`Planar3PSim._fast_path`):
    cffi pointers for the Python calls, addresses and arrays for the compiled step
    (:mod:`planar3p_gym.sim.chipmunk`)."""

    space: Any  #: the ``cpSpace *``
    servos: tuple  #: the three servos' ``cpConstraint *``
    read: chipmunk.BodyReadout  #: the bodies' batch request, kept alive for :attr:`handles`
    handles: np.ndarray  #: :data:`planar3p_gym.sim.chipmunk.HANDLE_FIELDS`, addresses (uintp)
    readout: np.ndarray  #: the bodies' numbers in :attr:`read`'s memory (float64, 60)
    impulses: np.ndarray  #: the last step's summed and largest servo impulses (N s, 6)
    push: chipmunk.BodyReadout  #: the bodies' force and torque request (viscous friction)
    push_handles: np.ndarray  #: its ``pmBatchedData *`` and ``pmFloatArray *`` (uintp)
    applied: np.ndarray  #: its memory: ``fx, fy, t`` per body in readout order (N, N m)


class BatchLink(NamedTuple):
    """What a step batched over many simulations needs of one (:meth:`Planar3PSim.batch_link`):
    its Chipmunk handles, its record of drive commands and its projection's constants."""

    space: Any  #: the ``cpSpace *``
    servos: tuple  #: the three servos' ``cpConstraint *``
    commands: list  #: the drive commands of every step (m/s, flattened); a batch appends its own
    projection: np.ndarray  #: the projector's constants
    time: float  #: simulated time (s)
    force_limit: float  #: the servo impulse counted as saturated (N s)
    lag: float  #: the servo lag's share of a step (:meth:`MachineDynamics.lag_factor`; 1: none)
    lagged: tuple[float, float, float]  #: the lagged servo setpoint velocities (m/s)
    viscous: tuple[float, float]  #: the slider (N s/m) and joint (N m s/rad) viscous friction


class CompiledStep(NamedTuple):
    """:meth:`Planar3PSim.compiled_step`: the arguments of
    :func:`planar3p_gym.sim.chipmunk.step_projected` after the three drive commands."""

    fns: np.ndarray  #: :data:`planar3p_gym.sim.chipmunk.FUNCTIONS`
    handles: np.ndarray  #: the simulation's Chipmunk addresses
    h: float  #: the physics step (s)
    substeps: int  #: physics steps per control period
    force_limit: float  #: the servo impulse counted as saturated (N s)
    readout: np.ndarray  #: the bodies' batch array (60)
    consts: np.ndarray  #: the projector's constants
    setpoint_limit: float  #: :data:`FOLLOWING_ERROR_LIMIT` (m)
    impulses: np.ndarray  #: receives the servos' summed and largest impulses (N s, 6)


class Planar3PSim:
    """The 3-PRR mechanism as a pymunk space, stepped one control period at a time.

    Class attribute ``use_fast_path`` (default True) lets the hot loop call Chipmunk directly
    through pymunk's own bindings; set it False to use only pymunk's public API (same results).

    Args:
        design: the machine.
        pose: initial pose ``(x, y, theta)`` (m, m, rad); must be reachable in ``working_mode``
            with travels inside the stroke.
        working_mode: ``(sigma_1, sigma_2, sigma_3)`` of +-1.
        dt: control period (s): one :meth:`step` advances the simulation by ``dt``.
        substeps: physics steps per control period.
        iterations: constraint-solver iterations per physics step.
        error_bias: position-error correction of the rails, servos and pivots ``B_i``
            (fraction of an error left after 1 s).
        platform_error_bias: the same for the platform's pivots ``C_i``.
        projection: project the state exactly onto the constraint manifold after every control
            step (module docstring); ``False`` keeps the original model (``Planar3P-v0``).
        dynamics: friction, servo lag, base tilt and inertia errors of the machine
            (:class:`~planar3p_gym.sim.dynamics.MachineDynamics` or a dict of its fields);
            ``None`` or the ideal machine builds exactly the model built without it.
    """

    use_fast_path: bool = True
    #: Whether a projected model with viscous friction steps in one compiled call
    #: (:func:`~planar3p_gym.sim.chipmunk.step_projected_viscous`), else through pymunk's API
    #: (the same numbers, ``tests/sim/test_chipmunk.py``).
    use_compiled_viscous: bool = True
    #: Whether pymunk's batch readout lists the bodies as :meth:`body_values` does (checked
    #: on the first build).
    _batch_layout_ok: ClassVar[bool | None] = None

    def __init__(
        self,
        design: Design,
        pose: ArrayLike,
        working_mode: ArrayLike = (1, 1, -1),
        *,
        dt: float = 0.02,
        substeps: int = DEFAULT_SUBSTEPS,
        iterations: int = DEFAULT_ITERATIONS,
        error_bias: float = DEFAULT_ERROR_BIAS,
        platform_error_bias: float = DEFAULT_PLATFORM_ERROR_BIAS,
        projection: bool = False,
        dynamics: MachineDynamics | dict | None = None,
    ) -> None:
        if not isinstance(design, Design):
            raise ValueError(f"design must be a Design, got {type(design).__name__}")
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a finite number > 0 (s), got {dt!r}")
        if not (isinstance(substeps, (int, np.integer)) and substeps >= 1):
            raise ValueError(f"substeps must be an integer >= 1, got {substeps!r}")
        if not (isinstance(iterations, (int, np.integer)) and iterations >= 1):
            raise ValueError(f"iterations must be an integer >= 1, got {iterations!r}")
        for name, bias in (
            ("error_bias", error_bias),
            ("platform_error_bias", platform_error_bias),
        ):
            if not (isinstance(bias, (int, float)) and math.isfinite(bias) and 0.0 <= bias <= 1.0):
                raise ValueError(f"{name} must be in [0, 1], got {bias!r}")
        if not isinstance(projection, (bool, np.bool_)):
            raise ValueError(f"projection must be True or False, got {projection!r}")
        dyn = MachineDynamics.from_value(dynamics, "dynamics")
        _check_viscous(design, dyn, float(dt) / int(substeps))
        p, rho = _start(design, pose, working_mode)
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.iterations = int(iterations)
        self._h = self.dt / self.substeps
        self._force_scale = 1.0 / (self.substeps * self._h)  # impulse sum -> mean force (1/s)
        self._time = 0.0
        self._forces = (0.0, 0.0, 0.0)
        self._saturated = (False, False, False)
        self.projection = bool(projection)
        self._error_bias = float(error_bias)
        #: Whether the last step was taken by the constrained dynamics of
        #: :mod:`planar3p_gym.sim.recovery` (its projection had failed).
        self.recovered = False
        #: The machine's design (:meth:`reset` may give a new one).
        self.design = design
        #: The machine's imperfections; ``None`` for the ideal machine (the default model).
        self.dynamics: MachineDynamics | None = None
        self._use_machine(design, dyn)
        #: Servo setpoint velocities after the servo lag (m/s), with a lag only.
        self._lagged = np.zeros(3)
        self._origin = (
            (float(p[0]), float(p[1]), float(p[2])),
            tuple(int(m) for m in working_mode),
            {
                "dt": self.dt,
                "substeps": self.substeps,
                "iterations": self.iterations,
                "error_bias": float(error_bias),
                "platform_error_bias": float(platform_error_bias),
                "projection": self.projection,
                **({} if self.dynamics is None else {"dynamics": self.dynamics.to_dict()}),
            },
        )
        self._commands = array("d")
        self._closed = False
        #: Whether the last :meth:`reset` moved the bodies (False: it rebuilt the model).
        self.moved = False
        #: ``(u_1x, u_1y, u_2x, u_2y, u_3x, u_3y, cos theta, sin theta)`` after the last
        #: projected step (:class:`planar3p_gym.sim.projection.Projected`); None without one.
        self.geometry: tuple[float, ...] | None = None
        self._build(p, rho, error_bias, platform_error_bias)

    # ------------------------------------------------------------------ construction
    def _use_machine(self, design: Design, dyn: MachineDynamics) -> None:
        """Take ``design`` and ``dyn`` (validated) as the machine: every number derived from
        them, except the pymunk model's own (:meth:`_numbers`)."""
        self.design = design
        self._force_limit = 0.999 * design.max_force * self._h  # saturated impulse (N s)
        self._k = design.joint_offsets
        self._legs = design.leg_lengths
        self._origins = design.rail_origins
        self.dynamics = None if dyn.is_ideal else dyn
        self._viscous = dyn.slider_viscous > 0.0 or dyn.joint_viscous > 0.0
        self._lag = 1.0 if self.dynamics is None else self.dynamics.lag_factor(self.dt)
        self._projector = (
            LoopProjector(design, self.dt, FOLLOWING_ERROR_LIMIT, self._recovery_numbers())
            if self.projection
            else None
        )

    def _recovery_numbers(self) -> np.ndarray:
        """The constrained-dynamics numbers of the steps whose projection fails
        (:data:`~planar3p_gym.sim.projection.RECOVERY_OFFSET`): this model's solver
        iterations, the warm-start iterations, the energy slack, and the machine's numbers
        (:func:`~planar3p_gym.sim.recovery.recovery_constants` of :meth:`_numbers`)."""
        n, d, dyn = self._numbers(), self.design, self.dynamics
        half = 0.5 * self._k[0]
        numbers = recovery.recovery_constants(
            self._origins, self._legs, tuple(k - half for k in self._k), d.stroke, n.platform,
            n.slider_mass, n.legs, n.gravity, n.servo_force, SERVO_CORRECTION_SPEED,
            self._error_bias, 0.0 if dyn is None else dyn.slider_viscous,
            0.0 if dyn is None else dyn.joint_viscous, n.slider_coulomb, n.joint_coulomb,
        )  # fmt: skip
        head = [self.iterations, WARM_START_ITERATIONS, recovery.ENERGY_SLACK]
        return np.concatenate((head, numbers))

    def _numbers(self) -> ModelNumbers:
        """The pymunk model's numbers for this machine (:class:`ModelNumbers`)."""
        d, dyn = self.design, self.dynamics
        inertia = 1.0 if dyn is None else dyn.inertia_scale
        k1 = self._k[0]
        grooves: list = []
        stops: list = []
        for a in self._origins:
            if self.projection:
                ends = (a - PROJECTED_RAIL_OVERRUN, a + d.stroke + PROJECTED_RAIL_OVERRUN)
                grooves.append(((ends[0], 0.0), (ends[1], 0.0)))
                half = 0.5 * d.stroke
                stops.append(((a + half, 0.0), half))
            else:  # the groove's ends are the stops
                grooves.append(((a, 0.0), (a + d.stroke, 0.0)))
        return ModelNumbers(
            gravity=(0.0, -d.gravity) if dyn is None else dyn.gravity_vector(d.gravity),
            platform=(d.platform_mass, inertia * d.platform_mass * k1 * k1 / 12.0),
            slider_mass=d.slider_mass,
            legs=tuple((d.leg_mass, inertia * d.leg_mass * L * L / 12.0) for L in self._legs),
            grooves=tuple(grooves),
            stops=tuple(stops),
            servo_force=d.max_force,
            slider_coulomb=0.0 if dyn is None else dyn.slider_coulomb,
            joint_coulomb=0.0 if dyn is None else dyn.joint_coulomb,
        )

    def _set_numbers(self, n: ModelNumbers) -> None:
        """Give the kept model the numbers ``n`` through Chipmunk's setters (those pymunk's
        properties call, called directly as :meth:`_place` does), which store what its
        constructors store: the model :meth:`_build` makes with them, for a machine with the
        same kinds of constraints (:func:`_constraint_kinds`).  Needs Chipmunk's C API
        (``_MOVE``)."""
        cp = _cp
        set_mass, set_moment = cp.cpBodySetMass, cp.cpBodySetMoment
        set_force = cp.cpConstraintSetMaxForce
        cp.cpSpaceSetGravity(self.space._space, n.gravity)
        set_mass(self.platform._body, n.platform[0])
        set_moment(self.platform._body, n.platform[1])
        for i in range(3):
            set_mass(self.sliders[i]._body, n.slider_mass)
            set_mass(self.legs[i]._body, n.legs[i][0])
            set_moment(self.legs[i]._body, n.legs[i][1])
            rail = self._rails[i]._constraint
            cp.cpGrooveJointSetGrooveA(rail, n.grooves[i][0])
            cp.cpGrooveJointSetGrooveB(rail, n.grooves[i][1])
            if self.projection:
                stop = self._stops[i]._constraint
                cp.cpSlideJointSetAnchorA(stop, n.stops[i][0])
                cp.cpSlideJointSetMax(stop, n.stops[i][1])
            set_force(self.servos[i]._constraint, n.servo_force)
        for c in self._frictions:  # (_friction: a slider's pin, a joint's motor)
            pin = isinstance(c, pymunk.PinJoint)
            set_force(c._constraint, n.slider_coulomb if pin else n.joint_coulomb)
        constraints, _ = self._limits  # type: ignore[misc]
        self._limits = (constraints, np.array([c.max_force for c in self.space.constraints]))

    def _build(
        self, pose: np.ndarray, rho: np.ndarray, error_bias: float, platform_error_bias: float
    ) -> None:
        dyn = self.dynamics
        n = self._numbers()
        space = pymunk.Space()
        space.iterations = self.iterations
        space.gravity = n.gravity
        places, points = self._places(pose, rho)
        platform = pymunk.Body(*n.platform)
        platform.position, platform.angle = places[0]
        space.add(platform)
        sliders, drives, servos, legs, joints = [], [], [], [], []
        for i in range(3):
            slider = pymunk.Body(n.slider_mass, math.inf)
            slider.position = places[1 + 3 * i][0]
            drive = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            drive.position = places[2 + 3 * i][0]
            leg = pymunk.Body(*n.legs[i])
            leg.position, leg.angle = places[3 + 3 * i]
            rail = pymunk.GrooveJoint(space.static_body, slider, *n.grooves[i], (0, 0))
            if self.projection:
                # The groove only keeps the slider on its line; the end stops are a separate
                # unilateral limit whose impulse is dropped whenever it is not touching.
                anchor, half = n.stops[i]
                stop = pymunk.SlideJoint(space.static_body, slider, anchor, (0.0, 0.0), 0.0, half)
                stop.error_bias = error_bias
                extra: tuple = (stop,)
            else:
                extra = ()
            arm = PROJECTED_SERVO_ARM if self.projection else SERVO_ARM
            servo = pymunk.PinJoint(drive, slider, (-arm, 0.0), (0.0, 0.0))
            servo.max_bias = SERVO_CORRECTION_SPEED
            servo.max_force = n.servo_force
            servo.error_bias = error_bias
            pin_b = pymunk.PivotJoint(slider, leg, points[2 * i])
            pin_c = pymunk.PivotJoint(leg, platform, points[2 * i + 1])
            rail.error_bias = pin_b.error_bias = error_bias
            pin_c.error_bias = platform_error_bias
            space.add(slider, drive, leg)
            joints.append((rail, *extra, pin_b, pin_c))
            sliders.append(slider)
            drives.append(drive)
            servos.append(servo)
            legs.append(leg)
        # The iterative solver visits constraints in the order they were added; with the
        # servos last, an unsaturated servo's slider ends each iteration at exactly the
        # commanded velocity.
        for group in joints:
            space.add(*group)
        ground = space.static_body
        frictions = [] if dyn is None else _friction(dyn, ground, sliders, legs, platform)
        space.add(*frictions)
        space.add(*servos)
        self.space = space
        self._space = space  # the model's own space, for the recovery's re-warm step
        self._step_start: tuple = (np.zeros(60), (0.0, 0.0, 0.0))
        self._before_projection: Callable[[], object] | None = None
        self._pivots = tuple((group[-2], group[-1]) for group in joints)
        # The constraints whose numbers depend on the machine (_set_numbers).
        self._rails = tuple(group[0] for group in joints)
        self._stops = tuple(group[1] for group in joints) if self.projection else ()
        self._frictions = tuple(frictions)
        # The pin joints whose length their constructor measures: servos, sliders' friction.
        self._pins = (
            *servos,
            *(c for c in space.constraints if isinstance(c, pymunk.PinJoint) and c not in servos),
        )
        #: Every constraint's address and force limit (N), for :meth:`reset` (moving bodies).
        self._limits = (
            (
                np.array([chipmunk.address(c._constraint) for c in space.constraints], np.uintp),
                np.array([c.max_force for c in space.constraints]),
            )
            if _MOVE
            else None
        )
        self.platform = platform
        self.sliders = tuple(sliders)
        self.drives = tuple(drives)
        self.servos = tuple(servos)
        self.legs = tuple(legs)
        # Readout order: platform, then slider, drive and leg of each leg in turn (the order in
        # which the bodies were added, which is the order Chipmunk iterates them in).
        self._bodies = (platform, *(b for i in range(3) for b in (sliders[i], drives[i], legs[i])))
        self._warm_start(space, (platform, *sliders, *legs))
        self._fast = self._fast_path(space, servos) if self.use_fast_path else None
        self._move = self._move_handles() if _MOVE and self._fast is not None else None
        self._state = self._read()

    def _fast_path(self, space: pymunk.Space, servos: list[pymunk.PinJoint]) -> FastPath | None:
        """Handles for calling Chipmunk directly: one call reads every body (pymunk's batch
        iterator into a reused array); ``None`` if unavailable or if its layout does not match
        the public API's readout here."""
        if not _FAST:
            return None
        # Twice the room a readout needs (the array never grows).
        read = chipmunk.body_readout(np.zeros(2 * _BODY_FIELDS * (len(self._bodies) + 1)))
        fast_servos = tuple(sv._constraint for sv in servos)
        push = chipmunk.body_readout(np.zeros(2 * 3 * (len(self._bodies) + 1)), forces=True)
        fast = FastPath(
            space=space._space,
            servos=fast_servos,
            read=read,
            handles=chipmunk.handle_row(space._space, fast_servos, read),
            readout=read.memory[: _BODY_FIELDS * len(self._bodies)],
            impulses=np.zeros(7),  # (the 7th: 1.0 after a recovered step)
            push=push,
            push_handles=np.array(
                [chipmunk.address(push.request), chipmunk.address(push.array)], dtype=np.uintp
            ),
            applied=push.memory,
        )
        if Planar3PSim._batch_layout_ok is None:  # checked once per process
            public = self.body_values()
            Planar3PSim._batch_layout_ok = self._batch_values(fast)[: len(public)] == public
        return fast if Planar3PSim._batch_layout_ok else None

    def _warm_start(self, space: pymunk.Space, bodies: tuple[pymunk.Body, ...]) -> None:
        """Solve the joint loads of the initial (resting) state before the first step.

        One physics step with many solver iterations caches every constraint's impulse (the
        solver warm-starts from it); the bodies are then put back exactly where and as they
        were (at rest).  Without it, the first steps under gravity start from zero joint forces
        and an ill-conditioned configuration sags before the solver catches up.  This first
        step also goes through pymunk's public API, which validates the bodies, so later steps
        may call Chipmunk directly.
        """
        saved = [(b.position, b.angle) for b in bodies]
        space.iterations = WARM_START_ITERATIONS
        space.step(self._h)
        for body, (position, angle) in zip(bodies, saved, strict=True):
            body.position = position
            body.angle = angle
            body.velocity = (0.0, 0.0)
            body.angular_velocity = 0.0
        space.iterations = self.iterations

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called (stepping and :meth:`reset` then raise)."""
        return self._closed

    # ------------------------------------------------------------------ moving
    def reset(
        self,
        pose: ArrayLike,
        working_mode: ArrayLike = (1, 1, -1),
        *,
        design: Design | None = None,
        dynamics: MachineDynamics | dict | None = None,
    ) -> SimState:
        """Start a new episode at rest at ``pose`` (m, m, rad) in ``working_mode``: afterwards
        the simulation is, bit for bit, the one ``Planar3PSim(design, pose, working_mode,
        **settings)`` builds with this one's settings (its state, its next steps and
        :meth:`get_state`), whatever it went through before.  Returns the state.

        ``design`` and ``dynamics`` give the machine of the new episode (a machine drawn per
        episode, ``Planar3PReal-v0``'s; ``dynamics`` ``None``: the ideal machine); without
        ``design``, the machine stays (``dynamics`` must then be ``None``).

        The pymunk space is kept and its bodies moved (Chipmunk's C API, :meth:`_place`): every
        constraint's accumulated impulse, which the solver warm-starts from, is first cleared
        by one solver step with every force limit at zero (the clamp leaves exactly zero); a
        new machine's numbers are set (:meth:`_set_numbers`); the bodies are then placed,
        anchored and warm-started as :meth:`_build` does.  The model is rebuilt instead without
        Chipmunk's C API (``use_fast_path`` False, other pymunk builds) and for a machine with
        other kinds of friction constraints (:func:`_constraint_kinds`); :attr:`moved` tells
        which.  ``ValueError`` (nothing changed) if the pose is not reachable in
        ``working_mode`` within the stroke, the machine is not valid, or the simulation was
        closed.
        """
        if self._closed:
            raise ValueError("this simulation was closed (Planar3PSim.close); build a new one")
        if design is None:
            if dynamics is not None:
                raise ValueError("dynamics is given only with a design (the new machine)")
            new_design = self.design
            dyn = IDEAL if self.dynamics is None else self.dynamics  # (not validated again)
        else:
            if not isinstance(design, Design):
                raise ValueError(f"design must be a Design, got {type(design).__name__}")
            new_design = design
            dyn = MachineDynamics.from_value(dynamics, "dynamics")
            _check_viscous(design, dyn, self._h)
        p, rho = _start(new_design, pose, working_mode)
        new_dyn = None if dyn.is_ideal else dyn
        settings = self._origin[2]
        if design is not None:  # (the settings of a new machine: its dynamics)
            settings = {k: v for k, v in settings.items() if k != "dynamics"}
            if new_dyn is not None:
                settings["dynamics"] = new_dyn.to_dict()
        if self._move is None or _constraint_kinds(new_dyn) != _constraint_kinds(self.dynamics):
            fresh = Planar3PSim(new_design, p, working_mode, **settings)
            self.close()
            self.__dict__.update(fresh.__dict__)
            return self._state
        if new_design is not self.design or new_dyn != self.dynamics:
            self._use_machine(new_design, dyn)
            self._set_numbers(self._numbers())
        self._place(p, rho)
        constraints, limits = self._limits  # type: ignore[misc]
        chipmunk.settle(  # (the anchors stay: a step does not move them)
            chipmunk.FUNCTIONS, self._fast.handles, constraints, limits, self._h,
            WARM_START_ITERATIONS, self.iterations,
        )  # fmt: skip
        self._time = 0.0
        self._forces = (0.0, 0.0, 0.0)
        self._saturated = (False, False, False)
        self._lagged = np.zeros(3)
        self.recovered = False
        del self._commands[:]  # (in place: a vector env holds this array)
        self.geometry = None
        self._origin = (
            (float(p[0]), float(p[1]), float(p[2])),
            tuple(int(m) for m in working_mode),
            settings,
        )
        self.moved = True
        self._state = self._read()
        return self._state

    def _place(self, pose: np.ndarray, rho: np.ndarray) -> list:
        """Put every body at rest where :meth:`_build` puts it for ``pose`` (travels ``rho``)
        and re-anchor the joints as their constructors do (Chipmunk's world-to-local transforms
        for the pivots, the pins' lengths measured between their anchors): bit for bit the
        model a new build has before its warm start.  Through Chipmunk's C API
        (:meth:`_move_handles`).  Returns the bodies' places for :meth:`_rest`."""
        cp = _cp
        to_local, to_world = cp.cpBodyWorldToLocal, cp.cpBodyLocalToWorld
        set_a, set_b = cp.cpPivotJointSetAnchorA, cp.cpPivotJointSetAnchorB
        _, pivots, pins = self._move
        places, points = self._places(pose, rho)
        self._rest(places)
        for (ptr, a, b), point in zip(pivots, points, strict=True):  # as cpPivotJointNew
            set_a(ptr, to_local(a, point))
            set_b(ptr, to_local(b, point))
        for ptr, a, b, anchor_a, anchor_b in pins:  # the length as cpPinJointInit measures it
            if anchor_a is None:  # a slider's friction pin, anchored on the ground (_friction)
                anchor_a = (cp.cpBodyGetPosition(b).x - FRICTION_ARM, 0.0)
                cp.cpPinJointSetAnchorA(ptr, anchor_a)
            p1, p2 = to_world(a, anchor_a), to_world(b, anchor_b)
            dx, dy = p2.x - p1.x, p2.y - p1.y
            cp.cpPinJointSetDist(ptr, math.sqrt(dx * dx + dy * dy))
        return places

    def _places(
        self, pose: ArrayLike, rho: ArrayLike
    ) -> tuple[list[tuple[tuple[float, float], float]], list[tuple[float, float]]]:
        """Where the model of ``pose`` (m, m, rad; travels ``rho``, m) has its bodies, the one
        definition :meth:`_build` and :meth:`_place` use: each body's ``(position (m), angle
        (rad))`` in readout order (platform, then slider, drive and leg of each leg), and the
        pivot points ``B_1, C_1, B_2, ...`` (m)."""
        x, y, th = (float(v) for v in pose)
        c, s = math.cos(th), math.sin(th)
        k1 = self._k[0]
        places = [((x + 0.5 * k1 * c, y + 0.5 * k1 * s), th)]
        points = []
        for i in range(3):
            b = self._origins[i] + float(rho[i])
            k = self._k[i]
            cx, cy = x + k * c, y + k * s
            places += [((b, 0.0), 0.0), ((b, 0.0), 0.0)]  # slider, drive
            places.append(((0.5 * (b + cx), 0.5 * cy), math.atan2(cy, cx - b)))  # leg
            points += [(b, 0.0), (cx, cy)]  # pivots B_i, C_i
        return places, points

    def _rest(self, places: list) -> None:
        """Put each body at its place ``(position, angle)`` (readout order), at rest: one
        compiled write of every body (:func:`planar3p_gym.sim.chipmunk.write_bodies`, which
        sets position, angle, velocity and angular velocity as the C API's setters do).

        Body forces need no clearing: Chipmunk zeroes a dynamic body's force and torque in
        every step, nothing here sets them between steps, and a kinematic body (a drive) has
        none."""
        readout = self._fast.readout
        readout[:] = [v for (x, y), angle in places for v in (x, y, angle, 0.0, 0.0, 0.0)]
        chipmunk.write_bodies(chipmunk.FUNCTIONS, self._fast.handles)

    def _move_handles(self) -> tuple:
        """Chipmunk handles of :meth:`_place`: the bodies in readout order; each pivot's joint
        and bodies (``B_1, C_1, B_2, ...``); each pin's joint, bodies and anchors (``None``
        for the anchor a slider's friction pin takes from the slider's position)."""
        pivots = tuple(
            (joint._constraint, joint.a._body, joint.b._body)
            for pair in self._pivots
            for joint in pair
        )
        pins = tuple(
            (
                pin._constraint,
                pin.a._body,
                pin.b._body,
                None if pin.a.body_type == pymunk.Body.STATIC else tuple(pin.anchor_a),
                tuple(pin.anchor_b),
            )
            for pin in self._pins
        )
        return tuple(b._body for b in self._bodies), pivots, pins

    # ------------------------------------------------------------------ stepping
    def step(self, velocity_command: ArrayLike) -> SimState:
        """Hold the slider velocity commands (m/s, 3 values) for one control period ``dt``.

        The servos follow the commands within the actuator force limit; returns the new state.
        """
        v = np.asarray(velocity_command, dtype=np.float64)
        if v.shape != (3,) or not np.isfinite(v).all():
            raise ValueError(f"velocity_command must be 3 finite numbers (m/s), got {v!r}")
        v0, v1, v2 = v.tolist()
        return self.step_unchecked(v0, v1, v2)

    def step_unchecked(self, v0: float, v1: float, v2: float) -> SimState:
        """:meth:`step` without input validation, for callers that validated already."""
        if self._closed:
            raise ValueError("this simulation was closed (Planar3PSim.close); build a new one")
        self._commands.extend((v0, v1, v2))
        if self._lag != 1.0:  # first-order servo lag (MachineDynamics.servo_lag)
            v0, v1, v2 = servo_lag(self._lagged, self._lag, v0, v1, v2)
        fast, projector = self._fast, self._projector
        viscous = self._viscous
        compiled = not viscous or (projector is not None and self.use_compiled_viscous)
        if fast is not None and compiled:  # one compiled call (sim/chipmunk.py)
            handles, readout, impulses = fast.handles, fast.readout, fast.impulses
            if projector is not None:
                if viscous:
                    dyn = self.dynamics
                    assert dyn is not None
                    st, closure = chipmunk.step_projected_viscous(
                        chipmunk.FUNCTIONS, handles, fast.push_handles, v0, v1, v2, self._h,
                        self.substeps, self._force_limit, readout, projector.constants,
                        FOLLOWING_ERROR_LIMIT, impulses, fast.applied, dyn.slider_viscous,
                        dyn.joint_viscous,
                    )  # fmt: skip
                else:
                    st, closure = chipmunk.step_projected(
                        chipmunk.FUNCTIONS, handles, v0, v1, v2, self._h, self.substeps,
                        self._force_limit, readout, projector.constants,
                        FOLLOWING_ERROR_LIMIT, impulses,
                    )  # fmt: skip
                projector.last_state = st
                self.recovered = impulses[6] == 1.0
                self._account(impulses)
                self._state = self._projected_state(st, closure, readout)
                return self._state
            self._limit_following_error()
            chipmunk.read_bodies(chipmunk.FUNCTIONS, handles)  # (moved by the line above)
            chipmunk.advance(
                chipmunk.FUNCTIONS, handles, v0, v1, v2, self._h, self.substeps, readout, impulses
            )
            self._account(impulses)
            self._state = self._read()
            return self._state
        # pymunk's API: viscous friction (set before each physics step), or no Chipmunk C API.
        if projector is None:  # (with projection, done when the state is written back)
            self._limit_following_error()
            start = None
        else:  # the step's start, for a recovery (_project)
            start = np.array(self.body_values() if fast is None else self._batch_values(fast))[:60]
        for drive, v in zip(self.drives, (v0, v1, v2), strict=True):
            drive.velocity = (v, 0.0)
        totals, largest = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
        for _ in range(self.substeps):
            if self._viscous:
                self._apply_viscous()
            self.space.step(self._h)
            for i, servo in enumerate(self.servos):
                j = servo.impulse
                totals[i] += j
                largest[i] = max(largest[i], j)
        self._account(np.array(totals + largest))
        self.recovered = False
        if start is None:
            self._state = self._read()
        else:
            self._step_start = (start, (v0, v1, v2))
            if self._before_projection is not None:
                self._before_projection()
            self._state = self._project()
        return self._state

    def compiled_step(self) -> CompiledStep | None:
        """The arguments of :func:`planar3p_gym.sim.chipmunk.step_projected` (all but the three
        drive commands) when one control step of this simulation is exactly that compiled call
        (:meth:`step_unchecked`'s fast path: projection on, Chipmunk's C API, no servo lag, no
        viscous friction), else ``None``.  For compiled loops that take many closed-loop steps
        at once; they then hand their commands to :meth:`record_compiled_steps`."""
        fast, projector = self._fast, self._projector
        if self._closed or fast is None or projector is None or self._viscous or self._lag != 1.0:
            return None
        return CompiledStep(
            chipmunk.FUNCTIONS, fast.handles, self._h, self.substeps, self._force_limit,
            fast.readout, projector.constants, FOLLOWING_ERROR_LIMIT, fast.impulses,
        )  # fmt: skip

    def record_compiled_steps(
        self, commands: np.ndarray, state: np.ndarray, closure: float
    ) -> None:
        """Bring the simulation's record up to date after compiled code took ``len(commands)``
        control steps through :meth:`compiled_step`'s arguments, with the drive ``commands``
        ``(n, 3)`` (m/s) and the last step's projected ``state`` (23 values) and ``closure``
        error (m): the command log, the clock, the last step's forces and saturation (from the
        impulses the call left), the state.  Afterwards the simulation is, bit for bit, the one
        :meth:`step_unchecked` would have left with the same commands."""
        n = len(commands)
        if not n:
            return
        self._commands.extend(np.asarray(commands, dtype=np.float64).ravel().tolist())
        for _ in range(n - 1):  # the clock is a sum of periods, as step by step
            self._time += self.dt
        self._projector.last_state = state  # type: ignore[union-attr]
        self.recovered = self._fast.impulses[6] == 1.0  # type: ignore[union-attr]
        self._account(self._fast.impulses)  # type: ignore[union-attr]
        readout = self._fast.readout  # type: ignore[union-attr]
        self._state = self._projected_state(state, closure, readout)

    def _account(self, impulses: np.ndarray) -> None:
        """Advance the clock by a control period and set the mean actuator forces (N) and the
        saturation flags from the servos' summed and largest substep ``impulses`` (N s)."""
        self._time += self.dt
        self._set_forces(impulses)

    def _set_forces(self, impulses: np.ndarray) -> None:
        """The mean actuator forces (N) and the saturation flags from the servos' summed and
        largest substep ``impulses`` (N s, the first 6 numbers)."""
        f0, f1, f2, m0, m1, m2 = impulses[:6].tolist()
        scale, limit = self._force_scale, self._force_limit
        self._forces = (f0 * scale, f1 * scale, f2 * scale)
        self._saturated = (m0 >= limit, m1 >= limit, m2 >= limit)

    def _apply_viscous(self) -> None:
        """Set the viscous friction forces of :attr:`dynamics` for the next physics step, from
        the current velocities (explicit: held over the step; Chipmunk clears body forces
        after each step): ``-c v`` on each slider along its rail, ``-c (w_a - w_b)`` on the
        two bodies of each revolute joint, opposite on the other."""
        dyn = self.dynamics
        assert dyn is not None
        cs, cj = dyn.slider_viscous, dyn.joint_viscous
        platform = self.platform
        for slider, leg in zip(self.sliders, self.legs, strict=True):
            if cs > 0.0:
                slider.force = (-cs * slider.velocity.x, 0.0)
            if cj > 0.0:
                # Joint B_i: the slider does not turn; joint C_i: leg against platform.
                leg.torque = -cj * leg.angular_velocity - cj * (
                    leg.angular_velocity - platform.angular_velocity
                )
                platform.torque += cj * (leg.angular_velocity - platform.angular_velocity)

    def _project(self) -> SimState:
        """Project the bodies onto the constraint manifold, write them back, return the state
        (after a physics step taken through pymunk's API from the readout and with the drive
        commands, m/s, of ``_step_start``); where it :func:`~chipmunk.needs_recovery`, the
        step is taken again by the constrained dynamics (:meth:`_recover`) as the compiled step
        does."""
        start, commands = self._step_start
        state = self._project_bodies()
        end = np.array(self.body_values())
        projector = self._projector
        assert projector is not None
        if not chipmunk.needs_recovery(start, end, state.closure_error, projector.constants):
            return state
        return self._recover(start, commands) or state

    def _recover(self, start: np.ndarray, commands: tuple[float, float, float]) -> SimState | None:
        """:func:`~planar3p_gym.sim.chipmunk.recovered_step` of a step taken through pymunk's
        API: the recovered bodies written back, the solver re-warmed as the compiled step does
        (one physics step with the warm-start iterations, the bodies put back), the forces
        and saturation of the recovered step; ``None`` (nothing changed) where it fails."""
        projector = self._projector
        assert projector is not None
        impulses = np.zeros(6)
        ok, bodies, st, closure = chipmunk.recovered_step(
            start, *commands, self._h, self._force_limit, projector.constants,
            FOLLOWING_ERROR_LIMIT, impulses,
        )  # fmt: skip
        if not ok:
            return None
        projector.last_state = st
        self._write_public(bodies.tolist(), start.tolist())
        space = self._space  # (pymunk's own, whatever wraps self.space)
        space.iterations = WARM_START_ITERATIONS
        space.step(self._h)
        self._write_public(bodies.tolist(), start.tolist())
        space.iterations = self.iterations
        self._set_forces(impulses)
        self.recovered = True
        if self._fast is not None:
            self._fast.readout[:60] = bodies
        return self._projected_state(st, closure, bodies)

    def _write_public(self, out: list[float], v: list[float]) -> None:
        """Write the body values ``out`` (readout order) through pymunk's API; a drive's
        position only where it differs from ``v`` (the values read)."""
        for n, body in enumerate(self._bodies):
            o = 6 * n
            if body.body_type == pymunk.Body.KINEMATIC:
                if out[o] != v[o]:
                    body.position = (out[o], out[o + 1])
                continue
            body.position = (out[o], out[o + 1])
            body.angle = out[o + 2]
            body.velocity = (out[o + 3], out[o + 4])
            body.angular_velocity = out[o + 5]

    def _project_bodies(self) -> SimState:
        """The projection of :meth:`_project` (its result may be a failed one)."""
        fast = self._fast
        projector = self._projector
        assert projector is not None
        if fast is not None:
            # Read the bodies into pymunk's array, project them in place there (one compiled
            # call on a view of it) and write them back from it.
            chipmunk.read_bodies(chipmunk.FUNCTIONS, fast.handles)
            readout = fast.readout
            sat = self._saturated
            st, closure = projector.project_in_place(
                readout, sat[0], sat[1], sat[2], FOLLOWING_ERROR_LIMIT
            )
            chipmunk.write_bodies(chipmunk.FUNCTIONS, fast.handles)
            return self._projected_state(st, closure, readout)
        v = self.body_values()
        # (The drives' setpoints for the next step are pulled to within
        # FOLLOWING_ERROR_LIMIT of their sliders, :meth:`_limit_following_error`.)
        pr = projector.project(v, self._saturated, FOLLOWING_ERROR_LIMIT)
        out = pr.bodies
        self._write_public(out, v)
        self._setpoints = [out[12], out[30], out[48]]
        self.geometry = pr.geometry
        return SimState(
            self._time,
            pr.rho,
            pr.rho_dot,
            (pr.pose[0], pr.pose[1], wrap_angle(pr.pose[2])),
            pr.twist,
            pr.leg_angles,
            self._forces,
            self._saturated,
            pr.closure_error,
        )

    def _projected_state(self, st: np.ndarray, closure: float, readout: np.ndarray) -> SimState:
        """The state of a projection's state array ``st`` (23 values,
        :func:`~planar3p_gym.sim.projection.project_readout`), with the projected bodies in
        ``readout``: also keeps the drives' setpoints and :attr:`geometry`."""
        self._setpoints = readout[12:49:18].tolist()
        s = st.tolist()
        self.geometry = (s[15], s[16], s[17], s[18], s[19], s[20], s[21], s[22])
        return SimState(
            self._time,
            (s[0], s[1], s[2]),
            (s[3], s[4], s[5]),
            (s[6], s[7], wrap_angle(s[8])),
            (s[9], s[10], s[11]),
            (s[12], s[13], s[14]),
            self._forces,
            self._saturated,
            float(closure),
        )

    def _limit_following_error(self) -> None:
        """Pull each drive's setpoint to within :data:`FOLLOWING_ERROR_LIMIT` of its slider."""
        rho, setpoints = self._state.rho, self._setpoints
        for i, drive in enumerate(self.drives):
            slider_x = self._origins[i] + rho[i]
            if setpoints[i] - slider_x > FOLLOWING_ERROR_LIMIT:
                drive.position = (slider_x + FOLLOWING_ERROR_LIMIT, 0.0)
            elif slider_x - setpoints[i] > FOLLOWING_ERROR_LIMIT:
                drive.position = (slider_x - FOLLOWING_ERROR_LIMIT, 0.0)

    # ------------------------------------------------------------------ release
    def close(self) -> None:
        """Free the pymunk model now (idempotent): stepping raises ``ValueError`` afterwards;
        :attr:`state` and :meth:`get_state` stay readable.

        Why by hand: every pymunk body and constraint keeps a cffi handle to itself as its
        Chipmunk user data, a reference cycle that only the garbage collector frees.  Each
        discarded model would leave some 400 objects to the collector, whose survivors of the
        young collections trigger the full ones; a full collection traverses the whole process
        (about 100 ms once numba is loaded), which showed as 100-200 ms resets
        (docs/throughput.md, reset tails).  Closing removes the constraints and bodies from the
        space, clears their user data in Chipmunk (pymunk's destructors only remove and free,
        they never read it) and drops the handles, so the model is freed by reference
        counting as soon as its last reference goes.  The handles are pymunk's private
        ``_data_handle`` attributes (pymunk 7, pinned); without them the objects are only
        removed from the space and left to the collector."""
        if self._closed:
            return
        self._closed = True
        space = self.space
        constraints, bodies = list(space.constraints), list(space.bodies)
        space.remove(*constraints, *bodies)
        if not _RELEASE:  # pragma: no cover - other pymunk builds
            return
        for obj in (*constraints, *bodies, space.static_body):
            if not hasattr(obj, "_data_handle"):
                continue
            if isinstance(obj, pymunk.Constraint):
                _cp.cpConstraintSetUserData(obj._constraint, _ffi.NULL)
            else:
                _cp.cpBodySetUserData(obj._body, _ffi.NULL)
            obj._data_handle = None

    # ------------------------------------------------------------------ snapshots
    def get_state(self) -> SimSnapshot:
        """A snapshot from which :meth:`set_state` / :meth:`from_state` restore this simulation
        bit for bit (plain data; its size grows with the steps since the build)."""
        pose, mode, settings = self._origin
        return SimSnapshot(self.design.to_dict(), pose, mode, dict(settings), tuple(self._commands))

    @classmethod
    def from_state(cls, snapshot: SimSnapshot) -> Planar3PSim:
        """A new simulation in the state of ``snapshot`` (rebuilt, then the recorded commands
        replayed: pymunk's solver caches are restored with everything else)."""
        if not isinstance(snapshot, SimSnapshot):
            raise ValueError(f"expected a SimSnapshot, got {type(snapshot).__name__}")
        commands = snapshot.commands
        if len(commands) % 3 or not all(math.isfinite(c) for c in commands):
            raise ValueError("snapshot commands must be finite, three per step")
        sim = cls(
            Design.from_dict(snapshot.design),
            snapshot.pose,
            snapshot.working_mode,
            **snapshot.settings,
        )
        step = sim.step_unchecked
        for i in range(0, len(commands), 3):
            step(commands[i], commands[i + 1], commands[i + 2])
        return sim

    def set_state(self, snapshot: SimSnapshot) -> None:
        """Put this simulation in the state of ``snapshot`` (see :meth:`from_state`)."""
        fresh = Planar3PSim.from_state(snapshot)
        self.close()  # the model being replaced
        self.__dict__.update(fresh.__dict__)

    def __getstate__(self) -> dict:
        # pymunk's C structures cannot be pickled; a snapshot rebuilds them exactly.
        return {"snapshot": self.get_state()}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(Planar3PSim.from_state(state["snapshot"]).__dict__)

    # ------------------------------------------------------------------ readout
    @property
    def state(self) -> SimState:
        """The state after the last step (or at construction)."""
        return self._state

    def batch_link(self) -> BatchLink | None:
        """The simulation's :class:`BatchLink` when a batched step can take it (projection on,
        Chipmunk's C API), else ``None``."""
        fast, projector = self._fast, self._projector
        if fast is None or projector is None:
            return None
        dyn = self.dynamics
        viscous = (0.0, 0.0) if dyn is None else (dyn.slider_viscous, dyn.joint_viscous)
        return BatchLink(
            fast.space, fast.servos, self._commands, projector.constants, self._time,
            self._force_limit, self._lag, tuple(self._lagged.tolist()), viscous,
        )  # fmt: skip

    def adopt_state(
        self,
        state: SimState,
        setpoints: tuple[float, float, float],
        geometry: tuple[float, ...],
        lagged: tuple[float, float, float] | None = None,
        array: np.ndarray | None = None,
    ) -> None:
        """Take ``state`` computed by a batched step of this simulation's bodies (its commands
        already in :attr:`BatchLink.commands`) as the current one: the clock, forces and
        saturation of ``state``, the drives' ``setpoints`` (m) and the projection's
        :attr:`geometry`; with a servo lag its ``lagged`` setpoint velocities (m/s), and
        the projected state ``array`` (:attr:`state_array`) where given."""
        if lagged is not None:
            self._lagged[:] = lagged
        if array is not None and self._projector is not None:
            self._projector.last_state = array
        self._state = state
        self._time = state.time
        self._forces = state.actuator_forces
        self._saturated = state.saturated
        self._setpoints = list(setpoints)
        self.geometry = geometry

    def step_through_api(self, before_projection: Callable[[], object] | None = None) -> None:
        """Take the episode's next control steps through pymunk's public API, one step of
        ``space`` (the pymunk space) at a time, with the compiled path's numbers
        (``tests/sim/test_recovery.py``): for an instrument that wraps ``space`` to book every
        physics step.  ``before_projection`` is called between a step's physics and its
        projection (with the projection on; without it, never).  The next :meth:`reset`
        builds the model anew, on the compiled path.  ``ValueError``, nothing changed, where
        ``before_projection`` is neither ``None`` nor callable."""
        if before_projection is not None and not callable(before_projection):
            raise ValueError(
                f"before_projection must be None or a callable, got {before_projection!r}"
            )
        self._fast = self._move = None
        self._before_projection = before_projection

    @property
    def state_array(self) -> np.ndarray | None:
        """The projected state of the last step as the projection's array of 23 float64 (SI
        units: ``rho``, ``rho_dot``, the pose, the twist, the leg angles and the geometry
        ``(u_1x, u_1y, u_2x, u_2y, u_3x, u_3y, cos theta, sin theta)``,
        :func:`planar3p_gym.sim.projection.project_readout`'s layout); ``None`` without the
        projection or before the first projected step.  Read only: the simulation owns it."""
        projector = self._projector
        return None if projector is None else projector.last_state

    def body_values(self) -> list[float]:
        """``x, y`` (m), ``angle`` (rad), ``vx, vy`` (m/s) and angular velocity (rad/s) of
        every body in readout order (the platform, then the slider, drive and leg of each leg),
        read through pymunk's public API: the numbers energy balances and tests compare."""
        out: list[float] = []
        for b in self._bodies:
            p, v = b.position, b.velocity
            out += (p.x, p.y, b.angle, v.x, v.y, b.angular_velocity)
        return out

    @staticmethod
    def _batch_values(fast: FastPath) -> list[float]:
        """The same numbers as :meth:`body_values` (then those of any other body of the
        space), read by one compiled pass."""
        chipmunk.read_bodies(chipmunk.FUNCTIONS, fast.handles)
        return fast.read.memory[: fast.read.array.num].tolist()

    def _read(self) -> SimState:
        k, legs_len, origins = self._k, self._legs, self._origins
        v = self.body_values() if self._fast is None else self._batch_values(self._fast)
        px, py, th, pvx, pvy, w = v[:6]
        c, s = math.cos(th), math.sin(th)
        half = 0.5 * k[0]
        gx, gy = px - half * c, py - half * s
        err2 = 0.0  # largest squared joint separation (m^2)
        nan_check = 0.0
        rho, rho_dot, alphas, setpoints = [], [], [], []
        for i, o in enumerate((6, 24, 42)):
            # Slider, drive and leg of leg i: 18 numbers from offset o (x, y, angle, vx, vy, w).
            sx, sy, _, svx, _, _, drive_x, _, _, _, _, _, lx, ly, phi, _, _, _ = v[o : o + 18]
            rho.append(sx - origins[i])
            rho_dot.append(svx)
            setpoints.append(drive_x)
            hl = 0.5 * legs_len[i]
            lc, ls = hl * math.cos(phi), hl * math.sin(phi)
            # Pivot at B_i: slider centre vs the leg's lower end; at C_i: the leg's upper end
            # vs the platform point at distance k_i from G; and the slider's offset from its rail.
            bx, by = lx - lc - sx, ly - ls - sy
            cx, cy = lx + lc - (gx + k[i] * c), ly + ls - (gy + k[i] * s)
            e2 = max(bx * bx + by * by, cx * cx + cy * cy, sy * sy)
            if e2 > err2:
                err2 = e2
            nan_check += bx + by + cx + cy + sy  # max() and > skip NaN; a sum keeps it
            alphas.append(wrap_angle(phi))
        err = math.sqrt(err2) if math.isfinite(nan_check) else math.nan
        self._setpoints = setpoints
        return SimState(
            self._time,
            (rho[0], rho[1], rho[2]),
            (rho_dot[0], rho_dot[1], rho_dot[2]),
            (gx, gy, wrap_angle(th)),
            (pvx + w * half * s, pvy - w * half * c, w),
            (alphas[0], alphas[1], alphas[2]),
            self._forces,
            self._saturated,
            err,
        )

    def closure_error(self) -> float:
        """Largest joint separation of the closed loop (m) in the current state."""
        return self._state.closure_error
