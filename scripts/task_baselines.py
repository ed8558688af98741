"""Measure the analytic controller on ``Planar3PTrack-v0``, with and without the reference
velocity fed forward: per reference kind, the episodes' RMS and maximum pose error.

    python scripts/track_baseline.py --episodes 50 --seed 0 [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import sys

import gymnasium as gym

import planar3p_gym
from agents.tracking import TrackingController, run_tracking_episodes, summarize_tracking


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", help="also write the summaries to this file")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        print("error: --episodes must be >= 1", file=sys.stderr)
        return 2
    results = {}
    print(
        "reference     controller               failures  RMS mean  RMS median  RMS worst  "
        "max mean  max worst  (pose error |dp| + L_ref |dtheta|, mm)"
    )
    for kind in ("segments", "figure_eight"):
        for label, ff in (("analytic (feedback)", 0.0), ("analytic + feed-forward", 1.0)):
            env = gym.make(planar3p_gym.TRACK_ENV_ID, reference=kind)
            ctrl = TrackingController.from_env(env, feedforward=ff)
            s = summarize_tracking(run_tracking_episodes(env, ctrl, args.episodes, args.seed))
            results[f"{kind}/{label}"] = s
            print(
                f"{kind:13s} {label:24s} {s['failures']:3d}/{s['episodes']:<4d}"
                f" {1e3 * s['rms_error_mean']:8.2f}  {1e3 * s['rms_error_median']:10.2f}"
                f" {1e3 * s['rms_error_worst']:9.2f}  {1e3 * s['max_error_mean']:8.2f}"
                f" {1e3 * s['max_error_worst']:9.2f}"
            )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(results, fh, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
