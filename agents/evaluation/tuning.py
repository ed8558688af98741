"""The analytic controllers' gains tuned per suite on a separate draw (baselines
``analytic-tuned`` and ``analytic-feedforward-tuned``).

A baseline tuned on the episodes it is then scored on would be flattered; so each suite is
drawn again from :data:`TUNING_SEED` (never the benchmark's seed), and the gain is chosen on
that draw among a fixed grid:

* reach suites (``standard``, ``hard``, ``far``, the goal-conditioned ``goal`` and
  ``goal-dense`` and the built machine's ``real-reach``), the simple motions
  (``analytic-simultaneous:gain=K`` of the baseline registry, through the goal adapter on the
  goal ids): the highest success rate, then the shortest median time to success, then the
  smaller gain;
* tracking suites (``track-segments``, ``track-figure-eight``), the feed-forward controller
  (:class:`~planar3p_agents.controllers.tracking.TrackingController`): no failure (crossing or
  breakdown), then the smallest median RMS tracking error, then the smaller gain.

The chosen gains are data, :data:`TUNED_GAINS_FILE` (``tuned_gains.json`` beside this module,
with the command that produced it and every gain's figures); the registry's builders read them
with :func:`tuned_gain`.  Regenerate::

    python -m planar3p_agents.evaluation.tuning --out agents/evaluation/tuned_gains.json
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
from collections.abc import Sequence
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from planar3p_gym.envs.end_reason import TIME_LIMIT

__all__ = [
    "REACH_GRID",
    "TRACK_GRID",
    "TUNED_BASELINES",
    "TUNED_GAINS_FILE",
    "TUNING_SEED",
    "tune_all",
    "tune_gain",
    "tuned_gain",
]

#: Seed of the tuning draws (the benchmark's suites use ``--seed``, 0 by default).
TUNING_SEED = 1000
#: Gains tried on the reach suites (1/s).
REACH_GRID: tuple[float, ...] = (4.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0, 25.0, 30.0)
#: Gains tried on the tracking suites (1/s).
TRACK_GRID: tuple[float, ...] = (4.0, 6.0, 8.0, 12.0, 16.0, 20.0, 25.0, 30.0, 40.0)
#: The file of tuned gains.
TUNED_GAINS_FILE = Path(__file__).with_name("tuned_gains.json")
#: Tuned baseline -> (the controller tuned, the suites it is tuned on, default suite).
TUNED_BASELINES: dict[str, tuple[str, tuple[str, ...], str]] = {
    "analytic-tuned": (
        "analytic-simultaneous",
        ("standard", "hard", "far", "goal", "goal-dense", "real-reach"),
        "standard",
    ),
    "analytic-feedforward-tuned": (
        "analytic-feedforward",
        ("track-segments", "track-figure-eight"),
        "track-segments",
    ),
}


def _controller(name: str, env: Any, gain: float) -> Any:
    from planar3p_agents.controllers.tracking import TrackingController
    from planar3p_agents.policies.factory import load_policy

    if name == "analytic-feedforward":
        return TrackingController.from_env(env, position_gain=gain, orientation_gain=gain)
    return load_policy(f"{name}:gain={gain:g}", env)


def _draw(suite: str, episodes: int, seed: int) -> tuple[Any, Any]:
    """The suite's environment and its episodes drawn from ``seed``."""
    import gymnasium as gym

    import planar3p_gym
    from planar3p_agents.evaluation.reach_suites import SUITE_NAMES, make_suite
    from planar3p_agents.evaluation.task_suites import make_task_env, make_task_suite

    if suite in SUITE_NAMES:
        env = gym.make(planar3p_gym.ENV_ID)
        return env, make_suite(suite, episodes, seed, env.unwrapped.design)
    env = make_task_env(suite)
    return env, make_task_suite(suite, episodes, seed, env=env)


def _score(suite: str, results: list[Any]) -> dict[str, Any]:
    times = [r.time_to_success for r in results if r.success]
    rms = [r.task_metrics["tracking_rms_error"] for r in results if r.task_metrics]
    return {
        "success_rate": float(np.mean([r.success for r in results])),
        "median_time_to_success": float(np.median(times)) if times else math.nan,
        "failures": sum(r.termination_reason not in ("success", TIME_LIMIT) for r in results),
        "median_tracking_rms_error": float(np.median(rms)) if rms else math.nan,
    }


