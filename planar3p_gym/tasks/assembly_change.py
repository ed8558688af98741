"""Assembly-mode change: cross a parallel singularity with the dynamics
(``Planar3PAssemblyChange-v0``).

Start and target are in the same working mode but in opposite assembly modes (``sign det A``).
No motion joins them without passing ``det A = 0``, where the actuators lose control of one
direction of the platform: the crossing has to use the platform's inertia and gravity within
the actuator force limits.  Crossing is the goal here, so it does not end the episode; a
physics breakdown still does (a failure).

**Feasibility (how the sampler checks it).**  Start and target are drawn like the reach task's
poses (reachable, in stroke away from the end stops, both margins above thresholds, holdable
with at most 75 % of the actuator force; :mod:`planar3p_gym.task`) in the episode's working
mode, the target in the other assembly mode.  The pair is kept when

1. *kinematics*: the straight path in pose space between them stays reachable within the
   stroke (``CrossingLimits.travel_margin`` kept free), keeps every leg's serial margin above
   ``CrossingLimits.min_serial_margin`` (so no working-mode change happens on the way), and
   changes ``sign det A`` exactly once (:func:`crossing_path`); and
2. *dynamics* (``verify=True``, the default): the demonstration motion of
   :func:`demonstration_travels` -- the travels of that pose path followed slowly with a
   minimum-jerk time law by the simulated, force-limited servos (:class:`TravelCurve`) --
   ends, in the simulation the environment uses (same design, control rate, substeps, solver
   iterations, projection), in the target's assembly mode within
   ``CrossingLimits.verify_tolerance`` (pose distance) of the target with no physics
   breakdown (:func:`verify_crossing`).  From there the target is a reach within one assembly
   mode.  So every sampled episode has been crossed, in the same simulator, by an open-loop
   command sequence a policy could issue.

Working mode: the default design has poses in both assembly modes (holdable, with margins) only
in the working modes ``(+1, +1, +1)``, ``(-1, -1, -1)`` and the sparsely populated
``(+1, -1, +1)``, ``(-1, +1, -1)``; the registered id uses ``(+1, +1, +1)``.

**Gravity.**  At a parallel singularity the platform has a free motion ``n`` the actuators
cannot resist; a singular pose can be held at rest only where the weight does not push along
``n``.  On the default design no singular pose of ``(+1, +1, +1)`` with serial margin >= 0.1 is
such a pose (:func:`gravity_alignment`: ``|cos(n, c)| >= 0.12``), so under gravity the servos
saturate near ``det A = 0`` and the platform falls across, usually onto another branch of the
direct kinematics.  With the plain solver (8 substeps, 18 iterations) the demonstration
motion ended within 1 cm of the target in 0 of 25 + 25 candidate pairs (peak slider rate 0.05
and 0.2 m/s), so such a design is rejected at construction.  The projected physics
(``projection=True``) lets half the candidates pass, but its energy balance through those
crossings is off by about 1 J (the servos do 0.7 J; README, "Crossing fidelity"), so the
registered id uses the default design mounted horizontally, ``gravity = 0``
(:func:`planar3p_gym.assembly_change_env.assembly_change_design`), where both physics agree.

Episode spec: ``{"task": "assembly_change", "working_mode", "start", "target"}``.  Reset options:
``start``, ``target``, ``working_mode`` (any subset; a requested pair must pass the checks,
including the simulated demonstration when ``verify`` is on).

Observation: the 31 reach entries, then ``target_travels`` (m, 3 entries),
``target_assembly`` (+-1), and ``signed_parallel_margin`` (``sign det A`` times the parallel
margin of the current configuration: it passes through 0 at the crossing).

Metrics in ``info``: ``target_assembly``, ``in_target_assembly`` (``sign det A`` equals the
target's), ``crossings`` (changes of ``sign det A`` so far).  Success: the reach test (pose
within tolerances, at rest) in the target's assembly mode.

Reward: the reach reward's terms except the parallel-margin barrier (the task is to pass the
parallel singularity; the serial-margin barrier stays).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import kinematics, task
from ..design import Design
from ..physics import Planar3PSim, SimState
from ..scalar_kinematics import ConfigurationMeasures, ScalarKinematics
from .base import ModeTriple, Pose, Task, mode_option, pose_list

__all__ = [
    "AssemblyChangeTask",
    "CrossingLimits",
    "TravelCurve",
    "crossing_path",
    "demonstration_travels",
    "gravity_alignment",
    "pose_path_travels",
    "verify_crossing",
]

FloatArray = NDArray[np.float64]
#: Candidate pairs tried per working mode at construction to show that episodes exist.
BIND_TRIES = 10
#: ... drawn from this many independent samplers (fixed seeds 0, 1, ...).
BIND_SEEDS = 5
#: Smallest fraction of feasible candidates for a working mode to be used (below it sampling
#: would be slow and could fail).
MIN_FEASIBLE_RATE = 0.5
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
        if not (isinstance(self.points, int) and self.points >= 2):
            raise ValueError(f"CrossingLimits.points must be an int >= 2, got {self.points!r}")
        if not isinstance(self.verify, bool):
            raise ValueError(f"CrossingLimits.verify must be a bool, got {self.verify!r}")
        for name, lo, hi in (
            ("min_serial_margin", 0.0, 1.0),
            ("travel_margin", 0.0, 0.5),
        ):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and lo <= v < hi):
                raise ValueError(f"CrossingLimits.{name} must be in [{lo}, {hi}), got {v!r}")
        for name in ("travel_gain", "verify_tolerance"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"CrossingLimits.{name} must be finite and > 0, got {v!r}")
        if not (isinstance(self.speed_fraction, (int, float)) and 0 < self.speed_fraction <= 1):
            raise ValueError(
                f"CrossingLimits.speed_fraction must be in (0, 1], got {self.speed_fraction!r}"
            )


def _straight(start: ArrayLike, target: ArrayLike, points: int) -> FloatArray:
    s = np.asarray(start, dtype=np.float64)
    t = np.asarray(target, dtype=np.float64)
    delta = t - s
    delta[2] = (delta[2] + math.pi) % (2.0 * math.pi) - math.pi
    u = np.linspace(0.0, 1.0, points)[:, None]
    return s + u * delta


def pose_path_travels(
    design: Design, start: ArrayLike, target: ArrayLike, mode: ArrayLike, points: int = 200
) -> FloatArray:
    """Travels (m) ``(points, 3)`` along the straight pose path from ``start`` to ``target``
    (poses, m, m, rad; shortest rotation) in working mode ``mode``; NaN where a leg cannot
    close.  Smooth through a parallel singularity (only ``A`` loses rank there)."""
    path = _straight(start, target, points)
    return kinematics.inverse(design, path, np.asarray(mode, dtype=np.float64)).rho


def crossing_path(
    design: Design, start: ArrayLike, target: ArrayLike, mode: ArrayLike, limits: CrossingLimits
) -> tuple[bool, str]:
    """Kinematic condition of an assembly change: ``(ok, reason)``; ``reason`` is ``"ok"``,
    ``"stroke"`` (a pose of the straight path leaves the stroke or cannot close),
    ``"serial_margin"`` or ``"crossings"`` (``sign det A`` does not change exactly once)."""
    path = _straight(start, target, limits.points)
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


class TravelCurve:
    """Minimum-jerk motion along a sampled travel curve ``(n, 3)`` (m), whose peak slider rate
    is ``peak`` (m/s)."""

    def __init__(self, travels: FloatArray, peak: float) -> None:
        travels = np.asarray(travels, dtype=np.float64)
        n = len(travels)
        if travels.ndim != 2 or travels.shape[1] != 3 or n < 2:
            raise ValueError(f"travels must have shape (n >= 2, 3), got {travels.shape}")
        if not (math.isfinite(peak) and peak > 0):
            raise ValueError(f"peak must be finite and > 0 (m/s), got {peak!r}")
        self.travels = travels
        self.slopes = np.gradient(travels, 1.0 / (n - 1), axis=0)  # d rho / d s (m)
        # the minimum-jerk s(t) peaks at s_dot = 1.875 / T
        self.duration = max(1.875 * float(np.abs(self.slopes).max()) / peak, 1e-3)
        self._n = n

    def reference(self, t: float) -> tuple[FloatArray, FloatArray]:
        """Travels (m) and rates (m/s) of the reference at time ``t`` (s)."""
        u = min(max(t / self.duration, 0.0), 1.0)
        s = u**3 * (10.0 - 15.0 * u + 6.0 * u * u)
        s_dot = 30.0 * u * u * (1.0 - u) ** 2 / self.duration
        x = s * (self._n - 1)
        j = min(int(x), self._n - 2)
        w = x - j
        rho = (1.0 - w) * self.travels[j] + w * self.travels[j + 1]
        slope = (1.0 - w) * self.slopes[j] + w * self.slopes[j + 1]
        return rho, s_dot * slope

    def command(self, t: float, rho: ArrayLike, gain: float, max_speed: float) -> FloatArray:
        """Slider velocity command (m/s) at time ``t`` (s) for measured travels ``rho`` (m):
        the reference rate one control period ahead plus ``gain`` times the travel error,
        clipped to ``max_speed``."""
        ref, rate = self.reference(t)
        return np.clip(rate + gain * (ref - np.asarray(rho)), -max_speed, max_speed)


def demonstration_travels(
    design: Design, start_rho: ArrayLike, start: ArrayLike, target: ArrayLike, mode: ArrayLike
) -> FloatArray:
    """The demonstration's travel curve ``(200, 3)`` (m): the straight pose path's travels in
    ``mode``, beginning at the measured travels ``start_rho``; where a leg cannot close on the
    way, the straight travel line to the target's travels instead."""
    travels = pose_path_travels(design, start, target, mode)
    r0 = np.asarray(start_rho, dtype=np.float64)
    if not np.isfinite(travels).all():
        end = kinematics.inverse(design, target, np.asarray(mode, dtype=np.float64)).rho
        end = np.where(np.isfinite(end), end, r0)
        u = np.linspace(0.0, 1.0, len(travels))[:, None]
        travels = r0 + u * (end - r0)
    travels[0] = r0
    return travels


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
    kin = ScalarKinematics(design)
    state = sim.state
    target_asm = -kin.measures(state.pose, state.rho).det_sign
    curve = TravelCurve(
        demonstration_travels(design, state.rho, s, t, mode),
        limits.speed_fraction * design.max_speed,
    )
    steps = int(math.ceil(curve.duration / sim.dt)) + 1
    worst = 0.0
    for k in range(steps):
        v0, v1, v2 = curve.command(
            (k + 1) * sim.dt, state.rho, limits.travel_gain, design.max_speed
        ).tolist()
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


