"""The task kernel: one step's outputs from the simulation's state, for every task.

After the physics step :class:`planar3p_gym.envs.core.Planar3PEnv` hands the task's kernel the
new state, the episode's record (:class:`Episode`) and the executed action; the kernel writes
the observation, the errors, the end code, the reward terms and the task's metrics.  Every id
takes this one path:

- :class:`StepKernel`, the reference: the task's hooks (:mod:`planar3p_gym.tasks.base`) on the
  state and the measures of the episode's machine, observed through the machine's sensing
  (:class:`Sensing`); it also handles the step where the physics broke down (the last good
  observation and errors kept, ``"physics_breakdown"``);
- :class:`CompiledKernel`, the base of the compiled kernels: the one step prologue (the
  reference kernel where there is no state array or the physics broke down, the moving
  reference's target of the step) before the kernel's :meth:`CompiledKernel.compiled_step`;
- :class:`ReachKernel`, the reach task's compiled kernel on the projected physics
  (:func:`planar3p_gym.tasks.reach_step.reach_outputs` on the simulation's state array), equal
  to the reference to float64 rounding (``tests/sim/test_batch_step.py``); :class:`HookKernel`,
  the compiled outputs with the task's hooks (and, in their modules, the goal and tracking
  tasks' kernels).

A task picks its kernel in :meth:`planar3p_gym.tasks.base.Task.kernel` from the
:class:`KernelSettings` the environment gives it; the environment never tests the task's type.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from gymnasium import spaces

from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures
from planar3p_gym.sim.physics import SimState
from planar3p_gym.tasks.observation import (
    bounds,
    build_observation,
    pose_errors,
    travel_goal_bounds,
    travel_goal_entries,
)
from planar3p_gym.tasks.reach_step import REASONS, TERMS_START, ReachStep
from planar3p_gym.tasks.rewards import TERM_NAMES, RewardWeights, weighted_terms

if TYPE_CHECKING:
    from planar3p_gym.machine.design import Design

__all__ = [
    "CompiledKernel",
    "Episode",
    "HookKernel",
    "KernelSettings",
    "ReachKernel",
    "ReachOutputsKernel",
    "Sensing",
    "StepKernel",
    "StepOutputs",
    "mode_changed",
]

#: A pose ``(x, y, theta)`` (m, m, rad).
Pose = tuple[float, float, float]
#: ``(observation, reward, termination reason, info)`` of a step.
StepOutputs = tuple[np.ndarray, float, "str | None", dict[str, Any]]


@dataclass
class Episode:
    """The environment's per-episode record (plain, deep-copyable data; snapshots copy it).

    Attributes:
        spec: the episode spec (:mod:`planar3p_gym.tasks.base`).
        steps: control steps taken.
        mode: working mode of the episode.
        target: the reference pose of the last step (m, m, rad); ``target_cs`` its
            ``(cos, sin)``; ``target_rho`` its slider travels (m, with ``travel_goal``).
        assembly: ``sign det A`` at the start.
        obs: the last observation (before any observation delay).
        measures: the last good state's measures (true machine).
        info: the last step's ``info``.
    """

    spec: dict[str, Any] = field(default_factory=dict)
    steps: int = 0
    mode: tuple[int, int, int] = (1, 1, -1)
    target: Pose = (0.0, 0.0, 0.0)
    target_cs: tuple[float, float] = (1.0, 0.0)
    target_rho: np.ndarray = field(default_factory=lambda: np.zeros(3))
    assembly: int = 0
    obs: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.float32))
    measures: ConfigurationMeasures | None = None
    info: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, spec: dict[str, Any], mode: tuple[int, int, int], target: Pose) -> Episode:
        """The record of an episode starting: its ``spec``, working ``mode`` and first
        reference ``target``."""
        return cls(spec, 0, mode, target, (math.cos(target[2]), math.sin(target[2])))


class TaskHooks(Protocol):
    """The hooks of a task a kernel calls (:class:`planar3p_gym.tasks.base.Task` has them; the
    contract is there)."""

    name: str
    failure_reasons: tuple[str, ...]
    travel_goal: bool

    def reference(self, step: int) -> Pose: ...
    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]: ...
    def observation_extra(
        self, step: int, state: SimState, measures: ConfigurationMeasures
    ) -> list[float]: ...
    def termination(
        self, state: SimState, measures: ConfigurationMeasures, errors: tuple[float, float],
        assembly: int,
    ) -> str | None: ...  # fmt: skip
    def reward_terms(self, **kwargs: Any) -> dict[str, float]: ...
    def step_info(
        self, step: int, state: SimState, errors: tuple[float, float]
    ) -> dict[str, Any]: ...


class Sensing(Protocol):
    """The machine's side of a step (:class:`planar3p_gym.envs.actuation.BuiltMachine`)."""

    def measures(self, state: SimState) -> ConfigurationMeasures:
        """The true measures of ``state``."""
        ...

    def sense(
        self, state: SimState, measures: ConfigurationMeasures, rng: np.random.Generator
    ) -> tuple[SimState, ConfigurationMeasures]:
        """The state the policy observes and its measures."""
        ...


