"""A native Gymnasium vector environment: ``gym.make_vec("Planar3P-v0", num_envs=16)``.

:class:`Planar3PVectorEnv` steps ``num_envs`` simulations of one id in one process, with
Gymnasium 1.x's next-step autoreset and the registered time limit applied in the batch;
observations, rewards, flags and infos are batch numpy arrays (infos in Gymnasium's vector
layout, for the keys in :data:`INFO_KEYS`).  Every path gives the single environments'
trajectories bit for bit (``tests/envs/test_vector_env.py``):

- ``batch="numpy"`` (from :data:`NUMPY_BATCH_MIN` envs under ``"auto"``): one compiled call per
  step over the batch (:mod:`planar3p_gym.envs.batch_kernel`: the physics, then the task's
  kernel over the rows) for the reach, goal, tracking, mode- and assembly-change ids (their
  travel term too), and for the reach task and the mode and assembly changes on the machine
  as built;
- ``batch="scalar"``: each simulation and the single environment's compiled outputs, written
  into the batch arrays;
- every other configuration (a task of hooks of its own) steps each environment through
  its own ``step``.

The single environments' own attributes are brought up to date when :attr:`~Planar3PVectorEnv.envs`
or :meth:`~Planar3PVectorEnv.get_state` is used; a state that fails the physics-breakdown test
takes the single environment's own step.  The design of the fast paths is on
``docs/architecture.md``.
"""

from __future__ import annotations

import copy
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, create_empty_array
from numba import typed

from planar3p_gym import checks
from planar3p_gym.envs.actuation import on_off_actions
from planar3p_gym.envs.assembly_change import Planar3PAssemblyChangeEnv
from planar3p_gym.envs.batch_kernel import (
    BuiltBatch,
    ReachBatch,
    assembly_batch_step,
    built_assembly_batch_step,
    built_batch_step,
    built_mode_batch_step,
    built_rows,
    delay_rows,
    goal_batch_step,
    mode_batch_step,
    reach_batch_step,
    track_batch_step,
)
from planar3p_gym.envs.core import Planar3PEnv
from planar3p_gym.envs.goal import Planar3PGoalEnv, goal_observation
from planar3p_gym.envs.latency import MAX_DELAY
from planar3p_gym.envs.mode_change import Planar3PModeChangeEnv
from planar3p_gym.envs.track import Planar3PTrackEnv
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures
from planar3p_gym.sim import chipmunk, physics
from planar3p_gym.sim.batch_step import BatchState
from planar3p_gym.sim.physics import FOLLOWING_ERROR_LIMIT, SimState
from planar3p_gym.sim.sensors import LAST_SIZE, Encoders
from planar3p_gym.tasks import sampling as task_module
from planar3p_gym.tasks.goal import RELABEL_INFO_KEYS, GoalKernel, goal_bounds
from planar3p_gym.tasks.kernel import HookKernel, ReachKernel, ReachOutputsKernel, StepKernel
from planar3p_gym.tasks.observation import OBS_SIZE, travel_goal_entries
from planar3p_gym.tasks.reach_step import REASONS, TERMS_START, BatchReach
from planar3p_gym.tasks.rewards import TERM_NAMES
from planar3p_gym.tasks.sampling import TaskConfig
from planar3p_gym.tasks.track import RUNNING_SIZE, SAMPLE_CHUNK, TrackKernel

__all__ = [
    "INFO_KEYS",
    "NUMPY_BATCH_MIN",
    "Planar3PAssemblyChangeVectorEnv",
    "Planar3PGoalVectorEnv",
    "Planar3PModeChangeVectorEnv",
    "Planar3PTrackVectorEnv",
    "Planar3PVectorEnv",
]

#: Batch size from which ``batch="auto"`` steps the batch in one compiled call rather than
#: environment by environment (the batched call saves each environment's Python work and pays
#: from a few environments on; the measurement is on docs/throughput.md).
NUMPY_BATCH_MIN = 4

#: ``info`` entries returned over the batch (as in the single env's ``info``).
INFO_KEYS = (
    "is_success",
    "termination_reason",
    "position_error",
    "orientation_error",
    "parallel_margin",
    "serial_margin",
    "assembly_mode",
    "closure_error",
)
_DTYPES = {"is_success": np.bool_, "termination_reason": object, "assembly_mode": np.int64}
#: The info entries of the scalar batch's per-env results, after the reward (all but the
#: first of :data:`INFO_KEYS`).
_RESULT_KEYS = INFO_KEYS[1:]
#: ``termination_reason`` codes of the batched step.
_REASONS = np.array([None, "success", "singularity_crossing", "physics_breakdown"], dtype=object)
#: Batched steps of drive commands a native vector env keeps per environment before it appends
#: them to the simulations' records.
COMMAND_LOG = 256
#: Numbers per simulation in the shared body buffer: room for twice a readout (11 bodies x 6),
#: so pymunk's array over a row never needs to grow (move).
_ROW = 132


