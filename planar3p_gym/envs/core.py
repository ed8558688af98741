"""``Planar3P-v0``: move the gripper of a 3-PRR parallel manipulator to a target pose."""

from __future__ import annotations

import copy
import importlib
import itertools
import math
from dataclasses import asdict
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from planar3p_gym import checks
from planar3p_gym.checks import (
    RESET_OPTIONS,
    check_reset_options,
    config_from,
    design_from,
    mode_from,
    parse_action,
)
from planar3p_gym.envs.end_reason import END_REASONS, TERMINATION_REASONS, TIME_LIMIT
from planar3p_gym.envs.latency import DelayLine, LatencyConfig
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures, ScalarKinematics
from planar3p_gym.sim.dynamics import MachineDynamics
from planar3p_gym.sim.physics import (
    DEFAULT_ITERATIONS,
    DEFAULT_SUBSTEPS,
    PROJECTED_ITERATIONS,
    PROJECTED_SUBSTEPS,
    Planar3PSim,
    SimState,
)
from planar3p_gym.sim.randomization import DynamicsRandomization, SampledMachine
from planar3p_gym.sim.sensors import Encoders, SensorConfig
from planar3p_gym.tasks import ReachTask, Task
from planar3p_gym.tasks import sampling as task_module
from planar3p_gym.tasks.base import copy_spec
from planar3p_gym.tasks.observation import (
    bounds,
    build_observation,
    travel_goal_bounds,
    travel_goal_entries,
    wrap_angle,
)
from planar3p_gym.tasks.reach_step import REASONS, TERMS_START, ReachStep
from planar3p_gym.tasks.rewards import TERM_NAMES, RewardWeights
from planar3p_gym.tasks.sampling import TaskConfig

__all__ = [
    "ACTION_TYPES",
    "DEFAULT_WORKING_MODE",
    "END_REASONS",
    "OBSERVATION_ARGUMENTS",
    "ON_OFF_ACTION_TYPES",
    "RESET_OPTIONS",
    "TERMINATION_REASONS",
    "TIME_LIMIT",
    "Planar3PEnv",
    "check_reset_options",
    "make_task",
    "parse_action",
]

#: The working mode used unless another is asked for: the mode of the default design with the
#: largest well-conditioned workspace.
DEFAULT_WORKING_MODE: tuple[int, int, int] = (1, 1, -1)
#: Arguments of :class:`Planar3PEnv` and its goal env
#: (:class:`planar3p_gym.envs.goal.Planar3PGoalEnv`) that change what a policy observes (the
#: shape of the observation): a model trained with them must be played with them.
OBSERVATION_ARGUMENTS: tuple[str, ...] = ("travel_goal", "observe_working_mode")


#: The action types of :class:`Planar3PEnv`: slider velocities, or the prototype's on-off
#: motors (each stopped, forward or backward at their rated speed, :data:`ON_OFF_SPEED`) as
#: ``MultiDiscrete([3, 3, 3])`` or as one ``Discrete(27)`` index (for DQN).
ACTION_TYPES: tuple[str, ...] = ("continuous", "on-off", "on-off-discrete")
#: Action types that command the same motors and differ only in how an action is written (three
#: commands or one index): a model trained with one can be played on an environment made with
#: the other by making that environment with the model's action type.
ON_OFF_ACTION_TYPES: tuple[str, ...] = ("on-off", "on-off-discrete")
#: The motor command of each value of an on-off action: 0 stop, 1 forward (+x), 2 backward
#: (times the rated speed).
ON_OFF_COMMANDS: tuple[float, float, float] = (0.0, 1.0, -1.0)
#: Default rated speed of the on-off motors, as a fraction of ``max_speed``: one control step
#: at it moves a slider 0.4 mm on the default design at 50 Hz.  The travels an on-off machine
#: can stop at are that coarse, and where the gripper moves several millimetres per
#: millimetre of slider travel (towards a parallel singularity) a coarser step leaves no stop
#: within the reach task's 2 mm tolerance: given 20 s, the on-off analytic controller
#: (:mod:`planar3p_agents.controllers.on_off`) succeeded in 8 of 30 episodes of
#: ``Planar3PReal-v0`` at 0.25 (1 mm a step) and in 17 of 30 at 0.1.
ON_OFF_SPEED = 0.1
#: Draws of a randomised machine at a reset before falling back to the nominal one, if the
#: start pose is out of the drawn machine's reach (never happens with millimetre errors).
MACHINE_DRAWS = 20


