"""A non-learning demonstration of crossing a parallel singularity (``Planar3PAssemblyChange-v0``).

:class:`CrossingController` takes, at the first step of an episode, the straight path in pose
space from the observed pose to the observed target (which lies in the other assembly mode, so
the path crosses ``det A = 0``), turns it into slider travels with the exact inverse kinematics
of the working mode (smooth and finite through the parallel singularity: only ``A`` loses rank
there, not ``B``), and follows those travels with a minimum-jerk time law at up to the full
slider speed (feed-forward rates plus a proportional correction of the travel error):
:func:`planar3p_gym.tasks.travel_motion.demonstration_travels` and
:class:`~planar3p_gym.tasks.travel_motion.TravelCurve`, the motion the task's sampler
verifies in simulation.  Near the singularity the servos saturate and the platform passes the
singular pose on its momentum, onto the other branch of the direct kinematics, which the
travel references then lead to the target.  Once the references have arrived, the paper's
simultaneous simple motions
(:class:`planar3p_agents.controllers.analytic.AnalyticController`) remove the remaining error.

Calling convention: Stable-Baselines3's ``predict``; a new episode is recognised by
``episode_start`` (or :meth:`CrossingController.reset`).  The crossing-fidelity study that
measures the physics along such a crossing is
:mod:`planar3p_agents.evaluation.crossing_fidelity`.
"""

from __future__ import annotations

from typing import Any, Self

import numpy as np
from numpy.typing import NDArray

from planar3p_agents.controllers.travel_follower import TravelFollower, observed_configuration
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.observation import SLICES
from planar3p_gym.tasks.travel_motion import TravelCurve, demonstration_travels

__all__ = ["CrossingController"]


class CrossingController(TravelFollower):
    """Travel-space motion through the parallel singularity, then simple motions.

    Args:
        design: the machine; default ``Design.fig8(gravity=0.0)`` (the task's default).
        dt: control period (s) of the environment.
        speed_fraction: peak slider rate of the references as a fraction of ``max_speed``.
        travel_gain: proportional gain on the travel error (1/s).
    """

    def __init__(
        self,
        design: Design | None = None,
        *,
        dt: float = 0.02,
        speed_fraction: float = 1.0,
        travel_gain: float = 10.0,
    ) -> None:
        super().__init__(
            design if design is not None else Design.fig8(gravity=0.0),
            dt=dt,
            speed_fraction=speed_fraction,
            travel_gain=travel_gain,
        )

    @classmethod
    def from_env(cls, env: Any, **kwargs: Any) -> Self:
        """A controller for the design and control period of ``env`` (possibly wrapped); the
        speed and gain default to those the environment's task verifies with."""
        limits = getattr(env.unwrapped.task, "limits", None)
        if limits is not None and hasattr(limits, "travel_gain"):
            kwargs.setdefault("speed_fraction", limits.speed_fraction)
            kwargs.setdefault("travel_gain", limits.travel_gain)
        return super().from_env(env, **kwargs)

    def plan(self, i: int, obs: NDArray[np.float64]) -> TravelCurve:
        """The demonstration's travel curve from ``obs`` to its target."""
        cfg = observed_configuration(obs)
        travels = demonstration_travels(
            self.design, cfg["rho"], cfg["pose"], cfg["target"], cfg["mode"]
        )
        return TravelCurve(travels, self.speed_fraction * self.design.max_speed)

    def follow(
        self, plan: TravelCurve, t: float, obs: NDArray[np.float64]
    ) -> NDArray[np.float64] | None:
        """The curve's command one period ahead (until one period after it ends), over
        ``max_speed``."""
        t = t + self.dt
        if t > plan.duration + self.dt:
            return None
        vmax = self.design.max_speed
        return plan.command(t, obs[SLICES["rho"]], self.travel_gain, vmax) / vmax
