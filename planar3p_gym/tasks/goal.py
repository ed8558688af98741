"""Goal-conditioned reach: the goal vectors, the vectorised success test and reward (the task of
``Planar3PGoal-v0`` and ``Planar3PGoalDense-v0``; the ids' page is
:class:`planar3p_gym.envs.goal.Planar3PGoalEnv`).

A goal holds the gripper pose (its angle as cosine and sine) and a slider speed
(:func:`goal_of_pose`), so that hindsight relabelling can recompute every reward from the goals
alone
(why, and what ``info`` adds: docs/environments.md, "How the task modules work").  Each formula
is defined once and compiled; the numpy API loops the same functions over a batch, so
``env.compute_reward`` equals the returned reward bit for bit.

* :func:`goal_test`, :func:`goal_reward_value`, :func:`write_achieved_goal`: the compiled
  definitions; :func:`goal_tests`, :func:`goal_rewards`: their batches;
* :func:`goal_success`, :func:`goal_reward`, :func:`goal_errors`: the numpy API;
* :class:`GoalTask`: the reach task with a goal vector; :class:`GoalKernel`: its step outputs.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from planar3p_gym import checks
from planar3p_gym.machine.design import Design
from planar3p_gym.sim.physics import SimState
from planar3p_gym.tasks.base import Pose
from planar3p_gym.tasks.kernel import (
    CompiledKernel,
    Episode,
    KernelSettings,
    ReachKernel,
    Sensing,
    StepKernel,
    StepOutputs,
)
from planar3p_gym.tasks.observation import SLICES, SPEED_BOUND_FACTOR, bounds
from planar3p_gym.tasks.reach import ReachTask
from planar3p_gym.tasks.reach_step import TERMS_START, rejudge_row
from planar3p_gym.tasks.rewards import TERM_NAMES, RewardWeights, weighted_terms
from planar3p_gym.tasks.sampling import TaskConfig

__all__ = [
    "GOAL_SIZE",
    "RELABEL_INFO_KEYS",
    "REWARD_TYPES",
    "GoalKernel",
    "GoalTask",
    "achieved_goal",
    "evaluate_state_goal",
    "goal_arrays",
    "goal_bounds",
    "goal_errors",
    "goal_free_reward",
    "goal_free_value",
    "goal_of_pose",
    "goal_reward",
    "goal_reward_value",
    "goal_rewards",
    "goal_rows",
    "goal_success",
    "goal_test",
    "goal_tests",
    "info_field",
    "pose_of_goal",
    "poses_of_goals",
    "write_achieved_goal",
]

#: Length of a goal vector ``(x, y, cos theta, sin theta, v)``.
GOAL_SIZE = 5
#: The keys of a step's ``info`` that :func:`goal_reward` (and so the goal env's
#: ``compute_reward``) reads: all a replay buffer must keep of ``info`` for exact relabelling.
RELABEL_INFO_KEYS = ("goal_free_reward", "failure")
#: Reward variants: ``"sparse"`` (0 on success, -1 otherwise) or ``"dense"`` (the reach
#: reward's shaping terms).
REWARD_TYPES = ("sparse", "dense")
#: ``(low, high)`` float32 bounds that clip nothing.
_NO_BOUND = (np.full(GOAL_SIZE, -np.inf, np.float32), np.full(GOAL_SIZE, np.inf, np.float32))


def goal_of_pose(pose: ArrayLike, speed: float = 0.0) -> NDArray[np.float32]:
    """The goal vector (float32, shape ``(5,)``) of a pose ``(x, y, theta)`` (m, m, rad) and a
    slider speed (m/s, >= 0) (:func:`write_achieved_goal`, not clipped)."""
    x, y, th = (float(v) for v in np.asarray(pose, dtype=np.float64).reshape(3))
    out = np.empty(GOAL_SIZE, dtype=np.float32)
    write_achieved_goal(out, x, y, th, float(speed), 0.0, 0.0, _NO_BOUND[0], _NO_BOUND[1])
    return out


def pose_of_goal(goal: ArrayLike) -> Pose:
    """The pose ``(x, y, theta)`` (m, m, rad) a goal vector stands for."""
    g = np.asarray(goal, dtype=np.float64).reshape(-1)
    if g.size not in (4, GOAL_SIZE):
        raise ValueError(f"a goal has {GOAL_SIZE} entries (x, y, cos, sin, v), got {g.size}")
    return float(g[0]), float(g[1]), math.atan2(float(g[3]), float(g[2]))


def poses_of_goals(goals: ArrayLike) -> NDArray[np.float64]:
    """:func:`pose_of_goal` of a batch: poses ``(n, 3)`` (m, m, rad) of goal vectors ``(n, 4)``
    or ``(n, 5)`` (numpy's ``arctan2``; the scalar function keeps ``math.atan2``, which the
    episode specs it builds were recorded with)."""
    g = np.asarray(goals, dtype=np.float64)
    if g.ndim != 2 or g.shape[1] not in (4, GOAL_SIZE):
        raise ValueError(f"goals must have shape (n, {GOAL_SIZE}), got {g.shape}")
    return np.column_stack([g[:, 0], g[:, 1], np.arctan2(g[:, 3], g[:, 2])])


def goal_bounds(design: Design) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """``(low, high)`` float32 bounds of a goal vector for ``design``: the observation's
    bounds of the gripper position (m), ``[-1, 1]`` for ``cos`` and ``sin``, and
    ``[0, SPEED_BOUND_FACTOR * max_speed]`` for the speed (m/s); the ``Box`` of the goal env's
    ``achieved_goal`` and ``desired_goal``."""
    low, high = bounds(design)
    pos = SLICES["position"]
    vmax = SPEED_BOUND_FACTOR * design.max_speed
    g_low = np.concatenate([low[pos], [-1.0, -1.0, 0.0]]).astype(np.float32)
    g_high = np.concatenate([high[pos], [1.0, 1.0, vmax]]).astype(np.float32)
    return g_low, g_high


def goal_arrays(achieved: ArrayLike, desired: ArrayLike) -> tuple[np.ndarray, np.ndarray, bool]:
    """Both goal arrays as float64 ``(n, 5)`` and whether they were single goals; ``ValueError``
    for non-real entries (complex, bool, strings), wrong shapes, mismatched batches or
    non-finite values."""
    arrays = []
    for name, g in (("achieved_goal", achieved), ("desired_goal", desired)):
        arr = checks.real_array(g)
        if arr is None:
            raise ValueError(
                f"{name} must be real numbers of shape ({GOAL_SIZE},) or (n, {GOAL_SIZE}), "
                f"got {checks.short(g)}"
            )
        if arr.ndim not in (1, 2) or arr.shape[-1] != GOAL_SIZE:
            raise ValueError(
                f"{name} must have shape ({GOAL_SIZE},) or (n, {GOAL_SIZE}), got {arr.shape}"
            )
        if not np.isfinite(arr).all():
            raise ValueError(f"{name} must be finite")
        arrays.append(arr)
    a, d = arrays
    if a.shape != d.shape:
        raise ValueError(
            f"achieved_goal and desired_goal must have the same shape, got {a.shape} and {d.shape}"
        )
    single = a.ndim == 1
    a = np.ascontiguousarray(a.reshape(-1, GOAL_SIZE))
    d = np.ascontiguousarray(d.reshape(-1, GOAL_SIZE))
    return a, d, single


def goal_errors(achieved: ArrayLike, desired: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Position error (m) and signed orientation error desired minus achieved (rad, in
    ``[-pi, pi]``), each of shape ``(n,)`` (``(1,)`` for single goals)."""
    a, d, _ = goal_arrays(achieved, desired)
    return _errors(a, d)


