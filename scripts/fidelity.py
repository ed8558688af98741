#!/usr/bin/env python
"""How faithful is the physics?  Closure error and DK gap of the unprojected and projected model.

For the unprojected pymunk model (8 substeps x 18 iterations, projection=False) and the
projected one (Planar3P-v0's physics), side by side:

  smooth motions        --pairs open-loop minimum-jerk motions between well-conditioned poses:
                        the largest closure error (joint separation, m) of each motion and the
                        largest gap between the simulated pose and the exact direct kinematics
                        of the simulated travels (|(dx, dy, L_ref dtheta)|, m)
  controller episodes   --episodes episodes per reach suite driven by the analytic controller:
                        per episode the largest closure error and DK gap, over all steps and
                        over the steps whose parallel margin is at least 0.02

Prints medians and maxima, and the median wall time of Planar3PSim.step; --json also writes
the figures (report keys: v0 = unprojected, v1 = projected).

Library: tooling.physics_fidelity.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser
from tooling import script

LABELS = {"v0": "unprojected (projection=False)", "v1": "projected (Planar3P-v0)"}


def add_arguments(p: CliParser) -> None:
    p.add_argument("--pairs", type=int, default=60, help="smooth motions")
    p.add_argument("--episodes", type=int, default=30, help="controller episodes per suite")
    p.add_argument("--suites", default="standard,hard,far", help="reach suites, comma-separated")
    p.add_argument("--seed", type=int, default=0, help="seed of the motions and the suites")
    p.add_argument("--json", type=Path, metavar="PATH", help="also write the figures as JSON")


def check(args: argparse.Namespace) -> None:
    from planar3p_agents.evaluation import reach_suites

    checks.at_least("--pairs", args.pairs, 1)
    checks.at_least("--episodes", args.episodes, 1)
    checks.at_least("--seed", args.seed, 0)
    args.suites = checks.split_list("--suites", args.suites)
    checks.known("--suites", args.suites, reach_suites.SUITE_NAMES, "suite")
    if args.json is not None:
        checks.output_file("--json", args.json)


def _describe(values: list[float]) -> str:
    import numpy as np

    v = np.asarray(values, dtype=float)
    return f"median {np.median(v):.1e}  max {v.max():.1e}"


def run(args: argparse.Namespace) -> int:
    from planar3p_gym import Design
    from planar3p_gym.sim import physics
    from tooling.physics_fidelity import MARGIN, fidelity_report
    from tooling.throughput import write_json_atomic

    report = fidelity_report(args.pairs, args.episodes, args.suites, args.seed)
    design = Design.fig8()
    print(f"closure error and DK gap in m (L_min = {design.shortest_leg} m), seed {args.seed}")
    for model, r in report["models"].items():
        sub = r["settings"].get("substeps", physics.DEFAULT_SUBSTEPS)
        it = r["settings"].get("iterations", physics.DEFAULT_ITERATIONS)
        print(f"\n{model}, {LABELS[model]}: {sub} substeps x {it} iterations")
        s = r["smooth"]
        print(f"  smooth motions ({args.pairs}): closure {_describe(s['closure'])}")
        print(f"  {'':22s}DK gap  {_describe(s['dk_gap'])}")
        print(f"  median Planar3PSim.step {s['step_us']:.1f} us")
        for name, e in r["episodes"].items():
            print(
                f"  {name:9s} ({args.episodes} analytic episodes): closure "
                f"{_describe(e['closure'])}"
            )
            print(
                f"  {'':10s}DK gap {_describe(e['dk_gap'])}; at margin >= {MARGIN}: "
                f"{_describe(e['dk_gap_margin_ok'])}"
            )
    if args.json:
        write_json_atomic(args.json, report)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run this script with ``argv`` (default: the process's arguments); the exit status."""
    return script.main(__name__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