def on_off_action(action: Any, action_type: str) -> tuple[float, float, float]:
    """The motor commands (-1, 0 or 1, :data:`ON_OFF_COMMANDS`) of an on-off action: three
    integers in ``{0, 1, 2}`` for ``"on-off"``, one integer in ``[0, 27)`` for
    ``"on-off-discrete"`` (its base-3 digits, slider 1 first); integral floats are accepted
    too; ``ValueError`` otherwise."""
    if action_type == "on-off-discrete":
        if isinstance(action, np.ndarray) and action.shape == (1,):
            action = action[0]  # (a batch of one, as some agents return it)
        value = action if np.ndim(action) == 0 else None
        n = checks.as_int(value)
        if n is None and (f := checks.as_finite_float(value)) is not None and f.is_integer():
            n = int(f)  # an integral float, as for the three commands
        if n is None or not 0 <= n < 27:
            raise ValueError(f"action must be an integer in [0, 27), got {checks.short(action)}")
        digits = (n // 9, (n // 3) % 3, n % 3)
    else:
        arr = checks.real_array(action)
        if arr is None or arr.shape != (3,) or not all(v in (0, 1, 2) for v in arr.tolist()):
            raise ValueError(
                f"action must be 3 integers in {{0, 1, 2}} (stop, forward, backward), got "
                f"{checks.short(action)}"
            )
        digits = tuple(int(v) for v in arr.tolist())
    c = ON_OFF_COMMANDS
    return c[digits[0]], c[digits[1]], c[digits[2]]


#: Keys of :meth:`Planar3PEnv.get_keys_to_action`: (+x, -x) for sliders 1, 2, 3.
KEYBOARD_KEYS = (("q", "a"), ("w", "s"), ("e", "d"))
#: Speed commanded by a pressed key, as a fraction of ``max_speed``.
KEYBOARD_SPEED = 0.5


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


class Planar3PEnv(gym.Env):
    """Reach a target pose with a 3-PRR planar parallel manipulator simulated in pymunk.

    ## Description
    Three sliders move on parallel horizontal rails (``y = 0``); each carries a rigid leg whose
    other end is pinned to a straight platform holding, in line, the joints ``C_1, C_2, C_3``
    and the gripper point ``G`` (``docs/mechanism.md``).  The closed chain is a pymunk rigid-body
    model with gravity; each slider is driven by a force-limited velocity servo.  The agent
    commands slider velocities and must bring the gripper to a target position and
    orientation, without crossing a parallel singularity (where the platform can no longer be
    controlled and the machine would switch assembly mode).

    ## Action Space
    ``Box(-1, 1, (3,), float32)``: slider velocity commands as fractions of the design's
    ``max_speed`` (m/s).  Values outside ``[-1, 1]`` are clipped; NaN/inf or a wrong shape
    raise ``ValueError`` and leave the state unchanged.  With ``action_type="on-off"`` (the
    paper's prototype, ``Planar3PRealOnOff-v0``) ``MultiDiscrete([3, 3, 3])``: each motor
    stopped (0), forward (1) or backward (2) at its rated speed; ``"on-off-discrete"``:
    ``Discrete(27)``, the same as one index (for DQN).

    ## Observation Space
    ``Box(low, high, (31,), float32)``, SI units, documented index by index in
    :mod:`planar3p_gym.tasks.observation`: slider travels and rates, gripper position,
    ``cos/sin theta``, gripper twist, ``cos/sin`` of each leg angle, target position and
    ``cos/sin`` of its angle, position and orientation errors, parallel and serial margins,
    and the pose error again on a millimetre scale (``tanh(error / 1 cm)``).  With
    ``travel_goal=True``, 37 entries: the goal in joint space follows (the target's slider
    travels and ``tanh`` of the travel errors over 1 cm).

    ## Rewards
    The reward of a step is ``-w_pose * e - w_precision * (1 - exp(-d / s)) - w_singularity *
    barrier - w_action * effort + w_success * success - w_failure * failure``
    (:mod:`planar3p_gym.tasks.rewards`): ``d = |dp| + L_ref |dtheta|`` (m), ``e = d / L_ref``;
    the precision term sharpens the signal within a few ``s`` (5 mm) of the target; the
    barrier is ``ref/m - 1`` for each margin ``m`` below its reference (capped); effort is the
    mean squared action; failure is a singularity crossing or a physics breakdown.  Weighted
    terms are in ``info["reward_terms"]`` and sum to the reward.

    ## Starting State
    Start and target are drawn from ``self.np_random``: reachable in the episode's working
    mode within the stroke (away from the end stops), with parallel and serial margins above
    thresholds, holdable at rest with at most 75 % of the actuator force, in the same assembly
    mode, and by default joined by a straight path in pose
    space that stays clear of singularities (:class:`planar3p_gym.tasks.sampling.TaskConfig`;
    ``task_config={"near_singular_fraction": p}`` makes a share ``p`` of the pairs instead pass
    within 0.01 of a parallel singularity, like the benchmark's ``hard`` suite, and
    ``{"detour_fraction": p}`` makes a share ``p`` of the other pairs ones that the straight
    line in slider space does not solve, :mod:`planar3p_gym.machine.slider_line`;
    :meth:`set_task_config` changes these shares and the tolerances of a running
    environment).  The
    mechanism starts at rest.  ``reset(options={"start": pose, "target": pose,
    "working_mode": (s1, s2, s3)})`` sets any of them (validated; ``ValueError`` if invalid).

    ## Episode End
    ``terminated`` when the gripper is within ``position_tolerance`` and
    ``orientation_tolerance`` of the target with every slider slower than ``rest_speed``
    (``"success"``), when ``sign det A`` changes (``"singularity_crossing"``), or when the
    loop-closure error exceeds ``breakdown_threshold`` or the state is not finite
    (``"physics_breakdown"``); ``info["termination_reason"]`` says which.  A leg swinging past
    the perpendicular to its rail (a serial singularity) changes the working mode without ending
    the episode; ``info["working_mode_changed"]`` reports it.  ``truncated`` only
    by the registered time limit (``max_episode_steps=250``, 5 s at 50 Hz; Gymnasium's
    ``TimeLimit`` wrapper): ``info["termination_reason"]`` stays ``None`` then, and the end is
    named ``"time_limit"`` (:func:`planar3p_gym.envs.end_reason.end_reason` names any end from
    the step's flags and ``info``, with the names of the training metrics and the benchmark,
    :data:`END_REASONS`; ``EndReason(gym.make(...))`` puts the name in ``info`` as well).

    ## Arguments
    - ``design``: a :class:`Design`, a dict of its fields, or a preset name (``"fig8"``,
      ``"fig7"``); default ``Design.fig8()``.
    - ``working_mode``: ``(s1, s2, s3)`` of +-1 (default ``(1, 1, -1)``) or ``"random"``
      (one of the modes with start/target pairs, drawn per episode).  A mode without pairs
      under the task's margins is rejected here (:func:`planar3p_gym.tasks.sampling.check_mode`), so
      ``reset()`` never fails on a valid setting: it redraws until it finds a pair.
    - ``control_frequency``: control rate (Hz), default 50; also the render fps.
    - ``projection``: project the simulated state exactly onto the mechanism's constraint
      manifold after every control step (:mod:`planar3p_gym.sim.projection`); default ``True``
      (the exact machine of every id).  ``False`` runs the unprojected pymunk-only model (its
      loop closes only as well as pymunk's iterative solver holds it), for fidelity studies.
    - ``substeps``: physics steps per control step; ``solver_iterations``: pymunk constraint
      iterations per physics step.  ``None`` (default) takes the settings of the physics:
      :data:`~planar3p_gym.sim.physics.PROJECTED_SUBSTEPS` and
      :data:`~planar3p_gym.sim.physics.PROJECTED_ITERATIONS` with the projection,
      :data:`~planar3p_gym.sim.physics.DEFAULT_SUBSTEPS` and
      :data:`~planar3p_gym.sim.physics.DEFAULT_ITERATIONS` without it.
    - ``reward_weights``: :class:`RewardWeights` or a dict of its fields.
    - ``task_config``: :class:`TaskConfig` or a dict of its fields (tolerances, sampling
      margins).
    - ``breakdown_threshold``: loop-closure error ending the episode, as a fraction of the
      shortest leg (default 0.01).
    - ``render_mode``: ``None``, ``"rgb_array"`` or ``"human"``; ``render_size`` in pixels.
    - ``travel_goal``: append the target's slider travels in the episode's working mode (its
      inverse kinematics, m) and ``tanh((target_rho - rho) / 1 cm)`` to the observation
      (:data:`planar3p_gym.tasks.observation.TRAVEL_GOAL_FIELDS`); reach task only, default
      ``False``.
    - ``randomization``: a :class:`~planar3p_gym.sim.randomization.DynamicsRandomization` or a
      dict of its fields: the ranges from which each episode's machine is drawn (masses,
      inertias, leg lengths, joint positions, rail offsets, servo force limit, friction, servo
      lag, base tilt), from ``np_random`` after the task's draws; the simulation and its loop
      projection run the drawn machine (``info["machine"]`` at reset), the observation bounds,
      the sensing model and ``self.design`` stay nominal.  Default: none (the nominal machine).
    - ``sensors``: a :class:`~planar3p_gym.sim.sensors.SensorConfig` or a dict of its fields:
      the observation is then computed from joint encoder readings (noise from ``np_random``,
      quantised) with the nominal model (:mod:`planar3p_gym.sim.sensors`) -- travels, their
      rates, pose, twist, leg angles and margins -- while success, reward and termination are
      judged on the true state.  ``None`` (default): the true state is observed.
    - ``latency``: a :class:`~planar3p_gym.envs.latency.LatencyConfig` or a dict of its fields:
      action and observation delays of 0 to 2 control steps, drawn per episode
      (``info["delays"]`` at reset).  Default: none.
    - ``action_type``: ``"continuous"`` (default, the Box above), ``"on-off"``
      (``MultiDiscrete([3, 3, 3])``: each motor stopped (0), forward (1) or backward (2) at
      its rated speed, as on the paper's prototype) or ``"on-off-discrete"`` (``Discrete(27)``,
      the three digits in base 3, slider 1 first; for DQN).  ``on_off_speed``: the motors'
      rated speed as a fraction of ``max_speed`` (default :data:`ON_OFF_SPEED`, 0.1).
    - ``task``: a :class:`planar3p_gym.tasks.Task`, or the ``"module:Class"`` path of a Task
      class built with ``task_kwargs`` (a dict of its constructor arguments) -- how a
      registration row names a new task without an environment class of its own
      (:mod:`planar3p_gym.tasks`, "Adding a task").  Default :class:`~planar3p_gym.tasks.
      ReachTask`, this docstring's task; other registered ids pass theirs.

    ``info["episode_spec"]`` (at reset) is a JSON-serialisable dict describing the episode;
    ``reset(options=spec)`` replays it exactly (:mod:`planar3p_gym.tasks.base`).

    ## Version History
    - v0 (0.2.0, issue 24): the same distribution of episodes, drawn faster: poses are proposed
      from the region that holds every reachable pose (:mod:`planar3p_gym.tasks.pose_proposal`);
      a seed draws other episodes than before.
    - v0 (0.2.0, issue 26): the machine as built (``randomization``, ``sensors``, ``latency``,
      ``action_type``), off by default: ``Planar3P-v0`` and every other id unchanged;
      ``Planar3PReal-v0`` and ``Planar3PRealOnOff-v0`` turn them on.
    - v0 (0.2.0): the exact machine: the projected physics (``projection=True``), whose loop
      closure is exact on every step.  Before 0.2.0 this id ran the unprojected model (now
      ``projection=False``) and ``Planar3P-v0`` ran today's v0; that id is gone.  The
      ``travel_goal`` argument, off by default, changes no observation.
    - v0 (0.1.0): initial release.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 50}

    def __init__(
        self,
        design: Design | dict | str | None = None,
        *,
        working_mode: tuple[int, int, int] | str = DEFAULT_WORKING_MODE,
        control_frequency: float = 50.0,
        substeps: int | None = None,
        solver_iterations: int | None = None,
        projection: bool = True,
        reward_weights: RewardWeights | dict | None = None,
        task_config: TaskConfig | dict | None = None,
        breakdown_threshold: float = 0.01,
        render_mode: str | None = None,
        render_size: tuple[int, int] = (640, 480),
        task: Task | str | None = None,
        task_kwargs: dict[str, Any] | None = None,
        travel_goal: bool = False,
        randomization: DynamicsRandomization | dict | None = None,
        sensors: SensorConfig | dict | None = None,
        latency: LatencyConfig | dict | None = None,
        action_type: str = "continuous",
        on_off_speed: float = ON_OFF_SPEED,
    ) -> None:
        self.task = make_task(task, task_kwargs)
        self.design = design_from(design)
        if isinstance(working_mode, str):
            if working_mode != "random":
                raise ValueError(
                    f"working_mode must be a triple of +-1 or 'random', got {working_mode!r}"
                )
            self._fixed_mode = None
        else:
            self._fixed_mode = mode_from(working_mode, "working_mode")
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
            checks.choice(render_mode, "render_mode", tuple(self.metadata["render_modes"]))
        self.reward_weights = config_from(reward_weights, RewardWeights, "reward_weights")
        self.task_config = config_from(task_config, TaskConfig, "task_config")
        if not (isinstance(render_size, (tuple, list)) and len(render_size) == 2):
            raise ValueError(
                f"render_size must be (width, height) in pixels, 16..8192, got {render_size!r}"
            )
        render_size = tuple(
            checks.integer(v, f"render_size[{i}]", low=16, high=8192)
            for i, v in enumerate(render_size)
        )
        travel_goal = checks.flag(travel_goal, "travel_goal")
        randomization = config_from(randomization, DynamicsRandomization, "randomization")
        sensors = None if sensors is None else config_from(sensors, SensorConfig, "sensors")
        latency = config_from(latency, LatencyConfig, "latency")
        action_type = checks.choice(action_type, "action_type", ACTION_TYPES)
        on_off_speed = checks.number(on_off_speed, "on_off_speed", low=0.0, high=1.0, low_open=True)
        #: Rated speed of the on-off motors as a fraction of ``max_speed``.
        self.on_off_speed = on_off_speed
        #: Ranges of the per-episode machine (``None``: the nominal machine).
        self.randomization = None if randomization.is_zero else randomization
        #: The encoders' noise and resolution (``None``: the policy observes the true state).
        self.sensors = sensors
        #: Ranges of the per-episode delays (``None``: none).
        self.latency = None if latency.is_zero else latency
        self.action_type = action_type
        #: Whether any feature of the built machine is on (the general step then runs).
        self._realistic = (
            self.randomization is not None
            or sensors is not None
            or self.latency is not None
            or action_type != "continuous"
        )
        self.control_frequency = float(control_frequency)
        self.dt = 1.0 / self.control_frequency
        self.substeps = int(substeps)
        self.solver_iterations = int(solver_iterations)
        self.projection = bool(projection)
        self.breakdown_distance = breakdown_threshold * self.design.shortest_leg
        self.render_mode = render_mode
        self.render_size = tuple(render_size)
        self.metadata = {**self.metadata, "render_fps": int(round(self.control_frequency))}

        if action_type == "on-off":
            self.action_space = spaces.MultiDiscrete([3, 3, 3])
        elif action_type == "on-off-discrete":
            self.action_space = spaces.Discrete(27)
        else:
            self.action_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)
        self._obs_low, self._obs_high = bounds(self.design)
        self._kin = ScalarKinematics(self.design)
        self._true_kin = self._kin  # the episode's machine (randomised: its true design)
        self._encoders = None if sensors is None else Encoders(self.design, sensors, self.dt)
        self._machine = SampledMachine(self.design, MachineDynamics())
        self._delays = (0, 0)
        self._action_line: DelayLine | None = None
        self._obs_line: DelayLine | None = None
        self._length = self.design.characteristic_length
        self._renderer = None
        if self._fixed_mode:  # rejected here if it has no usable start/target pair
            task_module.check_mode(self.design, self._fixed_mode, self.task_config)
        self._modes = [self._fixed_mode] if self._fixed_mode else self._usable_modes()
        self.task.bind(self)
        extra_low, extra_high = self.task.observation_bounds()
        self._extra_low = np.asarray(extra_low, dtype=np.float32)
        self._extra_high = np.asarray(extra_high, dtype=np.float32)
        self.observation_space = spaces.Box(
            np.concatenate([self._obs_low, self._extra_low]),
            np.concatenate([self._obs_high, self._extra_high]),
            dtype=np.float32,
        )
        if travel_goal and type(self.task) is not ReachTask:
            raise ValueError(
                f"travel_goal applies to the reach task (a fixed target per episode), not to "
                f"task {self.task.name!r}"
            )
        self.travel_goal = bool(travel_goal)
        if self.travel_goal:
            goal_low, goal_high = travel_goal_bounds(self.design)
            self.observation_space = spaces.Box(
                np.concatenate([self.observation_space.low, goal_low]),
                np.concatenate([self.observation_space.high, goal_high]),
                dtype=np.float32,
            )
        self._target_rho = np.zeros(3)  # the target's slider travels (m), with travel_goal
        self._sim: Planar3PSim | None = None
        self._target = (0.0, 0.0, 0.0)
        self._target_cs = (1.0, 0.0)  # cos, sin of the target angle (fused reach step)
        # The reach task on the projected physics takes the fused step (reach_step.py).
        self._reach_step = (
            ReachStep(
                self.design,
                self._obs_low,
                self._obs_high,
                self.reward_weights,
                self.task_config.success_tolerances,
            )
            if self.projection and type(self.task) is ReachTask and not self._realistic
            else None
        )
        self._steps = 0
        self._spec: dict[str, Any] = {}
        self._mode = self._modes[0]
        self._assembly = 0
        self._obs = np.zeros(self.observation_space.shape, dtype=np.float32)
        self._measures: ConfigurationMeasures | None = None
        self._last_info: dict[str, Any] = {}

    # ------------------------------------------------------------------ helpers
    def _usable_modes(self) -> list[tuple[int, int, int]]:
        """Working modes with usable start/target pairs
        (:func:`planar3p_gym.tasks.sampling.check_mode`, a fixed internal seed: the list never
        depends on, or consumes, the episode's stream)."""
        usable = [
            tuple(m)
            for m in kinematics.ALL_MODES.tolist()
            if task_module.has_pairs(self.design, m, self.task_config)
        ]
        if not usable:
            raise ValueError(
                "no working mode of this design has start/target pairs meeting the task's "
                "margins; relax the TaskConfig"
            )
        return usable

    @property
    def sim(self) -> Planar3PSim:
        """The physics model of the current episode."""
        if self._sim is None:
            raise RuntimeError("call reset() before using the environment")
        return self._sim

    @property
    def target(self) -> tuple[float, float, float]:
        """Target pose ``(x, y, theta)`` of the episode (m, m, rad)."""
        return self._target

    @property
    def modes(self) -> list[tuple[int, int, int]]:
        """The working modes episodes are drawn from (one when ``working_mode`` is fixed)."""
        return list(self._modes)

    @property
    def episode_spec(self) -> dict[str, Any]:
        """The JSON-serialisable spec of the current episode (``reset(options=spec)``
        replays it; see :mod:`planar3p_gym.tasks.base`)."""
        return copy_spec(self._spec)

    @property
    def working_mode(self) -> tuple[int, int, int]:
        """Working mode of the episode."""
        return self._mode

    @property
    def assembly_mode(self) -> int:
        """``sign(det A)`` at the start of the episode."""
        return self._assembly

    # ------------------------------------------------------------------ Gymnasium API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        options = check_reset_options(options, (*self.task.option_keys, "task"))
        requested = options.pop("task", None)
        if requested is not None and requested != self.task.name:
            raise ValueError(
                f"options are for task {requested!r}, but this environment's task is "
                f"{self.task.name!r}"
            )
        options = self.task.check_options(options)  # before seeding: a rejection changes nothing
        # Checks that need the episode's draw (a pose under a drawn working mode, a start no
        # target pairs with) can only reject after seeding: then the random stream and the
        # task's pools are put back, so a rejected reset changes nothing either.
        undo = self._random_state() if options else None
        try:
            super().reset(seed=seed)
            if seed is not None:
                self.task.reseed()
            spec = self.task.episode_spec(self.np_random, options)
            start, mode = self.task.begin(spec)
        except ValueError:
            if undo is not None:
                self._restore_random_state(undo)
            raise
        self._spec = spec
        self._steps = 0
        self._mode = mode
        self._target = self.task.reference(0)
        self._target_cs = (math.cos(self._target[2]), math.sin(self._target[2]))
        if self.travel_goal:
            self._target_rho = kinematics.inverse(self.design, self._target, mode).rho
        machine = self._draw_machine(start, mode) if self.randomization else self._machine
        previous = self._sim
        if previous is not None and not previous.closed:
            # The bodies are moved (and, for a machine drawn per episode, the model given its
            # numbers): bit for bit the model a new build would give (Planar3PSim.reset).
            if self.randomization is None:
                previous.reset(start, mode)
            else:
                previous.reset(start, mode, design=machine.design, dynamics=machine.dynamics)
        else:
            self._sim = Planar3PSim(
                machine.design,
                start,
                mode,
                dt=self.dt,
                substeps=self.substeps,
                iterations=self.solver_iterations,
                projection=self.projection,
                dynamics=None if self.randomization is None else machine.dynamics,
            )
            if previous is not None:  # freed now, not left to the garbage collector
                previous.close()
        state = self._sim.state
        self._measures = self._true_kin.measures(state.pose, state.rho)
        self._assembly = self._measures.det_sign
        if self._realistic:
            self._begin_realistic()
        self._obs = self._observe_machine(state, self._measures)
        errors = self._errors(state.pose)
        info = self._info(state, self._measures, None, {}, False, errors)
        info.update(self.task.step_info(0, state, errors))
        info["episode_spec"] = copy_spec(spec)
        if self.randomization is not None:
            info["machine"] = machine.to_dict()
        if self.latency is not None:
            info["delays"] = self._delays
        self._last_info = info
        if self._obs_line is not None:
            self._obs_line = DelayLine(self._delays[1], self._obs.copy())
        if self.render_mode == "human":
            self.render()
        return self._obs.copy(), info

    def _draw_machine(self, start: Any, mode: tuple[int, int, int]) -> SampledMachine:
        """The episode's machine from ``np_random`` (:attr:`randomization`): redrawn while the
        start pose is out of its reach (at most :data:`MACHINE_DRAWS` draws, then nominal)."""
        assert self.randomization is not None
        machine = SampledMachine(self.design, MachineDynamics())
        for _ in range(MACHINE_DRAWS):
            drawn = self.randomization.sample(self.design, self.np_random)
            if bool(kinematics.inverse(drawn.design, np.asarray(start), mode).reachable):
                machine = drawn
                break
        self._machine = machine
        self._true_kin = (
            self._kin if machine.design == self.design else ScalarKinematics(machine.design)
        )
        return machine

    def _begin_realistic(self) -> None:
        """Per-episode state of the built machine's features: the delays (drawn from
        ``np_random``), their delay lines, the encoders."""
        if self.latency is not None:
            self._delays = self.latency.sample(self.np_random)
        self._action_line = DelayLine(self._delays[0], (0.0, 0.0, 0.0))
        self._obs_line = DelayLine(self._delays[1], None)
        if self._encoders is not None:
            self._encoders.reset()

    def _observe_machine(self, state: SimState, measures: ConfigurationMeasures) -> np.ndarray:
        """The observation of the true ``state`` (with ``measures``, its true margins): of the
        encoders' reading and the nominal model's margins at it, with :attr:`sensors`."""
        if self._encoders is None:
            return self._observe(state, measures)
        seen = self._encoders.measure(state, self.np_random)
        return self._observe(seen, self._kin.measures(seen.pose, seen.rho))

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._realistic:
            return self._realistic_step(action)
        sim = self.sim
        a0, a1, a2 = parse_action(action)
        vmax = self.design.max_speed
        state = sim.step_unchecked(a0 * vmax, a1 * vmax, a2 * vmax)
        self._steps += 1
        if (
            self._reach_step is not None
            and state.finite
            and state.closure_error <= self.breakdown_distance
        ):  # (the reach task's reference is its fixed target)
            return self._fused_step(state, (a0, a1, a2))
        return self._general_step(state, (a0, a1, a2))

    def _realistic_step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """:meth:`step` with the built machine's features: the action type, the action delay,
        the general step (on the true state, observed through the encoders), the observation
        delay.  The reward's effort term is that of the action executed."""
        sim = self.sim
        if self.action_type == "continuous":
            chosen = parse_action(action)
        else:
            c0, c1, c2 = on_off_action(action, self.action_type)
            v = self.on_off_speed
            chosen = (c0 * v, c1 * v, c2 * v)
        assert self._action_line is not None and self._obs_line is not None
        a0, a1, a2 = self._action_line.push(chosen)
        vmax = self.design.max_speed
        state = sim.step_unchecked(a0 * vmax, a1 * vmax, a2 * vmax)
        self._steps += 1
        obs, reward, terminated, truncated, info = self._general_step(state, (a0, a1, a2))
        return self._obs_line.push(obs), reward, terminated, truncated, info

    def _general_step(
        self, state: SimState, action: tuple[float, float, float]
    ) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """The rest of :meth:`step` after the physics, through the task's hooks."""
        a0, a1, a2 = action
        self._target = self.task.reference(self._steps)

        reason = None
        success = False
        if not state.finite or state.closure_error > self.breakdown_distance:
            # The new state is not trustworthy: keep the last good observation and errors.
            reason = "physics_breakdown"
            measures = self._measures
            pos_err, ang_err = self._errors(self._last_info["pose"])
        else:
            measures = self._true_kin.measures(state.pose, state.rho)
            self._obs = self._observe_machine(state, measures)
            pos_err, ang_err = self._errors(state.pose)
            reason = self.task.termination(state, measures, (pos_err, ang_err), self._assembly)
            success = reason == "success"
        failure = reason in self.task.failure_reasons
        assert measures is not None
        terms = self.task.reward_terms(
            errors=(pos_err, ang_err),
            measures=measures,
            action=(a0, a1, a2),
            success=success,
            failure=failure,
        )
        reward = float(sum(terms.values()))
        if reason == "physics_breakdown":
            info = dict(self._last_info)
            info.update(
                termination_reason=reason,
                is_success=False,
                reward_terms=terms,
                closure_error=state.closure_error
                if math.isfinite(state.closure_error)
                else math.inf,
            )
        else:
            info = self._info(state, measures, reason, terms, success, (pos_err, ang_err))
            self._measures = measures
        info.update(self.task.step_info(self._steps, state, (pos_err, ang_err)))
        self._last_info = info
        if self.render_mode == "human":
            self.render()
        return self._obs.copy(), reward, reason is not None, False, info

    def _fused_step(
        self, state: SimState, action: tuple[float, float, float]
    ) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """The rest of :meth:`step` for the reach task on the projected physics: one compiled
        call (:func:`planar3p_gym.tasks.reach_step.reach_outputs`) on the projection's state
        array (same results as the general step to float64 rounding)."""
        rs = self._reach_step
        assert rs is not None and self._sim is not None
        st = self._sim._projector.last_state  # type: ignore[union-attr]
        res = rs.compute(
            st, state.pose[2], self._target, self._target_cs, self._assembly, action
        ).tolist()
        obs = rs.obs.copy()
        if self.travel_goal:
            obs = self._with_travel_goal(obs)
        self._obs = obs
        reason = REASONS[int(res[1])]
        measures = ConfigurationMeasures(res[4], res[5], int(res[6]), state.leg_angles)
        terms = dict(zip(TERM_NAMES, res[TERMS_START:], strict=True))
        info = self._info(state, measures, reason, terms, reason == "success", (res[2], res[3]))
        self._measures = measures
        self._last_info = info
        if self.render_mode == "human":
            self.render()
        return obs.copy(), res[0], reason is not None, False, info

    def set_task_config(self, changes: dict[str, Any]) -> TaskConfig:
        """Change fields of :attr:`task_config` in the running environment (a curriculum on
        the tolerances or on the mix of training pairs) and return the new configuration.

        Only :data:`planar3p_gym.tasks.sampling.SCHEDULABLE_FIELDS` may change; the success test
        uses the new values from the next step on, the pair sampling from the next reset.
        Invalid changes raise ``ValueError`` and change nothing.
        """
        cfg = task_module.updated_config(self.task_config, changes)
        self.task_config = cfg
        if self._reach_step is not None:
            self._reach_step.tolerances = cfg.success_tolerances
        self.task.config_changed()
        return cfg

    def get_keys_to_action(self) -> dict[tuple[str, ...], np.ndarray]:
        """Keyboard mapping for :func:`gymnasium.utils.play.play`: ``q``/``a`` drive slider 1
        towards +x/-x, ``w``/``s`` slider 2, ``e``/``d`` slider 3, at ``KEYBOARD_SPEED`` of
        ``max_speed``; keys of different sliders combine.  Use with
        ``play(env, noop=np.zeros(3, np.float32))`` (the default ``noop=0`` is not an action)."""
        mapping: dict[tuple[str, ...], np.ndarray] = {}
        for signs in itertools.product((0, 1, -1), repeat=3):
            keys = tuple(
                sorted(
                    up if sg > 0 else down
                    for (up, down), sg in zip(KEYBOARD_KEYS, signs, strict=True)
                    if sg
                )
            )
            if keys:
                mapping[keys] = KEYBOARD_SPEED * np.array(signs, dtype=np.float32)
        return mapping

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode to make()")
            return None
        from planar3p_gym.sim.render import Frame, Renderer

        if self._renderer is None:
            self._renderer = Renderer(
                self.design, self.render_size, self.render_mode, self.metadata["render_fps"]
            )
        info = self._last_info
        pos_err = info.get("position_error", 0.0)
        frame = Frame(
            rho=info.get("rho", (0.0, 0.0, 0.0)),
            pose=info.get("pose", (0.0, 0.0, 0.0)),
            target=self._target if self._sim is not None else None,
            parallel_margin=info.get("parallel_margin", 1.0),
            serial_margin=info.get("serial_margin", 1.0),
            time=info.get("time", 0.0),
            text=(
                f"position error {1000 * pos_err:6.1f} mm",
                f"orientation error {math.degrees(info.get('orientation_error', 0.0)):6.1f} deg",
            ),
            forces=info.get("actuator_forces"),
        )
        return self._renderer.render(frame)

    def close(self) -> None:
        """Close the renderer and free the simulation now (:meth:`Planar3PSim.close`), and
        the task's own simulations (its ``close``, if it has one); a later :meth:`reset`
        builds a new simulation."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        if self._sim is not None:
            self._sim.close()
        close_task = getattr(self.task, "close", None)
        if close_task is not None:
            close_task()

    # ------------------------------------------------------------------ snapshots
    #: Per-episode attributes a snapshot carries (besides the simulation, the random
    #: generator and the task).
    _EPISODE_FIELDS = (
        "_spec",
        "_steps",
        "_mode",
        "_target",
        "_target_cs",
        "_assembly",
        "_obs",
        "_measures",
        "_last_info",
        "_true_kin",
        "_machine",
        "_delays",
        "_action_line",
        "_obs_line",
        "_encoders",
    )

    def get_state(self) -> dict[str, Any]:
        """A snapshot of the environment (plain, picklable data): the simulation
        (:meth:`Planar3PSim.get_state`), ``np_random``'s state, the task's episode state
        (``task.get_state()`` if the task defines it, else a copy of its attributes) and the
        episode's bookkeeping.  :meth:`set_state` on an environment made with the same
        settings continues bit for bit as this one would."""
        return {
            "config": self.config(),
            "sim": None if self._sim is None else self._sim.get_state(),
            **self._random_state(),
            "episode": copy.deepcopy({k: getattr(self, k) for k in self._EPISODE_FIELDS}),
        }

    def _random_state(self) -> dict[str, Any]:
        """``np_random``'s state, its seed and the task's state (sampler pools included)."""
        task = self.task
        if hasattr(task, "get_state"):
            task_state = task.get_state()
        else:
            task_state = copy.deepcopy({k: v for k, v in vars(task).items() if k != "env"})
        return {
            "np_random": copy.deepcopy(self.np_random.bit_generator.state),
            "np_random_seed": self._np_random_seed,
            "task": task_state,
        }

    def _restore_random_state(self, state: dict[str, Any]) -> None:
        """Put back what :meth:`_random_state` recorded."""
        rng = np.random.Generator(type(self.np_random.bit_generator)())
        rng.bit_generator.state = copy.deepcopy(state["np_random"])
        self._np_random, self._np_random_seed = rng, state["np_random_seed"]
        if hasattr(self.task, "set_state"):
            self.task.set_state(copy.deepcopy(state["task"]))
        else:
            vars(self.task).update(copy.deepcopy(state["task"]))

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore a :meth:`get_state` snapshot (``ValueError`` if it is not one, or was taken
        from an environment with other settings; nothing is changed then).  This restores the
        environment; for one made with ``gym.make``, whose ``TimeLimit`` wrapper counts the
        episode's steps on its own, use :func:`planar3p_gym.envs.end_reason.restore_state`
        ``(env, state)``, which sets that counter too."""
        keys = {"config", "sim", "np_random", "np_random_seed", "task", "episode"}
        if not isinstance(state, dict) or set(state) != keys:
            raise ValueError("state must be a snapshot from Planar3PEnv.get_state()")
        if state["config"] != self.config():
            raise ValueError(
                "the snapshot was taken from an environment with other settings: "
                f"{state['config']} != {self.config()}"
            )
        sim = None if state["sim"] is None else Planar3PSim.from_state(state["sim"])
        self._restore_random_state(state)
        if self._sim is not None:  # the model being replaced (Planar3PSim.close)
            self._sim.close()
        self._sim = sim
        for key, value in copy.deepcopy(state["episode"]).items():
            setattr(self, key, value)

    def __getstate__(self) -> dict[str, Any]:
        # The renderer holds a pygame window or surface: copies are made without one.
        out = dict(self.__dict__)
        out["_renderer"] = None
        return out

    # ------------------------------------------------------------------ internals
    def _errors(self, pose: tuple[float, float, float]) -> tuple[float, float]:
        tx, ty, tth = self._target
        return math.hypot(tx - pose[0], ty - pose[1]), wrap_angle(tth - pose[2])

    def _observe(self, state: SimState, measures: ConfigurationMeasures) -> np.ndarray:
        obs = self._observe_base(state, measures)
        extra = self.task.observation_extra(self._steps)
        if extra:
            tail = np.array(extra, dtype=np.float32)
            np.minimum(tail, self._extra_high, out=tail)
            np.maximum(tail, self._extra_low, out=tail)
            obs = np.concatenate([obs, tail])
        return self._with_travel_goal(obs) if self.travel_goal else obs

    def _with_travel_goal(self, obs: np.ndarray) -> np.ndarray:
        """``obs`` with the joint-space goal block appended (``travel_goal=True``)."""
        return np.concatenate([obs, travel_goal_entries(obs[:3], self._target_rho)])

    def _observe_base(self, state: SimState, measures: ConfigurationMeasures) -> np.ndarray:
        """The 31 entries of :mod:`planar3p_gym.tasks.observation` against the current reference."""
        return build_observation(
            state.rho,
            state.rho_dot,
            state.pose,
            state.twist,
            state.leg_angles,
            self._target,
            measures.parallel_margin,
            measures.serial_margin,
            self._obs_low,
            self._obs_high,
            self._length,
        )

    def _info(
        self,
        state: SimState,
        measures: ConfigurationMeasures,
        reason: str | None,
        terms: dict[str, float],
        success: bool,
        errors: tuple[float, float],
    ) -> dict[str, Any]:
        pos_err, ang_err = errors
        return {
            "is_success": success,
            "termination_reason": reason,
            "position_error": pos_err,
            "orientation_error": ang_err,
            "parallel_margin": measures.parallel_margin,
            "serial_margin": measures.serial_margin,
            "assembly_mode": measures.det_sign,
            "working_mode": self._mode,
            "working_mode_changed": _mode_changed(measures.leg_angles, self._mode),
            "actuator_forces": state.actuator_forces,
            "actuator_saturated": state.saturated,
            "closure_error": state.closure_error,
            "reward_terms": terms,
            "pose": state.pose,
            "rho": state.rho,
            "rho_dot": state.rho_dot,
            "time": state.time,
        }

    def config(self) -> dict[str, Any]:
        """The environment's settings as plain data (for run records)."""
        return {
            "design": self.design.to_dict(),
            "working_mode": self._fixed_mode or "random",
            "control_frequency": self.control_frequency,
            "substeps": self.substeps,
            "solver_iterations": self.solver_iterations,
            "projection": self.projection,
            "reward_weights": asdict(self.reward_weights),
            "task_config": asdict(self.task_config),
            "breakdown_threshold": self.breakdown_distance / self.design.shortest_leg,
            "task": self.task.name,
            "task_arguments": self.task.arguments(),
            "travel_goal": self.travel_goal,
            # The built machine's features, only where on (the records of earlier runs stay
            # valid as they are).
            **({"randomization": self.randomization.to_dict()} if self.randomization else {}),
            **({"sensors": self.sensors.to_dict()} if self.sensors is not None else {}),
            **({"latency": self.latency.to_dict()} if self.latency else {}),
            **(
                {"action_type": self.action_type, "on_off_speed": self.on_off_speed}
                if self.action_type != "continuous"
                else {}
            ),
        }


def _mode_changed(leg_angles: tuple[float, float, float], mode: tuple[int, int, int]) -> bool:
    """Whether a leg's ``sign(cos alpha_i)`` differs from the working mode's ``sigma_i``."""
    a1, a2, a3 = leg_angles
    m1, m2, m3 = mode
    return (
        (math.cos(a1) >= 0.0) != (m1 > 0)
        or (math.cos(a2) >= 0.0) != (m2 > 0)
        or (math.cos(a3) >= 0.0) != (m3 > 0)
    )
