"""A reach planner that uses what the kinematics can certify (baseline ``certified``).

At the first step of an episode it picks the first motion the kinematics certifies from the
observed start to the target (in order; the certificates: docs/controllers.md, "How the
controller modules work"), recorded per environment in ``choices``:

* ``line``: the straight line in slider space;
* ``cartesian``: the simultaneous simple motions, where the straight pose path is clear;
* ``detour``: a travel-space path through one certified waypoint, then the slider line;
* ``fallback``: the simple motions anyway.

:class:`CertifiedPlanner` follows SB3's ``predict``; a new episode is recognised by
``episode_start`` or :meth:`CertifiedPlanner.reset`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.base import BatchPolicy
from planar3p_agents.controllers.slider_line import DEFAULT_TRAVEL_GAIN, line_rates
from planar3p_agents.controllers.travel_follower import observed_configuration
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks import sampling
from planar3p_gym.tasks.joint_paths import PathLimits, certify_joint_path
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

__all__ = ["CHOICES", "DEFAULT_CARTESIAN_GAIN", "CertifiedPlanner"]

#: The motions the planner chooses among, in order of preference.
CHOICES = ("line", "cartesian", "detour", "fallback")
#: Gain of the simple motions (1/s) where the planner uses them.
DEFAULT_CARTESIAN_GAIN = 20.0
#: The certificate's limits: the environment's path margin, holding forces up to the
#: actuators' limit, the whole stroke.
DEFAULT_LIMITS = PathLimits(min_parallel_margin=0.02, max_holding_force=1.0, travel_margin=0.0)

FloatArray = NDArray[np.float64]


@dataclass
class _Plan:
    kind: str
    target_rho: FloatArray
    travels: FloatArray | None = None  # (m, 3) travel waypoints of a detour
    arc: FloatArray | None = None  # (m,) cumulative max-norm length along them (m)


class CertifiedPlanner(BatchPolicy):
    """Slider line where certified, else simple motions on a clear pose path, else a certified
    travel-space detour (module docstring).

    Args:
        design: the machine; default ``Design.fig8()``.
        dt: control period (s) of the environment.
        gain: proportional gain on the travel error (1/s) of the line and the detour.
        cartesian_gain: gain (1/s) of the simple motions.
        speed_fraction: the fastest slider's rate as a fraction of ``max_speed``.
        limits: the travel-space certificate (:class:`~planar3p_gym.tasks.joint_paths.
            PathLimits`).
        task_config: the environment's task configuration (its clear-path test).
        detour_margin: parallel margin of a detour's pose segments.
        candidates: waypoints screened per detour (the cheapest of the pool).
        pool_size: acceptable poses in the waypoint pool of each working mode.
        seed: seed of the waypoint pool (the planner is deterministic).
        observation_size: length of the flat observations (at least 31).
    """

    obs_size = OBS_SIZE

    def __init__(
        self,
        design: Design | None = None,
        *,
        dt: float = 0.02,
        gain: float = DEFAULT_TRAVEL_GAIN,
        cartesian_gain: float = DEFAULT_CARTESIAN_GAIN,
        speed_fraction: float = 1.0,
        limits: PathLimits = DEFAULT_LIMITS,
        task_config: sampling.TaskConfig | None = None,
        detour_margin: float = 0.04,
        candidates: int = 400,
        pool_size: int = 3000,
        seed: int = 0,
        observation_size: int | None = None,
    ) -> None:
        self._use_design(design)
        for name, value in (("dt", dt), ("gain", gain), ("cartesian_gain", cartesian_gain)):
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        if not 0 < speed_fraction <= 1:
            raise ValueError(f"speed_fraction must be in (0, 1], got {speed_fraction!r}")
        if candidates < 1 or pool_size < 1:
            raise ValueError("candidates and pool_size must be >= 1")
        self.dt, self.gain, self.speed_fraction = float(dt), float(gain), float(speed_fraction)
        self.limits = limits
        self.task_config = task_config or sampling.TaskConfig()
        self.detour_config = replace(self.task_config, path_parallel_margin=detour_margin)
        self.candidates, self.pool_size, self.seed = int(candidates), int(pool_size), int(seed)
        self._use_observation_size(observation_size)
        self.cartesian = AnalyticController(
            self.design, position_gain=cartesian_gain, orientation_gain=cartesian_gain
        )
        self._pools: dict[tuple[int, ...], tuple[FloatArray, FloatArray, FloatArray]] = {}
        self.reset()

    @classmethod
    def from_env(cls, env: Any, **kwargs: Any) -> CertifiedPlanner:
        """A planner for the design, control period and task configuration of ``env``."""
        base = env.unwrapped
        kwargs.setdefault("task_config", getattr(base, "task_config", None))
        return cls(base.design, dt=base.dt, **kwargs)

    def reset(self, seed: Any = None) -> None:
        """Forget the plans (the next observation starts an episode)."""
        self._plans: list[_Plan | None] = []
        self._times: list[float] = []
        #: The motion chosen for each environment's current episode (:data:`CHOICES`).
        self.choices: list[str] = []

    # ------------------------------------------------------------------ planning
    def plan(self, obs: FloatArray) -> _Plan:
        """The plan of one episode from its first flat observation ``obs``."""
        cfg = observed_configuration(obs)
        mode, start, target = cfg["mode"], cfg["pose"], cfg["target"]
        rho0 = cfg["rho"]
        rho_t = kinematics.inverse(self.design, target, mode).rho
        if not (np.isfinite(rho_t).all() and np.isfinite(rho0).all()):
            return _Plan("fallback", rho_t)
        line, _ = certify_joint_path(
            self.design, np.stack([rho0, rho_t]), start, target, self.limits
        )
        if line is not None:
            return _Plan("line", rho_t)
        assembly = float(kinematics.assembly_mode(self.design, start, rho0))
        clear = sampling.path_is_clear(
            self.design, start, target[None, :], mode, assembly, self.task_config
        )
        if bool(clear[0]):
            return _Plan("cartesian", rho_t)
        travels = self._detour(start, target, rho0, rho_t, mode, assembly)
        if travels is None:
            return _Plan("fallback", rho_t)
        arc = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(travels, axis=0)).max(axis=1))])
        return _Plan("detour", rho_t, travels, arc)

    def _pool(self, mode: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Acceptable poses of ``mode``, their assembly modes and travels (cached)."""
        key = tuple(int(m) for m in mode)
        if key not in self._pools:
            rng = np.random.default_rng(self.seed)
            poses, dets, total = [], [], 0
            while total < self.pool_size:
                p, d = sampling.sample_poses(self.design, mode, rng, self.task_config)
                poses.append(p)
                dets.append(d)
                total += len(p)
            pool = np.concatenate(poses)[: self.pool_size]
            det = np.concatenate(dets)[: self.pool_size]
            self._pools[key] = (pool, det, kinematics.inverse(self.design, pool, mode).rho)
        return self._pools[key]

    def _detour(
        self,
        start: FloatArray,
        target: FloatArray,
        rho0: FloatArray,
        rho_t: FloatArray,
        mode: FloatArray,
        assembly: float,
        tries: int = 8,
        points: int = 16,
    ) -> FloatArray | None:
        """Travel waypoints ``(m, 3)`` of the cheapest certified one-waypoint detour, or
        ``None``."""
        pool, det, rho_w = self._pool(mode)
        cost = np.abs(rho_w - rho0).max(axis=1) + np.abs(rho_t - rho_w).max(axis=1)
        cost = np.where(det == assembly, cost, np.inf)
        order = np.argsort(cost, kind="stable")[: self.candidates]
        order = order[np.isfinite(cost[order])]
        if order.size == 0:
            return None
        cfg = self.detour_config
        ok = sampling.path_is_clear(self.design, start, pool[order], mode, assembly, cfg)
        ok &= sampling.path_is_clear(self.design, target, pool[order], mode, assembly, cfg)
        for k in order[ok][:tries]:
            poses = np.concatenate(
                [
                    sampling.interpolate(start[None], pool[k][None], points)[0],
                    sampling.interpolate(pool[k][None], target[None], points)[0][1:],
                ]
            )
            travels = kinematics.inverse(self.design, poses, mode).rho
            travels[0], travels[-1] = rho0, rho_t
            path, _ = certify_joint_path(self.design, travels, start, target, self.limits)
            if path is not None:
                return travels
        return None

    # ------------------------------------------------------------------ acting
    def act(
        self, obs: FloatArray, state: Any, starts: NDArray[np.bool_], deterministic: bool
    ) -> tuple[np.ndarray, Any]:
        """Actions ``(n, 3)`` in ``[-1, 1]``: each environment's plan."""
        n = obs.shape[0]
        if len(self._plans) != n:
            self._plans, self._times, self.choices = [None] * n, [0.0] * n, [""] * n
        o = np.nan_to_num(obs, nan=0.0, posinf=0.0, neginf=0.0)
        vmax = self.speed_fraction * self.design.max_speed
        actions = np.zeros((n, 3), dtype=np.float32)
        for i in range(n):
            if starts[i] or self._plans[i] is None:
                self._plans[i] = self.plan(o[i])
                self._times[i] = 0.0
                self.choices[i] = self._plans[i].kind  # type: ignore[union-attr]
            plan = self._plans[i]
            assert plan is not None
            t = self._times[i]
            self._times[i] = t + self.dt
            rho = o[i, SLICES["rho"]]
            if plan.kind in ("cartesian", "fallback"):
                actions[i] = self.cartesian.predict(o[i, :OBS_SIZE])[0]
                continue
            rates = None
            if plan.kind == "detour":
                rates = self._follow(plan, t, rho, vmax)
            if rates is None:
                rates = line_rates((plan.target_rho - rho)[None], self.gain, vmax)[0]
            actions[i] = np.clip(rates / self.design.max_speed, -1.0, 1.0)
        return actions, None

    def _follow(self, plan: _Plan, t: float, rho: FloatArray, vmax: float) -> FloatArray | None:
        """Rates (m/s) along the detour at time ``t``: the reference one period ahead moving at
        ``vmax`` (max-norm) plus the travel-error correction, scaled as one motion to ``vmax``;
        ``None`` once the reference has arrived."""
        assert plan.travels is not None and plan.arc is not None
        s = vmax * (t + self.dt)
        if s >= plan.arc[-1]:
            return None
        k = int(np.clip(np.searchsorted(plan.arc, s, side="right") - 1, 0, len(plan.arc) - 2))
        a, b = plan.travels[k], plan.travels[k + 1]
        length = max(plan.arc[k + 1] - plan.arc[k], 1e-12)
        ref = a + (s - plan.arc[k]) / length * (b - a)
        rates = vmax * (b - a) / length + self.gain * (ref - rho)
        peak = float(np.abs(rates).max())
        return rates * (vmax / peak) if peak > vmax else rates

    def __repr__(self) -> str:
        return (
            f"CertifiedPlanner(gain={self.gain}, cartesian_gain={self.cartesian.position_gain}, "
            f"speed_fraction={self.speed_fraction})"
        )