def _errors(a: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`goal_errors` of validated ``(n, 5)`` float64 goals."""
    pos, ang, _ = goal_tests(a, d, np.zeros(a.shape[0], np.bool_), 0.0, 0.0, 0.0)
    return pos, ang


@njit(cache=True)
def goal_test(
    a0: float, a1: float, a2: float, a3: float, a4: float,
    d0: float, d1: float, d2: float, d3: float, d4: float,
    failed: bool, position_tolerance: float, orientation_tolerance: float, rest_speed: float,
) -> tuple[float, float, bool]:  # fmt: skip
    """The one definition of a goal pair's errors and success: ``(position error (m),
    orientation error desired minus achieved (rad, in [-pi, pi]), success)`` of an achieved
    goal ``a`` and a desired goal ``d`` (module docstring); ``failed``: the step ended by a
    failure (no success then).  Tolerances in m, rad and m/s."""
    pos = math.hypot(d0 - a0, d1 - a1)
    ang = math.atan2(a2 * d3 - a3 * d2, a2 * d2 + a3 * d3)
    close = pos <= position_tolerance and abs(ang) <= orientation_tolerance
    return pos, ang, close and a4 <= d4 + rest_speed and not failed


@njit(cache=True)
def goal_tests(
    a: np.ndarray, d: np.ndarray, failed: np.ndarray,
    position_tolerance: float, orientation_tolerance: float, rest_speed: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """:func:`goal_test` of ``n`` goal pairs (``a``, ``d`` float64 ``(n, 5)``, ``failed``
    ``(n,)`` bool): errors ``(n,)`` (m, rad) and successes ``(n,)``."""
    n = a.shape[0]
    pos = np.empty(n)
    ang = np.empty(n)
    success = np.empty(n, np.bool_)
    for j in range(n):
        pos[j], ang[j], success[j] = goal_test(
            a[j, 0], a[j, 1], a[j, 2], a[j, 3], a[j, 4],
            d[j, 0], d[j, 1], d[j, 2], d[j, 3], d[j, 4],
            failed[j], position_tolerance, orientation_tolerance, rest_speed,
        )  # fmt: skip
    return pos, ang, success


@njit(cache=True)
def goal_reward_value(
    w: np.ndarray, position_error: float, orientation_error: float, length: float,
    success: bool, dense: bool, goal_free: float,
) -> float:  # fmt: skip
    """The one definition of the goal reward of one goal pair: its goal-dependent part plus
    ``goal_free`` (the goal-independent part, :func:`goal_free_reward`).  Sparse: ``-1``
    unless ``success`` (``0``); dense: the reach reward's pose, precision and success terms
    (:func:`planar3p_gym.tasks.rewards.weighted_terms`, barriers and effort off: they are
    goal-free).  ``w`` is :meth:`RewardWeights.as_array`, errors in m and rad, ``length`` the
    characteristic length (m)."""
    if dense:
        t = weighted_terms(
            w, position_error, orientation_error, length, 1.0, 1.0, 0.0, 0.0, 0.0, success, False
        )
        goal = t[0] + t[1] + t[4]
    else:
        goal = (1.0 if success else 0.0) - 1.0
    return goal + goal_free


@njit(cache=True)
def goal_rewards(
    w: np.ndarray, a: np.ndarray, d: np.ndarray, failed: np.ndarray, goal_free: np.ndarray,
    length: float, dense: bool,
    position_tolerance: float, orientation_tolerance: float, rest_speed: float,
) -> np.ndarray:  # fmt: skip
    """:func:`goal_reward_value` of ``n`` goal pairs (``a``, ``d`` float64 ``(n, 5)``;
    ``failed``, ``goal_free`` ``(n,)``) after :func:`goal_test`: rewards ``(n,)``."""
    n = a.shape[0]
    out = np.empty(n)
    for j in range(n):
        pos, ang, success = goal_test(
            a[j, 0], a[j, 1], a[j, 2], a[j, 3], a[j, 4],
            d[j, 0], d[j, 1], d[j, 2], d[j, 3], d[j, 4],
            failed[j], position_tolerance, orientation_tolerance, rest_speed,
        )  # fmt: skip
        out[j] = goal_reward_value(w, pos, ang, length, success, dense, goal_free[j])
    return out


@njit(cache=True)
def write_achieved_goal(
    out: np.ndarray, x: float, y: float, theta: float,
    r0: float, r1: float, r2: float, low: np.ndarray, high: np.ndarray,
) -> None:  # fmt: skip
    """Write the achieved goal of a state, ``(x, y, cos theta, sin theta, max_i |rho_dot_i|)``
    (m, m, 1, 1, m/s; :func:`goal_of_pose`), as float32 clipped to ``[low, high]`` (the goal
    space, :func:`goal_bounds`) into ``out`` (float32 ``(5,)``)."""
    speed = max(abs(r0), abs(r1), abs(r2))
    values = (x, y, math.cos(theta), math.sin(theta), speed)
    for j in range(5):
        out[j] = min(max(np.float32(values[j]), low[j]), high[j])


def info_field(info: Any, key: str, n: int) -> np.ndarray:
    """``info[key]`` from one info dict, a sequence/array of ``n`` of them or a vector env's
    infos (a dict whose ``info[key]`` is an array of ``n``), shape ``(n,)``; 0 where an info
    dict lacks the key (SB3's HER passes empty dicts by default)."""
    if info is None:
        return np.zeros(n)
    if isinstance(info, dict) and np.ndim(info.get(key)) == 1 and len(info[key]) == n:
        try:
            return np.asarray(info[key], dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"info[{key!r}] must be numbers") from exc
    if isinstance(info, dict):
        items = [info] * n
    else:
        try:
            items = list(np.asarray(info, dtype=object).reshape(-1))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"info must be a dict or a sequence of dicts, got {info!r}") from exc
        if len(items) == 1 and n > 1:
            items = items * n
    if len(items) != n or not all(isinstance(i, dict) for i in items):
        raise ValueError(
            f"info must be None, the step's info dict or {n} of them (one per goal), got "
            f"{type(info).__name__} of {len(items)}"
        )
    try:
        return np.array([float(i.get(key, 0.0)) for i in items], dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"info[{key!r}] must be a number") from exc


