"""Baselines on the mode-change and assembly-change tasks, and the crossing-fidelity study
(the logic of ``scripts/task_baselines.py``).

Every policy plays the same seeded episodes of an id (``reset(seed=seed + i)``); reported per
policy: success rate (with a 95 % Wilson interval), median time to success, median final
errors, termination reasons.  Policies (:data:`STUDY_POLICIES`, names of the baseline registry
:data:`planar3p_agents.controllers.registry.BASELINES`, built by
:func:`planar3p_agents.policies.factory.load_policy`): ``planner`` (mode change), ``crossing``
(assembly change), ``analytic-simultaneous`` (the paper's superposed simple motions).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_agents.evaluation.crossing_fidelity import crossing_fidelity
from planar3p_agents.evaluation.intervals import success_interval
from planar3p_agents.policies.factory import load_policy
from planar3p_gym.envs.registry import ASSEMBLY_CHANGE_ENV_ID, ENV_ID, MODE_CHANGE_ENV_ID

__all__ = [
    "STUDY_POLICIES",
    "TaskResult",
    "run_baselines",
    "run_fidelity",
    "run_reach_fidelity",
    "verification_rate",
]

#: The ids of this study and the baselines it plays on each (registry names).
STUDY_POLICIES: dict[str, tuple[str, ...]] = {
    MODE_CHANGE_ENV_ID: ("planner", "analytic-simultaneous"),
    ASSEMBLY_CHANGE_ENV_ID: ("crossing", "analytic-simultaneous"),
}


@dataclass
class TaskResult:
    """Outcome of one policy on one id's episodes."""

    env_id: str
    policy: str
    episodes: int
    successes: int
    times: list[float] = field(default_factory=list)
    position_errors: list[float] = field(default_factory=list)
    orientation_errors: list[float] = field(default_factory=list)
    reasons: Counter = field(default_factory=Counter)

    def row(self) -> str:
        lo, hi = success_interval(self.successes, self.episodes)
        t = float(np.median(self.times)) if self.times else math.nan
        return (
            f"| {self.env_id} | {self.policy} | {self.episodes} | "
            f"{100 * self.successes / self.episodes:.0f} [{100 * lo:.0f}, {100 * hi:.0f}] | "
            f"{t:.2f} | {1000 * float(np.median(self.position_errors)):.1f} | "
            f"{math.degrees(float(np.median(self.orientation_errors))):.2f} | "
            + ", ".join(f"{k} {v}" for k, v in sorted(self.reasons.items()))
            + " |"
        )


TABLE_HEADER = (
    "| id | policy | n | success % [95% Wilson] | median time to success s | "
    "median pos. err. mm | median orient. err. deg | episode ends |\n"
    "|---|---|---|---|---|---|---|---|"
)


def run_baselines(
    env_id: str, policy: str, episodes: int, seed: int, env_kwargs: dict | None = None
) -> TaskResult:
    """Play ``episodes`` episodes of ``env_id`` (seeds ``seed``, ``seed + 1``, ...) with the
    baseline ``policy``."""
    env = gym.make(env_id, **(env_kwargs or {}))
    pol = load_policy(policy, env)
    res = TaskResult(env_id, policy, episodes, 0)
    try:
        for i in range(episodes):
            obs, info = env.reset(seed=seed + i)
            if hasattr(pol, "reset"):
                pol.reset()
            start = np.ones(1, dtype=bool)
            while True:
                action, _ = pol.predict(obs, episode_start=start)
                start = np.zeros(1, dtype=bool)
                obs, _, terminated, truncated, info = env.step(action)
                if terminated or truncated:
                    break
            reason = info["termination_reason"] or "time_limit"
            res.reasons[reason] += 1
            if info["is_success"]:
                res.successes += 1
                res.times.append(float(info["time"]))
            res.position_errors.append(float(info["position_error"]))
            res.orientation_errors.append(abs(float(info["orientation_error"])))
    finally:
        env.close()
    return res


def _summary(rows: list[dict[str, float]], projection: bool) -> dict[str, float]:
    out: dict[str, float] = {"episodes": float(len(rows)), "projection": float(projection)}
    for key in rows[0]:
        vals = np.array([r[key] for r in rows])
        out[f"{key}_median"] = float(np.median(vals))
        out[f"{key}_max"] = float(np.max(vals))
        out[f"{key}_min"] = float(np.min(vals))
    out["success_rate"] = float(np.mean([r["success"] for r in rows]))
    return out


