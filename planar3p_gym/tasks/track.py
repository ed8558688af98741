"""Trajectory tracking: the task of ``Planar3PTrack-v0`` (follow a moving reference pose; the
id's page is :class:`planar3p_gym.envs.track.Planar3PTrackEnv`).

The references (``"segments"``, ``"figure_eight"``, ``"mixed"``) are drawn, checked along their
whole length and tracked here; their form and the pose and velocity at a time are in
:mod:`planar3p_gym.tasks.track_references`.  How each kind is drawn and the episode spec:
docs/environments.md, "How the task modules work".

* :class:`TrackTask`: the task (reference drawn at reset, errors and reward against it, the
  metrics :data:`TRACKING_METRICS`); :class:`TrackKernel`: its compiled step outputs;
* :data:`EIGHT_AMPLITUDES`, :data:`EIGHT_SCALES`: the figure-eight's amplitudes and their
  scale-downs.
"""

from __future__ import annotations

import itertools
import math
from typing import Any, ClassVar

import numpy as np
from numba import njit

from planar3p_gym import checks
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures
from planar3p_gym.sim.physics import SimState
from planar3p_gym.tasks import sampling as task
from planar3p_gym.tasks.base import Pose, Task, pose_list
from planar3p_gym.tasks.kernel import (
    CompiledKernel,
    Episode,
    KernelSettings,
    ReachKernel,
    Sensing,
    StepKernel,
    StepOutputs,
)
from planar3p_gym.tasks.motions import MIN_JERK_PEAK
from planar3p_gym.tasks.observation import SPEED_BOUND_FACTOR
from planar3p_gym.tasks.reach_step import rejudge_row
from planar3p_gym.tasks.track_references import (
    CHECK_POINTS,
    MIN_DURATION,
    REFERENCE_KINDS,
    eight_curve,
    parse_reference,
    reference_at,
    reference_samples,
)

__all__ = [
    "DRAW_KINDS",
    "EIGHT_AMPLITUDES",
    "MIXED",
    "REFERENCE_KINDS",
    "RUNNING_SIZE",
    "SAMPLE_CHUNK",
    "TRACKING_METRICS",
    "TrackKernel",
    "TrackTask",
    "accumulate_errors",
    "track_rows",
    "tracking_errors",
]

#: Reference samples computed at a reset (control steps): :meth:`TrackTask.sample` extends
#: them, doubling, as the episode goes on (a reset computes few; an episode of the registered
#: 500 steps computes 512 in all).
SAMPLE_CHUNK = 32
#: Length of ``TrackTask.running`` (three sums of squares, three maxima, the count).
RUNNING_SIZE = 7

#: The constructor's ``reference`` value that draws either kind per episode.
MIXED = "mixed"
#: Accepted values of the constructor's ``reference``.
DRAW_KINDS = (*REFERENCE_KINDS, MIXED)

#: Ranges the figure-eight amplitudes are drawn from: ``ax`` (m), ``ay`` (m), ``|atheta|`` (rad).
EIGHT_AMPLITUDES = ((0.02, 0.06), (0.01, 0.03), (0.0, 0.25))
#: Scales tried on drawn figure-eight amplitudes that do not fit, in order.
EIGHT_SCALES = (1.0, 0.7, 0.5, 0.35, 0.25)
#: A working mode is used for figure-eights when at least this many of
#: :data:`EIGHT_MODE_TRIALS` drawn eights fit in it.
EIGHT_MODE_ACCEPTS = 3
EIGHT_MODE_TRIALS = 16
#: Draws of a reference before the sampler gives up (``ValueError``; never reached in a working
#: mode the environment draws from) ...
DRAW_ROUNDS = 1000
#: ... and when the start is requested (a budget: a start that cannot begin a reference is
#: rejected after this many tries).
GIVEN_ROUNDS = 20
#: Figure-eight ramp-up time from rest (s).
EIGHT_RAMP = 1.0
#: ``info`` keys of the tracking metrics.
TRACKING_METRICS = (
    "tracking_error",
    "tracking_rms_error",
    "tracking_max_error",
    "tracking_rms_position_error",
    "tracking_max_position_error",
    "tracking_rms_orientation_error",
    "tracking_max_orientation_error",
)


