"""Non-learning baselines for the mode-change task (``Planar3PModeChange-v0``).

* :class:`JointPathPlanner` plans, at the first step of an episode, the certified travel path
  of :func:`planar3p_gym.tasks.joint_paths.find_joint_path` from the observed configuration to
  the observed target (pose, travels and working mode are in the observation), follows it with
  minimum-jerk travel references (feed-forward rate plus a proportional correction of the
  travel error), and finishes with the paper's simultaneous simple motions
  (:class:`agents.analytic.AnalyticController`) once the travels have arrived.  Moving in
  travel space is what lets a leg pass the perpendicular to its rail: the slider under an
  upright leg just moves on while the platform stays put to first order.
* :class:`BaseObservation` runs a policy written for the 31-entry ``Planar3P-v0`` observation
  on a task whose observation appends entries (it drops them), e.g. the analytic controller.

Calling convention: Stable-Baselines3's ``predict`` (single observations or batches); a new
episode is recognised by ``episode_start`` (as SB3's evaluation loops pass it) or by
:meth:`JointPathPlanner.reset`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agents.analytic import AnalyticController
from planar3p_gym.design import Design
from planar3p_gym.observation import OBS_SIZE, SLICES
from planar3p_gym.tasks.joint_paths import PathLimits, find_joint_path

__all__ = [
    "BaseObservation",
    "JointPathPlanner",
    "check_follower_arguments",
    "episode_starts",
    "observation_batch",
    "observed_configuration",
]

#: Index of the target travels and target working mode in the mode-change observation.
TARGET_TRAVELS = slice(OBS_SIZE, OBS_SIZE + 3)
TARGET_MODE = slice(OBS_SIZE + 3, OBS_SIZE + 6)


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
    """``ValueError`` unless ``design`` is a :class:`~planar3p_gym.design.Design`, ``dt`` (s)
    and ``travel_gain`` (1/s) are finite and > 0 and ``speed_fraction`` is in ``(0, 1]`` (the
    arguments of the travel-following baselines)."""
    if not isinstance(design, Design):
        raise ValueError(f"design must be a planar3p_gym.Design, got {type(design).__name__}")
    for name, value in (("dt", dt), ("travel_gain", travel_gain)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    if not 0 < speed_fraction <= 1:
        raise ValueError(f"speed_fraction must be in (0, 1], got {speed_fraction!r}")


def observation_batch(
    observation: ArrayLike, min_size: int, expected: str
) -> tuple[NDArray[np.float64], bool]:
    """``observation`` as a float64 batch ``(n, m)`` and whether it was a single ``(m,)`` one;
    ``ValueError`` ("observation must have shape ``expected``, got ...") unless ``m >=
    min_size``."""
    obs = np.asarray(observation, dtype=np.float64)
    single = obs.ndim == 1
    obs2 = obs[None, :] if single else obs
    if obs2.ndim != 2 or obs2.shape[1] < min_size:
        raise ValueError(f"observation must have shape {expected}, got {obs.shape}")
    return obs2, single


def episode_starts(episode_start: ArrayLike | None, n: int) -> NDArray[np.bool_]:
    """SB3's ``episode_start`` as one bool per environment (``None``: no new episode)."""
    if episode_start is None:
        return np.zeros(n, dtype=bool)
    return np.broadcast_to(np.asarray(episode_start, dtype=bool).reshape(-1), (n,))


