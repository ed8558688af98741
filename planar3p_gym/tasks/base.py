"""The task interface: what an environment id asks of the machine.

:class:`planar3p_gym.envs.core.Planar3PEnv` owns the physics, the action parsing, the
configuration measures and the physics-breakdown test; a :class:`Task` owns everything that
makes an episode a particular problem.  The contract every task meets (episode specs that
replay, validated requests, sampling that never raises, determinism, metrics, reward,
snapshots, settings, observation) is in ``docs/adding_a_task.md``, "The task contract".

* :class:`Task`: the hooks the environment calls -- :meth:`Task.bind` and :meth:`Task.kernel`
  at construction; :meth:`Task.reset_options` (:meth:`Task.check_options`),
  :meth:`Task.reseed`, :meth:`Task.episode_spec` and :meth:`Task.begin` at a reset; per step,
  through the task's kernel (:mod:`planar3p_gym.tasks.kernel`), :meth:`Task.reference`,
  :meth:`Task.observation_extra`, :meth:`Task.termination`, :meth:`Task.reward_terms` and
  :meth:`Task.step_info`;
* :class:`TaskEnv`: what a task may read of the environment;
* :func:`copy_spec`, :func:`pose_list`: episode-spec helpers.
"""

from __future__ import annotations

import copy
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from planar3p_gym import checks
from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures
from planar3p_gym.sim.physics import SimState
from planar3p_gym.tasks import sampling as task
from planar3p_gym.tasks.kernel import HookKernel, KernelSettings, Sensing, StepKernel
from planar3p_gym.tasks.observation import within_tolerances
from planar3p_gym.tasks.rewards import reward_terms

if TYPE_CHECKING:
    from planar3p_gym.machine.design import Design
    from planar3p_gym.tasks.rewards import RewardWeights

__all__ = [
    "COMPILED_HOOKS",
    "ModeTriple",
    "Pose",
    "Task",
    "TaskEnv",
    "copy_spec",
    "pose_list",
]

#: A pose ``(x, y, theta)`` (m, m, rad).
Pose = tuple[float, float, float]
#: The per-step hooks whose formulas compiled code computes in place of calling them (a task
#: kernel, the native vector env's batched steps; :attr:`Task.compiled_family`): a subclass
#: that overrides any of them is stepped through its hooks.
COMPILED_HOOKS = (
    "reference",
    "observation_extra",
    "is_success",
    "termination",
    "reward_terms",
    "step_info",
)
#: A working mode: ``sign cos alpha_i`` of the three legs (+1 or -1 each).
ModeTriple = tuple[int, int, int]


def copy_spec(value: Any) -> Any:
    """A copy of an episode spec (plain JSON data: dicts, lists, strings, numbers), as
    ``copy.deepcopy`` makes it; other values are deep-copied.  Why by hand: deepcopy's general
    machinery (its memo, the dispatch per object) costs a reset more than the rest of its
    bookkeeping, and a spec is copied at every reset."""
    kind = type(value)
    if kind is dict:
        return {k: copy_spec(v) for k, v in value.items()}
    if kind is list:
        return [copy_spec(v) for v in value]
    if kind in (str, int, float, bool) or value is None:
        return value
    return copy.deepcopy(value)


def pose_list(pose: Any) -> list[float]:
    """A pose as a JSON-friendly list of three Python floats (exact: float64 round-trips)."""
    return [float(v) for v in np.asarray(pose, dtype=np.float64).reshape(3).tolist()]


class TaskEnv(Protocol):
    """What a task may read of the environment it is bound to (:meth:`Task.bind`): the
    machine and the settings of its episodes, nothing of the simulation (a hook is handed the
    state and the measures the environment computed) and nothing of Gymnasium.  The
    environment (:class:`planar3p_gym.envs.core.Planar3PEnv`) provides it; a task never imports
    the environment's module, so the layers stay one-way (tasks below envs)."""

    design: Design
    task_config: task.TaskConfig
    reward_weights: RewardWeights
    #: Control period (s) and the breakdown threshold on the loop-closure error (m).
    dt: float
    breakdown_distance: float
    np_random: np.random.Generator

    @property
    def modes(self) -> list[tuple[int, int, int]]:
        """Working modes episodes may start in."""
        ...