class TrackTask(Task):
    """Follow a moving reference pose (see the module docstring).

    Args:
        reference: ``"segments"``, ``"figure_eight"`` or ``"mixed"`` (either, per episode).
        speed_fraction: largest slider rate the reference needs, as a fraction of
            ``max_speed`` (leaves the rest for feedback), in ``(0, 1]``.
        duration: time covered by random segments (s); the reference then rests.
    """

    name: ClassVar[str] = "track"
    hooks_family: ClassVar[str | None] = "track"
    observation_fields = (
        ("reference_velocity", 3, "x_dot, y_dot, theta_dot of the reference (m/s, m/s, rad/s)"),
    )
    option_keys: ClassVar[tuple[str, ...]] = ("start", "working_mode", "reference")
    termination_reasons: ClassVar[tuple[str, ...]] = ("singularity_crossing", "physics_breakdown")
    metric_keys: ClassVar[tuple[str, ...]] = TRACKING_METRICS

    def __init__(
        self, reference: str = "segments", speed_fraction: float = 0.5, duration: float = 10.0
    ) -> None:
        self.kind = checks.choice(reference, "reference", DRAW_KINDS)
        self.speed_fraction = checks.number(
            speed_fraction, "speed_fraction", low=0.0, high=1.0, low_open=True
        )
        self.duration = checks.number(duration, "duration", low=MIN_DURATION, high=3600.0, unit="s")

    # ------------------------------------------------------------------ set-up
    def arguments(self) -> dict[str, Any]:
        return {
            "reference": self.kind,
            "speed_fraction": self.speed_fraction,
            "duration": self.duration,
        }

    def bind(self, env: Any) -> None:
        super().bind(env)
        self._ref: dict[str, Any] = {}
        #: The episode's reference at its steps so far computed
        #: (:func:`~planar3p_gym.tasks.track_references.reference_samples`: pose, cos and
        #: sin theta, velocity), extended by :meth:`sample`.
        self.samples = np.zeros((0, 8))
        #: The running tracking errors: the sums of squares and the maxima of the pose,
        #: position and orientation errors (m^2, m^2, rad^2; m, m, rad), then the steps
        #: counted (:func:`accumulate_errors`).
        self.running = np.zeros(RUNNING_SIZE)
        kinds = REFERENCE_KINDS if self.kind == MIXED else (self.kind,)
        self._draw_modes = {kind: self._reference_modes(kind) for kind in kinds}
        self._mode_problems: dict[tuple[str, tuple[int, int, int]], str | None] = {}

    def _reference_modes(self, kind: str) -> list[tuple[int, int, int]]:
        """The env's working modes in which references of ``kind`` are drawn: all of them for
        segments; for the figure-eight those where at least :data:`EIGHT_MODE_ACCEPTS` of
        :data:`EIGHT_MODE_TRIALS` drawn eights fit (fixed internal seed, so the list never
        depends on, or consumes, the episode's random stream); ``ValueError`` if none."""
        modes = list(self.env.modes)
        if kind == "segments":
            return modes
        rng = np.random.default_rng(0)
        usable = []
        for mode in modes:
            sampler = self.pose_sampler(mode)
            fits = sum(
                self._draw_eight(rng, mode, None) is not None for _ in range(EIGHT_MODE_TRIALS)
            )
            sampler.clear()
            if fits >= EIGHT_MODE_ACCEPTS:
                usable.append(mode)
        if not usable:
            raise ValueError(
                f"figure-eight references hardly fit in working mode(s) {modes} of this design "
                f"(fewer than {EIGHT_MODE_ACCEPTS} of {EIGHT_MODE_TRIALS} drawn eights, "
                f"amplitudes down to {EIGHT_SCALES[-1]} of {EIGHT_AMPLITUDES}); use "
                "reference='segments' or another working mode"
            )
        return usable

    def _mode_problem(self, kind: str, mode: tuple[int, int, int]) -> str | None:
        """Why references of ``kind`` cannot be drawn in a requested working ``mode`` that is
        not among the env's drawn ones, or ``None`` (bounded: :func:`~planar3p_gym.tasks.
        sampling.check_mode`, and for the figure-eight :data:`EIGHT_MODE_TRIALS` drawn eights
        with a fixed internal seed, from a sampler of their own; cached)."""
        key = (kind, mode)
        if key not in self._mode_problems:
            env = self.env
            problem = None
            if not task.has_pairs(env.design, mode, env.task_config):
                problem = "it has no start/target pair meeting the task's margins"
            elif kind == "figure_eight":
                rng = np.random.default_rng(0)
                sampler = task.PoseSampler(env.design, mode, env.task_config)
                fits = sum(
                    self._draw_eight(rng, mode, None, sampler) is not None
                    for _ in range(EIGHT_MODE_TRIALS)
                )
                if fits < EIGHT_MODE_ACCEPTS:
                    problem = (
                        f"fewer than {EIGHT_MODE_ACCEPTS} of {EIGHT_MODE_TRIALS} drawn "
                        "figure-eights fit in it"
                    )
            self._mode_problems[key] = problem
        return self._mode_problems[key]

    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        ref = options.get("reference")
        requested = options.get("working_mode")
        if requested is not None:
            if ref is not None and isinstance(ref, dict) and ref.get("kind") in REFERENCE_KINDS:
                kinds: tuple[str, ...] = ()  # a given reference is checked in full below
            else:
                kinds = tuple(self._draw_modes)
            for kind in kinds:
                if requested in self._draw_modes[kind]:
                    continue
                problem = self._mode_problem(kind, requested)
                if problem is not None:
                    raise ValueError(
                        f"working_mode {requested} cannot have {kind} references: {problem}"
                    )
        if ref is not None:
            options["reference"] = parse_reference(ref)
            start = self._reference_at(options["reference"], 0)[0]
            if options.get("start") is not None:
                given = self.finite_pose(options["start"], "start")
                if np.abs(wrap_angle(given - start)).max() > 1e-9:
                    raise ValueError(
                        f"start {given.tolist()} is not the reference's initial pose "
                        f"{start.tolist()}"
                    )
            options["start"] = start
        mode = self.known_mode(options)
        if mode is not None:
            self._check_start_and_reference(options, mode)
        return options

    def _check_start_and_reference(self, options: dict[str, Any], mode: Any) -> None:
        if options.get("start") is not None:
            options["start"] = task.check_pose(self.env.design, options["start"], mode, "start")
        if options.get("reference") is not None:
            problem = self._reference_problem(options["reference"], mode)
            if problem:
                raise ValueError(f"reference is not feasible in working mode {mode}: {problem}")

    def episode_spec(self, rng: np.random.Generator, options: dict[str, Any]) -> dict[str, Any]:
        ref = options.get("reference")
        kind = self.kind
        if kind == MIXED:
            kind = ref["kind"] if ref is not None else REFERENCE_KINDS[int(rng.integers(2))]
        mode = self.known_mode(options)
        if mode is None:
            modes = self._draw_modes[kind]
            mode = modes[int(rng.integers(len(modes)))]
            self._check_start_and_reference(options, mode)
        if ref is None:
            draw = self._draw_segments if kind == "segments" else self._draw_eight
            start = options.get("start")
            ref = None
            for _ in range(DRAW_ROUNDS if start is None else GIVEN_ROUNDS):
                ref = draw(rng, mode, start)
                if ref is not None:
                    break
            if ref is None:
                raise ValueError(
                    f"could not build a {kind} reference from start {start} in working "
                    f"mode {mode} under the task's margins"
                )
        start = self._reference_at(ref, 0)[0]
        return {
            "task": self.name,
            "working_mode": [int(m) for m in mode],
            "start": pose_list(start),
            "reference": ref,
        }

    def begin(self, spec: dict[str, Any]) -> tuple[np.ndarray, tuple[int, int, int]]:
        self._ref = parse_reference(spec["reference"])
        self.samples = reference_samples(self._ref, self.env.dt, 0, SAMPLE_CHUNK)
        self.running = np.zeros(RUNNING_SIZE)
        mode = tuple(int(m) for m in spec["working_mode"])
        return np.asarray(spec["start"], dtype=np.float64), mode  # type: ignore[return-value]

    # ------------------------------------------------------------------ reference
    def _reference_at(self, ref: dict[str, Any], step: int) -> tuple[np.ndarray, np.ndarray]:
        """Reference pose and velocity at ``step`` control steps (m, rad; m/s, rad/s)."""
        return reference_at(ref, step * self.env.dt)

    def sample(self, step: int) -> np.ndarray:
        """The reference at ``step`` control steps: a row of ``samples`` (pose (m, m,
        rad), ``cos theta``, ``sin theta``, velocity (m/s, m/s, rad/s)), the samples extended
        to cover it (at least doubled) where they end before it."""
        have = self.samples.shape[0]
        if step >= have:
            more = reference_samples(self._ref, self.env.dt, have, max(step + 1, 2 * have))
            self.samples = np.concatenate([self.samples, more])
        return self.samples[step]

    def reference(self, step: int) -> Pose:
        x, y, theta = self.sample(step)[:3].tolist()
        return x, y, theta

    # ------------------------------------------------------------------ feasibility
    def _limits(self, assembly: float | None) -> dict[str, Any]:
        """The tests a reference's poses pass (the screens' keyword arguments): travels in
        the task's band, the path margins, and ``sign det A == assembly``."""
        cfg = self.env.task_config
        return {
            "travel": self.env.design.travel_band(cfg.travel_margin),
            "min_parallel": cfg.path_parallel_margin,
            "min_serial": cfg.path_serial_margin,
            "assembly": assembly,
        }

    def _screen(self, paths: np.ndarray, mode: Any, assembly: float | None) -> np.ndarray:
        return kinematics.screen_paths(
            self.env.design, paths, np.asarray(mode, dtype=np.float64), **self._limits(assembly)
        )

    def _assembly(self, pose: np.ndarray, mode: Any) -> float:
        design = self.env.design
        rho = kinematics.inverse(design, pose, mode).rho
        return float(kinematics.assembly_mode(design, pose, rho))

    def _peak_rate(self, poses: np.ndarray, mode: Any) -> float:
        """Largest ``|d rho / d(parameter)|`` along densely sampled poses ``(n, 3)`` spanning
        a unit parameter interval (m per unit parameter)."""
        return _peak_of(kinematics.inverse(self.env.design, poses, mode).rho)

    def _screened_travels(self, path: np.ndarray, mode: Any, assembly: float) -> Any:
        """The travels ``(n, 3)`` (m) of ``path`` if it passes :meth:`_screen` (the same
        decision: every pose passes), else ``None``; one screen instead of a screen and an
        inverse (the screen's travels are the inverse's, bit for bit)."""
        screening = kinematics.screen_poses(
            self.env.design, path, np.asarray(mode, dtype=np.float64), **self._limits(assembly)
        )
        return screening.rho if screening.ok.all() else None

    def _reference_problem(self, ref: dict[str, Any], mode: Any) -> str | None:
        """Why ``ref`` is infeasible in ``mode`` (None if it is feasible)."""
        if ref["kind"] == "segments":
            wps = np.asarray(ref["waypoints"])
            asm = self._assembly(wps[0], mode)
            for i, (a, b) in enumerate(itertools.pairwise(wps)):
                path = task.interpolate(a, b, CHECK_POINTS)
                if not self._screen(path, mode, asm):
                    return f"segment {i} leaves the stroke, its margins or the assembly mode"
            return None
        curve = eight_curve(ref)
        if not self._screen(curve, mode, self._assembly(curve[0], mode)):
            return "the curve leaves the stroke, its margins or the assembly mode"
        return None

    # ------------------------------------------------------------------ sampling
    def _draw_start(
        self,
        rng: np.random.Generator,
        mode: Any,
        start: Any,
        sampler: task.PoseSampler | None = None,
    ) -> tuple[np.ndarray, float]:
        """The given start or one drawn from ``sampler`` (by default the task's), with its
        assembly mode (``sign det A``: the sampler's, else computed)."""
        if start is not None:
            pose = np.asarray(start, dtype=np.float64)
            return pose, self._assembly(pose, mode)
        return (self.pose_sampler(mode) if sampler is None else sampler).draw(rng)

    def _draw_segments(
        self, rng: np.random.Generator, mode: Any, start: Any
    ) -> dict[str, Any] | None:
        """Random waypoints and minimum-jerk durations covering ``duration`` (None if a
        waypoint could not be paired; the caller draws again)."""
        design, cfg = self.env.design, self.env.task_config
        vmax = self.speed_fraction * design.max_speed
        first, asm = self._draw_start(rng, mode, start)
        wps = [first]
        durations: list[float] = []
        while sum(durations) < self.duration:
            for _ in range(20):
                try:
                    _, nxt = task.sample_pair(
                        design, mode, rng, cfg, start=wps[-1], sampler=self.pose_sampler(mode),
                        assembly=asm,
                    )  # fmt: skip
                except ValueError:
                    return None
                path = task.interpolate(wps[-1], nxt, CHECK_POINTS)
                # The validation of requested references (travel margins included).
                rho = self._screened_travels(path, mode, asm)
                if rho is not None:
                    break
            else:
                return None
            peak = _peak_of(rho) * MIN_JERK_PEAK
            durations.append(max(peak / vmax, MIN_DURATION))
            wps.append(nxt)
        return {
            "kind": "segments",
            "waypoints": [pose_list(w) for w in wps],
            "durations": durations,
        }

    def _draw_eight(
        self,
        rng: np.random.Generator,
        mode: Any,
        start: Any,
        sampler: task.PoseSampler | None = None,
    ) -> dict[str, Any] | None:
        """A feasible figure-eight around a drawn (from ``sampler``, by default the task's) or
        the given centre (None if the drawn amplitudes do not fit; the caller draws again)."""
        design = self.env.design
        centre, asm = self._draw_start(rng, mode, start, sampler)
        (x0, x1), (y0, y1), (_, t1) = EIGHT_AMPLITUDES
        amp = np.array(
            [rng.uniform(x0, x1), rng.uniform(y0, y1), rng.uniform(-t1, t1)], dtype=np.float64
        )
        # Shrink the drawn eight until it fits, if it can (all scales screened at once).
        refs = [
            {
                "kind": "figure_eight",
                "centre": pose_list(centre),
                "amplitude": pose_list(scale * amp),
                "period": 1.0,
                "ramp": EIGHT_RAMP,
            }
            for scale in EIGHT_SCALES
        ]
        curves = np.stack([eight_curve(r) for r in refs])
        fits = self._screen(curves, mode, asm)
        if not fits.any():
            return None
        ref = refs[int(np.argmax(fits))]
        curve = curves[int(np.argmax(fits))]
        # Rates per radian of phase, times 2 pi / period at full speed.
        peak = self._peak_rate(curve, mode) / (2.0 * math.pi)
        ref["period"] = max(2.0 * math.pi * peak / (self.speed_fraction * design.max_speed), 2.0)
        return ref

    # ------------------------------------------------------------------ per step
    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        d = self.env.design
        v = SPEED_BOUND_FACTOR * d.max_speed
        w = v / d.characteristic_length
        high = np.array([v, v, w], dtype=np.float32)
        return -high, high

    def observation_extra(
        self, step: int, state: SimState, measures: ConfigurationMeasures
    ) -> list[float]:
        return self.sample(step)[5:].tolist()

    def is_success(self, state: SimState, errors: tuple[float, float]) -> bool:
        """Never: a tracking episode runs to its time limit (or a crossing / breakdown), so
        :meth:`Task.termination` only ever returns ``"singularity_crossing"`` here."""
        return False

    def kernel(self, settings: KernelSettings, machine: Sensing) -> StepKernel:
        """The compiled tracking kernel (:class:`TrackKernel`) on the projected physics of the
        nominal machine when the per-step hooks are the tracking task's own
        (:attr:`~planar3p_gym.tasks.base.Task.compiled_family`), else the reference."""
        if self.compiled_family == "track" and settings.projection and settings.nominal:
            return TrackKernel(self, settings, machine)
        return StepKernel(self, settings, machine)

    def step_info(self, step: int, state: SimState, errors: tuple[float, float]) -> dict[str, Any]:
        length = self.env.design.characteristic_length
        if step > 0:
            accumulate_errors(self.running, errors[0], errors[1], length)
        return self.tracking_info(step, errors)

    def tracking_info(self, step: int, errors: tuple[float, float]) -> dict[str, Any]:
        """The tracking metrics (:data:`TRACKING_METRICS`) after step ``step``, whose
        position (m) and orientation (rad) ``errors`` ``running`` holds."""
        length = self.env.design.characteristic_length
        values = self.running.tolist()
        sums, maxes, n = values[0:3], values[3:6], values[6]
        rms = [math.sqrt(v / n) for v in sums] if n else [0.0, 0.0, 0.0]
        return {
            "tracking_error": tracking_errors(errors[0], errors[1], length)[0] if step else 0.0,
            "tracking_rms_error": rms[0],
            "tracking_max_error": maxes[0],
            "tracking_rms_position_error": rms[1],
            "tracking_max_position_error": maxes[1],
            "tracking_rms_orientation_error": rms[2],
            "tracking_max_orientation_error": maxes[2],
        }


