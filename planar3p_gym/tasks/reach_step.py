"""The outputs of one step of the reach task on the projected physics, fused (``Planar3P-v0``).

After :class:`planar3p_gym.sim.physics.Planar3PSim` has projected the state onto the constraint
manifold it knows the leg vectors ``u_i = C_i - B_i`` (m) and ``cos/sin theta`` at the new pose
(``sim.geometry``).  :class:`ReachStep` computes from them, in one pass of plain-float
arithmetic, what the general step of :class:`planar3p_gym.envs.core.Planar3PEnv` computes through
:class:`~planar3p_gym.machine.scalar_kinematics.ScalarKinematics`,
:func:`~planar3p_gym.tasks.observation.build_observation`, the task's hooks and
:func:`~planar3p_gym.tasks.rewards.reward_terms`: the configuration measures, the observation, the
errors to the target, the termination and the reward terms.  The formulas are those; only
intermediate values are shared (``cos alpha_i = u_ix / |u_i|`` instead of ``cos(atan2(...))``,
``|dp|`` as ``sqrt(dx^2 + dy^2)``), so the numbers agree with the general step to float64
rounding (``tests/sim/test_batch_step.py``).

:mod:`planar3p_gym.sim.batch_step` does the same arithmetic, operation for operation, on numpy
arrays over the environments of a vector env; keep the two in step.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numba import njit

from planar3p_gym.machine.design import Design
from planar3p_gym.machine.margins import leg_margins, leg_margins_batch
from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures
from planar3p_gym.tasks import rewards
from planar3p_gym.tasks.observation import OBS_SIZE, within_tolerances, write_reach_values
from planar3p_gym.tasks.rewards import TERM_NAMES, weighted_terms_batch

if TYPE_CHECKING:
    from planar3p_gym.sim.batch_step import BatchState
    from planar3p_gym.sim.physics import SimState

__all__ = ["BatchReach", "ReachStep", "leg_measures"]


def leg_measures(
    geometry: tuple[float, ...], k: tuple[float, float, float], legs: tuple[float, float, float],
    ref: float,
) -> tuple[float, float, int, float, float, float]:  # fmt: skip
    """``(parallel margin, serial margin, sign det A, |u_1|, |u_2|, |u_3|)`` from
    ``geometry = (u_1x, u_1y, u_2x, u_2y, u_3x, u_3y, cos theta, sin theta)`` (m, 1), the
    joint offsets ``k`` (m), leg lengths (m) and characteristic length ``ref`` (m):
    :func:`planar3p_gym.machine.margins.leg_margins`."""
    return leg_margins(*geometry, *k, *legs, ref)


class ReachStep:
    """Fused outputs of a reach step of ``env`` (module docstring); constants cached here.

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
        self.weights = weights
        self.tolerances = tolerances

    def outputs(
        self,
        state: SimState,
        geometry: tuple[float, ...],
        target: tuple[float, float, float],
        target_cs: tuple[float, float],
        assembly: int,
        action: tuple[float, float, float],
    ) -> tuple[np.ndarray, ConfigurationMeasures, str | None, dict[str, float], float, float]:
        """``(observation, measures, termination reason, reward terms, position error (m),
        orientation error (rad))`` of a finite state after a step with ``action``."""
        out = self.values(state, geometry, target, target_cs, assembly, action)
        obs = np.array(out[0], dtype=np.float32)
        np.minimum(obs, self.high, out=obs)
        np.maximum(obs, self.low, out=obs)
        return obs, *out[1:]  # type: ignore[return-value]

    def values(
        self,
        state: SimState,
        geometry: tuple[float, ...],
        target: tuple[float, float, float],
        target_cs: tuple[float, float],
        assembly: int,
        action: tuple[float, float, float],
    ) -> tuple[list[float], ConfigurationMeasures, str | None, dict[str, float], float, float]:
        """:meth:`outputs` with the observation as its 31 float64 values, not yet converted
        to float32 and clipped to the bounds (what a vector env does over the batch)."""
        parallel, serial, sign, n1, n2, n3 = leg_measures(geometry, self.k, self.legs, self.ref)
        x1, y1, x2, y2, x3, y3, c, s = geometry
        values = np.empty(OBS_SIZE)
        rho_dot = np.array(state.rho_dot)
        dx, dy, dth = write_reach_values(
            values, np.array(state.rho), rho_dot, np.array(state.pose), c, s,
            np.array(state.twist), np.array((x1 / n1, y1 / n1, x2 / n2, y2 / n2, x3 / n3, y3 / n3)),
            np.array(target), target_cs[0], target_cs[1], parallel, serial, self.ref,
        )  # fmt: skip
        length = self.ref
        pos_err = math.sqrt(dx * dx + dy * dy)
        if sign == -assembly:
            reason: str | None = "singularity_crossing"
        elif within_tolerances(pos_err, dth, rho_dot, *self.tolerances):
            reason = "success"
        else:
            reason = None
        terms = reward_terms(self.weights, pos_err, dth, length, parallel, serial, action, reason)
        measures = ConfigurationMeasures(parallel, serial, sign, state.leg_angles)
        return values.tolist(), measures, reason, terms, pos_err, dth


def reward_terms(
    w: Any,
    pos_err: float,
    ang_err: float,
    length: float,
    parallel: float,
    serial: float,
    action: tuple[float, float, float],
    reason: str | None,
) -> dict[str, float]:
    """:func:`planar3p_gym.tasks.rewards.reward_terms` of the reach task (both barriers on) for
    weights ``w``, errors (m, rad), margins and the termination ``reason``."""
    return rewards.reward_terms(
        w,
        position_error=pos_err,
        orientation_error=ang_err,
        length=length,
        parallel_margin=parallel,
        serial_margin=serial,
        action=action,
        success=reason == "success",
        failure=reason == "singularity_crossing",
    )


