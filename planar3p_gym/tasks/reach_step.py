"""The outputs of one step of the reach task on the projected physics, fused (``Planar3P-v0``).

From the projection's state array (leg vectors and ``cos/sin theta`` at the new pose),
:func:`reach_outputs` computes in one compiled pass what the reference kernel
(:class:`planar3p_gym.tasks.kernel.StepKernel`) computes through the scalar kinematics, the
observation, the task's hooks and the reward terms, calling the one definition of each formula;
the numbers agree with the reference to float64 rounding (``tests/sim/test_batch_step.py``;
details: docs/environments.md, "How the task modules work").

* :func:`reach_outputs`, :class:`ReachStep`: one step (the reach kernel and the vector env's
  scalar batch);
* :func:`reach_outputs_batch`, :class:`BatchReach`: the same function in a compiled loop over a
  batch (the native vector env's compiled step);
* :data:`RESULT_FIELDS`, :data:`REASONS`: the layout of the result.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from planar3p_gym.machine.design import Design
from planar3p_gym.machine.margins import leg_margins
from planar3p_gym.tasks import rewards
from planar3p_gym.tasks.observation import (
    OBS_SIZE,
    clip_float32,
    within_tolerances,
    write_reach_values,
)
from planar3p_gym.tasks.rewards import TERM_NAMES, weighted_terms

__all__ = [
    "REASONS",
    "RESULT_FIELDS",
    "TERMS_START",
    "TOLERANCES",
    "BatchReach",
    "ReachStep",
    "leg_measures",
    "reach_outputs",
    "reach_outputs_batch",
    "rejudge_row",
]


def leg_measures(
    geometry: tuple[float, ...], k: tuple[float, float, float], legs: tuple[float, float, float],
    ref: float,
) -> tuple[float, float, int, float, float, float]:  # fmt: skip
    """``(parallel margin, serial margin, sign det A, |u_1|, |u_2|, |u_3|)`` from
    ``geometry = (u_1x, u_1y, u_2x, u_2y, u_3x, u_3y, cos theta, sin theta)`` (m, 1), the
    joint offsets ``k`` (m), leg lengths (m) and characteristic length ``ref`` (m):
    :func:`planar3p_gym.machine.margins.leg_margins`."""
    return leg_margins(*geometry, *k, *legs, ref)


#: ``info["termination_reason"]`` of the codes of :func:`reach_outputs` (0, 1, 2).
REASONS: tuple[str | None, ...] = (None, "success", "singularity_crossing")
#: Entries of the result array of :func:`reach_outputs`, in order (the weighted reward terms
#: last, in the order of :data:`~planar3p_gym.tasks.rewards.TERM_NAMES`).
RESULT_FIELDS = (
    "reward",
    "reason",
    "position_error",
    "orientation_error",
    "parallel_margin",
    "serial_margin",
    "assembly_mode",
    *TERM_NAMES,
)
#: Index of the first reward term in the result array.
TERMS_START = RESULT_FIELDS.index(TERM_NAMES[0])
#: Entries of the constants of :func:`reach_outputs` that are the success tolerances.
TOLERANCES = slice(7, 10)


@njit(cache=True)
def reach_outputs(
    st: np.ndarray, theta: float, target: np.ndarray, assembly: int,
    a0: float, a1: float, a2: float,
    consts: np.ndarray, w: np.ndarray, low: np.ndarray, high: np.ndarray,
    row: np.ndarray, obs: np.ndarray, res: np.ndarray,
) -> None:  # fmt: skip
    """The outputs of a reach step in one compiled pass (module docstring).

    ``st``: the state after the step, 23 float64 (SI units): ``rho``, ``rho_dot``, the pose
    ``(x, y, theta)``, the twist, the leg angles and the geometry ``(u_1x, u_1y, u_2x, u_2y,
    u_3x, u_3y, cos theta, sin theta)`` (the layout of
    :func:`planar3p_gym.sim.projection.project_readout`'s state; its ``theta`` is not read);
    ``theta``: the platform angle wrapped into ``(-pi, pi]`` (rad, as
    :class:`~planar3p_gym.sim.physics.SimState` holds it).  ``target``: ``(x, y,
    theta, cos theta, sin theta)`` of the target (m, m, rad, 1, 1); ``assembly``: the start's
    ``sign det A``; ``a0, a1, a2``: the clipped action; ``consts``: the joint offsets (m), the
    leg lengths (m), the characteristic length (m) and the success tolerances (m, rad, m/s);
    ``w``: :meth:`~planar3p_gym.tasks.rewards.RewardWeights.as_array`; ``low``, ``high``: the
    observation's float32 bounds.

    Writes the 31 observation values (float64, not clipped) into ``row``, the observation
    (float32, clipped to ``[low, high]``) into ``obs`` and :data:`RESULT_FIELDS` into ``res``
    (the reason as 0 none, 1 success, 2 singularity crossing; the reward is the terms' sum
    from 0.0 in :data:`~planar3p_gym.tasks.rewards.TERM_NAMES` order, as ``sum`` adds them).
    """
    ref = consts[6]
    x1, y1, x2, y2, x3, y3, c, s = st[15], st[16], st[17], st[18], st[19], st[20], st[21], st[22]
    parallel, serial, sign, n1, n2, n3 = leg_margins(
        x1, y1, x2, y2, x3, y3, c, s,
        consts[0], consts[1], consts[2], consts[3], consts[4], consts[5], ref,
    )  # fmt: skip
    legs_cs = np.empty(6)
    legs_cs[0], legs_cs[1], legs_cs[2] = x1 / n1, y1 / n1, x2 / n2
    legs_cs[3], legs_cs[4], legs_cs[5] = y2 / n2, x3 / n3, y3 / n3
    rho_dot = st[3:6]
    pose = np.empty(3)
    pose[0], pose[1], pose[2] = st[6], st[7], theta
    dx, dy, dth = write_reach_values(
        row, st[0:3], rho_dot, pose, c, s, st[9:12], legs_cs, target[0:3], target[3],
        target[4], parallel, serial, ref,
    )  # fmt: skip
    pos_err = math.sqrt(dx * dx + dy * dy)
    reason = 0
    if sign == -assembly:
        reason = 2
    elif within_tolerances(pos_err, dth, rho_dot, consts[7], consts[8], consts[9]):
        reason = 1
    terms = weighted_terms(
        w, pos_err, dth, ref, parallel, serial, a0, a1, a2, reason == 1, reason == 2
    )
    total = 0.0
    for t in range(6):
        total += terms[t]
        res[TERMS_START + t] = terms[t]
    res[0], res[1], res[2], res[3] = total, reason, pos_err, dth
    res[4], res[5], res[6] = parallel, serial, sign
    clip_float32(row, low, high, obs)


@njit(cache=True)
def rejudge_row(
    res: np.ndarray, j: int, w: np.ndarray, length: float, a0: float, a1: float, a2: float,
    success: bool,
) -> None:  # fmt: skip
    """Give column ``j`` of a batch's results ``res`` (``(len(RESULT_FIELDS), n)``, a step
    that did not cross a singularity) another task's success verdict ``success``: its reason
    (1 or 0), its reward terms (:func:`~planar3p_gym.tasks.rewards.weighted_terms` of its
    errors and margins, no failure) and their sum, as
    :meth:`planar3p_gym.tasks.kernel.ReachKernel.rejudge` gives a single step.  ``w``: the
    reward weights; ``length``: the characteristic length (m); ``a0, a1, a2``: the clipped
    action."""
    terms = weighted_terms(
        w, res[2, j], res[3, j], length, res[4, j], res[5, j], a0, a1, a2, success, False
    )
    total = 0.0
    for t in range(6):
        total += terms[t]
        res[TERMS_START + t, j] = terms[t]
    res[0, j] = total
    res[1, j] = 1.0 if success else 0.0


class ReachStep:
    """Fused outputs of a reach step of ``env`` (module docstring); constants and the output
    buffers of :func:`reach_outputs` kept here.

    Args:
        design: the machine (:class:`~planar3p_gym.machine.design.Design`).
        low, high: the observation's bounds (31 values).
        weights: the reward weights (:class:`~planar3p_gym.tasks.rewards.RewardWeights`).
        tolerances: position (m), orientation (rad) and rest-speed (m/s) tolerances of the
            success test (:attr:`~planar3p_gym.tasks.sampling.TaskConfig.success_tolerances`).
    """

    def __init__(
        self,
        design: Design,
        low: np.ndarray,
        high: np.ndarray,
        weights: rewards.RewardWeights,
        tolerances: tuple[float, float, float],
    ) -> None:
        self.k = design.joint_offsets
        self.legs = design.leg_lengths
        self.ref = design.characteristic_length
        self.low, self.high = low, high
        self._low32 = np.ascontiguousarray(low, dtype=np.float32)
        self._high32 = np.ascontiguousarray(high, dtype=np.float32)
        self.weights = weights
        self._consts = np.zeros(10)
        self._consts[:7] = (*self.k, *self.legs, self.ref)
        self.tolerances = tolerances
        self._target = np.zeros(5)
        #: The last :meth:`compute`'s observation values (float64, not clipped), observation
        #: (float32, clipped) and results (:data:`RESULT_FIELDS`); overwritten by each call.
        self.row = np.zeros(OBS_SIZE)
        self.obs = np.zeros(OBS_SIZE, dtype=np.float32)
        self.res = np.zeros(len(RESULT_FIELDS))

    @property
    def tolerances(self) -> tuple[float, float, float]:
        """Position (m), orientation (rad) and rest-speed (m/s) tolerances of the success
        test."""
        return self._tolerances

    @tolerances.setter
    def tolerances(self, value: tuple[float, float, float]) -> None:
        self._tolerances = (float(value[0]), float(value[1]), float(value[2]))
        self._consts[TOLERANCES] = self._tolerances

    def share_constants(self, row: np.ndarray) -> None:
        """Keep the constants of :func:`reach_outputs` in ``row`` (a float64 view of 10
        numbers, e.g. a row of a vector env's array of every environment's constants), so
        that a change of :attr:`tolerances` shows there."""
        row[:] = self._consts
        self._consts = row

    def compute(
        self,
        st: np.ndarray,
        theta: float,
        target: tuple[float, float, float],
        target_cs: tuple[float, float],
        assembly: int,
        action: tuple[float, float, float],
    ) -> np.ndarray:
        """:func:`reach_outputs` of the state array ``st`` (its layout there) and the wrapped
        platform angle ``theta`` (rad) into :attr:`row`, :attr:`obs` and :attr:`res`
        (returned)."""
        t = self._target
        t[0], t[1], t[2] = target
        t[3], t[4] = target_cs
        reach_outputs(
            st, theta, t, assembly, action[0], action[1], action[2], self._consts,
            self.weights.as_array(), self._low32, self._high32, self.row, self.obs, self.res,
        )  # fmt: skip
        return self.res


@njit(cache=True)
def reach_outputs_batch(
    states: np.ndarray, target: np.ndarray, assembly: np.ndarray, action: np.ndarray,
    tolerances: np.ndarray, consts: np.ndarray, w: np.ndarray, low: np.ndarray,
    high: np.ndarray, rows: np.ndarray, obs: np.ndarray, res: np.ndarray,
) -> None:  # fmt: skip
    """:func:`reach_outputs` of ``N`` environments, in one compiled loop: ``states``
    ``(23, N)`` (:func:`~planar3p_gym.sim.chipmunk.advance_batch`'s, theta wrapped),
    ``target`` ``(5, N)``, ``assembly`` ``(N,)``, ``action`` ``(3, N)``, ``tolerances``
    ``(3, N)`` (each environment's; they replace those of ``consts``); writes ``rows``
    ``(N, 31)``, ``obs`` ``(N, 31)`` float32 and ``res`` ``(len(RESULT_FIELDS), N)``."""
    n = states.shape[1]
    st = np.empty(states.shape[0])
    tg = np.empty(target.shape[0])
    cs = consts.copy()
    r = np.empty(res.shape[0])
    for j in range(n):
        for k in range(st.shape[0]):
            st[k] = states[k, j]
        for k in range(tg.shape[0]):
            tg[k] = target[k, j]
        cs[7], cs[8], cs[9] = tolerances[0, j], tolerances[1, j], tolerances[2, j]  # TOLERANCES
        reach_outputs(
            st, st[8], tg, assembly[j], action[0, j], action[1, j], action[2, j], cs, w, low,
            high, rows[j], obs[j], r,
        )  # fmt: skip
        for k in range(r.shape[0]):
            res[k, j] = r[k]


class BatchReach:
    """:meth:`planar3p_gym.tasks.reach_step.ReachStep.compute` over a batch
    (:func:`reach_outputs_batch`: the same compiled outputs in a loop).

    Args:
        reach: the :class:`~planar3p_gym.tasks.reach_step.ReachStep` of one of the (identically
            configured) environments.
    """

    def __init__(self, reach: ReachStep) -> None:
        self.low = reach._low32
        self.high = reach._high32
        self.weights = reach.weights
        self.consts = reach._consts.copy()

    @staticmethod
    def results(obs: np.ndarray, res: np.ndarray) -> dict[str, Any]:
        """The batch's outputs from :func:`reach_outputs_batch`'s ``obs`` and ``res``:
        observations ``(N, 31)`` float32, margins, sign, termination (``reason``: 0 none,
        1 success, 2 singularity crossing), reward terms, their sum (``reward``) and the
        position (m) and orientation (rad) errors, one entry per environment."""
        return {
            "obs": obs,
            "reward": res[0],
            "parallel": res[4],
            "serial": res[5],
            "sign": res[6].astype(np.int64),
            "reason": res[1].astype(np.int64),
            "terms": dict(zip(TERM_NAMES, res[TERMS_START:], strict=True)),
            "position_error": res[2],
            "orientation_error": res[3],
        }
