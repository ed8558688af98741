"""``Planar3PGoal-v0`` / ``Planar3PGoalDense-v0``: the goal-conditioned reach.

A thin layer over :class:`planar3p_gym.envs.core.Planar3PEnv` with the goal task of
:mod:`planar3p_gym.tasks.goal`: the observation becomes a ``Dict`` of the robot's state and the
achieved and desired goals, and the reward is :meth:`Planar3PGoalEnv.compute_reward` on them,
the interface of Gymnasium-Robotics' ``GoalEnv`` that hindsight relabelling (SB3's
``HerReplayBuffer``) relies on.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces
from numba import njit
from numpy.typing import ArrayLike, NDArray

from planar3p_gym.envs.core import Planar3PEnv
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.goal import (
    GOAL_SIZE,
    GoalTask,
    goal_arrays,
    goal_bounds,
    goal_free_reward,
    goal_reward,
    goal_success,
    info_field,
    pose_of_goal,
    poses_of_goals,
)
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES, write_reach_values

__all__ = [
    "ROBOT_FIELDS",
    "ROBOT_INDEX",
    "Planar3PGoalEnv",
    "flat_observation",
    "goal_observation",
]

#: Blocks of the flat observation (:mod:`planar3p_gym.tasks.observation`) that describe the robot
#: alone, in order: the ``observation`` entry of the goal env (no goal in it).
ROBOT_FIELDS = (
    "rho",
    "rho_dot",
    "position",
    "orientation",
    "velocity",
    "angular_velocity",
    "legs",
    "parallel_margin",
    "serial_margin",
)
#: Indices of those blocks in the flat observation (21 entries).
ROBOT_INDEX = np.concatenate([np.arange(SLICES[f].start, SLICES[f].stop) for f in ROBOT_FIELDS])


@njit(cache=True)
def _write_flat_rows(flat: np.ndarray, targets: np.ndarray, length: float) -> None:
    """Complete each row of ``flat`` (its robot entries set) for the target poses ``targets``
    ``(n, 3)`` (m, m, rad) by the observation's one layout,
    :func:`~planar3p_gym.tasks.observation.write_reach_values`."""
    pose = np.empty(3)
    for i in range(flat.shape[0]):
        f, t = flat[i], targets[i]
        pose[0], pose[1], pose[2] = f[6], f[7], math.atan2(f[9], f[8])
        write_reach_values(
            f, f[0:3], f[3:6], pose, f[8], f[9], f[10:13], f[13:19],
            t, math.cos(t[2]), math.sin(t[2]), f[26], f[27], length,
        )  # fmt: skip


def flat_observation(obs: dict[str, ArrayLike], length: float) -> NDArray[np.float32]:
    """The 31-entry observation of ``Planar3P-v0`` rebuilt from a goal env's ``Dict``
    observation (single ``(21,)`` or batched ``(n, 21)`` entries), so that policies and
    controllers written for the flat observation act on the goal env.  ``length`` is the
    design's characteristic length (m).  Entries are computed as the flat env computes them
    (to float32 rounding; not clipped); the goal's speed entry is not used."""
    robot = np.asarray(obs["observation"], dtype=np.float64)
    goal = np.asarray(obs["desired_goal"], dtype=np.float64)
    single = robot.ndim == 1
    robot, goal = np.atleast_2d(robot), np.atleast_2d(goal)
    if robot.shape[1:] != (ROBOT_INDEX.size,) or goal.shape[1:] != (GOAL_SIZE,):
        raise ValueError(
            f"observation must have {ROBOT_INDEX.size} entries and desired_goal {GOAL_SIZE}, "
            f"got shapes {robot.shape} and {goal.shape}"
        )
    if robot.shape[0] != goal.shape[0]:
        raise ValueError("observation and desired_goal must have the same batch size")
    flat = np.zeros((robot.shape[0], OBS_SIZE))
    flat[:, ROBOT_INDEX] = robot
    _write_flat_rows(flat, poses_of_goals(goal), float(length))
    out = flat.astype(np.float32)
    return out[0] if single else out


def goal_observation(
    flat: np.ndarray, achieved: np.ndarray, desired: np.ndarray, working_mode: bool
) -> dict[str, np.ndarray]:
    """The goal env's ``Dict`` observation of flat observations ``flat`` (``(31,)`` or a batch
    ``(n, 31)``, float32) and the goals ``achieved``, ``desired`` (``(5,)`` or ``(n, 5)``,
    taken as they are); with ``working_mode`` the signs of the observed ``cos alpha_i``."""
    obs = {
        "observation": flat[..., ROBOT_INDEX],
        "achieved_goal": achieved,
        "desired_goal": desired,
    }
    if working_mode:
        # sign(cos alpha_i) of the observed leg angles: the working mode (legs exactly
        # perpendicular to their rails, a serial singularity the episode ends at, give 0).
        obs["working_mode"] = np.sign(flat[..., SLICES["legs"]][..., 0::2]).astype(np.float32)
    return obs


