"""The native vector env's step of a task in one compiled call.

Each function runs, for the stepped environments of a batch, the same definitions a single
environment runs, so that a step of the whole batch crosses from Python into compiled code
once:

- :func:`reach_batch_step` (the reach task): the compiled control step
  (:func:`planar3p_gym.sim.chipmunk.advance_batch`: pymunk's step through Chipmunk's C API and
  the projection), then the reach step's outputs
  (:func:`planar3p_gym.tasks.reach_step.reach_outputs_batch`);
- :func:`goal_batch_step` (the goal task): that step, then the goal test, the rejudged reward
  terms and the goal reward over the rows (:func:`planar3p_gym.tasks.goal.goal_rows`);
- :func:`track_batch_step` (the tracking task): each row's reference pose of the step from its
  episode's samples, that step, then the reference velocity entries, the rejudged terms and
  the running tracking errors (:func:`planar3p_gym.tasks.track.track_rows`);
- :func:`mode_batch_step` (the mode-change task): that step, then the success test in the
  target's working mode and the reward terms with the task's barriers
  (:func:`planar3p_gym.tasks.mode_change.mode_change_rows`);
- :func:`assembly_batch_step` (the assembly-change task): that step, then the signed parallel
  margin entry, the crossings counted, the success test in the target's assembly mode and the
  reward terms without the parallel barrier
  (:func:`planar3p_gym.tasks.assembly_change.assembly_rows`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from planar3p_gym.sim.chipmunk import advance_batch
from planar3p_gym.tasks.assembly_change import assembly_rows
from planar3p_gym.tasks.goal import goal_rows
from planar3p_gym.tasks.mode_change import mode_change_rows
from planar3p_gym.tasks.observation import OBS_SIZE
from planar3p_gym.tasks.reach_step import RESULT_FIELDS, TOLERANCES, reach_outputs_batch
from planar3p_gym.tasks.track import RUNNING_SIZE, track_rows

__all__ = [
    "assembly_batch_step",
    "goal_batch_step",
    "mode_batch_step",
    "reach_batch_step",
    "track_batch_step",
]

_RESULTS = len(RESULT_FIELDS)
_TOLERANCE_START = TOLERANCES.start


@njit(cache=True)
def reach_batch_step(
    fns: np.ndarray, handles: np.ndarray, rows: np.ndarray, actions: np.ndarray, vmax: float,
    h: float, substeps: int, force_limit: float, readouts: np.ndarray, projection: np.ndarray,
    setpoint_limit: float, targets: np.ndarray, assembly: np.ndarray, env_consts: np.ndarray,
    reach_consts: np.ndarray, weights: np.ndarray, low: np.ndarray, high: np.ndarray,
    log: np.ndarray, logged: np.ndarray,
) -> tuple[np.ndarray, ...]:  # fmt: skip
    """One step of the environments ``rows`` (int64) of a batch of ``N``.

    ``actions``: ``(N, 3)`` clipped actions (the drive commands are ``vmax`` m/s times them);
    ``handles``, ``readouts``, ``h`` (s), ``substeps``, ``force_limit`` (N s),
    ``projection`` (the projector's constants) and ``setpoint_limit`` (m): as
    :func:`~planar3p_gym.sim.chipmunk.advance_batch` takes them, over all ``N``;
    ``targets`` ``(5, N)`` (``x, y, theta, cos theta, sin theta`` of each target),
    ``assembly`` ``(N,)``, ``env_consts`` ``(N, >= 10)`` (each environment's reach constants,
    its tolerances among them), then the reach outputs' constants, reward weights and
    observation bounds as :func:`~planar3p_gym.tasks.reach_step.reach_outputs_batch` takes them;
    ``log`` ``(N, capacity, 3)`` and ``logged`` ``(N,)``: each environment's drive commands
    (m/s) not yet in its simulation's record, appended here (the caller keeps
    ``logged < capacity``).

    Returns ``(commands, forces, saturated, states, closure, obs, res)`` over the stepped
    environments: the drive commands (m/s), then
    :func:`~planar3p_gym.sim.chipmunk.advance_batch`'s outputs, then the observations
    (float32) and :data:`~planar3p_gym.tasks.reach_step.RESULT_FIELDS` (one column each).
    """
    n = rows.shape[0]
    commands = np.empty((n, 3))
    act = np.empty((3, n))
    target = np.empty((5, n))
    asm = np.empty(n, dtype=np.int64)
    tolerances = np.empty((3, n))
    for k in range(n):
        i = rows[k]
        for d in range(3):
            commands[k, d] = actions[i, d] * vmax
            log[i, logged[i], d] = commands[k, d]
            act[d, k] = actions[i, d]
            tolerances[d, k] = env_consts[i, _TOLERANCE_START + d]
        logged[i] += 1
        for d in range(5):
            target[d, k] = targets[d, i]
        asm[k] = assembly[i]
    forces, saturated, states, closure = advance_batch(
        fns, handles, rows, commands, h, substeps, force_limit, readouts, projection,
        setpoint_limit,
    )  # fmt: skip
    obs_rows = np.empty((n, OBS_SIZE))
    obs = np.empty((n, OBS_SIZE), dtype=np.float32)
    res = np.empty((_RESULTS, n))
    reach_outputs_batch(
        states, target, asm, act, tolerances, reach_consts, weights, low, high, obs_rows, obs, res
    )
    return commands, forces, saturated, states, closure, obs, res


@njit(cache=True)
def goal_batch_step(
    fns: np.ndarray, handles: np.ndarray, rows: np.ndarray, actions: np.ndarray, vmax: float,
    h: float, substeps: int, force_limit: float, readouts: np.ndarray, projection: np.ndarray,
    setpoint_limit: float, targets: np.ndarray, assembly: np.ndarray, env_consts: np.ndarray,
    reach_consts: np.ndarray, weights: np.ndarray, low: np.ndarray, high: np.ndarray,
    log: np.ndarray, logged: np.ndarray, desired: np.ndarray, goal_low: np.ndarray,
    goal_high: np.ndarray, length: float, dense: bool,
) -> tuple[np.ndarray, ...]:  # fmt: skip
    """:func:`reach_batch_step`, then :func:`~planar3p_gym.tasks.goal.goal_rows` of its outputs:
    ``desired`` ``(N, 5)`` float32 (each environment's desired goal), ``goal_low``,
    ``goal_high`` (the goal space's bounds), ``length`` (the characteristic length, m),
    ``dense`` (the reward type).

    Returns :func:`reach_batch_step`'s tuple (its results rejudged by the goal test), then the
    stepped environments' achieved goals ``(n, 5)`` float32, their evaluations ``(4, n)``
    (position error (m), orientation error (rad), success, goal-independent reward) and their
    goal rewards ``(n,)``."""
    commands, forces, saturated, states, closure, obs, res = reach_batch_step(
        fns, handles, rows, actions, vmax, h, substeps, force_limit, readouts, projection,
        setpoint_limit, targets, assembly, env_consts, reach_consts, weights, low, high, log,
        logged,
    )  # fmt: skip
    n = rows.shape[0]
    achieved = np.empty((n, 5), dtype=np.float32)
    evaluation = np.empty((4, n))
    rewards = np.empty(n)
    goal_rows(
        rows, states, actions, res, desired, env_consts[:, _TOLERANCE_START : _TOLERANCE_START + 3],
        weights, length, dense, goal_low, goal_high, achieved, evaluation, rewards,
    )  # fmt: skip
    return commands, forces, saturated, states, closure, obs, res, achieved, evaluation, rewards


@njit(cache=True)
def track_batch_step(
    fns: np.ndarray, handles: np.ndarray, rows: np.ndarray, actions: np.ndarray, vmax: float,
    h: float, substeps: int, force_limit: float, readouts: np.ndarray, projection: np.ndarray,
    setpoint_limit: float, targets: np.ndarray, assembly: np.ndarray, env_consts: np.ndarray,
    reach_consts: np.ndarray, weights: np.ndarray, low: np.ndarray, high: np.ndarray,
    log: np.ndarray, logged: np.ndarray, samples: np.ndarray, elapsed: np.ndarray,
    running: np.ndarray, extra_low: np.ndarray, extra_high: np.ndarray,
) -> tuple[np.ndarray, ...]:  # fmt: skip
    """:func:`reach_batch_step` against each stepped environment's reference pose at its new
    step ``elapsed[i] + 1`` (``samples`` ``(N, H, 8)``, each episode's
    ``TrackTask.samples`` (:mod:`planar3p_gym.tasks.track`); written into ``targets``), then
    :func:`~planar3p_gym.tasks.track.track_rows` of its outputs (``running`` ``(N, 7)``: each
    environment's running errors before the step; ``extra_low``, ``extra_high``: the
    reference velocity entries' bounds).

    Returns :func:`reach_batch_step`'s tuple (its results rejudged), then the stepped
    environments' reference velocity entries ``(n, 3)`` float32 and running errors after the
    step ``(n, 7)``."""
    n = rows.shape[0]
    steps = elapsed + 1
    for k in range(n):
        i = rows[k]
        for d in range(5):
            targets[d, i] = samples[i, steps[i], d]
    commands, forces, saturated, states, closure, obs, res = reach_batch_step(
        fns, handles, rows, actions, vmax, h, substeps, force_limit, readouts, projection,
        setpoint_limit, targets, assembly, env_consts, reach_consts, weights, low, high, log,
        logged,
    )  # fmt: skip
    extra = np.empty((n, 3), dtype=np.float32)
    running_out = np.empty((n, RUNNING_SIZE))
    track_rows(
        rows, steps, samples, res, actions, weights, reach_consts[6], extra_low, extra_high,
        running, extra, running_out,
    )  # fmt: skip
    return commands, forces, saturated, states, closure, obs, res, extra, running_out


@njit(cache=True)
def mode_batch_step(
    fns: np.ndarray, handles: np.ndarray, rows: np.ndarray, actions: np.ndarray, vmax: float,
    h: float, substeps: int, force_limit: float, readouts: np.ndarray, projection: np.ndarray,
    setpoint_limit: float, targets: np.ndarray, assembly: np.ndarray, env_consts: np.ndarray,
    reach_consts: np.ndarray, weights: np.ndarray, low: np.ndarray, high: np.ndarray,
    log: np.ndarray, logged: np.ndarray, target_modes: np.ndarray, parallel_barrier: bool,
    serial_barrier: bool,
) -> tuple[np.ndarray, ...]:  # fmt: skip
    """:func:`reach_batch_step`, then :func:`~planar3p_gym.tasks.mode_change.mode_change_rows`
    of its outputs (``target_modes`` ``(N, 3)`` int64: each episode's target working mode;
    the task's barriers); returns :func:`reach_batch_step`'s tuple, its results rejudged."""
    out = reach_batch_step(
        fns, handles, rows, actions, vmax, h, substeps, force_limit, readouts, projection,
        setpoint_limit, targets, assembly, env_consts, reach_consts, weights, low, high, log,
        logged,
    )  # fmt: skip
    mode_change_rows(
        rows, out[3], actions, out[6], target_modes, weights, reach_consts[6], parallel_barrier,
        serial_barrier,
    )  # fmt: skip
    return out


@njit(cache=True)
def assembly_batch_step(
    fns: np.ndarray, handles: np.ndarray, rows: np.ndarray, actions: np.ndarray, vmax: float,
    h: float, substeps: int, force_limit: float, readouts: np.ndarray, projection: np.ndarray,
    setpoint_limit: float, targets: np.ndarray, assembly: np.ndarray, env_consts: np.ndarray,
    reach_consts: np.ndarray, weights: np.ndarray, low: np.ndarray, high: np.ndarray,
    log: np.ndarray, logged: np.ndarray, target_assembly: np.ndarray, last_sign: np.ndarray,
    crossings: np.ndarray, serial_barrier: bool, signed_low: float, signed_high: float,
) -> tuple[np.ndarray, ...]:  # fmt: skip
    """:func:`reach_batch_step`, then :func:`~planar3p_gym.tasks.assembly_change.assembly_rows`
    of its outputs (``target_assembly``, ``last_sign``, ``crossings``: ``(N,)`` int64, each
    episode's target assembly mode and crossing count before the step; the task's serial
    barrier; the signed margin entry's bounds).

    Returns :func:`reach_batch_step`'s tuple (its results rejudged), then the stepped
    environments' signed margin entries ``(n,)`` float32 and their ``(last sign, crossings)``
    after the step ``(2, n)`` int64."""
    out = reach_batch_step(
        fns, handles, rows, actions, vmax, h, substeps, force_limit, readouts, projection,
        setpoint_limit, targets, assembly, env_consts, reach_consts, weights, low, high, log,
        logged,
    )  # fmt: skip
    n = rows.shape[0]
    signed = np.empty(n, dtype=np.float32)
    counts = np.empty((2, n), dtype=np.int64)
    assembly_rows(
        rows, out[3], actions, out[6], target_assembly, last_sign, crossings,
        env_consts[:, _TOLERANCE_START : _TOLERANCE_START + 3], weights, reach_consts[6],
        serial_barrier, signed_low, signed_high, signed, counts,
    )  # fmt: skip
    return (*out, signed, counts)
