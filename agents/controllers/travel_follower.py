"""What the travel-space baselines share: read the configuration from the observation, plan a
travel motion at the first step of each episode, follow it, then finish with simple motions.

:class:`TravelFollower` is the base of
:class:`planar3p_agents.controllers.planner.JointPathPlanner` (mode change) and
:class:`planar3p_agents.controllers.crossing.CrossingController` (assembly change); a subclass
says how a plan is made from the first observation (:meth:`TravelFollower.plan`) and what it
commands at a time (:meth:`TravelFollower.follow`).
"""

from __future__ import annotations

import math
from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.base import BatchPolicy
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

__all__ = ["TravelFollower", "check_follower_arguments", "observed_configuration"]


def observed_configuration(obs: ArrayLike) -> dict[str, NDArray[np.float64]]:
    """Travels ``rho`` (m), pose (m, m, rad), working mode (``sign cos alpha_i``) and target
    pose read from a flat observation (at least the 31 ``Planar3P-v0`` entries)."""
    o = np.asarray(obs, dtype=np.float64)
    pos, ori = o[SLICES["position"]], o[SLICES["orientation"]]
    tpos, tori = o[SLICES["target_position"]], o[SLICES["target_orientation"]]
    cos_a = o[SLICES["legs"]][0::2]
    return {
        "rho": o[SLICES["rho"]].copy(),
        "pose": np.array([pos[0], pos[1], math.atan2(ori[1], ori[0])]),
        "mode": np.where(cos_a >= 0.0, 1.0, -1.0),
        "target": np.array([tpos[0], tpos[1], math.atan2(tori[1], tori[0])]),
    }


def check_follower_arguments(
    design: Any, dt: float, speed_fraction: float, travel_gain: float
) -> None:
    """``ValueError`` unless ``design`` is a :class:`~planar3p_gym.machine.design.Design`,
    ``dt`` (s) and ``travel_gain`` (1/s) are finite and > 0 and ``speed_fraction`` is in
    ``(0, 1]`` (the arguments of the travel-following baselines)."""
    if not isinstance(design, Design):
        raise ValueError(f"design must be a planar3p_gym.Design, got {type(design).__name__}")
    for name, value in (("dt", dt), ("travel_gain", travel_gain)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    if not 0 < speed_fraction <= 1:
        raise ValueError(f"speed_fraction must be in (0, 1], got {speed_fraction!r}")


class TravelFollower(BatchPolicy):
    """A plan per environment, made at its first step and followed each control period; the
    paper's simultaneous simple motions once :meth:`follow` has no command left.

    Args:
        design: the machine.
        dt: control period (s) of the environment (one :meth:`predict` call per period).
        speed_fraction: peak slider rate of the references as a fraction of ``max_speed``.
        travel_gain: proportional gain on the travel error (1/s).

    Observations: at least the 31 ``Planar3P-v0`` entries (``obs_size``, ``obs_exact =
    False``).  A new batch size or ``episode_start`` starts the plans afresh.
    """

    obs_size = OBS_SIZE
    obs_exact = False

    def __init__(
        self, design: Design, *, dt: float, speed_fraction: float, travel_gain: float
    ) -> None:
        check_follower_arguments(design, dt, speed_fraction, travel_gain)
        self.design = design
        self.dt = float(dt)
        self.speed_fraction = float(speed_fraction)
        self.travel_gain = float(travel_gain)
        self.finisher = AnalyticController(self.design, "simultaneous")
        self.new_batch(0)

    @classmethod
    def from_env(cls, env: Any, **kwargs: Any) -> Self:
        """A follower for the design and control period of ``env`` (possibly wrapped);
        ``kwargs``: the other constructor arguments."""
        base = env.unwrapped
        return cls(base.design, dt=base.dt, **kwargs)

    def new_batch(self, n: int) -> None:
        """No plan yet for ``n`` environments."""
        self._plans: list[Any] = [None] * n
        self._times: list[float] = [0.0] * n

    def reset(self, seed: int | None = None) -> None:
        """Forget the plans (the next observation starts a new episode)."""
        self.new_batch(0)

    def plan(self, i: int, obs: NDArray[np.float64]) -> Any:
        """The plan of environment ``i`` from its first observation ``obs`` (finite)."""
        raise NotImplementedError

    def follow(self, plan: Any, t: float, obs: NDArray[np.float64]) -> NDArray[np.float64] | None:
        """The action in ``[-1, 1]`` at ``t`` (s since the plan began, at the start of this
        control period), or ``None`` once the plan is done."""
        raise NotImplementedError

    def act(
        self, obs: NDArray[np.float64], state: Any, starts: NDArray[np.bool_], deterministic: bool
    ) -> tuple[np.ndarray, Any]:
        """Actions for the batch ``obs``: each environment's plan, then simple motions."""
        n = obs.shape[0]
        if len(self._plans) != n:
            self.new_batch(n)
        actions = np.zeros((n, 3), dtype=np.float32)
        for i in range(n):
            o = np.nan_to_num(obs[i], nan=0.0, posinf=0.0, neginf=0.0)
            if starts[i] or self._plans[i] is None:
                self._plans[i] = self.plan(i, o)
                self._times[i] = 0.0
            t = self._times[i]
            self._times[i] = t + self.dt
            action = self.follow(self._plans[i], t, o)
            actions[i] = self.finisher.predict(o[:OBS_SIZE])[0] if action is None else action
        return actions, None

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(speed_fraction={self.speed_fraction}, "
            f"travel_gain={self.travel_gain})"
        )
