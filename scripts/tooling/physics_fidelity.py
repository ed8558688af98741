"""How faithful is the physics?  Loop-closure error and pose against the exact kinematics, for
the unprojected pymunk model (8 substeps x 18 iterations, ``projection=False``) and the
projected one (``Planar3P-v0``'s physics), side by side (``python scripts/fidelity.py``).

Two measurements per model:

* :func:`smooth_motions`: open-loop minimum-jerk motions between well-conditioned poses
  (:mod:`planar3p_gym.tasks.motions`; commands up to 0.8 of the speed limit): the largest
  closure error (the largest joint separation, m) of each motion and the largest gap between
  the simulated pose and the exact direct kinematics of the simulated travels
  (``|(dx, dy, L_ref dtheta)|``, m), and the median time of ``Planar3PSim.step``;
* :func:`controller_episodes`: episodes of the benchmark's reach suites driven by the analytic
  controller (full-speed commands changing abruptly at 50 Hz; ``hard`` passes close to
  singularities): per episode the largest closure error and the largest DK gap, over all steps
  and over the steps whose parallel margin is at least :data:`MARGIN`.

:func:`fidelity_report` runs both on both models.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.evaluation import reach_suites
from planar3p_agents.evaluation.episodes import reset_episode
from planar3p_gym import Design
from planar3p_gym.envs.core import DEFAULT_WORKING_MODE
from planar3p_gym.sim import physics
from planar3p_gym.sim.physics import Planar3PSim
from planar3p_gym.tasks import motions

__all__ = ["MARGIN", "MODELS", "controller_episodes", "fidelity_report", "smooth_motions"]

#: The two models: registered id, ``Planar3PSim`` settings, and the id's arguments for them.
#: The keys are those of the report (``v0``: the unprojected model the id ran before 0.2.0).
MODELS: dict[str, tuple[str, dict[str, Any], dict[str, Any]]] = {
    "v0": ("Planar3P-v0", {}, {"projection": False}),
    "v1": (
        "Planar3P-v0",
        {
            "projection": True,
            "substeps": physics.PROJECTED_SUBSTEPS,
            "iterations": physics.PROJECTED_ITERATIONS,
        },
        {"projection": True},
    ),
}
#: Control period (s), largest smooth-motion command (fraction of max speed), margin threshold.
DT, PEAK_FRACTION, MARGIN = 0.02, 0.8, 0.02


def smooth_motions(design: Design, n: int, seed: int, settings: dict) -> dict[str, Any]:
    """Largest closure error and DK gap (m) of each smooth motion, median step time (us)."""
    mode = DEFAULT_WORKING_MODE
    closure, gap, step_us = [], [], []
    for start, target in motions.well_conditioned_pairs(design, mode, n, seed):
        cmds = motions.min_jerk_commands(
            design, mode, start, target, DT, PEAK_FRACTION * design.max_speed
        )
        sim = Planar3PSim(design, start, mode, dt=DT, **settings)
        worst_c = worst_g = 0.0
        for c in [*cmds, *np.zeros((5, 3))]:
            t0 = time.perf_counter()
            st = sim.step(c)
            step_us.append(1e6 * (time.perf_counter() - t0))
            worst_c = max(worst_c, st.closure_error)
            worst_g = max(worst_g, motions.nearest_dk(design, st.rho, st.pose)[2])
        closure.append(worst_c)
        gap.append(worst_g)
    return {"closure": closure, "dk_gap": gap, "step_us": float(np.median(step_us))}


def controller_episodes(
    env_id: str,
    suites: Sequence[str],
    n: int,
    seed: int,
    env_kwargs: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Per suite and episode: largest closure error, DK gap and DK gap at margin >= 0.02 (m),
    in ``gym.make(env_id, **env_kwargs)``."""
    env = gym.make(env_id, **(env_kwargs or {}))
    design = env.unwrapped.design
    controller = AnalyticController.from_env(env)
    out: dict[str, Any] = {}
    for name in suites:
        rows = []
        for spec in reach_suites.make_suite(name, n, seed).episodes:
            obs, info = reset_episode(env, spec, seed)
            closure = gap = gap_ok = 0.0
            first, done = True, False
            while not done:
                action, _ = controller.predict(obs, episode_start=np.array([first]))
                first = False
                obs, _, terminated, truncated, info = env.step(action)
                done = terminated or truncated
                closure = max(closure, info["closure_error"])
                try:
                    g = motions.nearest_dk(design, info["rho"], info["pose"])[2]
                except ValueError:  # travels with no assembly at all
                    g = float("inf")
                gap = max(gap, g)
                if info["parallel_margin"] >= MARGIN:
                    gap_ok = max(gap_ok, g)
            rows.append((closure, gap, gap_ok))
        a = np.array(rows)
        out[name] = {"closure": a[:, 0].tolist(), "dk_gap": a[:, 1].tolist()}
        out[name]["dk_gap_margin_ok"] = a[:, 2].tolist()
    env.close()
    return out


def fidelity_report(pairs: int, episodes: int, suites: Sequence[str], seed: int) -> dict[str, Any]:
    """Both measurements on both :data:`MODELS`: ``{"models": {key: {"settings", "smooth",
    "episodes"}}}`` (no episodes when ``episodes`` is 0)."""
    design = Design.fig8()
    report: dict[str, Any] = {"models": {}}
    for model, (env_id, settings, env_kwargs) in MODELS.items():
        smooth = smooth_motions(design, pairs, seed, settings)
        played = controller_episodes(env_id, suites, episodes, seed, env_kwargs) if episodes else {}
        report["models"][model] = {"settings": settings, "smooth": smooth, "episodes": played}
    return report