@dataclass(frozen=True, eq=False)
class KernelSettings:
    """What a kernel is built from (the environment's settings, fixed for its life).

    Attributes:
        design: the nominal machine.
        low, high: bounds of the 31 entries of :mod:`planar3p_gym.tasks.observation` and of
            the task's extra entries (float32).
        weights: reward weights; ``tolerances``: success tolerances (m, rad, m/s).
        breakdown_distance: loop-closure error ending the episode (m).
        travel_goal: whether the joint-space goal block follows the observation.
        projection: whether the physics is projected (the state array exists).
        nominal: whether the machine is the nominal one (no feature of the built machine).
    """

    design: Design
    low: np.ndarray
    high: np.ndarray
    extra_low: np.ndarray
    extra_high: np.ndarray
    weights: RewardWeights
    tolerances: tuple[float, float, float]
    breakdown_distance: float
    travel_goal: bool
    projection: bool
    nominal: bool

    @classmethod
    def of(
        cls,
        task: TaskHooks,
        design: Design,
        weights: RewardWeights,
        tolerances: tuple[float, float, float],
        breakdown_distance: float,
        travel_goal: bool,
        projection: bool,
        nominal: bool,
    ) -> KernelSettings:
        """The settings of a bound ``task`` (its observation bounds); ``ValueError`` for
        ``travel_goal`` on a task it does not apply to."""
        if travel_goal and not task.travel_goal:
            raise ValueError(
                f"travel_goal applies to the reach task (a fixed target per episode), not to "
                f"task {task.name!r}"
            )
        low, high = bounds(design)
        extra_low, extra_high = (np.asarray(b, np.float32) for b in task.observation_bounds())
        return cls(
            design, low, high, extra_low, extra_high, weights, tolerances, breakdown_distance,
            travel_goal, projection, nominal,
        )  # fmt: skip

    def observation_space(self) -> spaces.Box:
        """The flat observation's space: the 31 entries, the task's, the joint-space goal."""
        goal = travel_goal_bounds(self.design) if self.travel_goal else (np.zeros(0),) * 2
        return spaces.Box(
            np.concatenate([self.low, self.extra_low, goal[0]]).astype(np.float32),
            np.concatenate([self.high, self.extra_high, goal[1]]).astype(np.float32),
            dtype=np.float32,
        )


def mode_changed(leg_angles: tuple[float, float, float], mode: tuple[int, int, int]) -> bool:
    """Whether a leg's ``sign(cos alpha_i)`` differs from the working mode's ``sigma_i``."""
    a1, a2, a3 = leg_angles
    m1, m2, m3 = mode
    return (
        (math.cos(a1) >= 0.0) != (m1 > 0)
        or (math.cos(a2) >= 0.0) != (m2 > 0)
        or (math.cos(a3) >= 0.0) != (m3 > 0)
    )