class Planar3PVectorEnv(VectorEnv):
    """``num_envs`` copies of :class:`Planar3PEnv` stepped together (module docstring).

    Args:
        num_envs: number of environments (>= 1).
        max_episode_steps: time limit in steps (``None`` or -1: none); ``gym.make_vec`` passes
            the registered one.
        batch: how the reach task on the projected physics is stepped: ``"scalar"`` (each
            environment's simulation step and compiled outputs in turn), ``"numpy"`` (pymunk
            per environment, then the projection and the outputs in compiled loops over the
            batch; the name is historical) or ``"auto"`` (``"numpy"`` from
            :data:`NUMPY_BATCH_MIN` environments); the same numbers either way.  The task
            ids and the built machine's ids take ``"numpy"`` too (``"scalar"``: environment
            by environment).
        autoreset_mode: ``AutoresetMode.NEXT_STEP`` (default, Gymnasium's) or
            ``AutoresetMode.SAME_STEP`` (an ended episode is reset within the same step: its
            last observation is in ``info["final_obs"]``, its last info entries in
            ``info["final_info"]``; what SB3's ``VecEnv`` expects, see
            :mod:`planar3p_agents.training.vec_adapter`).
        **kwargs: :class:`Planar3PEnv` arguments, the same for every copy.  With
            ``render_mode="rgb_array"`` every copy renders and :meth:`render` returns their
            frames, as Gymnasium's own vector envs do; Gymnasium's vector wrappers show them
            as a grid in a window (``gymnasium.wrappers.vector.HumanRendering``, which needs
            opencv) or record them as one tiled video (``gymnasium.wrappers.vector.RecordVideo``).
    """

    metadata = {
        "autoreset_mode": AutoresetMode.NEXT_STEP,
        "render_modes": ["rgb_array"],
        "render_fps": Planar3PEnv.metadata["render_fps"],
    }
    #: The single environment's class (subclasses below: the task ids' environments).
    env_class: type[Planar3PEnv] = Planar3PEnv
    #: ``info`` entries returned over the batch.
    info_keys: tuple[str, ...] = INFO_KEYS

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        batch: str = "auto",
        **kwargs: Any,
    ) -> None:
        batch = checks.choice(batch, "batch", ("auto", "scalar", "numpy"))
        num_envs = checks.count(num_envs, "num_envs")
        if max_episode_steps is not None and not (
            checks.is_int(max_episode_steps) and max_episode_steps == -1
        ):
            max_episode_steps = checks.count(max_episode_steps, "max_episode_steps")
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            mode = None
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(
                f"autoreset_mode must be NEXT_STEP or SAME_STEP, got {autoreset_mode!r}"
            )
        render_mode = kwargs.get("render_mode")
        if render_mode is not None:
            checks.choice(render_mode, "render_mode", tuple(self.metadata["render_modes"]))
        self.num_envs = int(num_envs)
        self._envs = [self.env_class(**kwargs) for _ in range(self.num_envs)]
        self.max_episode_steps = (
            None if max_episode_steps is None or max_episode_steps == -1 else int(max_episode_steps)
        )
        first = self._envs[0]
        self.metadata = {
            **self.metadata,
            "autoreset_mode": mode,
            "render_fps": first.metadata["render_fps"],
        }
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.render_mode = render_mode
        self._obs = create_empty_array(self.single_observation_space, self.num_envs, fn=np.zeros)
        self._elapsed = np.zeros(self.num_envs, dtype=np.int64)
        self._autoreset = np.zeros(self.num_envs, dtype=np.bool_)
        if batch == "auto":
            batch = "numpy" if self.num_envs >= NUMPY_BATCH_MIN else "scalar"
        numpy_batch = physics.BATCH_STEP and physics.Planar3PSim.use_fast_path and batch == "numpy"
        #: How the batch is stepped: None (environment by environment), or the batched step's
        #: mode (``True``: numpy over the batch); the batched step's C handles are rebuilt
        #: from it when the vector env is unpickled.
        self._numpy_batch: bool | None = _batch_mode(first, numpy_batch)
        self._core = _core(self, self._numpy_batch)

    @property
    def envs(self) -> list[Planar3PEnv]:
        """The single environments, their attributes up to date."""
        if self._core is not None:
            self._core.sync_all()
        return self._envs

    def reset(
        self,
        *,
        seed: int | list[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every environment: ``seed`` an int (env ``i`` gets ``seed + i``, as
        ``SyncVectorEnv`` does), a list of seeds, or None; ``options`` go to every env.

        Atomic: the options are checked as the single environment checks them, and if any
        environment rejects its reset (``ValueError``, e.g. a start that is not reachable in
        the working mode an environment drew) every environment is put back as it was, and
        so is the vector env."""
        if seed is None or checks.is_int(seed):
            first = checks.seed(seed)
            seeds = [None if first is None else first + i for i in range(self.num_envs)]
        else:
            if isinstance(seed, (str, bytes)) or not hasattr(seed, "__len__"):
                raise ValueError(f"seed must be an int, a list of seeds or None, got {seed!r}")
            seeds = [checks.seed(s) for s in seed]
            if len(seeds) != self.num_envs:
                raise ValueError(f"expected {self.num_envs} seeds, got {len(seeds)}")
        envs = self.envs  # (up to date: their snapshots are complete)
        undo = [env.get_state() for env in envs]
        results = []
        try:
            for env, s in zip(envs, seeds, strict=True):
                results.append(env.reset(seed=s, options=options))
        except ValueError:
            for i in range(len(results)):  # the env that raised changed nothing itself
                envs[i].set_state(undo[i])
                if self._core is not None and _has_sim(envs[i]):
                    self._core.load(i)
            raise
        if seed is not None:
            self._np_random, self._np_random_seed = gym.utils.seeding.np_random(seeds[0])
        infos = []
        for i, (obs, info) in enumerate(results):
            self._put(i, obs)
            infos.append(info)
            if self._core is not None:
                self._core.load(i)
        self._elapsed[:] = 0
        self._autoreset[:] = False
        return self._observations(), self._batch_infos(infos)

    def _put(self, i: int, obs: Any) -> None:
        """Write environment ``i``'s observation into the batch (a ``Dict``'s entries each)."""
        if isinstance(self._obs, dict):
            for key, value in obs.items():
                self._obs[key][i] = value
        else:
            self._obs[i] = obs

    def _observations(self) -> Any:
        """A copy of the batch of observations."""
        if isinstance(self._obs, dict):
            return {key: value.copy() for key, value in self._obs.items()}
        return self._obs.copy()

    def _check_actions(self, actions: Any) -> np.ndarray:
        """The batch of actions as float64 ``(num_envs, 3)`` (``(num_envs,)`` of
        ``Discrete(27)`` indices), checked as the single environment checks one
        (:func:`planar3p_gym.checks.parse_actions`, :func:`~planar3p_gym.envs.actuation.
        on_off_actions`: strings, bools, complex numbers, NaN/inf, values out of the action
        space and wrong shapes raise ``ValueError``, and no environment steps)."""
        if self._envs[0].machine.action_type != "on-off-discrete":
            return checks.parse_actions(actions, self.num_envs)
        arr = checks.real_array(actions)
        if arr is None or arr.shape != (self.num_envs,):
            raise ValueError(
                f"actions must be {self.num_envs} integers in [0, 27), got {checks.short(actions)}"
            )
        on_off_actions(arr, "on-off-discrete", 1.0)  # (every index, before any env steps)
        return arr

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        a = self._check_actions(actions)
        if self._core is not None:
            return self._core.step(a)
        n = self.num_envs
        rewards, terminated, truncated = [0.0] * n, [False] * n, [False] * n
        infos = []
        limit = self.max_episode_steps if self.max_episode_steps is not None else -1
        # Plain lists in the loop: numpy scalar indexing costs more than the bookkeeping.
        elapsed, autoreset = self._elapsed.tolist(), self._autoreset.tolist()
        same_step = self.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
        final: dict[int, tuple[np.ndarray, dict[str, Any]]] = {}
        for i, env in enumerate(self._envs):
            if autoreset[i]:
                obs, info = env.reset()
                elapsed[i] = 0
            else:
                obs, reward, term, _, info = env.step(a[i])
                steps = elapsed[i] = elapsed[i] + 1
                trunc = 0 < limit <= steps
                rewards[i], terminated[i], truncated[i] = reward, term, trunc
                if same_step and (term or trunc):
                    final[i] = (obs, info)
                    obs, info = env.reset()
                    elapsed[i] = 0
            self._put(i, obs)
            infos.append(info)
        self._elapsed[:] = elapsed
        terminated_a = np.array(terminated, dtype=np.bool_)
        truncated_a = np.array(truncated, dtype=np.bool_)
        if not same_step:
            np.logical_or(terminated_a, truncated_a, out=self._autoreset)
        out = self._batch_infos(infos)
        if final:
            self._final_entries(out, final, infos)
        return self._observations(), np.array(rewards), terminated_a, truncated_a, out

    def _final_entries(
        self,
        out: dict[str, Any],
        final: dict[int, tuple[np.ndarray, dict[str, Any]]],
        infos: list[dict[str, Any]] | dict[str, Any],
    ) -> None:
        """``final_obs`` / ``final_info`` of the episodes ended (and reset) in a ``SAME_STEP``
        step; ``infos`` are the step's entries (a list of info dicts, or batch arrays)."""
        final_obs = np.full(self.num_envs, None, dtype=object)
        done = np.zeros(self.num_envs, dtype=np.bool_)
        if isinstance(infos, dict):
            final_info = {k: infos[k].copy() for k in self.info_keys}
            for i, (obs, info) in final.items():
                final_obs[i], done[i] = obs, True
                for key in self.info_keys:
                    final_info[key][i] = info[key]
        else:
            last = list(infos)
            for i, (obs, info) in final.items():
                final_obs[i], done[i], last[i] = obs, True, info
            final_info = self._batch_infos(last)
        out["final_obs"], out["_final_obs"] = final_obs, done
        for key in self.info_keys:
            final_info["_" + key] = done
        out["final_info"], out["_final_info"] = final_info, done

    def _batch_infos(self, infos: list[dict[str, Any]]) -> dict[str, Any]:
        """Gymnasium's vector info layout for :attr:`info_keys`."""
        out: dict[str, Any] = {}
        mask = np.ones(self.num_envs, dtype=np.bool_)
        for key in self.info_keys:
            out[key] = np.array([info[key] for info in infos], dtype=_DTYPES.get(key, np.float64))
            out["_" + key] = mask
        return out

    def render(self) -> tuple[np.ndarray, ...] | None:
        """The frames of every environment (``render_mode="rgb_array"``: a tuple of
        ``(H, W, 3)`` uint8 arrays, environment ``i``'s at index ``i``), or ``None`` with a
        warning when the vector env was made without a render mode."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode to make_vec()")
            return None
        return tuple(env.render() for env in self.envs)

    def close_extras(self, **kwargs: Any) -> None:
        for env in self._envs:
            env.close()

    def set_task_config(self, changes: dict[str, Any]) -> TaskConfig:
        """:meth:`Planar3PEnv.set_task_config` on every environment (checked once first, so
        an invalid change raises ``ValueError`` and changes none); returns the new config."""
        new = task_module.updated_config(self._envs[0].task_config, changes)
        for env in self._envs:
            env.set_task_config(changes)
        if self._core is not None:
            self._core.config_changed()
        return new

    def get_state(self) -> dict[str, Any]:
        """Snapshots of every environment and the batch bookkeeping (see
        :meth:`Planar3PEnv.get_state`)."""
        return {
            "envs": [env.get_state() for env in self.envs],
            "obs": self._observations(),
            "elapsed": self._elapsed.copy(),
            "autoreset": self._autoreset.copy(),
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore a :meth:`get_state` snapshot (with the step counters of the time limit)."""
        keys = {"envs", "obs", "elapsed", "autoreset"}
        if not isinstance(state, dict) or set(state) != keys or len(state["envs"]) != self.num_envs:
            raise ValueError("state must be a snapshot from Planar3PVectorEnv.get_state()")
        for i, (env, s) in enumerate(zip(self._envs, state["envs"], strict=True)):
            env.set_state(s)
            if self._core is not None and _has_sim(env):
                self._core.load(i)
        self._obs = copy.deepcopy(state["obs"])
        self._elapsed[:] = state["elapsed"]
        self._autoreset[:] = state["autoreset"]

    def __getstate__(self) -> dict[str, Any]:
        """Picklable state (``copy.deepcopy`` and ``pickle``): the environments, up to date,
        and the bookkeeping; the batched step's C handles are left out and rebuilt."""
        self.envs  # noqa: B018  (brings every environment up to date)
        out = dict(self.__dict__)
        out["_core"] = None
        return out

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._core = _core(self, self._numpy_batch)
        if self._core is not None:
            for i, env in enumerate(self._envs):
                if _has_sim(env):
                    self._core.load(i)


def _batch_mode(env: Planar3PEnv, numpy_batch: bool) -> bool | None:
    """How a batch of ``env`` is stepped: the reach kernel in either mode of the batched
    step, the goal kernel of the goal env and the tracking kernel in compiled loops only
    (``numpy_batch``), anything else (None) environment by environment."""
    if isinstance(env.kernel, ReachKernel):
        return numpy_batch
    if numpy_batch and isinstance(env, Planar3PGoalEnv) and isinstance(env.kernel, GoalKernel):
        return True
    if numpy_batch and isinstance(env.kernel, TrackKernel):
        return True
    if numpy_batch and _hook_rows(env) is not None:
        return True
    if numpy_batch and _built_machine(env):
        return True
    return None


def _built_machine(env: Planar3PEnv) -> bool:
    """Whether ``env`` is a task on the machine as built that :class:`_BuiltCore` steps: the
    reference kernel of the reach task's own hooks, or of the mode or assembly change's
    (their travel term too), on the projected physics through the compiled steps (viscous friction's
    too), any action type, the joint-space goal too."""
    m = env.machine
    return (
        not m.nominal
        and type(env.kernel) is StepKernel
        and type(env) in (Planar3PEnv, Planar3PModeChangeEnv, Planar3PAssemblyChangeEnv)
        and env.task.compiled_family in ("reach", "mode_change", "assembly_change")
        and env.projection
        and physics.Planar3PSim.use_compiled_viscous
        and chipmunk.AVAILABLE
    )


def _core(venv: Planar3PVectorEnv, mode: bool | None) -> _BatchCore | None:
    """The batched step of ``venv`` in ``mode`` (:func:`_batch_mode`; None: none)."""
    if mode is None:
        return None
    if _built_machine(venv._envs[0]):
        return _BuiltCore(venv)
    return _BatchCore(venv, mode)


def _hook_rows(env: Planar3PEnv) -> type | None:
    """The batched part of ``env``'s task where it runs the mode- or assembly-change task's
    own hooks on the compiled measures (:class:`_ModeRows`, :class:`_AssemblyRows`), else
    None."""
    if not isinstance(env.kernel, HookKernel):
        return None
    rows = {"mode_change": _ModeRows, "assembly_change": _AssemblyRows}
    return rows.get(env.task.compiled_family or "")


def _reach_step(kernel: Any) -> Any:
    """The reach outputs (:class:`~planar3p_gym.tasks.reach_step.ReachStep`) a batched kernel
    computes (its own, or those of the reach kernel it is built on)."""
    if isinstance(kernel, ReachOutputsKernel):
        return kernel.reach
    return kernel.reach.reach


def _has_sim(env: Planar3PEnv) -> bool:
    """Whether ``env`` has a simulation (was reset, or restored from a reset one)."""
    try:
        env.sim  # noqa: B018  (the property raises before the first reset)
    except RuntimeError:
        return False
    return True


class _BatchCore:
    """The batched step of a :class:`Planar3PVectorEnv` (module docstring).

    Between steps the batch arrays are authoritative for the environments marked pending; the
    single environments' Python attributes and their pymunk bodies are brought up to date by
    :meth:`sync` (the bodies themselves are written at the start of every step anyway).
    """

    def __init__(self, venv: Planar3PVectorEnv, numpy_batch: bool) -> None:
        self.venv = venv
        self.numpy = numpy_batch
        n = venv.num_envs
        env = venv._envs[0]
        self.dt = env.dt
        self.substeps = env.substeps
        self.h = env.dt / env.substeps
        self.vmax = env.design.max_speed
        self.scale = 1.0 / (self.substeps * self.h)
        self.force_limit = 0.999 * env.design.max_force * self.h
        self.breakdown = env.breakdown_distance
        self.reach = BatchReach(_reach_step(env.kernel))
        self.low, self.high = env.kernel.settings.low, env.kernel.settings.high
        #: The projection's constants (LoopProjector.constants), from the first simulation.
        self.constants: np.ndarray | None = None
        #: Every environment's fused-step constants (their tolerances among them), one row
        #: each, shared with its ReachStep: a tolerance changed through an environment's
        #: ``set_task_config`` shows here with no loop over the environments.
        self.consts = np.zeros((n, 10))
        for i, e in enumerate(venv._envs):
            _reach_step(e.kernel).share_constants(self.consts[i])
        self.buf = np.zeros((n, _ROW))
        #: Each environment's batch request over its row of :attr:`buf`.
        self.reads = [chipmunk.body_readout(row) for row in self.buf]
        self.handles: list[tuple] = [()] * n
        #: The drive commands (m/s) of each environment's last batched steps, not yet appended
        #: to its simulation's record (``Planar3PSim.get_state``): :meth:`sync` appends them,
        #: and all are appended when :data:`COMMAND_LOG` steps have piled up.
        self.log = np.empty((n, COMMAND_LOG, 3))
        self.logged = np.zeros(n, dtype=np.int64)
        self.log_steps = 0  # batched steps since every log was last emptied
        #: Each simulation's handles for the compiled step (chipmunk.HANDLE_FIELDS).
        self.handle_rows = np.zeros((n, len(chipmunk.HANDLE_FIELDS)), dtype=np.uintp)
        self.time = np.zeros(n)
        #: Each target's ``x, y, theta, cos theta, sin theta`` (m, m, rad, 1, 1), a column each.
        self.targets = np.zeros((5, n))
        self.target, self.target_cs = self.targets[:3], self.targets[3:]
        self.travel_goal = env.travel_goal
        self.target_rho = np.zeros((n, 3))  # each target's slider travels (m), travel_goal
        self.assembly = np.zeros(n, dtype=np.int64)
        self.pending = np.zeros(n, dtype=np.bool_)
        #: Scalar mode: the arguments of ``env._info`` of each pending environment's last step.
        self.pending_info: list[tuple | None] = [None] * n
        self.last: dict[str, Any] | None = None  # the last batched step's arrays
        self.info_keys = venv.info_keys
        #: The goal or tracking task's part of the step, else None (the reach task).
        self.goal: _GoalRows | _TrackRows | _ModeRows | _AssemblyRows | None = None
        if isinstance(env, Planar3PGoalEnv):
            self.goal = _GoalRows(self, env)
        elif isinstance(env.kernel, TrackKernel):
            self.goal = _TrackRows(self, env)
        elif (rows := _hook_rows(env)) is not None:
            self.goal = rows(self, env)

    # ------------------------------------------------------------------ env <-> batch
    def load(self, i: int) -> None:
        """Take environment ``i``'s state (after a reset or a restored snapshot)."""
        env = self.venv._envs[i]
        self.pending[i] = False
        if not self.numpy:
            return
        link = env.sim.batch_link()
        if link is None:
            raise RuntimeError("the batched step needs pymunk's batch API (Planar3PSim.batch_link)")
        if self.constants is None:
            self.constants = link.projection
        space, servos = link.space, link.servos
        self.handles[i] = (space, *servos, link.commands)
        self.logged[i] = 0  # (the record was just cleared or restored)
        self.handle_rows[i] = chipmunk.handle_row(space, servos, self.reads[i])
        chipmunk.read_bodies(chipmunk.FUNCTIONS, self.handle_rows[i])
        self.time[i] = link.time
        ep = env.episode
        self.target[:, i] = ep.target
        self.target_cs[:, i] = ep.target_cs
        self.target_rho[i] = ep.target_rho
        self.assembly[i] = ep.assembly
        if self.goal is not None:
            self.goal.load(i, env)
        self.pending[i] = False

    def sync_all(self) -> None:
        """Bring every pending environment up to date (:meth:`sync`)."""
        for i in np.flatnonzero(self.pending).tolist():
            self.sync(i)

    def sync(self, i: int, bodies: bool = True) -> None:
        """Write the last batched step's results into environment ``i`` (its simulation's
        state and bodies, the episode's observation, measures and info)."""
        env = self.venv._envs[i]
        if not self.numpy:
            state, res = self.pending_info[i]  # type: ignore[misc]
            reason = REASONS[int(res[1])]
            measures = ConfigurationMeasures(res[4], res[5], int(res[6]), state.leg_angles)
            terms = dict(zip(TERM_NAMES, res[TERMS_START:], strict=True))
            errors = (res[2], res[3])
            ep = env.episode
            ep.obs = self.venv._obs[i].copy()
            ep.info = env.kernel.info(
                ep, state, measures, reason, terms, reason == "success", errors
            )
            self.pending[i] = False
            return
        self._append_commands(i)
        last = self.last
        assert last is not None
        j = int(last["row"][i])
        state = self._sim_state(last, j, i)
        self._set_sim(env, state, last, j, i)
        o = last["outputs"]
        measures = ConfigurationMeasures(
            float(o["parallel"][j]), float(o["serial"][j]), int(o["sign"][j]), state.leg_angles
        )
        reason = _REASONS[o["reason"][j]]
        terms = {k: float(v[j]) for k, v in o["terms"].items()}
        ep = env.episode
        ep.steps = int(self.venv._elapsed[i])
        ep.obs = o["obs"][j].copy()
        ep.measures = measures
        errors = (float(o["position_error"][j]), float(o["orientation_error"][j]))
        ep.info = env.kernel.info(ep, state, measures, reason, terms, reason == "success", errors)
        if self.goal is not None:
            self.goal.sync(i, env, ep.info, last, j)
        if bodies:
            chipmunk.write_bodies(chipmunk.FUNCTIONS, self.handle_rows[i])
        self.pending[i] = False

    def _append_commands(self, i: int) -> None:
        """Append environment ``i``'s logged commands to its simulation's record."""
        count = int(self.logged[i])
        if count:
            self.handles[i][4].extend(self.log[i, :count].ravel().tolist())
            self.logged[i] = 0

    def _sim_state(self, last: dict[str, Any], j: int, i: int) -> SimState:
        st: BatchState = last["state"]
        rho, rho_dot = st.rho[:, j].tolist(), st.rho_dot[:, j].tolist()
        pose, twist, legs = st.pose[:, j].tolist(), st.twist[:, j].tolist(), st.leg_angles[:, j]
        f, sat = last["forces"][j].tolist(), last["saturated"][j].tolist()
        return SimState(
            float(last["time"][j]),
            (rho[0], rho[1], rho[2]),
            (rho_dot[0], rho_dot[1], rho_dot[2]),
            (pose[0], pose[1], pose[2]),
            (twist[0], twist[1], twist[2]),
            tuple(legs.tolist()),  # type: ignore[arg-type]
            (f[0], f[1], f[2]),
            (bool(sat[0]), bool(sat[1]), bool(sat[2])),
            float(st.closure[j]),
        )

    def _set_sim(self, env: Planar3PEnv, state: SimState, last: dict, j: int, i: int) -> None:
        st: BatchState = last["state"]
        setpoints = (float(self.buf[i, 12]), float(self.buf[i, 30]), float(self.buf[i, 48]))
        x, y = st.ux[:, j].tolist(), st.uy[:, j].tolist()
        geometry = (x[0], y[0], x[1], y[1], x[2], y[2], float(st.c[j]), float(st.s[j]))
        env.sim.adopt_state(state, setpoints, geometry)

    # ------------------------------------------------------------------ stepping
    def step(
        self, a: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        venv = self.venv
        n = venv.num_envs
        a = self._actions(a)
        resetting = np.flatnonzero(venv._autoreset).tolist()  # the environments reset now
        idx = np.flatnonzero(~venv._autoreset)  # the environments stepped
        rewards = np.zeros(n)
        terminated = np.zeros(n, dtype=np.bool_)
        truncated = np.zeros(n, dtype=np.bool_)
        keys = self.info_keys
        info: dict[str, Any] = {
            key: np.zeros(n, dtype=_DTYPES.get(key, np.float64)) for key in keys
        }
        info["termination_reason"][:] = None
        if idx.size:
            self._advance(a, idx, rewards, terminated, info)
        limit = venv.max_episode_steps if venv.max_episode_steps is not None else -1
        if limit > 0:
            truncated[idx] = venv._elapsed[idx] >= limit
        for i in resetting:  # next-step autoreset
            self._reset(i, info)
        done = terminated | truncated
        out: dict[str, Any] = {}
        mask = np.ones(n, dtype=np.bool_)
        for key in keys:
            out[key] = info[key]
            out["_" + key] = mask
        if venv.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP:
            ended = np.nonzero(done)[0].tolist()
            if ended:  # the last observations and infos, then reset within the step
                final_obs = np.full(n, None, dtype=object)
                final_info: dict[str, Any] = {k: info[k].copy() for k in keys}
                for i in ended:
                    final_obs[i] = self._observation(i)
                for i in ended:
                    self._reset(i, info)
                final_info.update({"_" + k: done for k in keys})
                out["final_obs"], out["_final_obs"] = final_obs, done
                out["final_info"], out["_final_info"] = final_info, done
        else:
            venv._autoreset[:] = done
        return venv._observations(), rewards, terminated, truncated, out

    def _actions(self, a: np.ndarray) -> np.ndarray:
        """The batch's actions ``a`` (checked, ``(N, 3)``) clipped to ``[-1, 1]``."""
        a = np.minimum(a, 1.0)  # (a new array: the caller's actions are left alone)
        np.maximum(a, -1.0, out=a)
        return a

    def _advance(
        self,
        a: np.ndarray,
        idx: np.ndarray,
        rewards: np.ndarray,
        terminated: np.ndarray,
        info: dict[str, Any],
    ) -> None:
        """Step the environments ``idx`` (not empty) with the actions ``a``: their outputs
        into ``rewards``, ``terminated``, ``info`` and the batch's observations."""
        if self.numpy:
            self._outputs(a, idx, rewards, terminated, info, self._physics(a, idx))
        else:
            self._scalar(a, idx.tolist(), rewards, terminated, info)

    def config_changed(self) -> None:
        """The environments' task configs changed (the reach kernel shares its tolerances)."""

    def _observation(self, i: int) -> Any:
        """A copy of environment ``i``'s observation in the batch."""
        obs = self.venv._obs
        if isinstance(obs, dict):
            return {key: value[i].copy() for key, value in obs.items()}
        return obs[i].copy()

    def _scalar(
        self,
        a: np.ndarray,
        idx: list[int],
        rewards: np.ndarray,
        terminated: np.ndarray,
        info: dict[str, Any],
    ) -> None:
        """Step the environments ``idx``, each through its simulation and the single env's
        compiled outputs (:meth:`~planar3p_gym.tasks.reach_step.ReachStep.compute`, without its
        ``info`` dict, which :meth:`sync` builds when asked for); outputs into the batch."""
        venv = self.venv
        envs, obs_out, breakdown = venv._envs, venv._obs, self.breakdown
        commands, actions = (a * self.vmax).tolist(), a.tolist()
        pending, flags = self.pending_info, self.pending
        width = OBS_SIZE
        stepped: list[int] = []  # the envs stepped by the compiled outputs
        # One tuple per env: reward, reason, errors, margins, sign, closure error.
        results: list[tuple] = []
        for i in idx:
            env = envs[i]
            sim = env.sim
            v0, v1, v2 = commands[i]
            state = sim.step_unchecked(v0, v1, v2)
            ep = env.episode
            ep.steps += 1
            if state.finite and state.closure_error <= breakdown:
                rs = env.kernel.reach
                res = rs.compute(
                    sim.state_array, state.pose[2], ep.target, ep.target_cs, ep.assembly,
                    actions[i],
                ).tolist()  # fmt: skip
                obs_out[i, :width] = rs.obs
                stepped.append(i)
                ep.measures = ConfigurationMeasures(res[4], res[5], int(res[6]), state.leg_angles)
                pending[i] = (state, res)
                flags[i] = True
                results.append(
                    (res[0], REASONS[int(res[1])], res[2], res[3], res[4], res[5], int(res[6]),
                     state.closure_error)
                )  # fmt: skip
            else:  # physics breakdown: the reference kernel, as the single env
                if flags[i]:
                    self.sync(i)
                obs, r, _, full = env.kernel.reference_step(env.episode, state, actions[i])
                obs_out[i] = obs
                results.append(
                    (r, *(full[key] for key in _RESULT_KEYS))  # type: ignore[arg-type]
                )
        if stepped and self.travel_goal:  # the joint-space goal over the batch
            goal = np.array([envs[i].episode.target_rho for i in stepped])
            obs_out[stepped, width:] = travel_goal_entries(obs_out[stepped, :3], goal)
        sel = slice(None) if len(idx) == len(envs) else idx
        venv._elapsed[sel] += 1
        rew, reasons, *columns = zip(*results, strict=True)
        rewards[sel] = rew
        reason_a = np.array(reasons, dtype=object)
        terminated[sel] = reason_a != None  # noqa: E711  (elementwise)
        info["is_success"][sel] = reason_a == "success"
        info["termination_reason"][sel] = reason_a
        for key, values in zip(_RESULT_KEYS[1:], columns, strict=True):
            info[key][sel] = values

    def _reset(self, i: int, info: dict[str, Any]) -> None:
        venv = self.venv
        obs, reset_info = venv._envs[i].reset()
        venv._put(i, obs)
        venv._elapsed[i] = 0
        self.load(i)
        for key in self.info_keys:
            info[key][i] = reset_info[key]

    def _physics(self, a: np.ndarray, idx: np.ndarray) -> dict[str, Any]:
        """Step the simulations ``idx`` with actions ``a`` (clipped, ``(N, 3)``) and compute
        their reach outputs, in one compiled call
        (:func:`planar3p_gym.envs.batch_kernel.reach_batch_step`: write the bodies with the new
        servo commands, step pymunk, read them back, project, the outputs); returns the
        outputs (:meth:`~planar3p_gym.tasks.reach_step.BatchReach.results`)."""
        reach = self.reach
        if self.log_steps == COMMAND_LOG:  # (every log has room for the step after this)
            for i in np.flatnonzero(self.logged).tolist():
                self._append_commands(i)
            self.log_steps = 0
        self.log_steps += 1
        batch = ReachBatch(
            chipmunk.FUNCTIONS, self.handle_rows, self.vmax, self.h, self.substeps,
            self.force_limit, self.buf, self.constants, FOLLOWING_ERROR_LIMIT, self.targets,
            self.assembly, self.consts, reach.consts, reach.weights.as_array(), reach.low,
            reach.high, self.log, self.logged,
        )  # fmt: skip
        args = (idx, a, batch)
        if self.goal is None:
            _, forces, saturated, states, closure, obs, res = reach_batch_step(*args)
        else:
            _, forces, saturated, states, closure, obs, res = self.goal.advance(args, idx)
        self.venv._elapsed[idx] += 1
        self.time[idx] += self.dt
        self.forces = forces[:, :3] * self.scale
        self.saturated = saturated.T
        self.state = BatchState.of(states, closure)
        return BatchReach.results(obs, res)

    def _rows(self, idx: np.ndarray) -> np.ndarray:
        """Each environment's row among the stepped ``idx`` (-1 where not stepped)."""
        rows = np.full(len(self.pending), -1, dtype=np.int64)
        rows[idx] = np.arange(len(idx))
        return rows

    def _outputs(
        self,
        a: np.ndarray,
        idx: np.ndarray,
        rewards: np.ndarray,
        terminated: np.ndarray,
        info: dict[str, Any],
        o: dict[str, Any],
    ) -> None:
        """The step's results of the environments ``idx`` from their outputs ``o`` (a
        broken-down state's NaN outputs are replaced by the reference kernel's, as in the
        single env)."""
        venv, st = self.venv, self.state
        reward = o["reward"]  # (the terms' sum, as the single env adds them)
        bad = ~st.finite | (st.closure > self.breakdown)
        bad_rows = np.flatnonzero(bad).tolist()
        if bad_rows and self.last is not None:  # bring those envs to their previous step
            for j in bad_rows:
                i = int(idx[j])
                if self.pending[i]:
                    venv._elapsed[i] -= 1
                    self.sync(i, bodies=False)
                    venv._elapsed[i] += 1
        obs = o["obs"]
        if self.travel_goal:  # (kept in the outputs: sync gives each env its full row)
            goal = travel_goal_entries(obs[:, :3], self.target_rho[idx])
            obs = o["obs"] = np.concatenate([obs, goal], axis=1)
        sel = slice(None) if len(idx) == len(rewards) else idx  # (every env: no gather)
        reason = o["reason"]
        if self.goal is None:
            venv._obs[sel] = obs
            rewards[sel] = reward
        else:
            rewards[sel] = self.goal.outputs(sel, idx, o, ~bad, info)
        terminated[sel] = reason > 0
        info["is_success"][sel] = reason == 1
        info["termination_reason"][sel] = _REASONS[reason]
        info["position_error"][sel] = o["position_error"]
        info["orientation_error"][sel] = o["orientation_error"]
        info["parallel_margin"][sel] = o["parallel"]
        info["serial_margin"][sel] = o["serial"]
        info["assembly_mode"][sel] = o["sign"]
        info["closure_error"][sel] = st.closure
        self.last = {
            "row": self._rows(idx),
            "state": st,
            "outputs": o,
            "forces": self.forces,
            "saturated": self.saturated,
            "time": self.time[idx],
            "goal": None if self.goal is None else self.goal.current,
        }
        self.pending[sel] = True
        for j in bad_rows:  # the reference kernel, on the state just computed
            i = int(idx[j])
            env = venv._envs[i]
            state = self._sim_state(self.last, j, i)
            self._set_sim(env, state, self.last, j, i)
            env.episode.steps = int(venv._elapsed[i])
            ob, r, reason, inf = env.kernel.reference_step(env.episode, state, a[i].tolist())
            if self.goal is None:
                venv._obs[i] = ob
            else:
                r = self.goal.fallback(i, env, ob, r, inf)
            rewards[i] = r
            terminated[i] = reason is not None
            for key in self.info_keys:
                info[key][i] = inf[key]
            chipmunk.write_bodies(chipmunk.FUNCTIONS, self.handle_rows[i])
            self._append_commands(i)  # (no sync follows: the record takes this step's now)
            self.pending[i] = False


class _BuiltCore(_BatchCore):
    """The batched step of the reach task on the machine as built (:func:`_built_machine`):
    :func:`~planar3p_gym.envs.batch_kernel.built_batch_step` over the batch, with each
    environment's drawn machine (its physics' numbers, its true kinematics), its delay lines,
    its encoders' last reading and its generator (for the encoders' noise) kept in batch
    arrays, taken from the single environment at its reset and given back by :meth:`sync`.
    The per-episode draw stays the single environment's reset.  Between steps the
    simulations' pymunk bodies are their own (the compiled step reads and writes them)."""

    def __init__(self, venv: Planar3PVectorEnv) -> None:
        self.venv = venv
        self.numpy = True
        n = venv.num_envs
        env = venv._envs[0]
        m = env.machine
        self.dt, self.substeps = env.dt, env.substeps
        self.h = env.dt / env.substeps
        self.vmax = env.design.max_speed
        self.scale = 1.0 / (self.substeps * self.h)
        self.breakdown = env.breakdown_distance
        self.info_keys = venv.info_keys
        self.action_type, self.on_off_speed = m.action_type, m.on_off_speed
        task = env.task
        self.weights = env.reward_weights.as_array()
        self.length = env.design.characteristic_length
        self.barriers = (bool(task.parallel_barrier), bool(task.serial_barrier))
        self.crossing_fails = "singularity_crossing" in task.failure_reasons
        s = env.kernel.settings
        self.low = np.ascontiguousarray(s.low, dtype=np.float32)
        self.high = np.ascontiguousarray(s.high, dtype=np.float32)
        self.width = env.observation_space.shape[0]
        #: Each episode's fixed extra entries of the observation (the mode change's target
        #: travels and working mode) and its target working mode, with the mode change.
        self.mode = task.compiled_family == "mode_change"
        self.extra = np.zeros((n, self.width - OBS_SIZE), dtype=np.float32)
        self.target_modes = np.zeros((n, 3), dtype=np.int64)
        #: With the assembly change: each episode's target assembly mode and crossing count,
        #: and the signed margin entry's bounds.
        self.assembly_change = task.compiled_family == "assembly_change"
        self.target_assembly = np.zeros(n, dtype=np.int64)
        self.last_sign = np.zeros(n, dtype=np.int64)
        self.crossings = np.zeros(n, dtype=np.int64)
        self.signed_bounds = (float(s.extra_low[-1]), float(s.extra_high[-1])) if (
            self.assembly_change
        ) else (0.0, 0.0)  # fmt: skip
        #: With the joint-space goal (``travel_goal``): each episode's target travels (m).
        self.travel_goal = env.travel_goal
        self.goal_rho = np.zeros((n, 3))
        #: The travel term's weight (0: none) and each episode's target travels (m).
        self.shaping = float(getattr(task, "travel_shaping", 0.0))
        self.target_rho = np.zeros((n, 3))
        self.nominal_kin = m.kin.consts
        enc = m.encoders
        self.encoders = enc is not None
        self.sensing = np.zeros(4) if enc is None else enc.config.as_array()
        self.leg_1 = np.zeros(3) if enc is None else enc.leg_1
        self.enc_dt = env.dt if enc is None else enc.dt
        # Each environment's row of the bodies' numbers and its force request (viscous
        # friction), over memory of this batch, and the handles over them.
        self.buf = np.zeros((n, _ROW))
        self.reads = [chipmunk.body_readout(row) for row in self.buf]
        self.forces_buf = np.zeros((n, 36))
        self.pushes = [chipmunk.body_readout(row, forces=True) for row in self.forces_buf]
        self.push_rows = np.array(
            [[chipmunk.address(p.request), chipmunk.address(p.array)] for p in self.pushes],
            dtype=np.uintp,
        ).reshape(n, 2)
        self.handle_rows = np.zeros((n, len(chipmunk.HANDLE_FIELDS)), dtype=np.uintp)
        self.commands: list[Any] = [None] * n  # each simulation's record of commands
        self.log = np.empty((n, COMMAND_LOG, 3))
        self.logged = np.zeros(n, dtype=np.int64)
        self.log_steps = 0
        self.time = np.zeros(n)
        self.projection: np.ndarray | None = None  # (N, C): each machine's projector constants
        self.force_limit = np.zeros(n)
        self.lag = np.ones(n)
        self.lagged = np.zeros((n, 3))
        self.viscous = np.zeros((n, 2))
        self.true_kin = np.zeros((n, 10))
        self.last_reading = np.zeros((n, LAST_SIZE))
        self.targets = np.zeros((n, 3))
        self.assembly = np.zeros(n, dtype=np.int64)
        self.tolerances = np.zeros((n, 3))
        self.action_delay = np.zeros(n, dtype=np.int64)
        self.action_items = np.zeros((n, MAX_DELAY + 1, 3))
        self.action_count = np.zeros(n, dtype=np.int64)
        self.obs_delay = np.zeros(n, dtype=np.int64)
        self.obs_items = np.zeros((n, MAX_DELAY + 1, self.width), dtype=np.float32)
        self.obs_count = np.zeros(n, dtype=np.int64)
        #: Each environment's generator (its ``np_random``), for the encoders' noise (made at
        #: the first :meth:`load`, once there are generators).
        self.rngs: Any = None
        self.pending = np.zeros(n, dtype=np.bool_)
        self.last: dict[str, Any] | None = None

    # ------------------------------------------------------------------ env <-> batch
    def load(self, i: int) -> None:
        """Take environment ``i``'s state (after a reset or a restored snapshot): its
        simulation's handles and machine, its episode, its delay lines and encoders."""
        env = self.venv._envs[i]
        link = env.sim.batch_link()
        if link is None:
            raise RuntimeError("the batched step needs pymunk's batch API (Planar3PSim.batch_link)")
        if self.projection is None:
            self.projection = np.zeros((self.venv.num_envs, link.projection.shape[0]))
        self.projection[i] = link.projection
        self.handle_rows[i] = chipmunk.handle_row(link.space, link.servos, self.reads[i])
        self.commands[i] = link.commands
        self.logged[i] = 0
        self.time[i] = link.time
        self.force_limit[i] = link.force_limit
        self.lag[i] = link.lag
        self.lagged[i] = link.lagged
        self.viscous[i] = link.viscous
        m = env.machine
        me = m.episode
        self.true_kin[i] = me.true_kin.consts
        if m.encoders is not None:
            self.last_reading[i] = m.encoders.last_array()
        self._load_line(i, me.action_line, self.action_items, self.action_count)
        self.action_delay[i] = me.delays[0]
        self._load_line(i, me.obs_line, self.obs_items, self.obs_count)
        self.obs_delay[i] = me.delays[1]
        ep = env.episode
        self.targets[i] = ep.target
        self.assembly[i] = ep.assembly
        self.tolerances[i] = env.task_config.success_tolerances
        self.extra[i] = ep.obs[OBS_SIZE:]
        if self.mode:
            self.target_modes[i] = ep.info["target_working_mode"]
        if self.shaping:
            self.target_rho[i] = env.task.target_travels  # type: ignore[attr-defined]
        self.goal_rho[i] = ep.target_rho
        if self.assembly_change:
            task = env.task
            self.target_assembly[i] = ep.info["target_assembly"]
            self.last_sign[i] = task.last_sign  # type: ignore[attr-defined]
            self.crossings[i] = task.crossings  # type: ignore[attr-defined]
        if self.rngs is None:
            self.rngs = typed.List([env.np_random] * self.venv.num_envs)
        self.rngs[i] = env.np_random
        self.pending[i] = False

    @staticmethod
    def _load_line(i: int, line: Any, items: np.ndarray, count: np.ndarray) -> None:
        held = line.items
        count[i] = len(held)
        for q, item in enumerate(held):
            items[i, q] = item

    def config_changed(self) -> None:
        for i, env in enumerate(self.venv._envs):
            self.tolerances[i] = env.task_config.success_tolerances

    def _append_commands(self, i: int) -> None:
        count = int(self.logged[i])
        if count:
            self.commands[i].extend(self.log[i, :count].ravel().tolist())
            self.logged[i] = 0

    def _state(self, i: int, st: np.ndarray, closure: float, impulses: np.ndarray) -> SimState:
        """Environment ``i``'s simulation state of the projected state ``st`` (theta not
        wrapped), ``closure`` and the servos' ``impulses``, as its simulation gives it."""
        s = st.tolist()
        f0, f1, f2, m0, m1, m2 = impulses[:6].tolist()
        scale, limit = self.scale, float(self.force_limit[i])
        return SimState(
            float(self.time[i]),
            (s[0], s[1], s[2]),
            (s[3], s[4], s[5]),
            (s[6], s[7], wrap_angle(s[8])),
            (s[9], s[10], s[11]),
            (s[12], s[13], s[14]),
            (f0 * scale, f1 * scale, f2 * scale),
            (m0 >= limit, m1 >= limit, m2 >= limit),
            float(closure),
        )

    def _adopt(self, i: int, state: SimState, st: np.ndarray) -> None:
        """Give environment ``i``'s simulation ``state`` (of the projected ``st``)."""
        setpoints = (float(self.buf[i, 12]), float(self.buf[i, 30]), float(self.buf[i, 48]))
        geometry = tuple(st[15:23].tolist())
        lagged = tuple(self.lagged[i].tolist())
        self.venv._envs[i].sim.adopt_state(state, setpoints, geometry, lagged, st.copy())

    def _give_machine(self, i: int) -> None:
        """Give environment ``i`` its delay lines and its encoders' last reading."""
        m = self.venv._envs[i].machine
        me = m.episode
        c = int(self.action_count[i])
        me.action_line.items = [tuple(v) for v in self.action_items[i, :c].tolist()]
        c = int(self.obs_count[i])
        me.obs_line.items = [self.obs_items[i, q].copy() for q in range(c)]
        if m.encoders is not None:
            m.encoders.set_state(Encoders.last_of(self.last_reading[i]))

    def sync(self, i: int, bodies: bool = True) -> None:
        """Write the last batched step's results into environment ``i`` (its simulation's
        state, the episode's observation, measures and info, its machine's lines and
        encoders)."""
        env = self.venv._envs[i]
        self._append_commands(i)
        last = self.last
        assert last is not None
        j = int(last["row"][i])
        st = last["states"][j]
        state = self._state(i, st, last["closure"][j], last["impulses"][j])
        self._adopt(i, state, st)
        self._give_machine(i)
        res = last["res"][:, j].tolist()
        legs = last["legs"][j].tolist()
        measures = ConfigurationMeasures(res[4], res[5], int(res[6]), (legs[0], legs[1], legs[2]))
        reason = REASONS[int(res[1])]
        terms = dict(zip(TERM_NAMES, res[TERMS_START:], strict=True))
        errors = (res[2], res[3])
        ep = env.episode
        ep.steps = int(self.venv._elapsed[i])
        ep.target = env.task.reference(ep.steps)
        ep.obs = last["obs"][j].copy()
        ep.measures = measures
        ep.info = env.kernel.info(ep, state, measures, reason, terms, reason == "success", errors)
        if self.assembly_change:  # (the task's crossing count, which its metrics read)
            env.task.last_sign = int(self.last_sign[i])  # type: ignore[attr-defined]
            env.task.crossings = int(self.crossings[i])  # type: ignore[attr-defined]
        if self.shaping:  # (the term, and the task's fallback travels, as its step leaves them)
            ep.info["reward_terms"]["travel"] = env.task.step_travel(state.rho)  # type: ignore[attr-defined]
        ep.info.update(env.task.step_info(ep.steps, state, errors))
        self.pending[i] = False

    # ------------------------------------------------------------------ stepping
    def _actions(self, a: np.ndarray) -> np.ndarray:
        """The chosen slider velocities (fractions of ``max_speed``) of the checked actions
        ``a``: clipped, or the on-off motors' commands (``ValueError`` before anything
        changes for values that are not motor commands)."""
        if self.action_type == "continuous":
            return super()._actions(a)
        return on_off_actions(a, self.action_type, self.on_off_speed)

    def _advance(
        self,
        a: np.ndarray,
        idx: np.ndarray,
        rewards: np.ndarray,
        terminated: np.ndarray,
        info: dict[str, Any],
    ) -> None:
        venv = self.venv
        if self.log_steps == COMMAND_LOG:  # (every log has room for the step after this)
            for i in np.flatnonzero(self.logged).tolist():
                self._append_commands(i)
            self.log_steps = 0
        self.log_steps += 1
        b = BuiltBatch(
            chipmunk.FUNCTIONS, self.handle_rows, self.push_rows, self.action_delay,
            self.action_items, self.action_count, self.vmax, self.lag, self.lagged, self.h,
            self.substeps, self.force_limit, self.buf, self.projection, FOLLOWING_ERROR_LIMIT,
            self.forces_buf, self.viscous, self.log, self.logged, self.breakdown, self.true_kin,
            self.nominal_kin, self.encoders, self.sensing, self.leg_1, self.enc_dt,
            self.last_reading, self.targets, self.assembly, self.tolerances, self.weights,
            self.length, self.barriers[0], self.barriers[1], self.crossing_fails, self.low,
            self.high, self.extra, self.obs_delay, self.obs_items, self.obs_count,
        )  # fmt: skip
        if self.mode:
            *out, _ = built_mode_batch_step(
                idx, a, b, self.rngs, self.target_modes, self.shaping, self.target_rho
            )
        elif self.assembly_change:
            *out, counts, _ = built_assembly_batch_step(
                idx, a, b, self.rngs, self.target_assembly, self.last_sign, self.crossings,
                *self.signed_bounds, self.shaping, self.target_rho,
            )  # fmt: skip
            kept = idx[out[4]]
            self.last_sign[kept] = counts[0, out[4]]
            self.crossings[kept] = counts[1, out[4]]
        elif self.travel_goal:  # (the block of the observed travels, before the delay)
            executed, impulses, states, closure, good, obs, res, legs = built_rows(
                idx, a, b, self.rngs
            )
            obs[:, OBS_SIZE:] = travel_goal_entries(obs[:, :3], self.goal_rho[idx])
            delayed = delay_rows(idx, good, obs, b.obs_delay, b.obs_items, b.obs_count)
            out = [executed, impulses, states, closure, good, obs, delayed, res, legs]
        else:
            out = built_batch_step(idx, a, b, self.rngs)
        executed, impulses, states, closure, good, obs, delayed, res, legs = out
        bad_rows = np.flatnonzero(~good).tolist()
        for j in bad_rows:  # (their envs brought to their previous step first)
            i = int(idx[j])
            if self.pending[i]:
                self.sync(i)
        venv._elapsed[idx] += 1
        self.time[idx] += self.dt
        sel = slice(None) if len(idx) == len(rewards) else idx  # (every env: no gather)
        reason = res[1].astype(np.int64)
        venv._obs[sel] = delayed
        rewards[sel] = res[0]
        terminated[sel] = reason > 0
        info["is_success"][sel] = reason == 1
        info["termination_reason"][sel] = _REASONS[reason]
        info["position_error"][sel] = res[2]
        info["orientation_error"][sel] = res[3]
        info["parallel_margin"][sel] = res[4]
        info["serial_margin"][sel] = res[5]
        info["assembly_mode"][sel] = res[6].astype(np.int64)
        info["closure_error"][sel] = closure
        self.last = {
            "row": self._rows(idx),
            "states": states,
            "closure": closure,
            "impulses": impulses,
            "obs": obs,
            "res": res,
            "legs": legs,
        }
        self.pending[sel] = True
        for j in bad_rows:  # the reference kernel on the state just computed, as the single env
            i = int(idx[j])
            env = venv._envs[i]
            state = self._state(i, states[j], closure[j], impulses[j])
            self._adopt(i, state, states[j])
            self._append_commands(i)
            self._give_machine(i)
            ep = env.episode
            ep.steps = int(venv._elapsed[i])
            action = tuple(executed[j].tolist())
            ob, r, why, inf = env.kernel.step(ep, state, None, action, env.np_random)
            venv._obs[i] = env.machine.delay(ob.copy())
            me = env.machine.episode
            self._load_line(i, me.obs_line, self.obs_items, self.obs_count)
            rewards[i] = r
            terminated[i] = why is not None
            for key in self.info_keys:
                info[key][i] = inf[key]
            self.pending[i] = False


class _GoalRows:
    """The goal env's part of a batched step (:func:`~planar3p_gym.envs.batch_kernel.
    goal_batch_step`): each environment's desired goal, the ``Dict`` observations
    (:func:`~planar3p_gym.envs.goal.goal_observation`), the goal rewards and the relabelling
    entries of the infos."""

    def __init__(self, core: _BatchCore, env: Planar3PGoalEnv) -> None:
        self.core = core
        self.venv = core.venv
        n = self.venv.num_envs
        self.desired = np.zeros((n, 5), dtype=np.float32)
        self.low, self.high = goal_bounds(env.design)
        self.length = env.design.characteristic_length
        self.dense = env.reward_type == "dense"
        self.working_mode = env.observe_working_mode
        #: The last batched step's achieved goals, evaluations and goal rewards.
        self.current: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def load(self, i: int, env: Planar3PGoalEnv) -> None:
        """Take environment ``i``'s desired goal (after a reset or a restored snapshot)."""
        self.desired[i] = env.goal_task.desired

    def advance(self, args: tuple, idx: np.ndarray) -> tuple:
        """:func:`~planar3p_gym.envs.batch_kernel.goal_batch_step` of the reach step's
        arguments ``args`` (the environments ``idx``); keeps the goal outputs in
        :attr:`current`."""
        *reach, achieved, evaluation, rewards = goal_batch_step(
            *args, self.desired, self.low, self.high, self.length, self.dense
        )
        self.current = (achieved, evaluation, rewards)
        return tuple(reach)

    def outputs(
        self, sel: Any, idx: np.ndarray, o: dict[str, Any], good: np.ndarray, info: dict
    ) -> np.ndarray:
        """Write the stepped environments' (``idx``, ``sel`` over the batch) ``Dict``
        observations of their flat observations (the outputs ``o``) and their relabelling
        entries; returns their goal rewards (the rows not ``good``, whose physics broke
        down, take :meth:`fallback`)."""
        assert self.current is not None
        achieved, evaluation, rewards = self.current
        obs = goal_observation(o["obs"], achieved, self.desired[sel], self.working_mode)
        for key, value in obs.items():
            self.venv._obs[key][sel] = value
        info["failure"][sel] = o["reason"] == 2
        info["goal_free_reward"][sel] = evaluation[3]
        return rewards

    def fallback(
        self, i: int, env: Planar3PGoalEnv, flat: np.ndarray, reward: float, info: dict
    ) -> float:
        """Environment ``i``'s ``Dict`` observation and goal reward of the reference kernel's
        step (its flat observation ``flat`` and ``info``), as its own step gives them."""
        obs, reward = env.goal_outputs(flat, info)
        self.venv._put(i, obs)
        return reward

    def sync(
        self, i: int, env: Planar3PGoalEnv, info: dict[str, Any], last: dict[str, Any], j: int
    ) -> None:
        """Give environment ``i`` (row ``j`` of the ``last`` batched step) its goal
        evaluation and ``info``'s relabelling entries, as its own step leaves them."""
        achieved, evaluation, _ = last["goal"]
        task = env.goal_task
        task.achieved[:] = achieved[j]
        pos, ang, success, free = evaluation[:, j].tolist()
        task.evaluation = (pos, ang, bool(success))
        info["failure"] = info["termination_reason"] in task.failure_reasons
        info["goal_free_reward"] = free


class _TrackRows:
    """The tracking task's part of a batched step (:func:`~planar3p_gym.envs.batch_kernel.
    track_batch_step`): each episode's reference samples (``TrackTask.samples``, one row of
    :attr:`samples` per environment, extended as the episode goes on), the running tracking
    errors, and the reference velocity entries of the observations."""

    def __init__(self, core: _BatchCore, env: Planar3PEnv) -> None:
        self.core = core
        self.venv = core.venv
        n = self.venv.num_envs
        settings = env.kernel.settings
        self.low, self.high = settings.extra_low, settings.extra_high
        #: Each environment's reference samples (a row each, ``filled[i]`` of them).
        self.samples = np.zeros((n, SAMPLE_CHUNK, 8))
        self.filled = np.zeros(n, dtype=np.int64)
        self.running = np.zeros((n, RUNNING_SIZE))
        #: The last batched step's reference velocity entries and running errors of the
        #: stepped environments.
        self.extra: np.ndarray | None = None
        self.current: np.ndarray | None = None

    def _fill(self, i: int, env: Planar3PEnv, start: int) -> None:
        """Copy environment ``i``'s reference samples from step ``start`` on into its row of
        :attr:`samples` (grown to hold them)."""
        have = env.task.samples  # type: ignore[attr-defined]
        if have.shape[0] > self.samples.shape[1]:
            grown = np.zeros((self.venv.num_envs, max(have.shape[0], 2 * self.samples.shape[1]), 8))
            grown[:, : self.samples.shape[1]] = self.samples
            self.samples = grown
        self.samples[i, start : have.shape[0]] = have[start:]
        self.filled[i] = have.shape[0]

    def load(self, i: int, env: Planar3PEnv) -> None:
        """Take environment ``i``'s reference and running errors (after a reset or a restored
        snapshot)."""
        self._fill(i, env, 0)
        self.running[i] = env.task.running  # type: ignore[attr-defined]

    def advance(self, args: tuple, idx: np.ndarray) -> tuple:
        """:func:`~planar3p_gym.envs.batch_kernel.track_batch_step` of the reach step's
        arguments ``args`` (the environments ``idx``); keeps the reference velocity entries
        and the running errors in :attr:`current`.  An environment whose samples end before
        its new step has them extended first (:meth:`TrackTask.sample`, as its own step
        would)."""
        elapsed = self.venv._elapsed
        steps = elapsed[idx] + 1
        for k in np.flatnonzero(steps >= self.filled[idx]).tolist():
            i = int(idx[k])
            env = self.venv._envs[i]
            env.task.sample(int(steps[k]))  # type: ignore[attr-defined]
            self._fill(i, env, int(self.filled[i]))
        *reach, extra, running = track_batch_step(
            *args, self.samples, elapsed, self.running, self.low, self.high
        )
        self.extra = extra
        self.current = running
        return tuple(reach)

    def outputs(
        self, sel: Any, idx: np.ndarray, o: dict[str, Any], good: np.ndarray, info: dict
    ) -> np.ndarray:
        """Write the stepped environments' (``idx``, ``sel`` over the batch) observations
        (the outputs ``o`` with the reference velocity entries, kept there: :meth:`sync`
        gives each env its row) and keep the running errors of the rows whose physics held
        (``good``); returns their rewards."""
        assert self.current is not None
        obs = o["obs"] = np.concatenate([o["obs"], self.extra], axis=1)
        self.venv._obs[sel] = obs
        self.running[idx[good]] = self.current[good]
        return o["reward"]

    def fallback(
        self, i: int, env: Planar3PEnv, flat: np.ndarray, reward: float, info: dict
    ) -> float:
        """Environment ``i``'s observation of the reference kernel's step, and its running
        errors (counted by the task's own metrics)."""
        self.venv._obs[i] = flat
        self.running[i] = env.task.running  # type: ignore[attr-defined]
        return reward

    def sync(
        self, i: int, env: Planar3PEnv, info: dict[str, Any], last: dict[str, Any], j: int
    ) -> None:
        """Give environment ``i`` (row ``j`` of the ``last`` batched step) its reference
        target, its running errors and ``info``'s tracking metrics, as its own step leaves
        them."""
        task = env.task
        ep = env.episode
        x, y, theta, c, s = task.sample(ep.steps)[:5].tolist()  # type: ignore[attr-defined]
        ep.target, ep.target_cs = (x, y, theta), (c, s)
        task.running[:] = self.running[i]  # type: ignore[attr-defined]
        errors = (info["position_error"], info["orientation_error"])
        info.update(task.tracking_info(ep.steps, errors))  # type: ignore[attr-defined]


class _FlatRows:
    """What the task parts of a batched step with a flat observation share: the step of
    environment ``i`` that took the reference kernel (its physics broke down), and the
    mode and assembly changes' travel term (:mod:`planar3p_gym.tasks.travel_shaping`): its
    weight and each episode's target travels."""

    venv: Planar3PVectorEnv
    shaping: float
    target_rho: np.ndarray

    def _travel_init(self, env: Planar3PEnv) -> None:
        self.shaping = float(env.task.travel_shaping)  # type: ignore[attr-defined]
        self.target_rho = np.zeros((self.venv.num_envs, 3))

    def _travel_sync(self, env: Planar3PEnv, info: dict[str, Any]) -> None:
        """``info``'s travel term of ``env``'s step (its simulation's state already the
        step's) and the task's fallback travels, as its own step leaves them."""
        if self.shaping:
            term = env.task.step_travel(env.sim.state.rho)  # type: ignore[attr-defined]
            info["reward_terms"]["travel"] = term

    def fallback(
        self, i: int, env: Planar3PEnv, flat: np.ndarray, reward: float, info: dict
    ) -> float:
        """Environment ``i``'s observation of the reference kernel's step."""
        self.venv._obs[i] = flat
        return reward


class _ModeRows(_FlatRows):
    """The mode-change task's part of a batched step (:func:`~planar3p_gym.envs.batch_kernel.
    mode_batch_step`): each episode's target working mode and its observation's extra entries
    (the target's travels and working mode, fixed over the episode)."""

    def __init__(self, core: _BatchCore, env: Planar3PEnv) -> None:
        self.venv = core.venv
        n = self.venv.num_envs
        self.target_modes = np.zeros((n, 3), dtype=np.int64)
        self.extra = np.zeros((n, env.observation_space.shape[0] - OBS_SIZE), dtype=np.float32)
        self.parallel_barrier = bool(env.task.parallel_barrier)
        self.serial_barrier = bool(env.task.serial_barrier)
        self._travel_init(env)
        self.current = None  # (no outputs of its own: the reach outputs hold them)

    def load(self, i: int, env: Planar3PEnv) -> None:
        """Take environment ``i``'s target working mode and extra entries (from its reset's,
        or a restored snapshot's, ``info`` and observation)."""
        self.target_modes[i] = env.episode.info["target_working_mode"]
        self.extra[i] = env.episode.obs[OBS_SIZE:]
        self.target_rho[i] = env.task.target_travels  # type: ignore[attr-defined]

    def advance(self, args: tuple, idx: np.ndarray) -> tuple:
        """:func:`~planar3p_gym.envs.batch_kernel.mode_batch_step` of the reach step's
        arguments ``args`` (the environments ``idx``)."""
        *reach, _ = mode_batch_step(
            *args, self.target_modes, self.parallel_barrier, self.serial_barrier, self.shaping,
            self.target_rho,
        )  # fmt: skip
        return tuple(reach)

    def outputs(
        self, sel: Any, idx: np.ndarray, o: dict[str, Any], good: np.ndarray, info: dict
    ) -> np.ndarray:
        """Write the stepped environments' (``idx``, ``sel`` over the batch) observations:
        the outputs ``o`` with the extra entries (kept there: :meth:`sync` gives each env its
        row); returns their rewards."""
        obs = o["obs"] = np.concatenate([o["obs"], self.extra[idx]], axis=1)
        self.venv._obs[sel] = obs
        return o["reward"]

    def sync(
        self, i: int, env: Planar3PEnv, info: dict[str, Any], last: dict[str, Any], j: int
    ) -> None:
        """``info``'s mode-change metrics of environment ``i`` (its simulation's state
        already the step's), as its own step gives them (the task's hook)."""
        self._travel_sync(env, info)
        errors = (info["position_error"], info["orientation_error"])
        info.update(env.task.step_info(env.episode.steps, env.sim.state, errors))


class _AssemblyRows(_FlatRows):
    """The assembly-change task's part of a batched step (:func:`~planar3p_gym.envs.
    batch_kernel.assembly_batch_step`): each episode's target assembly mode, crossing count and
    fixed extra entries (the target's travels and assembly mode), the signed parallel margin
    entry of each step."""

    def __init__(self, core: _BatchCore, env: Planar3PEnv) -> None:
        self.venv = core.venv
        n = self.venv.num_envs
        self.target_assembly = np.zeros(n, dtype=np.int64)
        self.last_sign = np.zeros(n, dtype=np.int64)
        self.crossings = np.zeros(n, dtype=np.int64)
        self.extra = np.zeros((n, env.observation_space.shape[0] - OBS_SIZE), dtype=np.float32)
        settings = env.kernel.settings
        self.signed_low = float(settings.extra_low[-1])
        self.signed_high = float(settings.extra_high[-1])
        self.serial_barrier = bool(env.task.serial_barrier)
        self._travel_init(env)
        #: The last batched step's signed margin entries and crossing counts.
        self.signed: np.ndarray | None = None
        self.current: np.ndarray | None = None

    def load(self, i: int, env: Planar3PEnv) -> None:
        """Take environment ``i``'s target assembly mode, crossing count and extra entries
        (after a reset or a restored snapshot)."""
        task = env.task
        self.target_assembly[i] = env.episode.info["target_assembly"]
        self.last_sign[i] = task.last_sign  # type: ignore[attr-defined]
        self.crossings[i] = task.crossings  # type: ignore[attr-defined]
        self.extra[i] = env.episode.obs[OBS_SIZE:]
        self.target_rho[i] = task.target_travels  # type: ignore[attr-defined]

    def advance(self, args: tuple, idx: np.ndarray) -> tuple:
        """:func:`~planar3p_gym.envs.batch_kernel.assembly_batch_step` of the reach step's
        arguments ``args`` (the environments ``idx``)."""
        *reach, signed, counts, _ = assembly_batch_step(
            *args, self.target_assembly, self.last_sign, self.crossings, self.serial_barrier,
            self.signed_low, self.signed_high, self.shaping, self.target_rho,
        )  # fmt: skip
        self.signed, self.current = signed, counts
        return tuple(reach)

    def outputs(
        self, sel: Any, idx: np.ndarray, o: dict[str, Any], good: np.ndarray, info: dict
    ) -> np.ndarray:
        """Write the stepped environments' (``idx``, ``sel`` over the batch) observations
        (the outputs ``o`` with the extra entries, kept there: :meth:`sync` gives each env its
        row) and keep the crossing counts of the rows whose physics held (``good``); returns
        their rewards."""
        assert self.current is not None
        extra = self.extra[idx]
        extra[:, -1] = self.signed
        obs = o["obs"] = np.concatenate([o["obs"], extra], axis=1)
        self.venv._obs[sel] = obs
        kept = idx[good]
        self.last_sign[kept] = self.current[0, good]
        self.crossings[kept] = self.current[1, good]
        return o["reward"]

    def sync(
        self, i: int, env: Planar3PEnv, info: dict[str, Any], last: dict[str, Any], j: int
    ) -> None:
        """Give environment ``i`` its crossing count and ``info``'s metrics (the task's
        hook), as its own step leaves them."""
        task = env.task
        task.last_sign = int(self.last_sign[i])  # type: ignore[attr-defined]
        task.crossings = int(self.crossings[i])  # type: ignore[attr-defined]
        self._travel_sync(env, info)
        errors = (info["position_error"], info["orientation_error"])
        info.update(task.step_info(env.episode.steps, env.sim.state, errors))


class Planar3PTrackVectorEnv(Planar3PVectorEnv):
    """``Planar3PTrack-v0``'s native vector env (the batched step from
    :data:`NUMPY_BATCH_MIN` environments, module docstring)."""

    env_class = Planar3PTrackEnv


class Planar3PModeChangeVectorEnv(Planar3PVectorEnv):
    """``Planar3PModeChange-v0``'s native vector env (the batched step from
    :data:`NUMPY_BATCH_MIN` environments, module docstring)."""

    env_class = Planar3PModeChangeEnv


class Planar3PAssemblyChangeVectorEnv(Planar3PVectorEnv):
    """``Planar3PAssemblyChange-v0``'s native vector env (the batched step from
    :data:`NUMPY_BATCH_MIN` environments, module docstring)."""

    env_class = Planar3PAssemblyChangeEnv


class Planar3PGoalVectorEnv(Planar3PVectorEnv):
    """``Planar3PGoal-v0``'s and ``Planar3PGoalDense-v0``'s native vector env (the batched
    step from :data:`NUMPY_BATCH_MIN` environments, module docstring): the ``Dict``
    observations as a dict of batch arrays, the relabelling entries
    (:data:`planar3p_gym.tasks.goal.RELABEL_INFO_KEYS`) among the infos, and
    :meth:`compute_reward` over the batch."""

    env_class = Planar3PGoalEnv
    info_keys = (*INFO_KEYS, *RELABEL_INFO_KEYS)

    def compute_reward(self, achieved_goal: Any, desired_goal: Any, info: Any) -> Any:
        """:meth:`Planar3PGoalEnv.compute_reward` of goals ``(n, 5)`` (one per pair; ``info``
        this vector env's infos, a dict of arrays over the pairs, or one dict per pair)."""
        return self._envs[0].compute_reward(achieved_goal, desired_goal, info)
