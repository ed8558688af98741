#!/usr/bin/env python
"""Analytic baselines on the goal-conditioned and tracking ids.

  Planar3PGoal-v0, Planar3PGoalDense-v0   the analytic controller through GoalAdapter:
                                          success rate, steps to success, mean return
  Planar3PTrack-v0                        the analytic controller with and without the
                                          reference velocity fed forward, per reference kind:
                                          the episodes' RMS and maximum pose error
                                          |dp| + L_ref |dtheta| (mm)

Episodes: the first reset with --seed, the following ones unseeded.

example:
  python scripts/goal_track_baselines.py --episodes 100 --seed 0 --only track --json out.json

Library: tooling.goal_track_baselines.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser
from tooling import script


def add_arguments(p: CliParser) -> None:
    p.add_argument("--episodes", type=int, default=100, help="episodes per id and policy")
    p.add_argument("--seed", type=int, default=0, help="seed of the first reset")
    p.add_argument(
        "--only", choices=("goal", "track"), help="measure only one family (default: both)"
    )
    p.add_argument(
        "--json", type=Path, metavar="PATH", help="also write the summaries to this file"
    )


def check(args: argparse.Namespace) -> None:
    checks.at_least("--episodes", args.episodes, 1)
    checks.at_least("--seed", args.seed, 0)
    if args.json is not None:
        checks.output_file("--json", args.json)


def run(args: argparse.Namespace) -> int:
    import json

    import planar3p_gym
    from planar3p_gym.atomic_files import write_atomic
    from tooling.goal_track_baselines import goal_baseline, tracking_baselines

    results: dict[str, dict[str, float]] = {}
    if args.only != "track":
        print("id                    controller  success  steps to success  mean return")
        for env_id in (planar3p_gym.GOAL_ENV_ID, planar3p_gym.GOAL_DENSE_ENV_ID):
            s = goal_baseline(env_id, args.episodes, args.seed)
            results[f"{env_id}/analytic"] = s
            print(
                f"{env_id:21s} analytic   {100 * s['success_rate']:6.1f} %"
                f"  {s['steps_to_success_mean']:16.1f}  {s['return_mean']:11.2f}",
                flush=True,
            )
    if args.only != "goal":
        print(
            "reference     controller               failures  RMS mean  RMS median  RMS worst"
            "  max mean  max worst  (pose error, mm)"
        )
        for key, s in tracking_baselines(args.episodes, args.seed).items():
            kind, label = key.split("/")
            results[f"{planar3p_gym.TRACK_ENV_ID}/{key}"] = s
            print(
                f"{kind:13s} {label:24s} {s['failures']:3d}/{s['episodes']:<4d}"
                f" {1e3 * s['rms_error_mean']:8.2f}  {1e3 * s['rms_error_median']:10.2f}"
                f" {1e3 * s['rms_error_worst']:9.2f}  {1e3 * s['max_error_mean']:8.2f}"
                f" {1e3 * s['max_error_worst']:9.2f}"
            )
    if args.json:
        write_atomic(args.json, json.dumps(results, indent=2))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run this script with ``argv`` (default: the process's arguments); the exit status."""
    return script.main(__name__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