@njit(cache=True)
def tracking_errors(
    position_error: float, orientation_error: float, length: float
) -> tuple[float, float, float]:
    """The pose error ``|dp| + length |dtheta|`` (m), the position error (m) and ``|dtheta|``
    (rad) of a step's errors; ``length`` is the characteristic length (m)."""
    angle = abs(orientation_error)
    return position_error + length * angle, position_error, angle


@njit(cache=True)
def accumulate_errors(
    running: np.ndarray, position_error: float, orientation_error: float, length: float
) -> None:
    """Count a step's :func:`tracking_errors` into ``running`` (``TrackTask.running``:
    the sums of squares, the maxima, the count); a NaN maximum stays NaN, as
    ``np.maximum`` keeps it."""
    errors = tracking_errors(position_error, orientation_error, length)
    running[6] += 1.0
    for i in range(3):
        e = errors[i]
        running[i] += e * e
        m = running[3 + i]
        running[3 + i] = m if m >= e or m != m else e


@njit(cache=True)
def track_rows(
    rows: np.ndarray, steps: np.ndarray, samples: np.ndarray, res: np.ndarray,
    actions: np.ndarray, w: np.ndarray, length: float, low: np.ndarray, high: np.ndarray,
    running: np.ndarray, extra: np.ndarray, running_out: np.ndarray,
) -> None:  # fmt: skip
    """The tracking task's part of a batched step, after the reach outputs ``res``
    (``(len(RESULT_FIELDS), n)``) of the environments ``rows`` (int64 ``(n,)``, of a batch of
    ``N``) against their reference poses: for each stepped row ``j`` (environment ``i =
    rows[j]``, at step ``steps[i]``), the reference velocity entries of
    ``samples[i, steps[i]]`` (``(N, H, 8)``, ``TrackTask.samples``) as float32 clipped to
    ``[low, high]`` into ``extra[j]``, a step within the tolerances rejudged as no success
    (:func:`~planar3p_gym.tasks.reach_step.rejudge_row`), and ``running[i]`` (``(N, 7)``)
    with the step's errors counted (:func:`accumulate_errors`) into ``running_out[j]``.
    ``actions`` ``(N, 3)``: the clipped actions; ``w``: the reward weights; ``length``: the
    characteristic length (m)."""
    for j in range(rows.shape[0]):
        i = rows[j]
        row = samples[i, steps[i]]
        for d in range(3):
            v = min(np.float32(row[5 + d]), high[d])
            extra[j, d] = max(v, low[d])
        if res[1, j] == 1:  # (never a success for this task: within the tolerances, going on)
            rejudge_row(res, j, w, length, actions[i, 0], actions[i, 1], actions[i, 2], False)
        for d in range(RUNNING_SIZE):
            running_out[j, d] = running[i, d]
        accumulate_errors(running_out[j], res[2, j], res[3, j], length)


