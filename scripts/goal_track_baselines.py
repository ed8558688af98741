"""Analytic baselines on the goal-conditioned and tracking ids.

* ``Planar3PGoal-v0`` / ``Planar3PGoalDense-v0``: the analytic controller through
  :class:`planar3p_agents.controllers.goal_adapter.GoalAdapter` (success rate, steps to success, mean return).
* ``Planar3PTrack-v0``: the analytic controller with and without the reference velocity fed
  forward (:class:`planar3p_agents.controllers.tracking.TrackingController`), per reference kind: the episodes' RMS
  and maximum pose error ``|dp| + L_ref |dtheta|`` (mm).

    python scripts/goal_track_baselines.py --episodes 100 --seed 0 [--only goal|track]
        [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main(argv: list[str] | None = None) -> int:
    import planar3p_gym
    from planar3p_agents.studies.goal_track_baselines import goal_baseline, tracking_baselines

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=100, help="episodes per id and policy")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first reset")
    parser.add_argument("--only", choices=("goal", "track"), help="measure only one family")
    parser.add_argument("--json", help="also write the summaries to this file")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        print("error: --episodes must be >= 1", file=sys.stderr)
        return 2
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
        track = tracking_baselines(args.episodes, args.seed)
        for key, s in track.items():
            kind, label = key.split("/")
            results[f"{planar3p_gym.TRACK_ENV_ID}/{key}"] = s
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