@njit(cache=True)
def evaluate_state_goal(
    out: np.ndarray, x: float, y: float, theta: float, r0: float, r1: float, r2: float,
    low: np.ndarray, high: np.ndarray, desired: np.ndarray, failed: bool,
    position_tolerance: float, orientation_tolerance: float, rest_speed: float,
) -> tuple[float, float, bool]:  # fmt: skip
    """:func:`write_achieved_goal` of a state into ``out``, then :func:`goal_test` of that
    float32 goal against ``desired`` (float32 ``(5,)``): one compiled call per step."""
    write_achieved_goal(out, x, y, theta, r0, r1, r2, low, high)
    a = out.astype(np.float64)
    d = desired.astype(np.float64)
    return goal_test(
        a[0], a[1], a[2], a[3], a[4], d[0], d[1], d[2], d[3], d[4],
        failed, position_tolerance, orientation_tolerance, rest_speed,
    )  # fmt: skip


def _failed(info: Any, n: int) -> NDArray[np.bool_]:
    """``info["failure"]`` per goal pair (:func:`info_field`) as booleans."""
    return info_field(info, "failure", n) > 0.5


def goal_success(
    achieved: ArrayLike, desired: ArrayLike, info: Any, cfg: TaskConfig
) -> NDArray[np.bool_]:
    """Success per goal pair, shape ``(n,)``: within ``position_tolerance`` (m) and
    ``orientation_tolerance`` (rad), achieved speed at most desired speed plus ``rest_speed``
    (m/s), and not ``info["failure"]`` (:func:`goal_test`)."""
    a, d, _ = goal_arrays(achieved, desired)
    return goal_tests(a, d, _failed(info, a.shape[0]), *cfg.success_tolerances)[2]


