"""Measure the analytic baselines on the goal-conditioned and tracking ids.

* ``Planar3PGoal-v0``: the analytic controller through :class:`agents.goal_adapter.GoalAdapter`
  (success rate, steps to success, return).
* ``Planar3PTrack-v0``: the analytic controller with and without the reference velocity fed
  forward (:class:`agents.tracking.TrackingController`), per reference kind: the episodes' RMS
  and maximum pose error ``|dp| + L_ref |dtheta|``.

    python scripts/task_baselines.py --episodes 100 --seed 0 [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import sys

import gymnasium as gym
import numpy as np

import planar3p_gym
from agents.goal_adapter import GoalAdapter
from agents.tracking import TrackingController, run_tracking_episodes, summarize_tracking


def goal_baseline(env_id: str, episodes: int, seed: int) -> dict[str, float]:
    """Success rate, mean steps of the successful episodes and mean return of the analytic
    controller on a goal id."""
    env = gym.make(env_id)
    ctrl = GoalAdapter.analytic(env)
    obs, _ = env.reset(seed=seed)
    wins, steps, returns = 0, [], []
    for _ in range(episodes):
        ctrl.reset()
        total, n = 0.0, 0
        while True:
            obs, reward, terminated, truncated, info = env.step(ctrl.predict(obs)[0])
            total += reward
            n += 1
            if terminated or truncated:
                break
        if info["is_success"]:
            wins += 1
            steps.append(n)
        returns.append(total)
        obs, _ = env.reset()
    return {
        "episodes": episodes,
        "success_rate": wins / episodes,
        "steps_to_success_mean": float(np.mean(steps)) if steps else float("nan"),
        "return_mean": float(np.mean(returns)),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", help="also write the summaries to this file")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        print("error: --episodes must be >= 1", file=sys.stderr)
        return 2
    results: dict[str, dict[str, float]] = {}
    print("id                    controller  success  steps to success  mean return")
    for env_id in (planar3p_gym.GOAL_ENV_ID, planar3p_gym.GOAL_DENSE_ENV_ID):
        s = goal_baseline(env_id, args.episodes, args.seed)
        results[f"{env_id}/analytic"] = s
        print(
            f"{env_id:21s} analytic   {100 * s['success_rate']:6.1f} %"
            f"  {s['steps_to_success_mean']:16.1f}  {s['return_mean']:11.2f}"
        )
    print()
    print(
        "reference     controller               failures  RMS mean  RMS median  RMS worst  "
        "max mean  max worst  (pose error |dp| + L_ref |dtheta|, mm)"
    )
    for kind in ("segments", "figure_eight"):
        for label, ff in (("analytic (feedback)", 0.0), ("analytic + feed-forward", 1.0)):
            env = gym.make(planar3p_gym.TRACK_ENV_ID, reference=kind)
            ctrl = TrackingController.from_env(env, feedforward=ff)
            s = summarize_tracking(run_tracking_episodes(env, ctrl, args.episodes, args.seed))
            results[f"{planar3p_gym.TRACK_ENV_ID}/{kind}/{label}"] = s
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
