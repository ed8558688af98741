"""Whether an assembly change can be made: the kinematic check of the straight pose path and
the simulated demonstration crossing (the sampler's feasibility test of
:class:`planar3p_gym.tasks.assembly_change.AssemblyChangeTask`; see that module's docstring).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from planar3p_gym import checks
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.scalar_kinematics import ScalarKinematics
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
    lo, hi = limits.travel_margin * design.stroke, (1.0 - limits.travel_margin) * design.stroke
    rho = kinematics.inverse(design, path, m).rho
    if not (np.isfinite(rho).all() and (rho >= lo).all() and (rho <= hi).all()):
        return False, "stroke"
    marg = kinematics.margins(design, path, rho)
    if float(marg.serial.min()) < limits.min_serial_margin:
        return False, "serial_margin"
    signs = marg.assembly.astype(np.int64)
    if (signs == 0).any() or int(np.count_nonzero(np.diff(signs))) != 1:
        return False, "crossings"
    return True, "ok"


def _commands(
    curve: TravelCurve, dt: float, gain: float, vmax: float
) -> Callable[[int, tuple[float, float, float]], tuple[float, float, float]]:
    """:meth:`TravelCurve.command` at step ``k`` (time ``(k + 1) dt``) for measured travels,
    in plain floats: the same operations in the same order on the same numbers, so the same
    commands to the bit, at a tenth of the cost of the array version (the demonstration runs a
    few hundred steps per sampled pair)."""
    travels, slopes = curve.travels.tolist(), curve.slopes.tolist()
    last, duration = len(travels) - 2, curve.duration

    def command(k: int, rho: tuple[float, float, float]) -> tuple[float, float, float]:
        s, s_dot = minimum_jerk((k + 1) * dt, duration)
        x = s * (last + 1)
        j = min(int(x), last)
        w = x - j
        u = 1.0 - w
        a, b, sa, sb = travels[j], travels[j + 1], slopes[j], slopes[j + 1]
        out = []
        for i in range(3):
            ref = u * a[i] + w * b[i]
            v = s_dot * (u * sa[i] + w * sb[i]) + gain * (ref - rho[i])
            out.append(-vmax if v < -vmax else (vmax if v > vmax else v))
        return out[0], out[1], out[2]

    return command


def verify_crossing(
    design: Design,
    start: ArrayLike,
    target: ArrayLike,
    mode: ModeTriple,
    limits: CrossingLimits,
    make_sim: SimFactory,
    breakdown_distance: float,
) -> tuple[bool, dict[str, float]]:
    """Run the demonstration motion from ``start`` in a simulation built by ``make_sim`` and
    report whether it ends in the target's assembly mode within ``limits.verify_tolerance``
    (m) of the target without the closure error exceeding ``breakdown_distance`` (m).

    Returns ``(ok, figures)`` with ``figures``: ``end_distance`` (m), ``end_assembly``,
    ``max_closure_error`` (m), ``steps``."""
    s = np.asarray(start, dtype=np.float64)
    t = np.asarray(target, dtype=np.float64)
    sim = make_sim(s, mode)
    try:
        return _run_demonstration(design, sim, s, t, mode, limits, breakdown_distance)
    finally:
        sim.close()  # freed now, not left to the garbage collector (Planar3PSim.close)


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
    worst = 0.0
    command = _commands(curve, sim.dt, limits.travel_gain, design.max_speed)
    for k in range(steps):
        v0, v1, v2 = command(k, state.rho)
        state = sim.step_unchecked(v0, v1, v2)
        if not state.finite or state.closure_error > breakdown_distance:
            return False, {
                "end_distance": math.inf,
                "end_assembly": 0,
                "max_closure_error": math.inf,
                "steps": k + 1,
            }
        worst = max(worst, state.closure_error)
    asm = kin.measures(state.pose, state.rho).det_sign
    d = np.asarray(state.pose) - t
    d[2] = ((d[2] + math.pi) % (2.0 * math.pi) - math.pi) * design.characteristic_length
    dist = float(np.linalg.norm(d))
    ok = asm == target_asm and dist <= limits.verify_tolerance
    return ok, {
        "end_distance": dist,
        "end_assembly": asm,
        "max_closure_error": worst,
        "steps": steps,
    }
