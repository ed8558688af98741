"""The settings of a :class:`planar3p_gym.envs.core.Planar3PEnv`, validated in one place.

- :func:`make_task`: the task argument (a task, ``None`` for the reach, or ``"module:Class"``);
- :class:`EnvSettings`: every other constructor argument but the built machine's
  (:class:`planar3p_gym.envs.actuation.BuiltMachine` validates those), checked before anything
  is built (``ValueError`` naming the argument).
"""

from __future__ import annotations

import importlib
from dataclasses import asdict, dataclass
from typing import Any

from planar3p_gym import checks
from planar3p_gym.checks import config_from, design_from, mode_from
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.sim.physics import (
    DEFAULT_ITERATIONS,
    DEFAULT_SUBSTEPS,
    PROJECTED_ITERATIONS,
    PROJECTED_SUBSTEPS,
)
from planar3p_gym.tasks import ReachTask, Task
from planar3p_gym.tasks import sampling as task_module
from planar3p_gym.tasks.rewards import RewardWeights
from planar3p_gym.tasks.sampling import TaskConfig

__all__ = ["RENDER_MODES", "EnvSettings", "episode_modes", "make_task"]

#: The render modes of the environment.
RENDER_MODES: tuple[str, ...] = ("human", "rgb_array")


def make_task(task: Task | str | None, task_kwargs: dict[str, Any] | None) -> Task:
    """The task of a :class:`Planar3PEnv`: ``task`` itself, a new :class:`ReachTask` for
    ``None``, or the Task class at ``"module:Class"`` built with ``task_kwargs``; ``ValueError``
    naming the argument otherwise."""
    if task_kwargs is not None and not isinstance(task_kwargs, dict):
        raise ValueError(f"task_kwargs must be a dict or None, got {task_kwargs!r}")
    if isinstance(task, str):
        module, sep, name = task.partition(":")
        try:
            cls = getattr(importlib.import_module(module), name) if sep else None
        except (ImportError, AttributeError) as exc:
            raise ValueError(f"task {task!r} cannot be imported: {exc}") from exc
        if not (isinstance(cls, type) and issubclass(cls, Task)):
            raise ValueError(
                f"task must name a planar3p_gym.tasks.Task subclass as 'module:Class', got {task!r}"
            )
        try:
            return cls(**(task_kwargs or {}))
        except TypeError as exc:
            raise ValueError(f"task_kwargs do not fit {task}: {exc}") from exc
    if task_kwargs:
        raise ValueError("task_kwargs applies only to a task given as 'module:Class'")
    if task is None:
        return ReachTask()
    if not isinstance(task, Task):
        raise ValueError(f"task must be a planar3p_gym.tasks.Task, got {task!r}")
    return task


def episode_modes(
    design: Design, fixed: tuple[int, int, int] | None, cfg: TaskConfig
) -> list[tuple[int, int, int]]:
    """The working modes episodes are drawn from: ``fixed`` (rejected, ``ValueError``, if it
    has no usable start/target pair), or every mode with usable pairs
    (:func:`planar3p_gym.tasks.sampling.check_mode`, a fixed internal seed: the list never
    depends on, or consumes, the episode's stream); ``ValueError`` too if ``cfg`` asks for
    detour pairs none of them has (:func:`planar3p_gym.tasks.sampling.check_detours`)."""
    if fixed:
        task_module.check_mode(design, fixed, cfg)
        task_module.check_detours(design, [fixed], cfg)
        return [fixed]
    usable = [
        (int(m[0]), int(m[1]), int(m[2]))
        for m in kinematics.ALL_MODES.tolist()
        if task_module.has_pairs(design, m, cfg)
    ]
    if not usable:
        raise ValueError(
            "no working mode of this design has start/target pairs meeting the task's "
            "margins; relax the TaskConfig"
        )
    task_module.check_detours(design, usable, cfg)
    return usable


