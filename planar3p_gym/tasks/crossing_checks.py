"""Whether an assembly change can be made: the kinematic check of the straight pose path and
the simulated demonstration crossing (the sampler's feasibility test of
:class:`planar3p_gym.tasks.assembly_change.AssemblyChangeTask`; see that module's docstring).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from planar3p_gym import checks
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.scalar_kinematics import ScalarKinematics
from planar3p_gym.sim.chipmunk import step_projected
from planar3p_gym.sim.physics import Planar3PSim
from planar3p_gym.tasks.base import ModeTriple
from planar3p_gym.tasks.motions import minimum_jerk
from planar3p_gym.tasks.travel_motion import TravelCurve, demonstration_travels, straight_pose_path

__all__ = ["CrossingLimits", "SimFactory", "crossing_path", "verify_crossing"]

#: Builds a simulation from a pose and a working mode.
SimFactory = Callable[[np.ndarray, tuple[int, int, int]], Planar3PSim]


@dataclass(frozen=True)
class CrossingLimits:
    """Feasibility conditions of an assembly change.

    Attributes:
        points: poses checked along the straight pose path (>= 2).
        min_serial_margin: serial margin kept along the path (dimensionless).
        travel_margin: fraction of the stroke kept free at both ends along the path.
        verify: simulate the demonstration motion for every sampled pair.
        speed_fraction: peak slider rate of the demonstration as a fraction of ``max_speed``.
        travel_gain: proportional gain of the demonstration on the travel error (1/s).
        verify_tolerance: the demonstration must end within this pose distance
            ``|(dx, dy, L_ref dtheta)|`` of the target (m).
    """

    points: int = 48
    min_serial_margin: float = 0.1
    travel_margin: float = 0.03
    verify: bool = True
    speed_fraction: float = 1.0
    travel_gain: float = 10.0
    verify_tolerance: float = 0.01

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(
            self, "points", checks.integer(self.points, "CrossingLimits.points", low=2, high=10_000)
        )
        set_(self, "verify", checks.flag(self.verify, "CrossingLimits.verify"))
        for name, lo, hi in (("min_serial_margin", 0.0, 1.0), ("travel_margin", 0.0, 0.5)):
            value = checks.number(
                getattr(self, name), f"CrossingLimits.{name}", low=lo, high=hi, high_open=True
            )
            set_(self, name, value)
        for name in ("travel_gain", "verify_tolerance"):
            value = checks.number(
                getattr(self, name), f"CrossingLimits.{name}", low=0.0, low_open=True
            )
            set_(self, name, value)
        set_(
            self,
            "speed_fraction",
            checks.number(
                self.speed_fraction,
                "CrossingLimits.speed_fraction",
                low=0.0,
                high=1.0,
                low_open=True,
            ),
        )


def crossing_path(
    design: Design, start: ArrayLike, target: ArrayLike, mode: ArrayLike, limits: CrossingLimits
) -> tuple[bool, str]:
    """Kinematic condition of an assembly change: ``(ok, reason)``; ``reason`` is ``"ok"``,
    ``"stroke"`` (a pose of the straight path leaves the stroke or cannot close),
    ``"serial_margin"`` or ``"crossings"`` (``sign det A`` does not change exactly once)."""
    path = straight_pose_path(start, target, limits.points)
    m = np.asarray(mode, dtype=np.float64)
    lo, hi = design.travel_band(limits.travel_margin)
    rho = kinematics.inverse(design, path, m).rho
    if not (np.isfinite(rho).all() and (rho >= lo).all() and (rho <= hi).all()):
        return False, "stroke"
    # (the serial margins and assembly modes of kinematics.margins, without its SVD)
    if float(kinematics.serial_margin(design, path, rho).min()) < limits.min_serial_margin:
        return False, "serial_margin"
    signs = kinematics.assembly_mode(design, path, rho).astype(np.int64)
    if (signs == 0).any() or int(np.count_nonzero(np.diff(signs))) != 1:
        return False, "crossings"
    return True, "ok"


def _references(curve: TravelCurve, dt: float, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """The reference travels and rates of :meth:`TravelCurve.command` at the times ``(k + 1)
    dt`` of the steps ``k < steps``: ``(references (steps, 3) (m), rates (steps, 3) (m/s))``,
    with the same operations in the same order on the same numbers (the time law in Python
    floats, the interpolation elementwise), so :func:`travel_command` on them gives that
    method's commands to the bit."""
    n = len(curve.travels)
    duration = curve.duration
    law = np.array([minimum_jerk((k + 1) * dt, duration) for k in range(steps)]).reshape(-1, 2)
    x = law[:, 0] * (n - 1)
    j = np.minimum(x.astype(np.intp), n - 2)  # int() of a number >= 0: truncation
    w = (x - j)[:, None]
    u = 1.0 - w
    references = u * curve.travels[j] + w * curve.travels[j + 1]
    rates = law[:, 1:] * (u * curve.slopes[j] + w * curve.slopes[j + 1])
    return references, rates


