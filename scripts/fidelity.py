"""How faithful is the physics at given solver settings?  Loop-closure error and pose accuracy.

    python scripts/fidelity.py [--substeps 8] [--iterations 18] [--pairs 60] [--episodes 50]
                               [--suites standard,hard,far] [--seed 0] [--json PATH]

Two measurements, both in units of the shortest leg ``L_min`` (the specification's bound on the
loop-closure error, the largest joint separation, is ``1e-4 L_min``):

* **smooth motions**: ``--pairs`` open-loop minimum-jerk motions between well-conditioned poses
  (:mod:`planar3p_gym.motions`; commands up to 0.8 of the speed limit), as in
  ``tests/test_physics.py``: the largest closure error of each motion, and the largest gap
  between the simulated pose and the exact direct kinematics of the simulated travels
  (``|(dx, dy, L_ref dtheta)|``, m);
* **controller episodes**: ``--episodes`` episodes per benchmark suite of ``Planar3P-v0``
  driven by the analytic controller (full-speed commands that change abruptly at 50 Hz, and
  passes close to singularities on ``hard``): the largest closure error of each episode.

Prints the distributions (median, 95th percentile, maximum, share above the bound) and the
median wall time of a control step at these settings.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import planar3p_gym  # noqa: F401  (registers Planar3P-v0)
from agents import episodes as agent_episodes
from agents import suites as agent_suites
from agents.analytic import AnalyticController
from planar3p_gym import Design, motions
from planar3p_gym.env import DEFAULT_WORKING_MODE
from planar3p_gym.physics import DEFAULT_ITERATIONS, DEFAULT_SUBSTEPS, Planar3PSim

#: The specification's bound on the loop-closure error, as a fraction of the shortest leg.
CLOSURE_BOUND = 1e-4
#: Control period of the smooth motions (s) and their largest command (fraction of max speed).
DT, PEAK_FRACTION = 0.02, 0.8


def smooth_motions(
    design: Design, n: int, seed: int, substeps: int, iterations: int
) -> dict[str, Any]:
    """Largest closure error (fraction of L_min) and DK gap (m) of each smooth motion, and the
    median step time (us)."""
    mode = DEFAULT_WORKING_MODE
    closure, gap, step_us = [], [], []
    for start, target in motions.well_conditioned_pairs(design, mode, n, seed):
        cmds = motions.min_jerk_commands(
            design, mode, start, target, DT, PEAK_FRACTION * design.max_speed
        )
        sim = Planar3PSim(design, start, mode, dt=DT, substeps=substeps, iterations=iterations)
        worst_c = worst_g = 0.0
        for c in [*cmds, *np.zeros((5, 3))]:
            t0 = time.perf_counter()
            st = sim.step(c)
            step_us.append(1e6 * (time.perf_counter() - t0))
            worst_c = max(worst_c, st.closure_error)
            worst_g = max(worst_g, motions.nearest_dk(design, st.rho, st.pose)[2])
        closure.append(worst_c / design.shortest_leg)
        gap.append(worst_g)
    return {"closure": closure, "dk_gap": gap, "step_us": float(np.median(step_us))}


def controller_episodes(
    suites: list[str], n: int, seed: int, substeps: int, iterations: int
) -> dict[str, list[float]]:
    """Largest closure error (fraction of L_min) of each analytic-controller episode, by suite."""
    env = gym.make("Planar3P-v0", substeps=substeps, solver_iterations=iterations)
    length = env.unwrapped.design.shortest_leg
    controller = AnalyticController.from_env(env)
    out: dict[str, list[float]] = {}
    for name in suites:
        worst = []
        for spec in agent_suites.make_suite(name, n, seed).episodes:
            result = agent_episodes.run_episode(env, controller, spec, policy_name="analytic")
            worst.append(result.max_closure_error / length)
        out[name] = worst
    env.close()
    return out


def describe(values: list[float]) -> str:
    v = np.asarray(values)
    return (
        f"median {np.median(v):.2e}  p95 {np.percentile(v, 95):.2e}  max {v.max():.2e}  "
        f"above 1e-4: {int((v > CLOSURE_BOUND).sum())}/{len(v)}"
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--substeps", type=int, default=DEFAULT_SUBSTEPS)
    ap.add_argument("--iterations", type=int, default=DEFAULT_ITERATIONS)
    ap.add_argument("--pairs", type=int, default=60, help="smooth motions")
    ap.add_argument("--episodes", type=int, default=50, help="controller episodes per suite")
    ap.add_argument("--suites", default="standard,hard,far")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, help="also write the figures as JSON")
    args = ap.parse_args(argv)
    if args.substeps < 1 or args.iterations < 1 or args.pairs < 1 or args.episodes < 0:
        ap.error("--substeps, --iterations and --pairs must be >= 1, --episodes >= 0")
    suites = [s for s in args.suites.split(",") if s]
    unknown = sorted(set(suites) - set(agent_suites.SUITE_NAMES))
    if unknown:
        ap.error(f"unknown suites {unknown}; known: {', '.join(agent_suites.SUITE_NAMES)}")

    design = Design.fig8()
    print(
        f"substeps {args.substeps} ({1000 * DT / args.substeps:.2f} ms), "
        f"iterations {args.iterations}; closure errors in units of "
        f"L_min = {design.shortest_leg} m (bound {CLOSURE_BOUND:g})"
    )
    smooth = smooth_motions(design, args.pairs, args.seed, args.substeps, args.iterations)
    print(f"smooth motions ({args.pairs}, seed {args.seed}):")
    print(f"  closure error   {describe(smooth['closure'])}")
    print(f"  DK gap (m)      max {max(smooth['dk_gap']):.2e}")
    print(f"  median Planar3PSim.step {smooth['step_us']:.1f} us")
    episodes: dict[str, list[float]] = {}
    if args.episodes:
        episodes = controller_episodes(
            suites, args.episodes, args.seed, args.substeps, args.iterations
        )
        print(f"analytic-controller episodes ({args.episodes} per suite, seed {args.seed}):")
        for name, values in episodes.items():
            print(f"  {name:9s} closure error   {describe(values)}")
    if args.json:
        args.json.write_text(
            json.dumps(
                {
                    "substeps": args.substeps,
                    "iterations": args.iterations,
                    "smooth": smooth,
                    "episodes": episodes,
                },
                indent=1,
            )
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