class AssemblyChangeTask(Task):
    """Reach a target pose in the other assembly mode (see the module docstring).

    Args:
        limits: :class:`CrossingLimits` of the feasibility checks (or a dict of its fields).
        pair_tries: target candidates tried per start pose before another start is drawn.
    """

    name: ClassVar[str] = "assembly_change"
    option_keys: ClassVar[tuple[str, ...]] = ("start", "target", "working_mode")
    termination_reasons: ClassVar[tuple[str, ...]] = ("success", "physics_breakdown")
    failure_reasons: ClassVar[tuple[str, ...]] = ("physics_breakdown",)
    metric_keys: ClassVar[tuple[str, ...]] = (
        "target_assembly",
        "in_target_assembly",
        "crossings",
    )
    #: Passing the parallel singularity is the task: no parallel barrier in the reward.
    parallel_barrier: ClassVar[bool] = False

    def __init__(self, limits: CrossingLimits | dict | None = None, pair_tries: int = 8) -> None:
        if isinstance(limits, dict):
            limits = CrossingLimits(**limits)
        if limits is not None and not isinstance(limits, CrossingLimits):
            raise ValueError(f"limits must be a CrossingLimits or a dict, got {limits!r}")
        if not (isinstance(pair_tries, int) and pair_tries >= 1):
            raise ValueError(f"pair_tries must be an int >= 1, got {pair_tries!r}")
        self.limits = limits or CrossingLimits()
        self.pair_tries = pair_tries

    # ------------------------------------------------------------------ set-up
    def arguments(self) -> dict[str, Any]:
        return {"limits": asdict(self.limits), "pair_tries": self.pair_tries}

    def bind(self, env: Any) -> None:
        super().bind(env)
        self._target: Pose = (0.0, 0.0, 0.0)
        self._target_rho = (0.0, 0.0, 0.0)
        self._target_asm = 1
        self._last_sign = 1
        self._crossings = 0
        self._kin = ScalarKinematics(env.design)
        self.modes = self._modes_with_both()
        if not self.modes:
            raise ValueError(
                f"no working mode among {env.modes} has acceptable poses in both assembly "
                "modes on this design: no assembly change can be sampled"
            )
        self.modes = [m for m in self.modes if self._feasible_rate(m) >= MIN_FEASIBLE_RATE]
        if not self.modes:
            raise ValueError(
                "too few feasible assembly changes on this design (fewer than "
                f"{MIN_FEASIBLE_RATE:.0%} of {BIND_TRIES} candidate pairs per working mode, fixed "
                "internal seed): the simulated demonstration crossing does not reach the target "
                "(under gravity the platform falls onto another branch of the direct "
                "kinematics; see the module docstring). Use "
                "gravity=0 (the default design of Planar3PAssemblyChange-v0) or "
                "crossing_limits={'verify': False}"
            )

    def _modes_with_both(self) -> list[ModeTriple]:
        """The environment's working modes with acceptable poses of both assembly modes (fixed
        internal seed: never consumes the episode's random stream)."""
        rng = np.random.default_rng(0)
        out = []
        for m in self.env.modes:
            try:
                _, asm = task.sample_poses(
                    self.env.design, m, rng, self.env.task_config, max_batches=20
                )
            except ValueError:
                continue
            found = set(asm.tolist())
            for _ in range(20):
                if {1.0, -1.0} <= found:
                    break
                _, more = task.sample_poses(self.env.design, m, rng, self.env.task_config)
                found |= set(more.tolist())
            if {1.0, -1.0} <= found:
                out.append(tuple(m))
        return out  # type: ignore[return-value]

    def _feasible_rate(self, mode: ModeTriple) -> float:
        """Fraction of :data:`BIND_TRIES` candidate pairs (fixed internal seed: the episode's
        random stream is not touched) that are feasible."""
        hits = 0
        for seed in range(BIND_SEEDS):  # poses of one sampler batch are alike: several batches
            rng = np.random.default_rng(seed)
            sampler = task.PoseSampler(self.env.design, mode, self.env.task_config)
            for _ in range(BIND_TRIES // BIND_SEEDS):
                s, asm = sampler.draw(rng)
                t = sampler.draw_many(rng, -asm, 1)[0]
                hits += bool(self.feasible(s, t, mode)[0])
        return hits / (BIND_SEEDS * (BIND_TRIES // BIND_SEEDS))

    def make_sim(self, pose: np.ndarray, mode: tuple[int, int, int]) -> Planar3PSim:
        """A simulation with the environment's settings (what an episode runs on)."""
        env = self.env
        kwargs: dict[str, Any] = {
            "dt": env.dt,
            "substeps": env.substeps,
            "iterations": env.solver_iterations,
        }
        if getattr(env, "projection", False):
            kwargs["projection"] = True
        return Planar3PSim(env.design, pose, mode, **kwargs)

    # ------------------------------------------------------------------ options and sampling
    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        if options.get("working_mode") is not None:
            options["working_mode"] = mode_option(options["working_mode"], "working_mode")
        mode = options.get("working_mode")
        if mode is None and len(self.modes) == 1:
            mode = self.modes[0]
        if mode is not None:
            for name in ("start", "target"):
                if options.get(name) is not None:
                    options[name] = task.check_pose(self.env.design, options[name], mode, name)
        return options

    def _assembly(self, pose: np.ndarray, mode: ModeTriple) -> int:
        design = self.env.design
        return int(
            kinematics.assembly_mode(design, pose, kinematics.inverse(design, pose, mode).rho)
        )

    def feasible(self, start: np.ndarray, target: np.ndarray, mode: ModeTriple) -> tuple[bool, str]:
        """Whether ``(start, target)`` in ``mode`` passes the task's checks: ``(ok, reason)``."""
        design = self.env.design
        if self._assembly(start, mode) == self._assembly(target, mode):
            return False, "start and target are in the same assembly mode (sign det A)"
        ok, reason = crossing_path(design, start, target, mode, self.limits)
        if not ok:
            return False, f"the straight pose path fails the kinematic check ({reason})"
        if self.limits.verify:
            ok, fig = verify_crossing(
                design,
                start,
                target,
                mode,
                self.limits,
                self.make_sim,
                self.env.breakdown_distance,
            )
            if not ok:
                return False, (
                    "the simulated demonstration crossing does not reach the target "
                    f"(ends {fig['end_distance']:.4g} m away in assembly mode "
                    f"{fig['end_assembly']:+d})"
                )
        return True, "ok"

    def episode_spec(self, rng: np.random.Generator, options: dict[str, Any]) -> dict[str, Any]:
        design = self.env.design
        mode = options.get("working_mode")
        if mode is None:
            mode = (
                self.modes[int(rng.integers(len(self.modes)))]
                if len(self.modes) > 1
                else (self.modes[0])
            )
        start, target = options.get("start"), options.get("target")
        if start is not None:
            start = task.check_pose(design, start, mode, "start")
        if target is not None:
            target = task.check_pose(design, target, mode, "target")
        if start is not None and target is not None:
            ok, reason = self.feasible(start, target, mode)
            if not ok:
                raise ValueError(f"infeasible assembly change from start to target: {reason}")
        else:
            start, target = self._draw(rng, mode, start, target)
        return {
            "task": self.name,
            "working_mode": [int(m) for m in mode],
            "start": pose_list(start),
            "target": pose_list(target),
        }

    def _draw(
        self,
        rng: np.random.Generator,
        mode: ModeTriple,
        start: np.ndarray | None,
        target: np.ndarray | None,
    ) -> tuple[np.ndarray, np.ndarray]:
        sampler = self.pose_sampler(mode)
        for _ in range(1000):
            if start is None:
                s, asm = sampler.draw(rng)
            else:
                s, asm = start, float(self._assembly(start, mode))
            if target is None:
                cands = sampler.draw_many(rng, -asm, self.pair_tries)
            else:
                cands = target[None, :]
            for t in cands:
                if self.feasible(s, t, mode)[0]:
                    return s, t
            if start is not None and target is not None:
                break
        if start is None and target is None:
            raise ValueError(
                f"no feasible assembly change found in working mode {mode} after many draws"
            )
        fixed = "start" if start is not None else "target"
        raise ValueError(
            f"no feasible assembly change found for the requested {fixed} in working mode "
            f"{mode}; give another {fixed} or leave it to the sampler"
        )

    def begin(self, spec: dict[str, Any]) -> tuple[np.ndarray, tuple[int, int, int]]:
        mode = mode_option(spec["working_mode"], "working_mode")
        tx, ty, tth = spec["target"]
        self._target = (float(tx), float(ty), float(tth))
        rho = kinematics.inverse(self.env.design, self._target, mode).rho
        self._target_rho = (float(rho[0]), float(rho[1]), float(rho[2]))
        self._target_asm = self._assembly(np.asarray(self._target), mode)
        self._last_sign = -self._target_asm
        self._crossings = 0
        return np.asarray(spec["start"], dtype=np.float64), mode

    # ------------------------------------------------------------------ per step
    def reference(self, step: int) -> Pose:
        return self._target

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.travel_bounds(2)  # target travels, target assembly, signed parallel margin

    def observation_extra(self, step: int) -> list[float]:
        state = self.env.sim.state
        m = self._kin.measures(state.pose, state.rho)
        signed = (m.det_sign if m.det_sign else 1) * m.parallel_margin
        return [
            *self._target_rho,
            float(self._target_asm),
            signed if math.isfinite(signed) else 0.0,
        ]

    def termination(
        self,
        state: SimState,
        measures: ConfigurationMeasures,
        errors: tuple[float, float],
        assembly: int,
    ) -> str | None:
        sign = measures.det_sign
        if sign != 0 and sign != self._last_sign:
            self._crossings += 1
            self._last_sign = sign
        if sign == self._target_asm and self.is_success(state, errors):
            return "success"
        return None

    def step_info(self, step: int, state: SimState, errors: tuple[float, float]) -> dict[str, Any]:
        return {
            "target_assembly": self._target_asm,
            "in_target_assembly": self._last_sign == self._target_asm,
            "crossings": self._crossings,
        }


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
    :mod:`planar3p_gym.statics`, ``g c`` is the gradient of the potential energy).  The
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