class Planar3PGoalEnv(Planar3PEnv):
    """Goal-conditioned reach with a 3-PRR planar parallel manipulator (GoalEnv interface).

    ## Description
    The machine and episodes of ``Planar3P-v0`` (the projected physics: ``projection=True``
    with :data:`~planar3p_gym.sim.physics.PROJECTED_SUBSTEPS` and
    :data:`~planar3p_gym.sim.physics.PROJECTED_ITERATIONS`, as registered; the same start/target
    sampler and singularity handling as ``Planar3P-v0``), presented as a goal-conditioned
    task: the policy is told the goal pose and is rewarded by :meth:`compute_reward`, which
    depends only on the achieved and desired goals and on goal-independent facts of the step
    carried in ``info``, so hindsight relabelling (SB3's ``HerReplayBuffer``) gives exactly
    the reward the environment would have returned for the relabelled goal.

    ## Action Space
    ``Box(-1, 1, (3,), float32)``: slider velocity commands as fractions of ``max_speed``
    (as ``Planar3P-v0``).

    ## Observation Space
    ``Dict`` of
    - ``observation``: ``Box((21,), float32)``, the robot blocks of the flat observation
      (:data:`ROBOT_FIELDS`: travels (m) and rates (m/s), gripper position (m), ``cos/sin
      theta``, gripper twist (m/s, rad/s), ``cos/sin`` of the leg angles, parallel and serial
      margins); no goal in it;
    - ``achieved_goal``: ``Box((5,), float32)``, the gripper pose and the fastest slider's
      speed as ``(x, y, cos theta, sin theta, v)`` (m, m, 1, 1, m/s);
    - ``desired_goal``: the target pose in the same form, with ``v = 0`` ("at rest");
    - ``working_mode`` (only with ``observe_working_mode=True``): ``Box(-1, 1, (3,), float32)``,
      the signs of the observed ``cos alpha_i``: the working mode of the current configuration
      (:func:`planar3p_gym.machine.kinematics.working_mode`; the episode's unless a leg has
      passed perpendicular to its rail), kept apart from ``observation`` so
      that it reaches a policy unnormalised: with it a policy can put any goal, relabelled ones
      included, into joint space (``GoalTravelExtractor`` of ``planar3p_agents``).

    ## Rewards
    ``compute_reward(achieved_goal, desired_goal, info)``, vectorised
    (:func:`planar3p_gym.tasks.goal.goal_reward`).  Sparse (``Planar3PGoal-v0``): ``-1`` per
    step, ``0`` on success, and ``-w_failure`` (default 300) on a step that ends the episode by
    a singularity crossing or a physics breakdown (so ending early never pays).  Dense
    (``Planar3PGoalDense-v0``): the reach reward of ``Planar3P-v0`` (pose error, precision
    term, success bonus, singularity penalty, action effort, failure penalty).  Success: within
    ``position_tolerance`` (2 mm) and ``orientation_tolerance`` (1 deg) of the goal pose with
    the achieved speed at most the desired one plus ``rest_speed`` (0.01 m/s) (goal-only, so
    relabelled successes are exact); the goal-independent terms are in
    ``info["goal_free_reward"]``, the failure flag in ``info["failure"]``: ``info`` is the
    step's info dict, one per goal, or empty/None (those terms then count as 0; use
    ``HerReplayBuffer(copy_info_dict=True)`` for exact relabelled penalties).  Wrong goal
    shapes raise ``ValueError``.

    ## Starting State
    As ``Planar3P-v0``; ``reset(options=...)`` also accepts ``desired_goal`` (5 numbers; the
    goal pose must be reachable in the episode's working mode).

    ## Episode End
    ``terminated`` on success or failure (:meth:`compute_terminated`), ``truncated`` by the
    registered time limit (100 steps, 2 s: short episodes suit hindsight relabelling, and
    SB3's HER can sample before its default ``learning_starts`` of 100 steps is up).

    ## Arguments
    ``reward_type`` (``"sparse"`` or ``"dense"``), ``observe_working_mode`` (bool, default
    False: add the ``working_mode`` key above), and every argument of
    :class:`planar3p_gym.envs.core.Planar3PEnv` except ``task``.

    ## Version History
    - v0 (1.0.0): frozen, with the changes every id took in 1.0.0
      (:class:`~planar3p_gym.envs.core.Planar3PEnv`, Version History); the
      ``observe_working_mode`` argument, off by default.
    - v0 (0.1.0): initial release.
    """

    def __init__(
        self,
        design: Design | dict | str | None = None,
        *,
        reward_type: str = "sparse",
        observe_working_mode: bool = False,
        **kwargs,
    ) -> None:
        if "task" in kwargs:
            raise ValueError("Planar3PGoalEnv sets its own task; do not pass task=")
        if not isinstance(observe_working_mode, (bool, np.bool_)):
            raise ValueError(
                f"observe_working_mode must be True or False, got {observe_working_mode!r}"
            )
        self.observe_working_mode = bool(observe_working_mode)
        goal_task = GoalTask(reward_type)
        super().__init__(design, task=goal_task, **kwargs)
        self.goal_task = goal_task
        self.reward_type = reward_type
        flat = self.observation_space
        assert isinstance(flat, spaces.Box)
        g_low, g_high = goal_bounds(self.design)
        self._goal_low, self._goal_high = g_low, g_high
        entries = {
            "observation": spaces.Box(
                flat.low[ROBOT_INDEX], flat.high[ROBOT_INDEX], dtype=np.float32
            ),
            "achieved_goal": spaces.Box(g_low, g_high, dtype=np.float32),
            "desired_goal": spaces.Box(g_low, g_high, dtype=np.float32),
        }
        if self.observe_working_mode:
            entries["working_mode"] = spaces.Box(-1.0, 1.0, (3,), dtype=np.float32)
        self.observation_space = spaces.Dict(entries)

    # ------------------------------------------------------------------ GoalEnv API
    def compute_reward(self, achieved_goal: ArrayLike, desired_goal: ArrayLike, info: Any) -> Any:
        """Reward per goal pair: a float for single goals ``(5,)``, an array ``(n,)`` for
        batches ``(n, 5)``; ``info`` is the step's info dict or one per pair (``ValueError``
        for goals that are not real, finite and of those shapes, or a bad ``info``)."""
        out = goal_reward(
            achieved_goal,
            desired_goal,
            info,
            self.task_config,
            self.reward_weights,
            self.design.characteristic_length,
            self.reward_type,
        )
        return float(out[0]) if np.ndim(achieved_goal) == 1 else out  # (validated above)

    def compute_terminated(
        self, achieved_goal: ArrayLike, desired_goal: ArrayLike, info: Any
    ) -> Any:
        """Whether the episode ends: success or failure (bool, or a bool array for batches)."""
        a, d, single = goal_arrays(achieved_goal, desired_goal)
        success = goal_success(a, d, info, self.task_config)
        out = success | (info_field(info, "failure", success.shape[0]) > 0.5)
        return bool(out[0]) if single else out

    def compute_truncated(
        self, achieved_goal: ArrayLike, desired_goal: ArrayLike, info: Any
    ) -> Any:
        """Always False: truncation is the registered time limit's.  The arguments are
        checked as :meth:`compute_reward` checks them (``ValueError``)."""
        a, _, single = goal_arrays(achieved_goal, desired_goal)
        info_field(info, "failure", a.shape[0])
        return False if single else np.zeros(a.shape[0], dtype=bool)

    # ------------------------------------------------------------------ Gymnasium API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        flat, info = super().reset(seed=seed, options=options)
        info["failure"] = False
        info["goal_free_reward"] = 0.0
        self.episode.info = info
        return self._dict_obs(flat, info), info

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict]:
        flat, _, terminated, truncated, info = super().step(action)
        obs, reward = self.goal_outputs(flat, info)
        return obs, reward, terminated, truncated, info

    def goal_outputs(self, flat: np.ndarray, info: dict[str, Any]) -> tuple[dict, float]:
        """The ``Dict`` observation and the goal reward of a step of the flat env (its
        observation ``flat`` and ``info``, which gains the relabelling entries): also what the
        native vector env gives a step where the physics broke down."""
        task = self.goal_task
        reason = info["termination_reason"]
        failure = reason in task.failure_reasons
        info["failure"] = failure
        free = goal_free_reward(info["reward_terms"], self.reward_type)
        info["goal_free_reward"] = free
        if reason == "physics_breakdown":  # (no termination test ran: the last good state)
            task.evaluate(info["pose"], info["rho_dot"], True)
        # The goals were evaluated once, by the task's termination test (GoalTask.evaluate):
        # the observation and the reward read that evaluation.
        return self._observation(flat), task.step_reward(free)

    def _dict_obs(self, flat: np.ndarray, info: dict[str, Any]) -> dict[str, np.ndarray]:
        self.goal_task.evaluate(info["pose"], info["rho_dot"], False)
        return self._observation(flat)

    def _observation(self, flat: np.ndarray) -> dict[str, np.ndarray]:
        """The ``Dict`` observation of the flat one and the task's last goal evaluation."""
        task = self.goal_task
        return goal_observation(
            flat, task.achieved.copy(), task.desired.copy(), self.observe_working_mode
        )

    @property
    def goal_pose(self) -> tuple[float, float, float]:
        """The pose ``(x, y, theta)`` (m, m, rad) of the desired goal."""
        return pose_of_goal(self.goal_task.desired)
