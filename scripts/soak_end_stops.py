#!/usr/bin/env python
"""Soak the end stops: random actions on every registered id, counting the steps that leave
the stroke, exceed the slider rate limit or leave the loop open, and the breakdowns.

Examples::

    python scripts/soak_end_stops.py                      # 1 000 000 steps per id and policy
    python scripts/soak_end_stops.py --steps-per-id 50000 --seed 1
    python scripts/soak_end_stops.py --ids Planar3PAssemblyChange-v0

Each id runs ``--steps-per-id`` steps with uniform-random actions and as many with bang-bang
actions (each component -1 or +1), resetting as episodes end (reset seeds and actions from
``--seed``).  On every step the simulation's own state is checked (:func:`check_state`):

* stroke: a travel outside ``[-0.5 mm, stroke + 0.5 mm]``;
* rate: a slider faster than the projection's rate limit
  (:attr:`planar3p_gym.sim.projection.LoopProjector.rate_limit`, 1 m/s on the default design);
* closure: a loop-closure error above 1e-9 m on the projected ids (above the breakdown
  distance on ``Planar3P-v0``) on a step that was not reported as a breakdown;

and an episode that ends with ``info["termination_reason"] == "physics_breakdown"`` counts as a
breakdown.  The table gives, per id and policy: steps, episodes, violating steps of each kind,
episodes with a stroke or rate violation, breakdowns, the largest overshoot past a stop (mm)
and the largest slider rate (m/s).  Bad arguments: exit 2 naming the flag, before any work.
"""

from __future__ import annotations

import argparse
import time
import warnings
from collections.abc import Sequence

import gymnasium as gym
import numpy as np

import planar3p_gym
from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError
from planar3p_gym.sim.projection import MAX_CLOSURE_ERROR, LoopProjector
from tooling import script

#: Every registered id.
IDS = tuple(spec.id for spec in planar3p_gym.ENV_SPECS)
POLICIES = ("uniform", "bang-bang")
#: Allowed travel past an end of the stroke (m).
STROKE_TOLERANCE = 5e-4


def action(policy: str, rng: np.random.Generator, env: gym.Env | None = None) -> np.ndarray:
    """One action of ``policy`` (``"uniform"`` or ``"bang-bang"``) from ``rng``; for an
    ``env`` with on-off motors, as its motor commands (a rate above a third of the largest:
    forward, below minus a third: backward, else stop; the same draws either way)."""
    if policy == "uniform":
        a = rng.uniform(-1.0, 1.0, 3).astype(np.float32)
    else:
        a = rng.choice(np.array([-1.0, 1.0], dtype=np.float32), 3)
    action_type = getattr(getattr(env, "unwrapped", None), "action_type", "continuous")
    if action_type == "continuous":
        return a
    digits = np.where(a > 1.0 / 3.0, 1, np.where(a < -1.0 / 3.0, 2, 0)).astype(np.int64)
    return digits if action_type == "on-off" else digits @ np.array([9, 3, 1])


def rate_limit(env: gym.Env) -> float:
    """The slider rate limit (m/s) of ``env``'s design."""
    return LoopProjector(env.unwrapped.design).rate_limit


def check_state(env: gym.Env, breakdown: bool) -> dict[str, float]:
    """The end-stop measures of ``env``'s simulation after a step: ``overshoot`` (m past a
    stop, <= 0 inside the stroke), ``rate`` (largest ``|rho_dot|``, m/s) and ``closure_ok``
    (1.0 when the closure error is within tolerance or the step was a breakdown, else 0.0)."""
    unwrapped = env.unwrapped
    state = unwrapped.sim.state
    stroke = unwrapped.design.stroke
    rho = state.rho
    overshoot = max(-min(rho), max(rho) - stroke)
    rate = max(abs(r) for r in state.rho_dot)
    tolerance = MAX_CLOSURE_ERROR if unwrapped.projection else unwrapped.breakdown_distance
    closure_ok = breakdown or state.closure_error <= tolerance
    return {"overshoot": overshoot, "rate": rate, "closure_ok": float(closure_ok)}