def _key(row: dict[str, Any], tracking: bool) -> tuple[float, ...]:
    """Sort key: smaller is better (see the module docstring)."""
    if tracking:
        err = row["median_tracking_rms_error"]
        return (row["failures"], err if math.isfinite(err) else math.inf, row["gain"])
    t = row["median_time_to_success"]
    return (-row["success_rate"], t if math.isfinite(t) else math.inf, row["gain"])


def tune_gain(
    suite: str,
    seed: int = TUNING_SEED,
    *,
    episodes: int = 50,
    gains: Sequence[float] | None = None,
) -> tuple[float, list[dict[str, Any]]]:
    """The gain (1/s) chosen for ``suite`` on its draw from ``seed`` (``episodes`` episodes)
    and each gain's figures.  A reach suite tunes the simple motions, a tracking suite the
    feed-forward controller (module docstring).  ``ValueError`` for another suite."""
    tracking = suite.startswith("track-")
    controller = next((c for c, s, _ in TUNED_BASELINES.values() if suite in s), None)
    if controller is None:
        raise ValueError(
            f"no tuned baseline plays suite {suite!r}; tuned suites: "
            + ", ".join(s for _, ss, _ in TUNED_BASELINES.values() for s in ss)
        )
    grid = tuple(gains) if gains is not None else (TRACK_GRID if tracking else REACH_GRID)
    from planar3p_agents.evaluation.episodes import evaluate

    env, draw = _draw(suite, episodes, seed)
    rows = []
    try:
        for g in grid:
            res = evaluate(env, _controller(controller, env, float(g)), draw, seed=seed)
            rows.append({"gain": float(g), **_score(suite, res)})
    finally:
        env.close()
    best = min(rows, key=lambda r: _key(r, tracking))
    return best["gain"], rows


def tune_all(seed: int = TUNING_SEED, episodes: int = 50, track_episodes: int = 20) -> dict:
    """:func:`tune_gain` for every suite of :data:`TUNED_BASELINES`: the content of
    :data:`TUNED_GAINS_FILE` (without its ``command``)."""
    out: dict[str, Any] = {"seed": seed, "episodes": {}, "gains": {}, "sweeps": {}}
    for name, (_, suites, default) in TUNED_BASELINES.items():
        out["gains"][name] = {}
        for suite in suites:
            n = track_episodes if suite.startswith("track-") else episodes
            gain, rows = tune_gain(suite, seed, episodes=n)
            out["gains"][name][suite] = gain
            out["episodes"][suite] = n
            out["sweeps"][suite] = rows
        out["gains"][name]["default"] = out["gains"][name][default]
    return out


@cache
def _table(path: str) -> dict[str, Any]:
    return json.loads(Path(path).read_text())


def tuned_gain(baseline: str, suite: str | None = None, path: str | Path | None = None) -> float:
    """The gain (1/s) of tuned baseline ``baseline`` on ``suite`` from the tuned-gains file
    (``None`` or a suite it was not tuned on: its default suite's gain).  ``ValueError`` if
    the file or the entry is missing."""
    p = Path(path) if path is not None else TUNED_GAINS_FILE
    try:
        gains = _table(str(p))["gains"][baseline]
    except (OSError, ValueError, KeyError) as exc:
        raise ValueError(
            f"no tuned gain of {baseline!r} in {p.name} ({exc}); regenerate it with "
            "python -m planar3p_agents.evaluation.tuning"
        ) from exc
    return float(gains.get(suite or "default", gains["default"]))


def _json_safe(x: Any) -> Any:
    """``x`` with non-finite floats as ``None`` (strict JSON)."""
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_json_safe(v) for v in x]
    return x


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Tune the analytic baselines' gains per suite.")
    parser.add_argument("--out", default=str(TUNED_GAINS_FILE), help="the JSON file written")
    parser.add_argument("--seed", type=int, default=TUNING_SEED, help="seed of the tuning draws")
    parser.add_argument("--episodes", type=int, default=50, help="episodes per reach suite")
    parser.add_argument("--track-episodes", type=int, default=20, help="per tracking suite")
    args = parser.parse_args(argv)
    given = list(argv) if argv is not None else sys.argv[1:]
    data = {
        "command": "python -m planar3p_agents.evaluation.tuning " + shlex.join(given),
        **tune_all(args.seed, args.episodes, args.track_episodes),
    }
    Path(args.out).write_text(json.dumps(_json_safe(data), indent=1) + "\n")
    print(json.dumps(data["gains"], indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
