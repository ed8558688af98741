"""The native vector env's step of a task in one compiled call.

Each function runs, for the stepped environments of a batch, the same definitions a single
environment runs: a step of the whole batch crosses from Python into compiled code once.

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
- :func:`assembly_batch_step` (the assembly-change task): that step, then the signed margin
  entry, the crossings, the success in the target's assembly mode and the reward terms
  without the parallel barrier (:func:`planar3p_gym.tasks.assembly_change.assembly_rows`);
- :func:`built_batch_step` (the machine as built): the delays, the servo lag, each drawn
  machine's compiled physics, the true measures, the encoders' reading through the nominal
  model, the reach outputs; :func:`built_mode_batch_step`, :func:`built_assembly_batch_step`:
  the mode and assembly changes' parts after them; :func:`built_rows`, :func:`delay_rows`: its
  halves, with the joint-space goal block computed between them.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numba import njit

from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.scalar_kinematics import configuration_measures
from planar3p_gym.sim.chipmunk import advance_batch, step_projected, step_projected_viscous
from planar3p_gym.sim.dynamics import servo_lag
from planar3p_gym.sim.physics import state_finite
from planar3p_gym.sim.sensors import READING_SIZE, read_encoders
from planar3p_gym.tasks.assembly_change import assembly_rows
from planar3p_gym.tasks.goal import goal_rows
from planar3p_gym.tasks.mode_change import mode_change_rows
from planar3p_gym.tasks.observation import (
    OBS_SIZE,
    observation_of,
    pose_errors,
    within_tolerances,
)
from planar3p_gym.tasks.reach_step import (
    RESULT_FIELDS,
    TERMS_START,
    TOLERANCES,
    reach_outputs_batch,
)
from planar3p_gym.tasks.rewards import weighted_terms
from planar3p_gym.tasks.track import RUNNING_SIZE, track_rows
from planar3p_gym.tasks.travel_shaping import travel_rows

__all__ = [
    "BuiltBatch",
    "ReachBatch",
    "assembly_batch_step",
    "built_assembly_batch_step",
    "built_batch_step",
    "built_mode_batch_step",
    "built_rows",
    "delay_rows",
    "goal_batch_step",
    "mode_batch_step",
    "reach_batch_step",
    "track_batch_step",
]

_RESULTS = len(RESULT_FIELDS)
_TOLERANCE_START = TOLERANCES.start


class ReachBatch(NamedTuple):
    """What :func:`reach_batch_step` reads and writes of a batch of ``N`` environments of the
    nominal machine, over all its environments (the vector env's arrays, updated in place):
    the one argument list of the batched steps of the reach, goal, tracking, mode-change and
    assembly-change tasks."""

    #: Chipmunk's C functions (:data:`planar3p_gym.sim.chipmunk.FUNCTIONS`) and each
    #: simulation's handles ``(N, 6)``.
    fns: np.ndarray
    handles: np.ndarray
    #: Rated slider speed (m/s): a velocity command of 1 in the action.
    vmax: float
    #: Physics step (s), substeps of a control step, a servo's force limit per physics step
    #: (N s).
    h: float
    substeps: int
    force_limit: float
    #: Each simulation's batch array ``(N, >= 60)``, the projector's constants, the largest
    #: drive setpoint lead (m).
    readouts: np.ndarray
    projection: np.ndarray
    setpoint_limit: float
    #: Each target ``(5, N)`` (``x, y, theta, cos theta, sin theta``; m, m, rad, 1, 1), each
    #: start's ``sign det A`` ``(N,)``, each environment's reach constants ``(N, >= 10)`` (its
    #: tolerances among them).
    targets: np.ndarray
    assembly: np.ndarray
    env_consts: np.ndarray
    #: The reach outputs' constants, reward weights and observation bounds
    #: (:func:`~planar3p_gym.tasks.reach_step.reach_outputs_batch`).
    reach_consts: np.ndarray
    weights: np.ndarray
    low: np.ndarray
    high: np.ndarray
    #: Drive commands (m/s) not yet in each simulation's record ``(N, capacity, 3)``, counts.
    log: np.ndarray
    logged: np.ndarray


@njit(cache=True)
def reach_batch_step(
    rows: np.ndarray, actions: np.ndarray, r: ReachBatch
) -> tuple[np.ndarray, ...]:
    """One step of the environments ``rows`` (int64) of a batch of ``N`` (the names below are
    the fields of ``r``, :class:`ReachBatch`).

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
    # The fields as locals: a read of a tuple's array field in the loop would count a
    # reference to it each time.
    (
        fns, handles, vmax, h, substeps, force_limit, readouts, projection, setpoint_limit,
        targets, assembly, env_consts, reach_consts, weights, low, high, log, logged,
    ) = r  # fmt: skip
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
    rows: np.ndarray, actions: np.ndarray, r: ReachBatch, desired: np.ndarray, goal_low: np.ndarray,
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
    commands, forces, saturated, states, closure, obs, res = reach_batch_step(rows, actions, r)
    n = rows.shape[0]
    achieved = np.empty((n, 5), dtype=np.float32)
    evaluation = np.empty((4, n))
    rewards = np.empty(n)
    goal_rows(
        rows, states, actions, res, desired,
        r.env_consts[:, _TOLERANCE_START : _TOLERANCE_START + 3], r.weights, length, dense,
        goal_low, goal_high, achieved, evaluation, rewards,
    )  # fmt: skip
    return commands, forces, saturated, states, closure, obs, res, achieved, evaluation, rewards


@njit(cache=True)
def track_batch_step(
    rows: np.ndarray, actions: np.ndarray, r: ReachBatch, samples: np.ndarray, elapsed: np.ndarray,
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
    targets = r.targets
    for k in range(n):
        i = rows[k]
        for d in range(5):
            targets[d, i] = samples[i, steps[i], d]
    commands, forces, saturated, states, closure, obs, res = reach_batch_step(rows, actions, r)
    extra = np.empty((n, 3), dtype=np.float32)
    running_out = np.empty((n, RUNNING_SIZE))
    track_rows(
        rows, steps, samples, res, actions, r.weights, r.reach_consts[6], extra_low, extra_high,
        running, extra, running_out,
    )  # fmt: skip
    return commands, forces, saturated, states, closure, obs, res, extra, running_out


@njit(cache=True)
def mode_batch_step(
    rows: np.ndarray, actions: np.ndarray, r: ReachBatch, target_modes: np.ndarray,
    parallel_barrier: bool, serial_barrier: bool, shaping: float, target_rho: np.ndarray,
) -> tuple[np.ndarray, ...]:  # fmt: skip
    """:func:`reach_batch_step`, then :func:`~planar3p_gym.tasks.mode_change.mode_change_rows`
    of its outputs (``target_modes`` ``(N, 3)`` int64: each episode's target working mode;
    the task's barriers) and, with a travel term of weight ``shaping > 0``,
    :func:`~planar3p_gym.tasks.travel_shaping.travel_rows` to ``target_rho`` ``(N, 3)`` (m);
    returns :func:`reach_batch_step`'s tuple, its results rejudged, then the travel terms
    ``(n,)`` (zeros without)."""
    out = reach_batch_step(rows, actions, r)
    mode_change_rows(
        rows, out[3], actions, out[6], target_modes, r.weights, r.reach_consts[6], parallel_barrier,
        serial_barrier,
    )  # fmt: skip
    travel = np.zeros(rows.shape[0])
    if shaping > 0.0:
        travel_rows(rows, out[3], out[6], shaping, target_rho, r.reach_consts[6], travel)
    return (*out, travel)


@njit(cache=True)
def assembly_batch_step(
    rows: np.ndarray, actions: np.ndarray, r: ReachBatch, target_assembly: np.ndarray,
    last_sign: np.ndarray, crossings: np.ndarray, serial_barrier: bool, signed_low: float,
    signed_high: float, shaping: float, target_rho: np.ndarray,
) -> tuple[np.ndarray, ...]:  # fmt: skip
    """:func:`reach_batch_step`, then :func:`~planar3p_gym.tasks.assembly_change.assembly_rows`
    of its outputs (``target_assembly``, ``last_sign``, ``crossings``: ``(N,)`` int64, each
    episode's target assembly mode and crossing count before the step; the task's serial
    barrier; the signed margin entry's bounds).

    Returns :func:`reach_batch_step`'s tuple (its results rejudged, with the travel term of
    weight ``shaping`` to ``target_rho`` as :func:`mode_batch_step` adds it), then the stepped
    environments' signed margin entries ``(n,)`` float32, their ``(last sign, crossings)``
    after the step ``(2, n)`` int64 and their travel terms ``(n,)``."""
    out = reach_batch_step(rows, actions, r)
    n = rows.shape[0]
    signed = np.empty(n, dtype=np.float32)
    counts = np.empty((2, n), dtype=np.int64)
    assembly_rows(
        rows, out[3], actions, out[6], target_assembly, last_sign, crossings,
        r.env_consts[:, _TOLERANCE_START : _TOLERANCE_START + 3], r.weights, r.reach_consts[6],
        serial_barrier, signed_low, signed_high, signed, counts,
    )  # fmt: skip
    travel = np.zeros(n)
    if shaping > 0.0:
        travel_rows(rows, out[3], out[6], shaping, target_rho, r.reach_consts[6], travel)
    return (*out, signed, counts, travel)


class BuiltBatch(NamedTuple):
    """What :func:`built_rows` reads and writes of a batch of ``N`` built machines, over all
    its environments (the vector env's arrays, updated in place): the one argument list of
    :func:`built_batch_step`, :func:`built_mode_batch_step` and
    :func:`built_assembly_batch_step` (how each is used: :func:`built_batch_step`)."""

    #: Chipmunk's C functions (:data:`planar3p_gym.sim.chipmunk.FUNCTIONS`).
    fns: np.ndarray
    #: Each simulation's Chipmunk handles ``(N, 6)`` and force requests ``(N, 2)``.
    handles: np.ndarray
    push: np.ndarray
    #: The action delay line: delays (steps) ``(N,)``, items ``(N, MAX_DELAY + 1, 3)``,
    #: counts ``(N,)``.
    action_delay: np.ndarray
    action_items: np.ndarray
    action_count: np.ndarray
    #: Rated slider speed (m/s): a velocity command of 1 in the action.
    vmax: float
    #: Servo lag factors ``(N,)`` (1: none) and the lagged commands ``(N, 3)`` (m/s).
    lag: np.ndarray
    lagged: np.ndarray
    #: Physics step (s) and substeps of a control step.
    h: float
    substeps: int
    #: Each servo's force limit per physics step ``(N,)`` (N s).
    force_limit: np.ndarray
    #: Each simulation's batch array ``(N, >= 60)`` and projector constants ``(N, C)``.
    readouts: np.ndarray
    projection: np.ndarray
    #: Largest drive setpoint lead (m).
    setpoint_limit: float
    #: Viscous forces applied ``(N, ...)`` and coefficients ``(N, 2)`` (N s/m, N m s/rad).
    applied: np.ndarray
    viscous: np.ndarray
    #: Drive commands (m/s) not yet in each simulation's record ``(N, capacity, 3)``, counts.
    log: np.ndarray
    logged: np.ndarray
    #: Closure error (m) past which the physics broke down.
    breakdown: float
    #: Each drawn machine's kinematic numbers ``(N, 10)`` and the nominal machine's (10,).
    true_kin: np.ndarray
    nominal_kin: np.ndarray
    #: Whether the pose is read through the encoders; the sensor settings; the nominal leg 1
    #: (m); time between readings (s); each env's last reading (each env's generator is an
    #: argument of its own: numba types a typed list inside a tuple slowly, in Python).
    encoders: bool
    sensing: np.ndarray
    leg_1: np.ndarray
    dt: float
    last: np.ndarray
    #: Each episode's target ``(N, 3)`` (m, m, rad), start ``sign det A`` ``(N,)`` and
    #: success tolerances ``(N, 3)`` (m, rad, m/s).
    targets: np.ndarray
    assembly: np.ndarray
    tolerances: np.ndarray
    #: Reward weights, characteristic length (m), the task's barriers and whether a crossing
    #: fails the episode.
    weights: np.ndarray
    length: float
    parallel_barrier: bool
    serial_barrier: bool
    crossing_fails: bool
    #: Observation bounds (float32) and the task's fixed extra entries ``(N, D - 31)``.
    low: np.ndarray
    high: np.ndarray
    extra: np.ndarray
    #: The observation delay line: delays ``(N,)``, items ``(N, MAX_DELAY + 1, D)``, counts.
    obs_delay: np.ndarray
    obs_items: np.ndarray
    obs_count: np.ndarray


@njit(cache=True)
def _push(items: np.ndarray, count: np.ndarray, i: int, delay: int, item: np.ndarray) -> None:
    """:meth:`planar3p_gym.envs.latency.DelayLine.push` of ``item`` onto environment ``i``'s
    line (``items[i]``: ``(delay + 1, m)``, oldest first, ``count[i]`` of them): the oldest
    dropped when the line is full; the item ``delay`` pushes old is then ``items[i, 0]``."""
    c = count[i]
    if c == delay + 1:
        for q in range(c - 1):
            items[i, q] = items[i, q + 1]
        c -= 1
    items[i, c] = item
    count[i] = c + 1


@njit(cache=True)
def built_rows(
    rows: np.ndarray, chosen: np.ndarray, b: BuiltBatch, rngs: Any
) -> tuple[np.ndarray, ...]:
    """:func:`built_batch_step` without the observation delay; returns its tuple without
    ``delayed``."""
    # The fields as locals: a read of a tuple's array field in the loop would count a
    # reference to it each time.
    (
        fns, handles, push, action_delay, action_items, action_count, vmax, lag, lagged, h,
        substeps, force_limit, readouts, projection, setpoint_limit, applied, viscous, log,
        logged, breakdown, true_kin, nominal_kin, encoders, sensing, leg_1, dt, last, targets,
        assembly, tolerances, weights, length, parallel_barrier, serial_barrier,
        crossing_fails, low, high, extra, _, _, _,
    ) = b  # fmt: skip
    n = rows.shape[0]
    width = OBS_SIZE + extra.shape[1]
    executed = np.empty((n, 3))
    impulses = np.zeros((n, 7))
    states = np.empty((n, 23))
    closure = np.empty(n)
    good = np.zeros(n, dtype=np.bool_)
    obs = np.zeros((n, width), dtype=np.float32)
    res = np.zeros((_RESULTS, n))
    legs = np.zeros((n, 3))
    noise = np.zeros(7)
    reading = np.empty(READING_SIZE)
    x = np.empty(21)
    rate = np.empty(3)
    for k in range(n):
        i = rows[k]
        _push(action_items, action_count, i, action_delay[i], chosen[i])
        for d in range(3):
            executed[k, d] = action_items[i, 0, d]
            log[i, logged[i], d] = executed[k, d] * vmax
        logged[i] += 1
        v0, v1, v2 = (
            log[i, logged[i] - 1, 0],
            log[i, logged[i] - 1, 1],
            log[i, logged[i] - 1, 2],
        )
        if lag[i] != 1.0:
            v0, v1, v2 = servo_lag(lagged[i], lag[i], v0, v1, v2)
        if viscous[i, 0] > 0.0 or viscous[i, 1] > 0.0:
            st, err = step_projected_viscous(
                fns, handles[i], push[i], v0, v1, v2, h, substeps, force_limit[i],
                readouts[i], projection[i], setpoint_limit, impulses[k], applied[i],
                viscous[i, 0], viscous[i, 1],
            )  # fmt: skip
        else:
            st, err = step_projected(
                fns, handles[i], v0, v1, v2, h, substeps, force_limit[i], readouts[i],
                projection[i], setpoint_limit, impulses[k],
            )  # fmt: skip
        states[k] = st
        closure[k] = err
        theta = wrap_angle(st[8])
        finite = state_finite(
            st[0], st[1], st[2], st[3], st[4], st[5], st[6], st[7], theta, st[9], st[10],
            st[11], st[12], st[13], st[14], err,
        )  # fmt: skip
        if not finite or err > breakdown:
            continue
        good[k] = True
        parallel, serial, sign, a1, a2, a3 = configuration_measures(
            st[6], st[7], theta, st[0], st[1], st[2], true_kin[i]
        )
        legs[k, 0], legs[k, 1], legs[k, 2] = a1, a2, a3
        for d in range(15):
            reading[d] = st[d]
        reading[8] = theta
        seen_parallel, seen_serial = parallel, serial
        if encoders:
            rng = rngs[i]
            for d in range(3):
                if sensing[0] > 0.0:
                    noise[d] = rng.normal(0.0, sensing[0])
            for d in range(3, 7):
                if sensing[2] > 0.0:
                    noise[d] = rng.normal(0.0, sensing[2])
            read_encoders(
                st[0:3], st[12:15], reading[6:9].copy(), noise, sensing, leg_1, dt, last[i],
                reading,
            )  # fmt: skip
            seen_parallel, seen_serial, _, _, _, _ = configuration_measures(
                reading[6], reading[7], reading[8], reading[0], reading[1], reading[2],
                nominal_kin,
            )  # fmt: skip
        for d in range(15):
            x[d] = reading[d]
        x[15], x[16], x[17] = targets[i, 0], targets[i, 1], targets[i, 2]
        x[18], x[19], x[20] = seen_parallel, seen_serial, length
        obs[k, :OBS_SIZE] = observation_of(x, low, high)
        obs[k, OBS_SIZE:] = extra[i]
        pos_err, ang_err = pose_errors(
            targets[i, 0], targets[i, 1], targets[i, 2], st[6], st[7], theta
        )
        reason = 0
        if sign == -assembly[i]:
            reason = 2
        else:
            rate[0], rate[1], rate[2] = st[3], st[4], st[5]
            if within_tolerances(
                pos_err, ang_err, rate, tolerances[i, 0], tolerances[i, 1], tolerances[i, 2]
            ):
                reason = 1
        terms = weighted_terms(
            weights, pos_err, ang_err, length, parallel if parallel_barrier else 1.0,
            serial if serial_barrier else 1.0, executed[k, 0], executed[k, 1], executed[k, 2],
            reason == 1, reason == 2 and crossing_fails,
        )  # fmt: skip
        total = 0.0
        for t in range(6):
            total += terms[t]
            res[TERMS_START + t, k] = terms[t]
        res[0, k], res[1, k], res[2, k], res[3, k] = total, reason, pos_err, ang_err
        res[4, k], res[5, k], res[6, k] = parallel, serial, sign
    return executed, impulses, states, closure, good, obs, res, legs


@njit(cache=True)
def built_batch_step(
    rows: np.ndarray, chosen: np.ndarray, b: BuiltBatch, rngs: Any,
) -> tuple[np.ndarray, ...]:  # fmt: skip
    """One step of the environments ``rows`` of a batch of ``N`` built machines (the reach
    task's hooks on the reference kernel), each as its single environment steps it (the names
    below are the fields of ``b``, :class:`BuiltBatch`):

    - the action delay: each row's ``chosen`` velocities (fractions of ``vmax``, m/s) pushed
      onto its line (``action_delay``, ``action_items`` ``(N, MAX_DELAY + 1, 3)``,
      ``action_count``), the executed action the oldest; its drive commands (m/s) logged
      into ``log`` ``(N, capacity, 3)`` / ``logged`` as :func:`reach_batch_step` logs them;
    - the servo lag (:func:`~planar3p_gym.sim.dynamics.servo_lag` where ``lag`` is not 1,
      ``lagged`` ``(N, 3)``) and the drawn machine's physics: its compiled control step
      (:func:`~planar3p_gym.sim.chipmunk.step_projected`, or with viscous friction
      ``viscous`` ``(N, 2)`` :func:`~planar3p_gym.sim.chipmunk.step_projected_viscous`
      through the force requests ``push`` ``(N, 2)`` over ``applied``), with its
      ``force_limit`` (N s) and ``projection`` constants (``(N, C)``);
    - where the state is finite and closed within ``breakdown`` (m): the true measures
      (:func:`~planar3p_gym.machine.scalar_kinematics.configuration_measures` of
      ``true_kin`` ``(N, 10)``), the encoders' reading (noise drawn from each row's generator
      in ``rngs`` in the single environment's order, :func:`~planar3p_gym.sim.sensors.
      read_encoders` with ``sensing``, ``leg_1``, ``dt`` and each row's ``last`` ``(N, 7)``)
      and the nominal model's measures of it (``nominal_kin``), the observation
      (:func:`~planar3p_gym.tasks.observation.observation_of`, bounds ``low``, ``high``), the
      errors to ``targets`` ``(N, 3)``, the end (a crossing of ``assembly``, or
      :func:`~planar3p_gym.tasks.observation.within_tolerances` of ``tolerances`` ``(N, 3)``),
      the reward terms (:func:`~planar3p_gym.tasks.rewards.weighted_terms`; the barriers
      and whether a crossing is a failure are the task's), the task's fixed extra entries
      ``extra`` ``(N, D - 31)`` float32 appended, and the observation delay (``obs_delay``,
      ``obs_items`` ``(N, MAX_DELAY + 1, D)``, ``obs_count``).

    Returns ``(executed (n, 3), impulses (n, 7), states (n, 23), closure (n,), good (n,),
    obs (n, D) float32, delayed (n, D) float32, res (len(RESULT_FIELDS), n), legs (n, 3))``:
    the executed actions, the servos' impulses (N s; the 7th 1.0 after a recovered step), the
    projected states (theta not wrapped) and closure errors (m), whether the physics held
    (else nothing of the row past the physics was computed and no noise drawn), the
    observations before and after the delay, :data:`~planar3p_gym.tasks.reach_step.
    RESULT_FIELDS` and the true leg angles (rad)."""
    executed, impulses, states, closure, good, obs, res, legs = built_rows(rows, chosen, b, rngs)
    delayed = delay_rows(rows, good, obs, b.obs_delay, b.obs_items, b.obs_count)
    return executed, impulses, states, closure, good, obs, delayed, res, legs


@njit(cache=True)
def delay_rows(
    rows: np.ndarray, good: np.ndarray, obs: np.ndarray, obs_delay: np.ndarray,
    obs_items: np.ndarray, obs_count: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """The observation delay of the rows whose physics held: each of ``obs`` pushed onto its
    environment's line (:func:`_push`); returns the observations the policy gets (float32,
    zeros for the other rows)."""
    delayed = np.zeros(obs.shape, dtype=np.float32)
    for k in range(rows.shape[0]):
        if good[k]:
            i = rows[k]
            _push(obs_items, obs_count, i, obs_delay[i], obs[k])
            delayed[k] = obs_items[i, 0]
    return delayed


@njit(cache=True)
def built_mode_batch_step(
    rows: np.ndarray, chosen: np.ndarray, b: BuiltBatch, rngs: Any,
    target_modes: np.ndarray, shaping: float, target_rho: np.ndarray,
) -> tuple[np.ndarray, ...]:  # fmt: skip
    """:func:`built_batch_step` of the mode-change task (its extra entries in ``extra``),
    then :func:`~planar3p_gym.tasks.mode_change.mode_change_rows` of its outputs
    (``target_modes`` ``(N, 3)`` int64: each episode's target working mode; the task's
    barriers) and the travel term of weight ``shaping`` to ``target_rho`` as
    :func:`mode_batch_step` adds it; returns :func:`built_batch_step`'s tuple, its results
    rejudged, then the travel terms ``(n,)``."""
    executed, impulses, states, closure, good, obs, res, legs = built_rows(rows, chosen, b, rngs)
    n = rows.shape[0]
    local = np.arange(n)
    modes = np.empty((n, 3), dtype=np.int64)
    for k in range(n):
        modes[k] = target_modes[rows[k]]
    by_row = np.ascontiguousarray(states.T)
    mode_change_rows(
        local, by_row, executed, res, modes, b.weights, b.length, b.parallel_barrier,
        b.serial_barrier,
    )  # fmt: skip
    travel = np.zeros(n)
    if shaping > 0.0:
        travel_rows(rows, by_row, res, shaping, target_rho, b.length, travel)
    delayed = delay_rows(rows, good, obs, b.obs_delay, b.obs_items, b.obs_count)
    return executed, impulses, states, closure, good, obs, delayed, res, legs, travel


@njit(cache=True)
def built_assembly_batch_step(
    rows: np.ndarray, chosen: np.ndarray, b: BuiltBatch, rngs: Any,
    target_assembly: np.ndarray, last_sign: np.ndarray, crossings: np.ndarray,
    signed_low: float, signed_high: float, shaping: float, target_rho: np.ndarray,
) -> tuple[np.ndarray, ...]:  # fmt: skip
    """:func:`built_batch_step` of the assembly-change task (its fixed extra entries in
    ``extra``), with :func:`~planar3p_gym.tasks.assembly_change.assembly_rows` of its outputs
    before the observation delay (``target_assembly``, ``last_sign``, ``crossings``: ``(N,)``
    int64, each episode's target assembly mode and crossing count before the step; the
    signed margin entry, the observation's last, and its bounds); returns
    :func:`built_batch_step`'s tuple (its results rejudged, with the travel term of weight
    ``shaping`` to ``target_rho`` as :func:`mode_batch_step` adds it), then the rows' ``(last
    sign, crossings)`` after the step ``(2, n)`` int64 (of the rows whose physics held) and
    their travel terms ``(n,)``."""
    executed, impulses, states, closure, good, obs, res, legs = built_rows(rows, chosen, b, rngs)
    n = rows.shape[0]
    local = np.arange(n)
    target = np.empty(n, dtype=np.int64)
    sign = np.empty(n, dtype=np.int64)
    count = np.empty(n, dtype=np.int64)
    tol = np.empty((n, 3))
    for k in range(n):
        i = rows[k]
        target[k], sign[k], count[k] = target_assembly[i], last_sign[i], crossings[i]
        tol[k] = b.tolerances[i]
    signed = np.empty(n, dtype=np.float32)
    counts = np.empty((2, n), dtype=np.int64)
    by_row = np.ascontiguousarray(states.T)
    assembly_rows(
        local, by_row, executed, res, target, sign, count, tol, b.weights, b.length,
        b.serial_barrier, signed_low, signed_high, signed, counts,
    )  # fmt: skip
    travel = np.zeros(n)
    if shaping > 0.0:
        travel_rows(rows, by_row, res, shaping, target_rho, b.length, travel)
    width = obs.shape[1]
    for k in range(n):
        obs[k, width - 1] = signed[k]
    delayed = delay_rows(rows, good, obs, b.obs_delay, b.obs_items, b.obs_count)
    return executed, impulses, states, closure, good, obs, delayed, res, legs, counts, travel