class Task:
    """Base class of the tasks; see the module docstring for the contract.

    Subclasses set :attr:`name` and :attr:`option_keys` and implement :meth:`episode_spec`,
    :meth:`begin` and :meth:`reference`; the defaults of the other hooks give the reach task's
    behaviour (success at the reference pose at rest, a parallel-singularity crossing is a
    failure, the reward of :mod:`planar3p_gym.tasks.rewards`).
    """

    #: Value of ``spec["task"]``.
    name: ClassVar[str] = ""
    #: Keys ``reset(options=...)`` accepts besides ``"task"`` (a superset of the spec's keys).
    option_keys: ClassVar[tuple[str, ...]] = ()
    #: Possible values of ``info["termination_reason"]`` (``None`` while the episode runs).
    termination_reasons: ClassVar[tuple[str, ...]] = (
        "success",
        "singularity_crossing",
        "physics_breakdown",
    )
    #: Termination reasons that count as failures (the failure penalty applies).
    failure_reasons: ClassVar[tuple[str, ...]] = ("singularity_crossing", "physics_breakdown")
    #: Task-specific ``info`` keys (metrics) added by :meth:`step_info`.
    metric_keys: ClassVar[tuple[str, ...]] = ()
    #: ``(name, size, description)`` of the entries :meth:`observation_extra` appends to the
    #: 31 entries of :data:`planar3p_gym.tasks.observation.OBS_FIELDS`, in order (their one
    #: definition: controllers and documentation read them here).
    observation_fields: ClassVar[tuple[tuple[str, int, str], ...]] = ()
    #: Whether the default reward keeps its barrier near parallel / serial singularities; a
    #: task whose problem is to pass one turns that barrier off (its margin counts as 1).
    parallel_barrier: ClassVar[bool] = True
    serial_barrier: ClassVar[bool] = True
    #: Whether the default :meth:`kernel` takes the observation and measures from the compiled
    #: outputs on the projected physics of the nominal machine
    #: (:class:`~planar3p_gym.tasks.kernel.HookKernel`: within float64 rounding of the
    #: reference); the hooks run either way.
    compiled_measures: ClassVar[bool] = False
    #: The compiled form of the per-step hooks (:data:`COMPILED_HOOKS`) of the class that
    #: names it (``"reach"``, ``"goal"``, ``"track"``, ``"mode_change"``,
    #: ``"assembly_change"``), which the task's kernel or the native vector env's batched
    #: steps run; ``None``: none.  Read through :attr:`compiled_family`.
    hooks_family: ClassVar[str | None] = None
    #: Whether the environment's ``travel_goal`` block (the fixed target's slider travels)
    #: applies to the task's observation.
    travel_goal: ClassVar[bool] = False

    env: TaskEnv

    # ------------------------------------------------------------------ set-up
    def bind(self, env: TaskEnv) -> None:
        """Attach to ``env`` (its design, working modes, task config, reward weights, ``dt``).
        Raise ``ValueError`` here if no episode can exist under the env's settings.
        Subclasses call this first (it also starts the cache of :meth:`pose_sampler`)."""
        self.env = env
        self._samplers: dict[tuple[int, int, int], task.PoseSampler] = {}

    def arguments(self) -> dict[str, Any]:
        """The task's constructor arguments as plain data (for ``env.config()``)."""
        return {}

    def reseed(self) -> None:
        """The environment was re-seeded: drop anything cached from the old random stream
        (default: the pose batches of the samplers of :meth:`pose_sampler`)."""
        for sampler in self._samplers.values():
            sampler.clear()

    def config_changed(self) -> None:
        """The environment's ``task_config`` changed (:meth:`Planar3PEnv.set_task_config`):
        the samplers of :meth:`pose_sampler` take the new one (their pose batches stay valid:
        the fields that may change do not affect which poses are acceptable)."""
        for sampler in self._samplers.values():
            sampler.cfg = self.env.task_config

    def reset_options(self, options: Any) -> dict[str, Any]:
        """``reset``'s ``options`` checked before seeding (``ValueError``: a rejection changes
        nothing): the keys (:attr:`option_keys` and ``"task"``,
        :func:`planar3p_gym.checks.check_reset_options`), ``"task"`` equal to :attr:`name`
        (then removed), then :meth:`check_options`."""
        options = checks.check_reset_options(options, (*self.option_keys, "task"))
        requested = options.pop("task", None)
        if requested is not None and requested != self.name:
            raise ValueError(
                f"options are for task {requested!r}, but this environment's task is {self.name!r}"
            )
        return self.check_options(options)

    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        """Validate ``reset`` options that need no randomness (``ValueError`` if invalid);
        return them, parsed.  Called before seeding.  Keys are already restricted to
        :attr:`option_keys` and ``"task"`` is already checked and removed."""
        return options

    def episode_spec(self, rng: np.random.Generator, options: dict[str, Any]) -> dict[str, Any]:
        """The spec of the next episode: what ``options`` fixes, the rest drawn from ``rng``
        (the environment's ``np_random``).  Must not raise without options."""
        raise NotImplementedError

    def begin(self, spec: dict[str, Any]) -> tuple[np.ndarray, tuple[int, int, int]]:
        """Install the episode ``spec``; return its start pose (m, m, rad) and working mode."""
        raise NotImplementedError

    # ------------------------------------------------------------------ per step
    def reference(self, step: int) -> Pose:
        """The pose the observation and the errors refer to after ``step`` control steps
        (the target of a reach, the moving reference of a tracking task)."""
        raise NotImplementedError

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)`` of the entries :meth:`observation_extra` appends (default none)."""
        empty = np.zeros(0, dtype=np.float32)
        return empty, empty.copy()

    def observation_extra(
        self, step: int, state: SimState, measures: ConfigurationMeasures
    ) -> list[float]:
        """Task entries appended to the 31-entry observation after ``step`` steps, of the
        (true) ``state`` and its ``measures`` the environment computed."""
        return []

    def is_success(self, state: SimState, errors: tuple[float, float]) -> bool:
        """Default success test: within ``position_tolerance`` (m) and
        ``orientation_tolerance`` (rad) of the reference with every slider slower than
        ``rest_speed`` (m/s).  ``errors`` are (position error (m), orientation error (rad))."""
        pos_err, ang_err = errors
        return within_tolerances(
            pos_err, ang_err, np.array(state.rho_dot), *self.env.task_config.success_tolerances
        )

    def termination(
        self,
        state: SimState,
        measures: ConfigurationMeasures,
        errors: tuple[float, float],
        assembly: int,
    ) -> str | None:
        """The reason the episode ends after this step, or ``None`` (physics breakdown is the
        environment's test and comes first).  Default: ``"singularity_crossing"`` when
        ``sign det A`` is opposite to the start's ``assembly``, else ``"success"`` when
        :meth:`is_success`."""
        if measures.det_sign == -assembly:
            return "singularity_crossing"
        if self.is_success(state, errors):
            return "success"
        return None

    def reward_terms(
        self,
        *,
        errors: tuple[float, float],
        measures: ConfigurationMeasures,
        action: tuple[float, float, float],
        success: bool,
        failure: bool,
        state: SimState | None = None,
    ) -> dict[str, float]:
        """Weighted reward terms (their sum is the reward) of the step to ``state``; default
        :func:`planar3p_gym.tasks.rewards.reward_terms` on the errors to the reference, with the
        singularity barriers :attr:`parallel_barrier` and :attr:`serial_barrier`."""
        env = self.env
        pos_err, ang_err = errors
        length = env.design.characteristic_length
        return reward_terms(
            env.reward_weights,
            position_error=pos_err,
            orientation_error=ang_err,
            length=length,
            parallel_margin=measures.parallel_margin if self.parallel_barrier else 1.0,
            serial_margin=measures.serial_margin if self.serial_barrier else 1.0,
            action=action,
            success=success,
            failure=failure,
        )

    def step_info(self, step: int, state: SimState, errors: tuple[float, float]) -> dict[str, Any]:
        """Task metrics for ``info`` after ``step`` steps (``step == 0`` at reset); keys are
        :attr:`metric_keys`.  Called once per step, also on the step that ends the episode."""
        return {}

    @property
    def compiled_family(self) -> str | None:
        """:attr:`hooks_family` while this task's per-step hooks (:data:`COMPILED_HOOKS`) are
        those of the class that names it, else ``None`` (a subclass that overrides one is
        stepped through its hooks, one environment at a time)."""
        cls = type(self)
        owner = next(c for c in cls.__mro__ if "hooks_family" in vars(c))
        own = all(getattr(cls, h) is getattr(owner, h) for h in COMPILED_HOOKS)
        return self.hooks_family if own else None

    def kernel(self, settings: KernelSettings, machine: Sensing) -> StepKernel:
        """The task's kernel (:mod:`planar3p_gym.tasks.kernel`): default the reference, this
        task's hooks (with :attr:`compiled_measures`, on the compiled measures where they
        exist)."""
        if self.compiled_measures and settings.projection and settings.nominal:
            return HookKernel(self, settings, machine)
        return StepKernel(self, settings, machine)

    # ------------------------------------------------------------------ helpers
    def pose_sampler(self, mode: tuple[int, int, int]) -> task.PoseSampler:
        """The task's :class:`planar3p_gym.tasks.sampling.PoseSampler` for working ``mode`` (made on
        first use, kept for the task's life; :meth:`reseed` clears its pose batches)."""
        if mode not in self._samplers:
            self._samplers[mode] = task.PoseSampler(self.env.design, mode, self.env.task_config)
        return self._samplers[mode]

    def known_mode(self, options: dict[str, Any]) -> tuple[int, int, int] | None:
        """The working mode fixed without drawing: the requested ``options["working_mode"]``,
        or the env's only working mode; ``None`` if it must be drawn."""
        if options.get("working_mode") is not None:
            return options["working_mode"]
        modes = self.env.modes
        return modes[0] if len(modes) == 1 else None

    def travel_bounds(self, unit_entries: int) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)`` of extra entries made of three slider travels (m, within 5 % of
        the stroke beyond either end) followed by ``unit_entries`` values in ``[-1, 1]``."""
        stroke = self.env.design.stroke
        low = np.array([-0.05 * stroke] * 3 + [-1.0] * unit_entries, dtype=np.float32)
        high = np.array([1.05 * stroke] * 3 + [1.0] * unit_entries, dtype=np.float32)
        return low, high

    @staticmethod
    def finite_pose(pose: Any, name: str) -> np.ndarray:
        """``pose`` as a float64 array of 3 finite numbers, or ``ValueError`` naming ``name``."""
        return checks.numbers(pose, 3, name, " (x, y, theta)")
