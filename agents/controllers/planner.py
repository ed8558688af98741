"""Non-learning baselines for the mode-change task (``Planar3PModeChange-v0``).

* :class:`JointPathPlanner` plans, at the first step of an episode, the certified travel path
  of :func:`planar3p_gym.tasks.joint_paths.find_joint_path` from the observed configuration to
  the observed target (pose, travels and working mode are in the observation), follows it with
  minimum-jerk travel references (feed-forward rate plus a proportional correction of the
  travel error), and finishes with the paper's simultaneous simple motions
  (:class:`planar3p_agents.controllers.analytic.AnalyticController`) once the travels have
  arrived.  Moving in travel space is what lets a leg pass the perpendicular to its rail: the
  slider under an upright leg just moves on while the platform stays put to first order.

Calling convention: Stable-Baselines3's ``predict`` (single observations or batches); a new
episode is recognised by ``episode_start`` (as SB3's evaluation loops pass it) or by
:meth:`JointPathPlanner.reset`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from planar3p_agents.controllers.layout import extra_slice, task_observation_size
from planar3p_agents.controllers.travel_follower import TravelFollower, observed_configuration
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.joint_paths import PathLimits, find_joint_path
from planar3p_gym.tasks.motions import MIN_JERK_PEAK, minimum_jerk
from planar3p_gym.tasks.observation import SLICES

__all__ = ["JointPathPlanner"]

#: Index of the target travels and target working mode in the mode-change observation.
TARGET_TRAVELS = extra_slice("mode_change", "target_rho")
TARGET_MODE = extra_slice("mode_change", "target_working_mode")
#: Length of the mode-change observation.
MODE_CHANGE_OBS_SIZE = task_observation_size("mode_change")


class _Plan:
    """Minimum-jerk travel references along a piecewise-straight travel path."""

    def __init__(self, travels: NDArray[np.float64], peak: float) -> None:
        self.travels = travels
        steps = np.abs(np.diff(travels, axis=0)).max(axis=1)
        self.durations = np.maximum(MIN_JERK_PEAK * steps / peak, 1e-3)
        self.ends = np.cumsum(self.durations)

    @property
    def duration(self) -> float:
        return float(self.ends[-1])

    def reference(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Travels (m) and rates (m/s) of the reference at time ``t`` (s)."""
        if t >= self.ends[-1]:
            return self.travels[-1], np.zeros(3)
        k = int(np.searchsorted(self.ends, t, side="right"))
        t0 = self.ends[k] - self.durations[k]
        s, s_dot = minimum_jerk(t - t0, self.durations[k])
        a, b = self.travels[k], self.travels[k + 1]
        return a + s * (b - a), s_dot * (b - a)


class JointPathPlanner(TravelFollower):
    """Travel-space planner through the leg's upright position, then simple motions.

    Args:
        design: the machine; default ``Design.fig8()``.
        dt: control period (s) of the environment (one :meth:`predict` call per period).
        speed_fraction: peak slider rate of the references as a fraction of ``max_speed``.
        travel_gain: proportional gain on the travel error (1/s).
        limits: margins of the certified path (default those of the task).

    The plan is made from the first observation of an episode: current travels, pose and
    working mode, target pose and target working mode (entries 34-36 of the mode-change
    observation).  If no certified path exists from there, the straight travel line is used.
    """

    obs_size = MODE_CHANGE_OBS_SIZE
    obs_expected = (
        f"({MODE_CHANGE_OBS_SIZE},) or (n, {MODE_CHANGE_OBS_SIZE}) (the mode-change observation)"
    )

    def __init__(
        self,
        design: Design | None = None,
        *,
        dt: float = 0.02,
        speed_fraction: float = 0.6,
        travel_gain: float = 10.0,
        limits: PathLimits | None = None,
    ) -> None:
        super().__init__(
            design if design is not None else Design.fig8(),
            dt=dt,
            speed_fraction=speed_fraction,
            travel_gain=travel_gain,
        )
        self.limits = limits or PathLimits()

    def new_batch(self, n: int) -> None:
        """No plan yet for ``n`` environments (none certified)."""
        super().new_batch(n)
        #: Whether the last plan of each environment was certified (``find_joint_path``).
        self.certified: list[bool] = [False] * n

    def plan(self, i: int, obs: NDArray[np.float64]) -> _Plan:
        """The certified travel path from ``obs`` to its target (the straight travel line if
        none exists)."""
        cfg = observed_configuration(obs)
        target_mode = np.where(obs[TARGET_MODE] >= 0.0, 1.0, -1.0)
        path, _ = find_joint_path(
            self.design, cfg["pose"], cfg["mode"], cfg["target"], target_mode, self.limits
        )
        if path is not None:
            travels = path.travels.copy()
            travels[0] = cfg["rho"]
        else:
            travels = np.stack([cfg["rho"], obs[TARGET_TRAVELS].astype(np.float64)])
        self.certified[i] = path is not None
        return _Plan(travels, self.speed_fraction * self.design.max_speed)

    def follow(self, plan: _Plan, t: float, obs: NDArray[np.float64]) -> NDArray[np.float64] | None:
        """Reference rate one period ahead plus the travel-error correction, in ``[-1, 1]``."""
        if t >= plan.duration:
            return None
        ref, rate = plan.reference(t + self.dt)
        cmd = rate + self.travel_gain * (ref - obs[SLICES["rho"]])
        return np.clip(cmd / self.design.max_speed, -1.0, 1.0)
