"""``Planar3P-v0``: move the gripper of a 3-PRR planar parallel manipulator to a target pose.

:class:`Planar3PEnv` owns the Gymnasium API: spaces, seeding, reset, snapshots, rendering and one
``step`` for every task: the action through the machine's actuation
(:class:`planar3p_gym.envs.actuation.BuiltMachine`), the physics, the task's kernel
(:mod:`planar3p_gym.tasks.kernel`).
"""

from __future__ import annotations

import copy
from typing import Any

import gymnasium as gym
import numpy as np

from planar3p_gym import checks
from planar3p_gym.envs.actuation import ON_OFF_SPEED, BuiltMachine, keys_to_action
from planar3p_gym.envs.latency import LatencyConfig
from planar3p_gym.envs.settings import RENDER_MODES, EnvSettings, episode_modes, make_task
from planar3p_gym.envs.snapshot import check_snapshot, random_state, restored_random
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.sim.physics import Planar3PSim
from planar3p_gym.sim.randomization import DynamicsRandomization
from planar3p_gym.sim.sensors import SensorConfig
from planar3p_gym.tasks import Task
from planar3p_gym.tasks.base import copy_spec
from planar3p_gym.tasks.kernel import Episode, KernelSettings
from planar3p_gym.tasks.rewards import RewardWeights
from planar3p_gym.tasks.sampling import TaskConfig

__all__ = [
    "DEFAULT_WORKING_MODE",
    "OBSERVATION_ARGUMENTS",
    "Planar3PEnv",
]