class StepKernel:
    """The reference kernel: a step through the task's hooks (module docstring).

    Args:
        task: the bound task.
        settings: the environment's :class:`KernelSettings`.
        machine: the machine's sensing (:class:`Sensing`).
    """

    def __init__(self, task: TaskHooks, settings: KernelSettings, machine: Sensing) -> None:
        self.task = task
        self.settings = settings
        self.machine = machine
        self._length = settings.design.characteristic_length

    def config_changed(self, tolerances: tuple[float, float, float]) -> None:
        """The success tolerances changed (the hooks read them from the task's env)."""

    # ------------------------------------------------------------------ reset
    def start(self, ep: Episode, state: SimState, rng: np.random.Generator) -> dict[str, Any]:
        """The reset's observation (into ``ep.obs``) and ``info`` of the start ``state``."""
        ep.measures = self.machine.measures(state)
        ep.assembly = ep.measures.det_sign
        return self._start_info(ep, state, rng)

    def _start_info(self, ep: Episode, state: SimState, rng: np.random.Generator) -> dict[str, Any]:
        measures = ep.measures
        assert measures is not None
        ep.obs = self.observe(ep, state, measures, rng)
        errors = self.errors(ep.target, state.pose)
        info = self.info(ep, state, measures, None, {}, False, errors)
        info.update(self.task.step_info(0, state, errors))
        return info

    # ------------------------------------------------------------------ per step
    def step(
        self,
        ep: Episode,
        state: SimState,
        array: np.ndarray | None,
        action: tuple[float, float, float],
        rng: np.random.Generator,
    ) -> StepOutputs:
        """The outputs of step ``ep.steps`` to the new ``state`` (the simulation's state array
        ``array``, unused here) after the executed ``action``; updates ``ep``."""
        task = self.task
        ep.target = task.reference(ep.steps)
        success = False
        if not state.finite or state.closure_error > self.settings.breakdown_distance:
            # The new state is not trustworthy: keep the last good observation and errors.
            reason: str | None = "physics_breakdown"
            measures = ep.measures
            errors = self.errors(ep.target, ep.info["pose"])
        else:
            measures = self.machine.measures(state)
            ep.obs = self.observe(ep, state, measures, rng)
            errors = self.errors(ep.target, state.pose)
            reason = task.termination(state, measures, errors, ep.assembly)
            success = reason == "success"
        assert measures is not None
        terms = task.reward_terms(
            errors=errors,
            measures=measures,
            action=action,
            success=success,
            failure=reason in task.failure_reasons,
            state=state,
        )
        reward = float(sum(terms.values()))
        if reason == "physics_breakdown":
            # The last good step's entries, copied: a step returns no object an earlier one did.
            info = copy.deepcopy(ep.info)
            closure = state.closure_error
            info.update(
                termination_reason=reason,
                is_success=False,
                reward_terms=terms,
                closure_error=closure if math.isfinite(closure) else math.inf,
            )
        else:
            info = self.info(ep, state, measures, reason, terms, success, errors)
            ep.measures = measures
        info.update(task.step_info(ep.steps, state, errors))
        ep.info = info
        return ep.obs, reward, reason, info

    def reference_step(
        self,
        ep: Episode,
        state: SimState,
        action: Any,
        rng: np.random.Generator | None = None,
    ) -> StepOutputs:
        """:meth:`step` through the task's hooks whatever the kernel (a copy of the
        observation): what a batched step falls back on where the physics broke down."""
        a = (float(action[0]), float(action[1]), float(action[2]))
        obs, reward, reason, info = StepKernel.step(self, ep, state, None, a, rng)  # type: ignore[arg-type]
        return obs.copy(), reward, reason, info

    # ------------------------------------------------------------------ pieces
    @staticmethod
    def errors(target: Pose, pose: tuple[float, float, float]) -> tuple[float, float]:
        """Position (m) and orientation (rad, wrapped) errors of ``pose`` to ``target``
        (:func:`~planar3p_gym.tasks.observation.pose_errors`)."""
        tx, ty, tth = target
        return pose_errors(tx, ty, tth, pose[0], pose[1], pose[2])

    def observe(
        self,
        ep: Episode,
        state: SimState,
        measures: ConfigurationMeasures,
        rng: np.random.Generator,
    ) -> np.ndarray:
        """The observation of the true ``state`` (its true ``measures``), as the machine's
        sensing shows it, against the reference ``ep.target``: the 31 entries, the task's
        extra entries (of the true state), the joint-space goal (``travel_goal``)."""
        s = self.settings
        seen, seen_measures = self.machine.sense(state, measures, rng)
        obs = build_observation(
            seen.rho, seen.rho_dot, seen.pose, seen.twist, seen.leg_angles, ep.target,
            seen_measures.parallel_margin, seen_measures.serial_margin, s.low, s.high,
            self._length,
        )  # fmt: skip
        return self.with_travel_goal(ep, self.with_extra(ep, obs, state, measures))

    def with_extra(
        self, ep: Episode, obs: np.ndarray, state: SimState, measures: ConfigurationMeasures
    ) -> np.ndarray:
        """``obs`` with the task's extra entries of the true ``state`` appended (float32,
        clipped to their bounds)."""
        extra = self.task.observation_extra(ep.steps, state, measures)
        if not extra:
            return obs
        s = self.settings
        tail = np.array(extra, dtype=np.float32)
        np.minimum(tail, s.extra_high, out=tail)
        np.maximum(tail, s.extra_low, out=tail)
        return np.concatenate([obs, tail])

    def with_travel_goal(self, ep: Episode, obs: np.ndarray) -> np.ndarray:
        """``obs`` with the joint-space goal block appended when ``travel_goal`` is on."""
        if not self.settings.travel_goal:
            return obs
        return np.concatenate([obs, travel_goal_entries(obs[:3], ep.target_rho)])

    @staticmethod
    def info(
        ep: Episode,
        state: SimState,
        measures: ConfigurationMeasures,
        reason: str | None,
        terms: dict[str, float],
        success: bool,
        errors: tuple[float, float],
    ) -> dict[str, Any]:
        """The step's ``info`` (the entries every task shares)."""
        return {
            "is_success": success,
            "termination_reason": reason,
            "position_error": errors[0],
            "orientation_error": errors[1],
            "parallel_margin": measures.parallel_margin,
            "serial_margin": measures.serial_margin,
            "assembly_mode": measures.det_sign,
            "working_mode": ep.mode,
            "working_mode_changed": mode_changed(measures.leg_angles, ep.mode),
            "actuator_forces": state.actuator_forces,
            "actuator_saturated": state.saturated,
            "closure_error": state.closure_error,
            "reward_terms": terms,
            "pose": state.pose,
            "rho": state.rho,
            "rho_dot": state.rho_dot,
            "time": state.time,
        }


