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
rounding (``tests/test_reach_step.py``).

:mod:`planar3p_gym.sim.batch_step` does the same arithmetic, operation for operation, on numpy
arrays over the environments of a vector env; keep the two in step.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures, _inverse_condition
from planar3p_gym.tasks import rewards
from planar3p_gym.tasks.observation import FINE_ERROR_SCALE, wrap_angle

if TYPE_CHECKING:
    from planar3p_gym.envs.core import Planar3PEnv
    from planar3p_gym.sim.physics import SimState

__all__ = ["ReachStep", "leg_measures"]


def leg_measures(
    geometry: tuple[float, ...], k: tuple[float, float, float], legs: tuple[float, float, float],
    ref: float,
) -> tuple[float, float, int, float, float, float]:  # fmt: skip
    """``(parallel margin, serial margin, sign det A, |u_1|, |u_2|, |u_3|)`` from
    ``geometry = (u_1x, u_1y, u_2x, u_2y, u_3x, u_3y, cos theta, sin theta)`` (m, 1), the
    joint offsets ``k`` (m), leg lengths (m) and characteristic length ``ref`` (m): the
    quantities of :meth:`ScalarKinematics.measures` (same formulas)."""
    x1, y1, x2, y2, x3, y3, c, s = geometry
    k1, k2, k3 = k
    l1, l2, l3 = legs
    a, b, cc = x1 / l1, y1 / l1, k1 * (y1 * c - x1 * s) / (l1 * ref)
    d, e, f = x2 / l2, y2 / l2, k2 * (y2 * c - x2 * s) / (l2 * ref)
    g, h, i = x3 / l3, y3 / l3, k3 * (y3 * c - x3 * s) / (l3 * ref)
    det = a * (e * i - f * h) - b * (d * i - f * g) + cc * (d * h - e * g)
    n1 = math.sqrt(x1 * x1 + y1 * y1)
    n2 = math.sqrt(x2 * x2 + y2 * y2)
    n3 = math.sqrt(x3 * x3 + y3 * y3)
    serial = min(
        1.0,
        abs(x1) / n1 if n1 > 0.0 else 0.0,
        abs(x2) / n2 if n2 > 0.0 else 0.0,
        abs(x3) / n3 if n3 > 0.0 else 0.0,
    )
    parallel = _inverse_condition(((a, b, cc), (d, e, f), (g, h, i)), det)  # type: ignore[arg-type]
    return parallel, serial, int(det > 0.0) - int(det < 0.0), n1, n2, n3


class ReachStep:
    """Fused outputs of a reach step of ``env`` (module docstring); constants cached here.

    Args:
        env: a :class:`~planar3p_gym.envs.core.Planar3PEnv` with ``projection=True`` and the reach
            task.
    """

    def __init__(self, env: Planar3PEnv) -> None:
        d = env.design
        self.k = d.joint_offsets
        self.legs = d.leg_lengths
        self.ref = d.characteristic_length
        self.low, self.high = env._obs_low, env._obs_high
        self.weights = env.reward_weights
        self.tolerances = env.task_config.success_tolerances

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
        px, py, th = state.pose
        tx, ty, tth = target
        dx, dy = tx - px, ty - py
        dth = wrap_angle(tth - th)
        length = self.ref
        rho, rho_dot, twist = state.rho, state.rho_dot, state.twist
        values = [
            rho[0], rho[1], rho[2], rho_dot[0], rho_dot[1], rho_dot[2],
            px, py, c, s, twist[0], twist[1], twist[2],
            x1 / n1, y1 / n1, x2 / n2, y2 / n2, x3 / n3, y3 / n3,
            tx, ty, target_cs[0], target_cs[1], dx, dy, dth, parallel, serial,
            math.tanh(dx / FINE_ERROR_SCALE),
            math.tanh(dy / FINE_ERROR_SCALE),
            math.tanh(length * dth / FINE_ERROR_SCALE),
        ]  # fmt: skip
        pos_err = math.sqrt(dx * dx + dy * dy)
        pos_tol, ang_tol, rest = self.tolerances
        if sign == -assembly:
            reason: str | None = "singularity_crossing"
        elif (
            pos_err <= pos_tol
            and abs(dth) <= ang_tol
            and max(abs(rho_dot[0]), abs(rho_dot[1]), abs(rho_dot[2])) <= rest
        ):
            reason = "success"
        else:
            reason = None
        terms = reward_terms(self.weights, pos_err, dth, length, parallel, serial, action, reason)
        measures = ConfigurationMeasures(parallel, serial, sign, state.leg_angles)
        return values, measures, reason, terms, pos_err, dth


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
    weights ``w``, errors (m, rad), margins and the termination ``reason`` (the pose distance
    is formed once for the pose and precision terms)."""
    distance = pos_err + length * abs(ang_err)
    return rewards.reward_terms(
        w,
        pose_err=distance / length,
        precision_err=1.0 - math.exp(-distance / w.precision_scale),
        parallel_margin=parallel,
        serial_margin=serial,
        action=action,
        success=reason == "success",
        failure=reason == "singularity_crossing",
    )
