"""How faithful is the physics?  Loop-closure error and pose against the exact kinematics, for the
original model (``Planar3P-v0``: 8 substeps x 18 iterations, no projection) and the projected one
(``Planar3P-v0``), side by side.

    python scripts/fidelity.py [--pairs 60] [--episodes 30] [--suites standard,hard,far]
                               [--seed 0] [--json PATH]

Two measurements per model:

* **smooth motions**: ``--pairs`` open-loop minimum-jerk motions between well-conditioned poses
  (:mod:`planar3p_gym.tasks.motions`; commands up to 0.8 of the speed limit), as in
  ``tests/sim/test_physics.py``: the largest closure error (the largest joint separation, m) of
  each motion and the largest gap between the simulated pose and the exact direct kinematics
  of the simulated travels (``|(dx, dy, L_ref dtheta)|``, m);
* **controller episodes**: ``--episodes`` episodes per benchmark suite driven by the analytic
  controller (full-speed commands changing abruptly at 50 Hz; ``hard`` passes close to
  singularities): per episode the largest closure error and the largest DK gap, over all steps
  and over the steps whose parallel margin is at least 0.02.

Prints medians and maxima, and the median wall time of ``Planar3PSim.step``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import planar3p_gym  # noqa: F401  (registers the ids)
from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.evaluation import reach_suites as agent_suites
from planar3p_agents.evaluation.episodes import reset_episode
from planar3p_agents.evaluation.throughput import write_json_atomic
from planar3p_gym import Design
from planar3p_gym.envs.core import DEFAULT_WORKING_MODE
from planar3p_gym.sim import physics
from planar3p_gym.sim.physics import Planar3PSim
from planar3p_gym.tasks import motions

#: The two models: simulation settings and registered id.
MODELS = {
    "v0": ("Planar3P-v0", {}),
    "v1": (
        "Planar3P-v0",
        {
            "projection": True,
            "substeps": physics.PROJECTED_SUBSTEPS,
            "iterations": physics.PROJECTED_ITERATIONS,
        },
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


def controller_episodes(env_id: str, suites: list[str], n: int, seed: int) -> dict[str, Any]:
    """Per suite and episode: largest closure error, DK gap and DK gap at margin >= 0.02 (m)."""
    env = gym.make(env_id)
    design = env.unwrapped.design
    controller = AnalyticController.from_env(env)
    out: dict[str, Any] = {}
    for name in suites:
        rows = []
        for spec in agent_suites.make_suite(name, n, seed).episodes:
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


def describe(values: list[float]) -> str:
    v = np.asarray(values, dtype=float)
    return f"median {np.median(v):.1e}  max {v.max():.1e}"


def fail(message: str) -> None:
    print(f"fidelity.py: error: {message}", file=sys.stderr)
    raise SystemExit(2)


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, status 2
        fail(message)


def main(argv: list[str] | None = None) -> int:
    ap = _Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pairs", type=int, default=60, help="smooth motions")
    ap.add_argument("--episodes", type=int, default=30, help="controller episodes per suite")
    ap.add_argument("--suites", default="standard,hard,far")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, help="also write the figures as JSON")
    args = ap.parse_args(argv)
    suites = [s for s in args.suites.split(",") if s]
    unknown = sorted(set(suites) - set(agent_suites.SUITE_NAMES))
    if args.pairs < 1 or args.episodes < 0 or args.seed < 0:
        fail("--pairs must be >= 1, --episodes and --seed >= 0")
    if unknown:
        fail(f"unknown suites {unknown}; known: {', '.join(agent_suites.SUITE_NAMES)}")
    if args.json is not None and not args.json.resolve().parent.is_dir():
        fail(f"--json: directory {args.json.resolve().parent} does not exist")

    design = Design.fig8()
    report: dict[str, Any] = {"models": {}}
    for model, (env_id, settings) in MODELS.items():
        smooth = smooth_motions(design, args.pairs, args.seed, settings)
        episodes = (
            controller_episodes(env_id, suites, args.episodes, args.seed) if args.episodes else {}
        )
        report["models"][model] = {"settings": settings, "smooth": smooth, "episodes": episodes}
    print(f"closure error and DK gap in m (L_min = {design.shortest_leg} m), seed {args.seed}")
    for model, r in report["models"].items():
        sub = r["settings"].get("substeps", physics.DEFAULT_SUBSTEPS)
        it = r["settings"].get("iterations", physics.DEFAULT_ITERATIONS)
        proj = "projection" if r["settings"].get("projection") else "no projection"
        print(f"\n{model}: {sub} substeps x {it} iterations, {proj}")
        s = r["smooth"]
        print(f"  smooth motions ({args.pairs}): closure {describe(s['closure'])}")
        print(f"  {'':22s}DK gap  {describe(s['dk_gap'])}")
        print(f"  median Planar3PSim.step {s['step_us']:.1f} us")
        for name, e in r["episodes"].items():
            print(
                f"  {name:9s} ({args.episodes} analytic episodes): closure {describe(e['closure'])}"
            )
            print(f"  {'':10s}DK gap {describe(e['dk_gap'])}; at margin >= {MARGIN}: "
                  f"{describe(e['dk_gap_margin_ok'])}")  # fmt: skip
    if args.json:
        write_json_atomic(args.json, report)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