#: The working mode used unless another is asked for: the mode of the default design with the
#: largest well-conditioned workspace.
DEFAULT_WORKING_MODE: tuple[int, int, int] = (1, 1, -1)
#: Arguments of :class:`Planar3PEnv` and its goal env
#: (:class:`planar3p_gym.envs.goal.Planar3PGoalEnv`) that change what a policy observes (the
#: shape of the observation): a model trained with them must be played with them.
OBSERVATION_ARGUMENTS: tuple[str, ...] = ("travel_goal", "observe_working_mode")


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
    Start and target are drawn from ``self.np_random``: reachable in the episode's working mode
    within the stroke (away from the end stops), with parallel and serial margins above thresholds,
    holdable at rest with at most 75 % of the actuator force, in the same assembly mode, and by
    default joined by a straight path in pose space that stays clear of singularities
    (:class:`planar3p_gym.tasks.sampling.TaskConfig`; ``task_config={"near_singular_fraction": p}``
    makes a share ``p`` of the pairs instead pass within 0.01 of a parallel singularity, like the
    benchmark's ``hard`` suite, and ``{"detour_fraction": p}`` makes a share ``p`` of the other
    pairs ones that the straight line in slider space does not solve,
    :mod:`planar3p_gym.machine.slider_line`; :meth:`set_task_config` changes these shares and the
    tolerances of a running environment).  The mechanism starts at rest.  ``reset(options={"start":
    pose, "target": pose, "working_mode": (s1, s2, s3)})`` sets any of them (validated;
    ``ValueError`` if invalid).

    ## Episode End
    ``terminated`` when the gripper is within ``position_tolerance`` and ``orientation_tolerance``
    of the target with every slider slower than ``rest_speed`` (``"success"``), when ``sign det A``
    changes (``"singularity_crossing"``), or when the loop-closure error exceeds
    ``breakdown_threshold`` or the state is not finite (``"physics_breakdown"``);
    ``info["termination_reason"]`` says which.  A leg swinging past the perpendicular to its rail (a
    serial singularity) changes the working mode without ending the episode;
    ``info["working_mode_changed"]`` reports it.  ``truncated`` only by the registered time limit
    (``max_episode_steps=250``, 5 s at 50 Hz; Gymnasium's ``TimeLimit`` wrapper):
    ``info["termination_reason"]`` stays ``None`` then, and the end is named ``"time_limit"``
    (:func:`planar3p_gym.envs.end_reason.end_reason` names any end from the step's flags and
    ``info``, with the names of the training metrics and the benchmark, :data:`END_REASONS`;
    ``EndReason(gym.make(...))`` puts the name in ``info`` as well).

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
      iterations per physics step; ``None`` (default): the physics' settings
      (:mod:`planar3p_gym.sim.physics`: ``PROJECTED_*`` with the projection, else ``DEFAULT_*``).
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
    - The machine as built (:class:`~planar3p_gym.envs.actuation.BuiltMachine`; each feature
      off by default): ``randomization`` (a
      :class:`~planar3p_gym.sim.randomization.DynamicsRandomization` or a dict of its fields:
      each episode's machine drawn from ``np_random`` after the task's draws, masses, inertias,
      geometry, servo force limit, friction, servo lag, base tilt; ``info["machine"]`` at
      reset; the observation bounds, the sensing model and ``self.design`` stay nominal);
      ``sensors`` (a :class:`~planar3p_gym.sim.sensors.SensorConfig` or a dict: the
      observation from noisy, quantised joint encoder readings through the nominal model,
      while success, reward and termination are judged on the true state); ``latency`` (a
      :class:`~planar3p_gym.envs.latency.LatencyConfig` or a dict: action and observation
      delays of 0 to 2 control steps drawn per episode, ``info["delays"]`` at reset);
      ``action_type``: ``"continuous"`` (the Box above), ``"on-off"`` (``MultiDiscrete([3, 3,
      3])``: each motor stopped (0), forward (1) or backward (2) at its rated speed
      ``on_off_speed``, a fraction of ``max_speed``, default 0.1, as on the paper's prototype)
      or ``"on-off-discrete"`` (``Discrete(27)``, the three digits in base 3; for DQN).
    - ``task``: a :class:`planar3p_gym.tasks.Task`, or the ``"module:Class"`` path of a Task
      class built with ``task_kwargs`` (a dict of its constructor arguments) -- how a
      registration row names a new task without an environment class of its own
      (``docs/adding_a_task.md``).  Default :class:`~planar3p_gym.tasks.
      ReachTask`, this docstring's task; other registered ids pass theirs.

    ``info["episode_spec"]`` (at reset) is a JSON-serialisable dict describing the episode;
    ``reset(options=spec)`` replays it exactly (:mod:`planar3p_gym.tasks.base`).

    ## Version History
    - v0 (1.0.0): frozen, as every id of 1.0.0: a change of its dynamics, reward, observation or
      episode stream registers ``-v1`` and keeps ``-v0`` registered.  The exact machine (the
      projected physics; the unprojected model of 0.1.0 is ``projection=False``); the machine as
      built (``randomization``, ``sensors``, ``latency``, ``action_type``), off by default;
      ``travel_goal``, off by default, changes no observation; the changes every id took in
      1.0.0 (``CHANGELOG.md``, 1.0.0: the projected physics, the constrained-dynamics step at a
      parallel singularity, poses proposed from the reachable region, one angle wrap, the
      compiled step outputs).
    - v0 (0.1.0): initial release.
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 50}

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
        s = EnvSettings.of(
            design, working_mode, control_frequency, substeps, solver_iterations, projection,
            reward_weights, task_config, breakdown_threshold, render_mode, render_size,
            travel_goal,
        )  # fmt: skip
        #: The machine's actuation and sensing (the nominal machine's: the identity).
        m = self.machine = BuiltMachine(
            s.design, s.dt, substeps=s.substeps, randomization=randomization, sensors=sensors,
            latency=latency, action_type=action_type, on_off_speed=on_off_speed,
        )  # fmt: skip
        self.randomization, self.sensors, self.latency = m.randomization, m.sensors, m.latency
        self.action_type, self.on_off_speed = m.action_type, m.on_off_speed
        self.settings, self.design, self._fixed_mode = s, s.design, s.fixed_mode
        self.control_frequency, self.dt, self.substeps = s.control_frequency, s.dt, s.substeps
        self.solver_iterations, self.projection = s.solver_iterations, s.projection
        self.breakdown_distance, self.travel_goal = s.breakdown_distance, s.travel_goal
        self.reward_weights, self.task_config = s.reward_weights, s.task_config
        self.render_mode, self.render_size = s.render_mode, s.render_size
        self.metadata = {**self.metadata, "render_fps": int(round(self.control_frequency))}
        self._renderer = None
        self._modes = episode_modes(self.design, self._fixed_mode, self.task_config)
        self.task.bind(self)
        k = KernelSettings.of(
            self.task, self.design, self.reward_weights, self.task_config.success_tolerances,
            self.breakdown_distance, self.travel_goal, self.projection, m.nominal,
        )  # fmt: skip
        self.action_space, self.observation_space = m.action_space, k.observation_space()
        #: The task's kernel: a step's outputs from the simulation's state.
        self.kernel = self.task.kernel(k, m)
        self._sim: Planar3PSim | None = None
        #: The per-episode record (:class:`planar3p_gym.tasks.kernel.Episode`).
        self.episode = Episode(
            mode=self._modes[0], obs=np.zeros(k.observation_space().shape, np.float32)
        )

    @property
    def sim(self) -> Planar3PSim:
        """The physics model of the current episode."""
        if self._sim is None:
            raise RuntimeError("call reset() before using the environment")
        return self._sim

    @property
    def target(self) -> tuple[float, float, float]:
        """Target pose ``(x, y, theta)`` of the episode (m, m, rad)."""
        return self.episode.target

    @property
    def modes(self) -> list[tuple[int, int, int]]:
        """The working modes episodes are drawn from (one when ``working_mode`` is fixed)."""
        return list(self._modes)

    @property
    def episode_spec(self) -> dict[str, Any]:
        """The JSON-serialisable spec of the current episode (``reset(options=spec)``
        replays it; see :mod:`planar3p_gym.tasks.base`)."""
        return copy_spec(self.episode.spec)

    @property
    def working_mode(self) -> tuple[int, int, int]:
        """Working mode of the episode."""
        return self.episode.mode

    @property
    def assembly_mode(self) -> int:
        """``sign(det A)`` at the start of the episode."""
        return self.episode.assembly

    # ------------------------------------------------------------------ Gymnasium API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        seed = checks.seed(seed)  # (NumPy integers too; bools and floats are refused)
        options = self.task.reset_options(options)  # before seeding: a rejection changes nothing
        # A draw that rejects (a pose under a drawn working mode, a start no target pairs with,
        # a drawn machine) puts the random stream and the task's pools back: nothing changed.
        can_reject = options or self.randomization is not None
        undo = random_state(self.np_random, self._np_random_seed, self.task) if can_reject else None
        try:
            super().reset(seed=seed)
            if seed is not None:
                self.task.reseed()
            spec = self.task.episode_spec(self.np_random, options)
            start, mode = self.task.begin(spec)
            machine = self.machine.draw(self.np_random, start, mode)
        except ValueError:
            if undo is not None:
                self._np_random, self._np_random_seed = restored_random(undo, self.task)
            raise
        ep = self.episode = Episode.of(spec, mode, self.task.reference(0))
        if self.travel_goal:
            ep.target_rho = kinematics.inverse(self.design, ep.target, mode).rho
        self._sim = self.machine.simulation(machine, self._sim, start, mode, self.settings)
        self.machine.begin(self.np_random)
        info = self.kernel.start(ep, self.sim.state, self.np_random)
        info["episode_spec"] = copy_spec(spec)
        info.update(self.machine.reset_info())
        ep.info = info
        self.machine.first_observation(ep.obs)
        if self.render_mode == "human":
            self.render()
        return ep.obs.copy(), info

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        sim = self.sim
        a = self.machine.command(action)  # (ValueError before anything changes)
        vmax = self.design.max_speed
        state = sim.step_unchecked(a[0] * vmax, a[1] * vmax, a[2] * vmax)
        ep = self.episode
        ep.steps += 1
        obs, reward, reason, info = self.kernel.step(ep, state, sim.state_array, a, self.np_random)
        if self.render_mode == "human":
            self.render()
        return self.machine.delay(obs.copy()), reward, reason is not None, False, info

    def set_task_config(self, changes: dict[str, Any]) -> TaskConfig:
        """Change fields of :attr:`task_config` (a curriculum) and return the new one: only
        :data:`planar3p_gym.tasks.sampling.SCHEDULABLE_FIELDS`, used by the success test from
        the next step on, by the pair sampling from the next reset (``ValueError``, nothing
        changed, for invalid changes)."""
        cfg = self.task_config = self.settings.updated(self.task_config, changes, self._modes)
        self.kernel.config_changed(cfg.success_tolerances)
        self.task.config_changed()
        return cfg

    def get_keys_to_action(self) -> dict[tuple[str, ...], np.ndarray]:
        """Keyboard mapping for :func:`gymnasium.utils.play.play`
        (:func:`planar3p_gym.envs.actuation.keys_to_action`).  Use with
        ``play(env, noop=np.zeros(3, np.float32))`` (the default ``noop=0`` is not an action)."""
        return keys_to_action()

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode to make()")
            return None
        from planar3p_gym.sim.render import Frame, Renderer

        if self._renderer is None:
            self._renderer = Renderer(
                self.design, self.render_size, self.render_mode, self.metadata["render_fps"]
            )
        target = self.episode.target if self._sim is not None else None
        return self._renderer.render(Frame.of_info(self.episode.info, target))

    def close(self) -> None:
        """Close the renderer and free the simulation now (:meth:`Planar3PSim.close`), and
        the task's own simulations (its ``close``, if it has one); a later :meth:`reset`
        builds a new simulation."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        if self._sim is not None:
            self._sim.close()
        getattr(self.task, "close", lambda: None)()

    # ------------------------------------------------------------------ snapshots
    def get_state(self) -> dict[str, Any]:
        """A snapshot (plain, picklable data): the simulation, ``np_random``, the task's state
        (its ``get_state()``, else a copy of its attributes) and the episode's records
        (:attr:`episode`, the built machine's); :meth:`set_state` on an environment made with
        the same settings continues bit for bit as this one would."""
        return {
            "config": self.config(),
            "sim": None if self._sim is None else self._sim.get_state(),
            **random_state(self.np_random, self._np_random_seed, self.task),
            "episode": {"record": copy.deepcopy(self.episode), "machine": self.machine.get_state()},
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore a :meth:`get_state` snapshot (``ValueError``, nothing changed, unless it is a
        whole one of an environment with these settings:
        :func:`~planar3p_gym.envs.snapshot.check_snapshot`); for a made environment, whose
        ``TimeLimit`` counts steps on its own, :func:`planar3p_gym.envs.end_reason.restore_state`
        sets that counter too."""
        check_snapshot(self, state)
        sim = None if state["sim"] is None else Planar3PSim.from_state(state["sim"])
        self._np_random, self._np_random_seed = restored_random(state, self.task)
        if self._sim is not None:  # the model being replaced (Planar3PSim.close)
            self._sim.close()
        self._sim = sim
        self.episode = copy.deepcopy(state["episode"]["record"])
        self.machine.set_state(state["episode"]["machine"])

    def __getstate__(self) -> dict[str, Any]:
        # The renderer holds a pygame window or surface: copies are made without one.
        out = dict(self.__dict__)
        out["_renderer"] = None
        return out

    def config(self) -> dict[str, Any]:
        """The environment's settings as plain data (for run records): the settings, the
        task, the built machine's features (only where on: earlier records stay valid)."""
        return {
            **self.settings.record(self.task_config),
            "task": self.task.name,
            "task_arguments": self.task.arguments(),
            **self.machine.config(),
        }