@njit(cache=True)
def reach_values_batch(
    rho: np.ndarray, rho_dot: np.ndarray, pose: np.ndarray, c: np.ndarray, s: np.ndarray,
    twist: np.ndarray, legs_cs: np.ndarray, target: np.ndarray, target_cs: np.ndarray,
    parallel: np.ndarray, serial: np.ndarray, length: float, tolerances: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """:func:`~planar3p_gym.tasks.observation.write_reach_values` and
    :func:`~planar3p_gym.tasks.observation.within_tolerances` of ``N`` environments (arrays
    ``(k, N)`` of the single env's values): the observation values ``(N, 31)``, the position
    and orientation errors ``(2, N)`` (m, rad) and the success tests ``(N,)`` (before the
    crossing test)."""
    n = c.shape[0]
    rows = np.empty((n, OBS_SIZE))
    errors = np.empty((2, n))
    success = np.empty(n, np.bool_)
    for j in range(n):
        dx, dy, dth = write_reach_values(
            rows[j], rho[:, j], rho_dot[:, j], pose[:, j], c[j], s[j], twist[:, j],
            legs_cs[:, j], target[:, j], target_cs[0, j], target_cs[1, j],
            parallel[j], serial[j], length,
        )  # fmt: skip
        pos_err = math.sqrt(dx * dx + dy * dy)
        errors[0, j], errors[1, j] = pos_err, dth
        success[j] = within_tolerances(
            pos_err, dth, rho_dot[:, j], tolerances[0, j], tolerances[1, j], tolerances[2, j]
        )
    return rows, errors, success


class BatchReach:
    """:meth:`planar3p_gym.tasks.reach_step.ReachStep.outputs` over a batch.

    Args:
        reach: the :class:`~planar3p_gym.tasks.reach_step.ReachStep` of one of the (identically
            configured) environments.
    """

    def __init__(self, reach: Any) -> None:
        self.k = np.array(reach.k).reshape(3, 1)
        self.legs = np.array(reach.legs).reshape(3, 1)
        self.ref = reach.ref
        self.low = reach.low.astype(np.float32)
        self.high = reach.high.astype(np.float32)
        self.weights = reach.weights

    def measures(self, st: BatchState) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(parallel margin, serial margin, sign det A, |u_i|)`` as in
        :func:`planar3p_gym.tasks.reach_step.leg_measures`."""
        return leg_margins_batch(
            np.ascontiguousarray(st.ux),
            np.ascontiguousarray(st.uy),
            np.ascontiguousarray(st.c),
            np.ascontiguousarray(st.s),
            self.k[:, 0],
            self.legs[:, 0],
            self.ref,
        )

    def outputs(
        self,
        st: BatchState,
        target: np.ndarray,
        target_cs: np.ndarray,
        assembly: np.ndarray,
        action: np.ndarray,
        tolerances: np.ndarray,
    ) -> dict[str, np.ndarray]:
        """Observations ``(N, 31)`` float32, margins, sign, termination (``reason``: 0 none,
        1 success, 2 singularity crossing), reward terms and errors of finite states;
        ``target`` ``(3, N)``, ``target_cs`` ``(2, N)``, ``assembly`` ``(N,)``, ``action``
        ``(3, N)`` clipped, ``tolerances`` ``(3, N)``: each environment's position (m),
        orientation (rad) and rest-speed (m/s) tolerances (``ReachStep.tolerances``)."""
        parallel, serial, sign, norm = self.measures(st)
        n = st.c.shape[0]
        legs_cs = np.empty((6, n))
        legs_cs[0::2] = st.ux / norm
        legs_cs[1::2] = st.uy / norm
        rows, errors, success = reach_values_batch(
            np.ascontiguousarray(st.rho),
            np.ascontiguousarray(st.rho_dot),
            np.ascontiguousarray(st.pose),
            np.ascontiguousarray(st.c),
            np.ascontiguousarray(st.s),
            np.ascontiguousarray(st.twist),
            legs_cs,
            np.ascontiguousarray(target, dtype=np.float64),
            np.ascontiguousarray(target_cs, dtype=np.float64),
            parallel,
            serial,
            self.ref,
            np.ascontiguousarray(tolerances, dtype=np.float64),
        )
        length = self.ref
        obs = rows.astype(np.float32)
        np.minimum(obs, self.high, out=obs)
        np.maximum(obs, self.low, out=obs)
        pos_err, dth = errors
        crossing = sign == -assembly
        success &= ~crossing
        terms_array = weighted_terms_batch(
            self.weights.as_array(),
            np.ascontiguousarray(pos_err),
            np.ascontiguousarray(dth),
            length,
            np.ascontiguousarray(parallel),
            np.ascontiguousarray(serial),
            np.ascontiguousarray(action, dtype=np.float64),
            np.ascontiguousarray(success),
            np.ascontiguousarray(crossing),
        )
        terms = dict(zip(TERM_NAMES, terms_array, strict=True))
        return {
            "obs": obs,
            "parallel": parallel,
            "serial": serial,
            "sign": sign,
            "reason": success.astype(np.int64) + 2 * crossing,
            "terms": terms,
            "position_error": pos_err,
            "orientation_error": dth,
        }