def goal_reward(
    achieved: ArrayLike,
    desired: ArrayLike,
    info: Any,
    cfg: TaskConfig,
    weights: RewardWeights,
    length: float,
    reward_type: str,
) -> NDArray[np.float64]:
    """The reward per goal pair, shape ``(n,)``: its goal-dependent part plus
    ``info["goal_free_reward"]`` (:func:`goal_reward_value` after :func:`goal_test`, the
    definitions the environment's step uses).

    Sparse: ``-1`` unless successful (``0``).  Dense: ``-w_pose e - w_precision (1 -
    exp(-d / s)) + w_success [success]`` with ``d = |dp| + length |dtheta|`` (m), ``e = d /
    length`` (the reach reward's goal terms, :mod:`planar3p_gym.tasks.rewards`).
    """
    a, d, _ = goal_arrays(achieved, desired)
    n = a.shape[0]
    return goal_rewards(
        weights.as_array(),
        a,
        d,
        _failed(info, n),
        info_field(info, "goal_free_reward", n),
        float(length),
        reward_type == "dense",
        *cfg.success_tolerances,
    )


@njit(cache=True)
def goal_free_value(singularity: float, action: float, failure: float, dense: bool) -> float:
    """The one definition of the goal-independent part of the reward from the reach reward's
    weighted ``singularity``, ``action`` and ``failure`` terms: all three for the dense
    reward, the failure term alone for the sparse one."""
    if dense:
        return singularity + action + failure
    return failure