@dataclass(frozen=True)
class EnvSettings:
    """The environment's validated settings (the constructor's arguments, SI units).

    ``fixed_mode`` is the working mode, ``None`` for ``"random"``; ``breakdown_distance`` the
    loop-closure error ending an episode (m); ``dt`` the control period (s).
    """

    design: Design
    fixed_mode: tuple[int, int, int] | None
    control_frequency: float
    substeps: int
    solver_iterations: int
    projection: bool
    reward_weights: RewardWeights
    task_config: TaskConfig
    breakdown_distance: float
    render_mode: str | None
    render_size: tuple[int, int]
    travel_goal: bool

    @property
    def dt(self) -> float:
        """Control period (s)."""
        return 1.0 / self.control_frequency

    def updated(
        self, task_config: TaskConfig, changes: dict[str, Any], modes: list[tuple[int, int, int]]
    ) -> TaskConfig:
        """``task_config`` with ``changes`` (:func:`planar3p_gym.tasks.sampling.updated_config`),
        its ``detour_fraction`` checked against the working ``modes`` episodes are drawn from
        (:func:`planar3p_gym.tasks.sampling.check_detours`); ``ValueError`` otherwise."""
        cfg = task_module.updated_config(task_config, changes)
        task_module.check_detours(self.design, modes, cfg)
        return cfg

    def record(self, task_config: TaskConfig) -> dict[str, Any]:
        """The settings as plain data (for run records), with the current ``task_config``."""
        return {
            "design": self.design.to_dict(),
            "working_mode": self.fixed_mode or "random",
            "control_frequency": self.control_frequency,
            "substeps": self.substeps,
            "solver_iterations": self.solver_iterations,
            "projection": self.projection,
            "reward_weights": asdict(self.reward_weights),
            "task_config": asdict(task_config),
            "breakdown_threshold": self.breakdown_distance / self.design.shortest_leg,
            "travel_goal": self.travel_goal,
        }

    @classmethod
    def of(
        cls,
        design: Any,
        working_mode: Any,
        control_frequency: Any,
        substeps: Any,
        solver_iterations: Any,
        projection: Any,
        reward_weights: Any,
        task_config: Any,
        breakdown_threshold: Any,
        render_mode: Any,
        render_size: Any,
        travel_goal: Any,
    ) -> EnvSettings:
        """The settings of the constructor's arguments, or ``ValueError`` naming one."""
        design = design_from(design)
        if isinstance(working_mode, str):
            if working_mode != "random":
                raise ValueError(
                    f"working_mode must be a triple of +-1 or 'random', got {working_mode!r}"
                )
            fixed_mode = None
        else:
            fixed_mode = mode_from(working_mode, "working_mode")
        control_frequency = checks.number(
            control_frequency, "control_frequency", low=1.0, high=10_000.0, unit="Hz"
        )
        projection = checks.flag(projection, "projection")
        if substeps is None:
            substeps = PROJECTED_SUBSTEPS if projection else DEFAULT_SUBSTEPS
        if solver_iterations is None:
            solver_iterations = PROJECTED_ITERATIONS if projection else DEFAULT_ITERATIONS
        substeps = checks.integer(substeps, "substeps", low=1, high=1000)
        solver_iterations = checks.integer(solver_iterations, "solver_iterations", low=1, high=1000)
        breakdown_threshold = checks.number(
            breakdown_threshold,
            "breakdown_threshold",
            low=0.0,
            high=1.0,
            low_open=True,
            high_open=True,
        )
        if render_mode is not None:
            checks.choice(render_mode, "render_mode", RENDER_MODES)
        reward_weights = config_from(reward_weights, RewardWeights, "reward_weights")
        task_config = config_from(task_config, TaskConfig, "task_config")
        if not (isinstance(render_size, (tuple, list)) and len(render_size) == 2):
            raise ValueError(
                f"render_size must be (width, height) in pixels, 16..8192, got {render_size!r}"
            )
        size = tuple(
            checks.integer(v, f"render_size[{i}]", low=16, high=8192)
            for i, v in enumerate(render_size)
        )
        return cls(
            design,
            fixed_mode,
            float(control_frequency),
            int(substeps),
            int(solver_iterations),
            bool(projection),
            reward_weights,
            task_config,
            breakdown_threshold * design.shortest_leg,
            render_mode,
            (int(size[0]), int(size[1])),
            bool(checks.flag(travel_goal, "travel_goal")),
        )