def soak(env_id: str, policy: str, steps: int, seed: int) -> dict[str, float]:
    """Run ``steps`` steps of ``policy`` on ``env_id``; the counts of the module docstring."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Planar3P-v0's deprecation notice
        env = gym.make(env_id)
    limit = rate_limit(env)
    rng = np.random.default_rng([seed, IDS.index(env_id), POLICIES.index(policy)])
    out = {
        "steps": 0,
        "episodes": 0,
        "stroke": 0,
        "rate": 0,
        "closure": 0,
        "bad_episodes": 0,
        "breakdowns": 0,
        "max_overshoot_mm": 0.0,
        "max_rate": 0.0,
    }
    episode_seed = int(rng.integers(2**31))
    while out["steps"] < steps:
        env.reset(seed=episode_seed + out["episodes"])
        out["episodes"] += 1
        bad = False
        while out["steps"] < steps:
            _, _, terminated, truncated, info = env.step(action(policy, rng, env))
            out["steps"] += 1
            breakdown = info["termination_reason"] == "physics_breakdown"
            m = check_state(env, breakdown)
            stroke_bad = m["overshoot"] > STROKE_TOLERANCE
            rate_bad = m["rate"] > limit
            out["stroke"] += stroke_bad
            out["rate"] += rate_bad
            out["closure"] += m["closure_ok"] == 0.0
            bad = bad or stroke_bad or rate_bad
            out["max_overshoot_mm"] = max(out["max_overshoot_mm"], 1e3 * m["overshoot"])
            out["max_rate"] = max(out["max_rate"], m["rate"])
            if terminated or truncated:
                out["breakdowns"] += breakdown
                break
        out["bad_episodes"] += bad
    env.close()
    return out


COLUMNS = (
    ("id", 26),
    ("policy", 9),
    ("steps", 9),
    ("episodes", 8),
    ("stroke", 6),
    ("rate", 6),
    ("closure", 7),
    ("bad_eps", 7),
    ("breakdowns", 10),
    ("max_over_mm", 11),
    ("max_rate", 8),
)


def row(values: list[str]) -> str:
    return " ".join(
        v.rjust(w) if i > 1 else v.ljust(w)
        for i, (v, (_, w)) in enumerate(zip(values, COLUMNS, strict=True))
    )


def add_arguments(p: CliParser) -> None:
    p.add_argument(
        "--steps-per-id",
        type=int,
        default=1_000_000,
        help="steps per id and policy (uniform, bang-bang)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of resets and actions (>= 0)")
    p.add_argument(
        "--ids",
        nargs="+",
        default=list(IDS),
        metavar="ID",
        help=f"environment ids to soak (default: all, {', '.join(IDS)})",
    )


def check(args: argparse.Namespace) -> None:
    if args.steps_per_id < 1:
        raise UsageError(f"--steps-per-id must be >= 1, got {args.steps_per_id}")
    if args.seed < 0:
        raise UsageError(f"--seed must be >= 0, got {args.seed}")
    checks.known("--ids", args.ids, IDS, "id")


def run(args: argparse.Namespace) -> int:
    print(row([name for name, _ in COLUMNS]))
    total = {"stroke": 0, "rate": 0, "closure": 0}
    start = time.perf_counter()
    for env_id in args.ids:
        for policy in POLICIES:
            r = soak(env_id, policy, args.steps_per_id, args.seed)
            for key in total:
                total[key] += r[key]
            print(
                row(
                    [
                        env_id,
                        policy,
                        str(r["steps"]),
                        str(r["episodes"]),
                        str(r["stroke"]),
                        str(r["rate"]),
                        str(r["closure"]),
                        str(r["bad_episodes"]),
                        str(r["breakdowns"]),
                        f"{r['max_overshoot_mm']:.3f}",
                        f"{r['max_rate']:.3f}",
                    ]
                ),
                flush=True,
            )
    print(
        f"violating steps: stroke {total['stroke']}, rate {total['rate']}, "
        f"closure {total['closure']} ({time.perf_counter() - start:.0f} s)"
    )
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run this script with ``argv`` (default: the process's arguments); the exit status."""
    return script.main(__name__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