@njit(cache=True)
def travel_command(rate: float, reference: float, rho: float, gain: float, vmax: float) -> float:
    """The demonstration's drive command of one slider (m/s): the reference ``rate`` plus
    ``gain`` (1/s) times the travel error ``reference - rho`` (m), clipped to ``vmax``."""
    v = rate + gain * (reference - rho)
    return -vmax if v < -vmax else (vmax if v > vmax else v)


@njit(cache=True)
def _demonstrate(
    rho: np.ndarray, references: np.ndarray, rates: np.ndarray, gain: float, vmax: float,
    breakdown: float, fns: np.ndarray, handles: np.ndarray, h: float, substeps: int,
    force_limit: float, readout: np.ndarray, consts: np.ndarray, setpoint_limit: float,
    impulses: np.ndarray, commands: np.ndarray,
) -> tuple[int, float, np.ndarray, float]:  # fmt: skip
    """The demonstration's steps as one compiled loop on a simulation's
    :meth:`~planar3p_gym.sim.physics.Planar3PSim.compiled_step` (its arguments after
    ``breakdown``): from the travels ``rho`` (3,), the commands of :func:`travel_command` on
    the last state's travels, one :func:`~planar3p_gym.sim.chipmunk.step_projected` each, until
    a state is not finite (:attr:`SimState.finite`'s sum, in its order) or its closure error
    exceeds ``breakdown`` (m).  Writes the commands into ``commands`` and returns ``(steps
    taken, largest closure error of the steps that passed, the last state (23 values), its
    closure error)``."""
    r0, r1, r2 = rho[0], rho[1], rho[2]
    worst = 0.0
    state = np.zeros(23)
    closure = 0.0
    for k in range(references.shape[0]):
        v0 = travel_command(rates[k, 0], references[k, 0], r0, gain, vmax)
        v1 = travel_command(rates[k, 1], references[k, 1], r1, gain, vmax)
        v2 = travel_command(rates[k, 2], references[k, 2], r2, gain, vmax)
        commands[k, 0], commands[k, 1], commands[k, 2] = v0, v1, v2
        state, closure = step_projected(
            fns, handles, v0, v1, v2, h, substeps, force_limit, readout, consts,
            setpoint_limit, impulses,
        )  # fmt: skip
        total = state[0] + state[1] + state[2] + state[3] + state[4] + state[5] + state[6]
        total = total + state[7] + wrap_angle(state[8]) + state[9] + state[10] + state[11]
        total = total + state[12] + state[13] + state[14] + closure
        if not math.isfinite(total) or closure > breakdown:
            return k + 1, worst, state, closure
        if closure > worst:
            worst = closure
        r0, r1, r2 = state[0], state[1], state[2]
    return references.shape[0], worst, state, closure


