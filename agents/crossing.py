"""A non-learning demonstration of crossing a parallel singularity (``Planar3PAssemblyChange-v0``).

:class:`CrossingController` takes, at the first step of an episode, the straight path in pose
space from the observed pose to the observed target (which lies in the other assembly mode, so
the path crosses ``det A = 0``), turns it into slider travels with the exact inverse kinematics
of the working mode (smooth and finite through the parallel singularity: only ``A`` loses rank
there, not ``B``), and follows those travels with a minimum-jerk time law at up to the full
slider speed (feed-forward rates plus a proportional correction of the travel error):
:func:`planar3p_gym.tasks.assembly_change.demonstration_travels` and
:class:`~planar3p_gym.tasks.assembly_change.TravelCurve`, the motion the task's sampler
verifies in simulation.  Near the singularity the servos saturate and the platform passes the
singular pose on its momentum, onto the other branch of the direct kinematics, which the
travel references then lead to the target.  Once the references have arrived, the paper's
simultaneous simple motions (:class:`agents.analytic.AnalyticController`) remove the remaining
error.

Calling convention: Stable-Baselines3's ``predict``; a new episode is recognised by
``episode_start`` (or :meth:`CrossingController.reset`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from agents.analytic import AnalyticController
from agents.planner import observed_configuration
from planar3p_gym.design import Design
from planar3p_gym.observation import OBS_SIZE, SLICES
from planar3p_gym.tasks.assembly_change import TravelCurve, demonstration_travels

__all__ = ["CrossingController"]


class CrossingController:
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
        self.design = design if design is not None else Design.fig8(gravity=0.0)
        if not isinstance(self.design, Design):
            raise ValueError(f"design must be a planar3p_gym.Design, got {type(design).__name__}")
        for name, value in (("dt", dt), ("travel_gain", travel_gain)):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        if not 0 < speed_fraction <= 1:
            raise ValueError(f"speed_fraction must be in (0, 1], got {speed_fraction!r}")
        self.dt = float(dt)
        self.speed_fraction = float(speed_fraction)
        self.travel_gain = float(travel_gain)
        self.finisher = AnalyticController(self.design, "simultaneous")
        self._curves: list[TravelCurve | None] = []
        self._times: list[float] = []

    @classmethod
    def from_env(cls, env: Any, **kwargs: Any) -> CrossingController:
        """A controller for the design and control period of ``env`` (possibly wrapped); the
        speed and gain default to those the environment's task verifies with."""
        base = env.unwrapped
        limits = getattr(base.task, "limits", None)
        if limits is not None and hasattr(limits, "travel_gain"):
            kwargs.setdefault("speed_fraction", limits.speed_fraction)
            kwargs.setdefault("travel_gain", limits.travel_gain)
        return cls(base.design, dt=base.dt, **kwargs)

    def reset(self, seed: int | None = None) -> None:
        """Forget the plans (the next observation starts a new episode)."""
        self._curves, self._times = [], []

    def predict(
        self,
        observation: ArrayLike,
        state: Any = None,
        episode_start: ArrayLike | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """Action(s) in ``[-1, 1]`` for observation(s) (at least the 31 base entries)."""
        obs = np.asarray(observation, dtype=np.float64)
        single = obs.ndim == 1
        obs2 = obs[None, :] if single else obs
        if obs2.ndim != 2 or obs2.shape[1] < OBS_SIZE:
            raise ValueError(
                f"observation must have shape (m,) or (n, m) with m >= {OBS_SIZE}, got {obs.shape}"
            )
        n = obs2.shape[0]
        if len(self._curves) != n:
            self._curves, self._times = [None] * n, [0.0] * n
        if episode_start is None:
            starts = np.zeros(n, dtype=bool)
        else:
            starts = np.broadcast_to(np.asarray(episode_start, dtype=bool).reshape(-1), (n,))
        vmax = self.design.max_speed
        actions = np.zeros((n, 3), dtype=np.float32)
        for i in range(n):
            o = np.nan_to_num(obs2[i], nan=0.0, posinf=0.0, neginf=0.0)
            if starts[i] or self._curves[i] is None:
                cfg = observed_configuration(o)
                travels = demonstration_travels(
                    self.design, cfg["rho"], cfg["pose"], cfg["target"], cfg["mode"]
                )
                self._curves[i] = TravelCurve(travels, self.speed_fraction * vmax)
                self._times[i] = 0.0
            curve = self._curves[i]
            assert curve is not None
            t = self._times[i] + self.dt
            self._times[i] = t
            if t > curve.duration + self.dt:
                actions[i] = self.finisher.predict(o[:OBS_SIZE])[0]
                continue
            cmd = curve.command(t, o[SLICES["rho"]], self.travel_gain, vmax)
            actions[i] = cmd / vmax
        return (actions[0] if single else actions), None

    def __repr__(self) -> str:
        return (
            f"CrossingController(speed_fraction={self.speed_fraction}, "
            f"travel_gain={self.travel_gain})"
        )