class CompiledKernel(StepKernel):
    """The base of the kernels with compiled outputs on the simulation's state array: a step
    takes the reference kernel (:meth:`StepKernel.step`) where there is no state array or the
    physics broke down (a non-finite state, or a closure error past the breakdown distance),
    else sets the step's reference target (:meth:`set_target`, for a task whose reference
    moves) and takes :meth:`compiled_step`."""

    #: Whether the task's reference pose moves over the episode (the target is set at every
    #: step); a fixed target is the episode's, set at its reset.
    moving_target: bool = False

    def step(
        self,
        ep: Episode,
        state: SimState,
        array: np.ndarray | None,
        action: tuple[float, float, float],
        rng: np.random.Generator,
    ) -> StepOutputs:
        if (
            array is None
            or not state.finite
            or state.closure_error > self.settings.breakdown_distance
        ):
            return StepKernel.step(self, ep, state, array, action, rng)
        if self.moving_target:
            self.set_target(ep)
        return self.compiled_step(ep, state, array, action, rng)

    def set_target(self, ep: Episode) -> None:
        """Set the reference target of step ``ep.steps`` (``ep.target``, m, m, rad; and
        ``ep.target_cs``, its ``cos``/``sin theta``) from the task's reference."""
        target = ep.target = self.task.reference(ep.steps)
        ep.target_cs = (math.cos(target[2]), math.sin(target[2]))

    def compiled_step(
        self,
        ep: Episode,
        state: SimState,
        array: np.ndarray,
        action: tuple[float, float, float],
        rng: np.random.Generator,
    ) -> StepOutputs:
        """The outputs of a step whose physics held, from the state array ``array`` and
        against ``ep.target`` (the arguments of :meth:`StepKernel.step`)."""
        raise NotImplementedError


class ReachOutputsKernel(CompiledKernel):
    """The base of the kernels built on the reach task's compiled outputs on the projected
    physics of the nominal machine (:class:`~planar3p_gym.tasks.reach_step.ReachStep`, kept in
    :attr:`reach`, with the success tolerances the task's configuration sets)."""

    def __init__(self, task: TaskHooks, settings: KernelSettings, machine: Sensing) -> None:
        super().__init__(task, settings, machine)
        #: The compiled outputs' constants and buffers (a batched step of the native vector
        #: env reads their tolerances).
        self.reach = ReachStep(
            settings.design, settings.low, settings.high, settings.weights, settings.tolerances
        )

    def config_changed(self, tolerances: tuple[float, float, float]) -> None:
        self.reach.tolerances = tolerances