def run_reach_fidelity(
    episodes: int, seed: int, projection: bool, gravity: float = 0.0
) -> dict[str, float]:
    """The same measurements on reach episodes without a crossing, for comparison:
    ``Planar3P-v0`` with the projected physics (the id's) or the plain solver
    (``projection=False``, its default substeps and iterations) on ``Design.fig8`` with
    ``gravity`` (m/s^2), played by the simultaneous simple motions."""
    from planar3p_gym import Design

    env = gym.make(ENV_ID, design=Design.fig8(gravity=gravity), projection=projection)
    pol = load_policy("analytic-simultaneous", env)
    rows = [crossing_fidelity(env, pol, seed + i) for i in range(episodes)]
    env.close()
    return _summary(rows, projection)


def run_fidelity(
    episodes: int, seed: int, projection: bool, gravity: float | None = None
) -> dict[str, float]:
    """Medians and extremes of
    :func:`planar3p_agents.evaluation.crossing_fidelity.crossing_fidelity` over ``episodes``
    seeded episodes of ``Planar3PAssemblyChange-v0`` played by the crossing controller, with
    the projected physics (the id's) or the plain solver (8 substeps, 18 iterations).
    ``gravity`` (m/s^2) replaces the design's (the sampler's simulated check is then turned
    off, so the episodes need not be feasible)."""
    kwargs: dict[str, Any] = {}
    if not projection:
        kwargs.update(projection=False, substeps=8, solver_iterations=18)
    if gravity is not None:
        from planar3p_gym.envs.assembly_change import assembly_change_design

        kwargs.update(
            design=assembly_change_design().with_(gravity=gravity),
            crossing_limits={"verify": False},
        )
    env = gym.make(ASSEMBLY_CHANGE_ENV_ID, **kwargs)
    pol = load_policy("crossing", env)
    rows = [crossing_fidelity(env, pol, seed + i) for i in range(episodes)]
    env.close()
    return _summary(rows, projection)


def verification_rate(
    pairs: int,
    seed: int,
    *,
    gravity: float,
    projection: bool,
    speed_fraction: float = 1.0,
    max_force: float | None = None,
) -> dict[str, float]:
    """How often the assembly-change demonstration motion reaches the target (within the
    task's 1 cm, and within 5 cm) on ``pairs`` start/target pairs that pass the kinematic check
    (:func:`planar3p_gym.tasks.assembly_change.crossing_path`), drawn from
    ``np.random.default_rng(seed)``, on ``Design.fig8`` with ``gravity`` (m/s^2) and
    ``max_force`` (N), with the projected or the plain physics; peak slider rate
    ``speed_fraction`` of ``max_speed``."""
    from dataclasses import replace

    from planar3p_gym import Design
    from planar3p_gym.envs.assembly_change import ASSEMBLY_CHANGE_MODE, Planar3PAssemblyChangeEnv
    from planar3p_gym.sim.physics import PROJECTED_ITERATIONS, PROJECTED_SUBSTEPS
    from planar3p_gym.tasks.assembly_change import crossing_path, verify_crossing

    design = Design.fig8(gravity=gravity)
    if max_force is not None:
        design = design.with_(max_force=max_force)
    physics: dict[str, Any] = (
        {
            "projection": True,
            "substeps": PROJECTED_SUBSTEPS,
            "solver_iterations": PROJECTED_ITERATIONS,
        }
        if projection
        else {"projection": False, "substeps": 8, "solver_iterations": 18}
    )
    env = Planar3PAssemblyChangeEnv(design=design, crossing_limits={"verify": False}, **physics)
    task = env.task
    limits = replace(task.limits, speed_fraction=speed_fraction)
    mode = ASSEMBLY_CHANGE_MODE
    sampler = task.pose_sampler(mode)
    rng = np.random.default_rng(seed)
    within, near, tried = 0, 0, 0
    while tried < pairs:
        s, asm = sampler.draw(rng)
        t = sampler.draw_many(rng, -asm, 1)[0]
        if not crossing_path(design, s, t, mode, limits)[0]:
            continue
        tried += 1
        ok, fig = verify_crossing(design, s, t, mode, limits, task.make_sim, env.breakdown_distance)
        within += ok
        near += fig["end_distance"] <= 0.05 and fig["end_assembly"] == -int(asm)
    env.close()
    return {"pairs": float(pairs), "within_1cm": within / pairs, "within_5cm": near / pairs}