def goal_free_reward(terms: dict[str, float], reward_type: str) -> float:
    """The goal-independent part of the reward from the reach reward's weighted terms
    (:func:`goal_free_value`)."""
    return goal_free_value(
        terms["singularity"], terms["action"], terms["failure"], reward_type == "dense"
    )


#: Indices of the reward terms :func:`goal_free_value` reads, in the reach outputs' results.
_FREE_TERMS = tuple(TERMS_START + TERM_NAMES.index(k) for k in ("singularity", "action", "failure"))


@njit(cache=True)
def goal_rows(
    rows: np.ndarray, states: np.ndarray, actions: np.ndarray, res: np.ndarray,
    desired: np.ndarray, tolerances: np.ndarray, w: np.ndarray, length: float, dense: bool,
    low: np.ndarray, high: np.ndarray, achieved: np.ndarray, evaluation: np.ndarray,
    rewards: np.ndarray,
) -> None:  # fmt: skip
    """The goal task's part of a batched step, after the reach outputs of the environments
    ``rows`` (int64 ``(n,)``, of a batch of ``N``): for each stepped row ``j`` (environment
    ``i = rows[j]``), :func:`evaluate_state_goal` of its state (``states`` ``(23, n)``, theta
    wrapped) against ``desired[i]`` (float32 ``(N, 5)``) with ``tolerances[i]`` (``(N, 3)``:
    m, rad, m/s), into ``achieved[j]`` (float32 ``(n, 5)``, clipped to ``[low, high]``) and
    ``evaluation[:3, j]`` (errors (m, rad), success); where that verdict differs from the
    reach outputs' ``res`` (``(len(RESULT_FIELDS), n)``), its reason, reward terms and their
    sum are rejudged as :meth:`planar3p_gym.tasks.kernel.ReachKernel.rejudge` does (the
    weighted terms with the goal's verdict, no failure); then ``evaluation[3, j]``, the
    goal-independent reward (:func:`goal_free_value` of the terms), and ``rewards[j]``, the
    goal reward (:func:`goal_reward_value`).  ``actions`` ``(N, 3)`` are the clipped actions,
    ``w`` the reward weights, ``length`` the characteristic length (m)."""
    for j in range(rows.shape[0]):
        i = rows[j]
        crossing = res[1, j] == 2
        pos, ang, success = evaluate_state_goal(
            achieved[j], states[6, j], states[7, j], states[8, j], states[3, j], states[4, j],
            states[5, j], low, high, desired[i], crossing, tolerances[i, 0], tolerances[i, 1],
            tolerances[i, 2],
        )  # fmt: skip
        evaluation[0, j], evaluation[1, j], evaluation[2, j] = pos, ang, success
        if success != (res[1, j] == 1):
            rejudge_row(res, j, w, length, actions[i, 0], actions[i, 1], actions[i, 2], success)
        free = goal_free_value(
            res[_FREE_TERMS[0], j], res[_FREE_TERMS[1], j], res[_FREE_TERMS[2], j], dense
        )
        evaluation[3, j] = free
        rewards[j] = goal_reward_value(w, pos, ang, length, success, dense, free)