class ReachKernel(ReachOutputsKernel):
    """The reach task's compiled kernel on the projected physics of the nominal machine: one
    call of :func:`planar3p_gym.tasks.reach_step.reach_outputs` on the simulation's state array
    (the reference kernel where the physics broke down).  The target is fixed over the
    episode (the reach task's reference)."""

    def __init__(self, task: TaskHooks, settings: KernelSettings, machine: Sensing) -> None:
        super().__init__(task, settings, machine)
        self.weights = settings.weights.as_array()

    def compiled_step(
        self,
        ep: Episode,
        state: SimState,
        array: np.ndarray,
        action: tuple[float, float, float],
        rng: np.random.Generator,
    ) -> StepOutputs:
        rs = self.reach
        res = rs.compute(array, state.pose[2], ep.target, ep.target_cs, ep.assembly, action)
        res = res.tolist()
        obs = self.with_travel_goal(ep, rs.obs.copy())
        reason = REASONS[int(res[1])]
        measures = ConfigurationMeasures(res[4], res[5], int(res[6]), state.leg_angles)
        terms = dict(zip(TERM_NAMES, res[TERMS_START:], strict=True))
        info = self.info(ep, state, measures, reason, terms, reason == "success", (res[2], res[3]))
        ep.obs, ep.measures, ep.info = obs, measures, info
        return obs, res[0], reason, info

    def rejudge(
        self, info: dict[str, Any], action: tuple[float, float, float], success: bool
    ) -> float:
        """Give a step of :meth:`step` that did not cross a singularity another task's success
        test's verdict ``success``: ``info``'s reason, success flag and reward terms
        (:func:`~planar3p_gym.tasks.rewards.weighted_terms` of the step's errors and margins)
        updated; returns the reward (the terms' sum)."""
        terms = dict(
            zip(
                TERM_NAMES,
                weighted_terms(
                    self.weights, info["position_error"], info["orientation_error"],
                    self._length, info["parallel_margin"], info["serial_margin"],
                    action[0], action[1], action[2], success, False,
                ),
                strict=True,
            )
        )  # fmt: skip
        info.update(
            termination_reason="success" if success else None,
            is_success=success,
            reward_terms=terms,
        )
        return float(sum(terms.values()))


class HookKernel(ReachOutputsKernel):
    """The reference kernel's step with its costly part compiled, for a task on the projected
    physics of the nominal machine: the 31 observation entries, the errors and the measures
    (margins, ``sign det A``) come from the reach task's compiled outputs on the simulation's
    state array (:func:`planar3p_gym.tasks.reach_step.reach_outputs`) against the task's
    reference pose; the task's hooks (extra entries, termination, reward terms, metrics) run as
    in :class:`StepKernel`, on those measures.  Within float64 rounding of the reference: the
    compiled margins share intermediate values instead of recomputing them."""

    moving_target = True

    def compiled_step(
        self,
        ep: Episode,
        state: SimState,
        array: np.ndarray,
        action: tuple[float, float, float],
        rng: np.random.Generator,
    ) -> StepOutputs:
        task = self.task
        rs = self.reach
        res = rs.compute(array, state.pose[2], ep.target, ep.target_cs, ep.assembly, action)
        measures = ConfigurationMeasures(
            float(res[4]), float(res[5]), int(res[6]), state.leg_angles
        )
        errors = (float(res[2]), float(res[3]))
        obs = ep.obs = self.with_travel_goal(
            ep, self.with_extra(ep, rs.obs.copy(), state, measures)
        )
        reason = task.termination(state, measures, errors, ep.assembly)
        success = reason == "success"
        terms = task.reward_terms(
            errors=errors,
            measures=measures,
            action=action,
            success=success,
            failure=reason in task.failure_reasons,
            state=state,
        )
        info = self.info(ep, state, measures, reason, terms, success, errors)
        ep.measures = measures
        info.update(task.step_info(ep.steps, state, errors))
        ep.info = info
        return obs, float(sum(terms.values())), reason, info