def _peak_of(rho: np.ndarray) -> float:
    """Largest ``|d rho / d(parameter)|`` (m per unit parameter) of travels ``(n, 3)`` at ``n``
    evenly spaced parameters spanning a unit interval."""
    return float(np.abs(np.diff(rho, axis=0)).max() * (len(rho) - 1))


class TrackKernel(CompiledKernel):
    """The tracking task's compiled kernel: the reach task's compiled outputs
    (:class:`~planar3p_gym.tasks.kernel.ReachKernel`: observation, errors, margins, reward
    terms) against the step's reference pose, with no success (a step within the tolerances is
    rejudged, :meth:`~planar3p_gym.tasks.kernel.ReachKernel.rejudge`), then the reference
    velocity entries and the tracking metrics (the task's hooks); the reference kernel where
    the physics broke down.  Its observations, margins and rewards are the reach kernel's:
    equal to the reference's to a few float64 rounding errors (``tests/tasks/test_track.py``)."""

    task: TrackTask
    moving_target = True

    def __init__(self, task: TrackTask, settings: KernelSettings, machine: Sensing) -> None:
        super().__init__(task, settings, machine)
        #: The reach task's compiled outputs, against each step's reference pose.
        self.reach = ReachKernel(task, settings, machine)

    def config_changed(self, tolerances: tuple[float, float, float]) -> None:
        self.reach.config_changed(tolerances)

    def set_target(self, ep: Episode) -> None:
        """The step's reference pose and its ``cos``/``sin theta`` from the episode's samples
        (:meth:`TrackTask.sample`)."""
        x, y, theta, c, s = self.task.sample(ep.steps)[:5].tolist()
        ep.target, ep.target_cs = (x, y, theta), (c, s)

    def compiled_step(
        self,
        ep: Episode,
        state: SimState,
        array: np.ndarray,
        action: tuple[float, float, float],
        rng: np.random.Generator,
    ) -> StepOutputs:
        task = self.task
        obs, reward, reason, info = self.reach.compiled_step(ep, state, array, action, rng)
        if reason == "success":  # (never for this task: within the tolerances, going on)
            reward, reason = self.reach.rejudge(info, action, False), None
        assert ep.measures is not None
        obs = ep.obs = self.with_extra(ep, obs, state, ep.measures)
        info.update(
            task.step_info(ep.steps, state, (info["position_error"], info["orientation_error"]))
        )
        return obs, reward, reason, info