class GoalTask(ReachTask):
    """The reach task with a goal vector; success is :func:`goal_success` on the float32 goals.

    Args:
        reward_type: ``"sparse"`` or ``"dense"`` (see :func:`goal_reward`).
    """

    name: ClassVar[str] = "goal"
    hooks_family: ClassVar[str | None] = "goal"
    travel_goal: ClassVar[bool] = False
    option_keys: ClassVar[tuple[str, ...]] = (
        "start",
        "target",
        "working_mode",
        "desired_goal",
        "pair",
    )

    def __init__(self, reward_type: str = "sparse") -> None:
        self.reward_type = checks.choice(reward_type, "reward_type", REWARD_TYPES)
        self.desired = np.zeros(GOAL_SIZE, dtype=np.float32)

    def arguments(self) -> dict[str, Any]:
        return {"reward_type": self.reward_type}

    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        goal = options.pop("desired_goal", None)
        if goal is not None:
            g = self.check_goal(goal)
            pose = pose_of_goal(g)
            if options.get("target") is not None:
                t = self.finite_pose(options["target"], "target")
                if tuple(t.tolist()) != pose:
                    raise ValueError(
                        f"target {tuple(t.tolist())} disagrees with desired_goal (pose {pose}); "
                        "give one of them"
                    )
            options["target"] = pose
            options["_goal"] = g
        goal_vec = options.pop("_goal", None)
        options = super().check_options(options)
        if goal_vec is not None:
            options["_goal"] = goal_vec
        return options

    def check_goal(self, goal: Any) -> NDArray[np.float32]:
        """A requested ``desired_goal`` as the float32 goal vector, or ``ValueError``: five
        finite numbers inside the goal space (:func:`goal_bounds`: the observation stays in
        ``observation_space``), ``(cos, sin)`` within ``[0.5, 2]`` of the unit circle's
        radius and the speed >= 0.  The pose must also be reachable (checked with the
        target)."""
        g64 = checks.numbers(goal, GOAL_SIZE, "desired_goal", " (x, y, cos theta, sin theta, v)")
        with np.errstate(over="ignore"):
            g = g64.astype(np.float32)
        if not 0.5 <= float(np.hypot(g[2], g[3])) <= 2.0:
            raise ValueError(
                "desired_goal must be (x, y, cos theta, sin theta, v) with (cos, sin) near "
                f"the unit circle, got {checks.short(goal)}"
            )
        if g[4] < 0:
            raise ValueError(f"desired_goal's speed (m/s) must be >= 0, got {checks.short(goal)}")
        low, high = goal_bounds(self.env.design)
        for i, name in ((2, "cos theta"), (3, "sin theta"), (4, "speed v (m/s)")):
            if not low[i] <= g[i] <= high[i]:
                raise ValueError(
                    f"desired_goal's {name} must be in [{low[i]:g}, {high[i]:g}] (the goal "
                    f"space), got {float(g64[i])!r}"
                )
        if not ((low[:2] <= g[:2]) & (g[:2] <= high[:2])).all():
            raise ValueError(
                f"desired_goal's position {tuple(g64[:2].tolist())} is not reachable: it lies "
                f"outside the workspace's bounds x in [{low[0]:g}, {high[0]:g}], y in "
                f"[{low[1]:g}, {high[1]:g}] m"
            )
        return g

    def episode_spec(self, rng: np.random.Generator, options: dict[str, Any]) -> dict[str, Any]:
        goal = options.pop("_goal", None)
        spec = super().episode_spec(rng, options)
        if goal is not None:
            spec["desired_goal"] = [float(v) for v in goal.tolist()]
        return spec

    def begin(self, spec: dict[str, Any]) -> tuple[np.ndarray, tuple[int, int, int]]:
        start, mode = super().begin(spec)
        if spec.get("desired_goal") is not None:
            self.desired = np.asarray(spec["desired_goal"], dtype=np.float32)
        else:
            self.desired = goal_of_pose(spec["target"])
        return start, mode

    def bind(self, env: Any) -> None:
        super().bind(env)
        self._goal_low, self._goal_high = goal_bounds(env.design)
        #: The achieved goal of the last state evaluated (float32, clipped to the goal space:
        #: the ``achieved_goal`` the environment returns), overwritten by :meth:`evaluate`.
        self.achieved = np.zeros(GOAL_SIZE, dtype=np.float32)
        #: ``(position error (m), orientation error (rad), success)`` of ``achieved``
        #: against ``desired`` (:func:`goal_test`), from :meth:`evaluate`.
        self.evaluation: tuple[float, float, bool] = (0.0, 0.0, False)

    def evaluate(
        self, pose: tuple[float, float, float], rho_dot: tuple[float, float, float], failed: bool
    ) -> tuple[float, float, bool]:
        """The achieved goal of a state (pose in m, m, rad; slider rates in m/s) into
        ``achieved``, and its errors and success against the desired goal into
        ``evaluation`` (returned): once per step, the success test and the reward read
        them.  ``failed``: the step ended by a failure (no success then)."""
        x, y, th = pose
        r0, r1, r2 = rho_dot
        pt, ot, rs = self.env.task_config.success_tolerances
        self.evaluation = evaluate_state_goal(
            self.achieved, x, y, th, r0, r1, r2, self._goal_low, self._goal_high, self.desired,
            failed, pt, ot, rs,
        )  # fmt: skip
        return self.evaluation

    def is_success(self, state: Any, errors: tuple[float, float]) -> bool:
        return self.evaluate(state.pose, state.rho_dot, False)[2]

    def termination(
        self, state: Any, measures: Any, errors: tuple[float, float], assembly: int
    ) -> str | None:
        """As the reach task's, with success on the goals; evaluates the step's goals
        (:meth:`evaluate`) whatever the outcome, for the reward."""
        crossing = measures.det_sign == -assembly
        success = self.evaluate(state.pose, state.rho_dot, crossing)[2]
        if crossing:
            return "singularity_crossing"
        return "success" if success else None

    def kernel(self, settings: KernelSettings, machine: Sensing) -> StepKernel:
        """The compiled goal kernel (:class:`GoalKernel`) on the projected physics of the
        nominal machine when the per-step hooks are the goal task's own
        (:attr:`~planar3p_gym.tasks.base.Task.compiled_family`), else the reference."""
        if self.compiled_family == "goal" and settings.projection and settings.nominal:
            return GoalKernel(self, settings, machine)
        return StepKernel(self, settings, machine)

    def step_reward(self, goal_free: float) -> float:
        """The reward of the step last evaluated (:meth:`evaluate`): :func:`goal_reward_value`
        of its ``evaluation`` and the goal-independent part ``goal_free``, so exactly
        :func:`goal_reward` of the goals the environment returns."""
        env = self.env
        pos, ang, success = self.evaluation
        return goal_reward_value(
            env.reward_weights.as_array(),
            pos,
            ang,
            env.design.characteristic_length,
            success,
            self.reward_type == "dense",
            goal_free,
        )