def verify_crossing(
    design: Design,
    start: ArrayLike,
    target: ArrayLike,
    mode: ModeTriple,
    limits: CrossingLimits,
    make_sim: SimFactory | None,
    breakdown_distance: float,
    *,
    sim: Planar3PSim | None = None,
) -> tuple[bool, dict[str, float]]:
    """Run the demonstration motion from ``start`` in a simulation built by ``make_sim`` and
    report whether it ends in the target's assembly mode within ``limits.verify_tolerance``
    (m) of the target without the closure error exceeding ``breakdown_distance`` (m).

    With ``sim``, the demonstration runs on that simulation instead, moved to ``start``
    (:meth:`Planar3PSim.reset`: bit for bit the simulation a new build gives, at a fraction of
    its cost) and left open for the next check; ``make_sim`` is then not used.

    Returns ``(ok, figures)`` with ``figures``: ``end_distance`` (m), ``end_assembly``,
    ``max_closure_error`` (m), ``steps``."""
    s = np.asarray(start, dtype=np.float64)
    t = np.asarray(target, dtype=np.float64)
    if sim is not None:
        sim.reset(s, mode)
        return _run_demonstration(design, sim, s, t, mode, limits, breakdown_distance)
    if make_sim is None:
        raise ValueError("verify_crossing needs make_sim or sim")
    built = make_sim(s, mode)
    try:
        return _run_demonstration(design, built, s, t, mode, limits, breakdown_distance)
    finally:
        built.close()  # freed now, not left to the garbage collector (Planar3PSim.close)


def _run_demonstration(
    design: Design,
    sim: Planar3PSim,
    s: np.ndarray,
    t: np.ndarray,
    mode: ModeTriple,
    limits: CrossingLimits,
    breakdown_distance: float,
) -> tuple[bool, dict[str, float]]:
    """The body of :func:`verify_crossing` on its simulation ``sim``."""
    kin = ScalarKinematics(design)
    state = sim.state
    target_asm = -kin.measures(state.pose, state.rho).det_sign
    curve = TravelCurve(
        demonstration_travels(design, state.rho, s, t, mode),
        limits.speed_fraction * design.max_speed,
    )
    steps = int(math.ceil(curve.duration / sim.dt)) + 1
    references, rates = _references(curve, sim.dt, steps)
    gain, vmax = limits.travel_gain, design.max_speed
    fast = sim.compiled_step()
    if fast is not None:  # one compiled loop, the same steps (tests/tasks/test_crossing_checks)
        commands = np.empty((steps, 3))
        taken, worst, last, closure = _demonstrate(
            np.array(state.rho), references, rates, gain, vmax, breakdown_distance, *fast,
            commands,
        )  # fmt: skip
        sim.record_compiled_steps(commands[:taken], last, closure)
        state = sim.state
        broke = taken < steps or not state.finite or state.closure_error > breakdown_distance
    else:  # servo lag, viscous friction or no Chipmunk C API: step by step
        worst, broke, taken = 0.0, False, 0
        ref, rate = references.tolist(), rates.tolist()
        for k in range(steps):
            rho = state.rho
            state = sim.step_unchecked(
                *(travel_command(rate[k][i], ref[k][i], rho[i], gain, vmax) for i in range(3))
            )
            taken = k + 1
            if not state.finite or state.closure_error > breakdown_distance:
                broke = True
                break
            worst = max(worst, state.closure_error)
    if broke:
        return False, {
            "end_distance": math.inf,
            "end_assembly": 0,
            "max_closure_error": math.inf,
            "steps": taken,
        }
    asm = kin.measures(state.pose, state.rho).det_sign
    dist = float(kinematics.pose_distance_euclidean(t, state.pose, design.characteristic_length))
    ok = asm == target_asm and dist <= limits.verify_tolerance
    return ok, {
        "end_distance": dist,
        "end_assembly": asm,
        "max_closure_error": worst,
        "steps": steps,
    }