class BaseObservation:
    """``policy`` (SB3-style ``predict`` on the 31-entry observation) applied to the first 31
    entries of a longer observation."""

    def __init__(self, policy: Any) -> None:
        self.policy = policy

    def reset(self, seed: int | None = None) -> None:
        """Reset the wrapped policy if it can be reset."""
        if hasattr(self.policy, "reset"):
            self.policy.reset()

    def predict(
        self,
        observation: ArrayLike,
        state: Any = None,
        episode_start: ArrayLike | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        obs = np.asarray(observation)
        return self.policy.predict(obs[..., :OBS_SIZE], state, episode_start, deterministic)


class _Plan:
    """Minimum-jerk travel references along a piecewise-straight travel path."""

    def __init__(self, travels: NDArray[np.float64], peak: float) -> None:
        self.travels = travels
        steps = np.abs(np.diff(travels, axis=0)).max(axis=1)
        # the minimum-jerk profile peaks at 1.875 times the mean rate
        self.durations = np.maximum(1.875 * steps / peak, 1e-3)
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
        T = self.durations[k]
        u = min(max((t - t0) / T, 0.0), 1.0)
        s = u**3 * (10.0 - 15.0 * u + 6.0 * u * u)
        s_dot = 30.0 * u * u * (1.0 - u) ** 2 / T
        a, b = self.travels[k], self.travels[k + 1]
        return a + s * (b - a), s_dot * (b - a)


class JointPathPlanner:
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

    def __init__(
        self,
        design: Design | None = None,
        *,
        dt: float = 0.02,
        speed_fraction: float = 0.6,
        travel_gain: float = 10.0,
        limits: PathLimits | None = None,
    ) -> None:
        self.design = design if design is not None else Design.fig8()
        check_follower_arguments(self.design, dt, speed_fraction, travel_gain)
        self.dt = float(dt)
        self.speed_fraction = float(speed_fraction)
        self.travel_gain = float(travel_gain)
        self.limits = limits or PathLimits()
        self.finisher = AnalyticController(self.design, "simultaneous")
        self._plans: list[_Plan | None] = []
        self._times: list[float] = []
        #: Whether the last plan of each environment was certified (``find_joint_path``).
        self.certified: list[bool] = []

    @classmethod
    def from_env(cls, env: Any, **kwargs: Any) -> JointPathPlanner:
        """A planner for the design and control period of ``env`` (possibly wrapped)."""
        base = env.unwrapped
        return cls(base.design, dt=base.dt, **kwargs)

    def reset(self, seed: int | None = None) -> None:
        """Forget the plans (the next observation starts a new episode)."""
        self._plans, self._times, self.certified = [], [], []

    def _plan(self, obs: NDArray[np.float64]) -> tuple[_Plan, bool]:
        cfg = observed_configuration(obs)
        target_mode = np.where(obs[TARGET_MODE] >= 0.0, 1.0, -1.0)
        path, _ = find_joint_path(
            self.design, cfg["pose"], cfg["mode"], cfg["target"], target_mode, self.limits
        )
        if path is not None:
            travels = path.travels.copy()
            travels[0] = cfg["rho"]
            certified = True
        else:
            travels = np.stack([cfg["rho"], obs[TARGET_TRAVELS].astype(np.float64)])
            certified = False
        return _Plan(travels, self.speed_fraction * self.design.max_speed), certified

    def predict(
        self,
        observation: ArrayLike,
        state: Any = None,
        episode_start: ArrayLike | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """Action(s) in ``[-1, 1]`` for observation(s) ``(37,)`` or ``(n, 37)``."""
        size = OBS_SIZE + 6
        obs2, single = observation_batch(
            observation, size, f"({size},) or (n, {size}) (the mode-change observation)"
        )
        n = obs2.shape[0]
        # a new batch size starts every plan afresh (they are all None)
        if len(self._plans) != n:
            self._plans, self._times, self.certified = [None] * n, [0.0] * n, [False] * n
        starts = episode_starts(episode_start, n)
        vmax = self.design.max_speed
        actions = np.zeros((n, 3), dtype=np.float32)
        for i in range(n):
            o = np.nan_to_num(obs2[i], nan=0.0, posinf=0.0, neginf=0.0)
            if starts[i] or self._plans[i] is None:
                self._plans[i], self.certified[i] = self._plan(o)
                self._times[i] = 0.0
            plan = self._plans[i]
            assert plan is not None
            t = self._times[i]
            self._times[i] = t + self.dt
            if t >= plan.duration:
                actions[i] = self.finisher.predict(o[:OBS_SIZE])[0]
                continue
            ref, rate = plan.reference(t + self.dt)
            rho = o[SLICES["rho"]]
            cmd = rate + self.travel_gain * (ref - rho)
            actions[i] = np.clip(cmd / vmax, -1.0, 1.0)
        return (actions[0] if single else actions), None

    def __repr__(self) -> str:
        return (
            f"JointPathPlanner(speed_fraction={self.speed_fraction}, "
            f"travel_gain={self.travel_gain})"
        )