def achieved_goal(pose: ArrayLike, rho_dot: ArrayLike) -> NDArray[np.float32]:
    """The achieved goal of a state: pose (m, m, rad) and fastest slider speed (m/s), not
    clipped (:func:`write_achieved_goal`)."""
    x, y, th = (float(v) for v in np.asarray(pose, dtype=np.float64).reshape(3))
    r0, r1, r2 = (float(v) for v in np.asarray(rho_dot, dtype=np.float64).reshape(3))
    out = np.empty(GOAL_SIZE, dtype=np.float32)
    write_achieved_goal(out, x, y, th, r0, r1, r2, _NO_BOUND[0], _NO_BOUND[1])
    return out


class GoalKernel(CompiledKernel):
    """The goal task's compiled kernel: the reach kernel's compiled outputs
    (:class:`~planar3p_gym.tasks.kernel.ReachKernel`: observation, errors, margins, reward
    terms) with the goal task's success test, on the goals (:meth:`GoalTask.evaluate`, compiled),
    in place of the reach one; the reference kernel where the physics broke down.  Its
    observations, margins and reward terms are the reach kernel's: equal to the reference's to a
    few float64 rounding errors (``tests/tasks/test_goal.py``)."""

    task: GoalTask

    def __init__(self, task: GoalTask, settings: KernelSettings, machine: Sensing) -> None:
        super().__init__(task, settings, machine)
        #: The reach task's compiled outputs (the goal task's reference pose is the reach's).
        self.reach = ReachKernel(task, settings, machine)

    def config_changed(self, tolerances: tuple[float, float, float]) -> None:
        self.reach.config_changed(tolerances)

    def compiled_step(
        self,
        ep: Episode,
        state: SimState,
        array: np.ndarray,
        action: tuple[float, float, float],
        rng: np.random.Generator,
    ) -> StepOutputs:
        obs, reward, reason, info = self.reach.compiled_step(ep, state, array, action, rng)
        # GoalTask.termination: a crossing first, else success on the goals (evaluated once).
        crossing = reason == "singularity_crossing"
        success = self.task.evaluate(state.pose, state.rho_dot, crossing)[2]
        if success == (reason == "success"):
            return obs, reward, reason, info
        reward = self.reach.rejudge(info, action, success)
        return obs, reward, info["termination_reason"], info
