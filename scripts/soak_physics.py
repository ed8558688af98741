#!/usr/bin/env python
"""Soak the physics: seeded random and bang-bang episodes of every registered id, counting how
each episode ends and what the accepted steps leave.

Examples::

    python scripts/soak_physics.py --episodes 1000 --jobs 1 --json soak.json
    python scripts/soak_physics.py --episodes 60 --ids Planar3PAssemblyChange-v0

For each id and policy, ``--episodes`` episodes with reset seeds ``--seed``, ``--seed + 1``,
...; the ``random`` policy takes ``env.action_space.sample()`` (the action space seeded with
the episode's seed), ``bang-bang`` each slider at -1 or +1 (on-off motors: backward or
forward) from a generator of the same seed.  Counted per id and policy:

* the end reason of each episode (``info["termination_reason"]``, ``"time_limit"`` for a
  truncation);
* on every accepted step (one not reported as ``physics_breakdown``): a travel more than
  0.5 mm outside the stroke, and a loop-closure error above 1e-9 m;
* the steps the simulation took through its constrained-dynamics recovery
  (``sim.recovered``, where the simulation has it) and the episodes with one;
* with ``--energy``, on every accepted step the mechanical energy it made beyond the most the
  servos can have done (:func:`excess_energy`): the steps above 1e-3, 0.01 and 1 J and the
  largest (slower: the bodies are read before and after each step).

Not a ``planar3p`` command and not installed: a measurement of the repository
(``docs/physics.md``).  Bad flags: exit 2 with one line naming the flag, before any work.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, NoReturn

import gymnasium as gym
import numpy as np

import planar3p_gym
from planar3p_gym.envs.end_reason import END_REASONS, end_reason

#: Every registered id.
IDS = tuple(spec.id for spec in planar3p_gym.ENV_SPECS)
POLICIES = ("random", "bang-bang")
#: Travel allowed past an end of the stroke on an accepted step (m).
STROKE_TOLERANCE = 5e-4
#: Loop-closure error allowed on an accepted step (m).
CLOSURE_TOLERANCE = 1e-9
#: The issue's first seed.
DEFAULT_SEED = 10_000


def bang_bang(env: gym.Env, rng: np.random.Generator) -> Any:
    """Each slider at full speed backward or forward (-1 or +1), in ``env``'s action type."""
    signs = rng.choice(np.array([-1.0, 1.0], dtype=np.float32), 3)
    action_type = getattr(env.unwrapped, "action_type", "continuous")
    if action_type == "continuous":
        return signs
    digits = np.where(signs > 0.0, 1, 2).astype(np.int64)  # on-off: 1 forward, 2 backward
    return digits if action_type == "on-off" else int(digits @ np.array([9, 3, 1]))


#: Thresholds (J) of the ``--energy`` counts.
ENERGY_LEVELS = (1e-3, 1e-2, 1.0)


def _energy(sim: Any, v: list[float]) -> float:
    """Mechanical energy (J) of the body values ``v`` (the simulation's readout order) with the
    pymunk bodies' masses and moments and the space's gravity."""
    gx, gy = tuple(sim.space.gravity)
    p = sim.platform
    e = 0.5 * p.mass * (v[3] ** 2 + v[4] ** 2) + 0.5 * p.moment * v[5] ** 2
    e -= p.mass * (gx * v[0] + gy * v[1])
    ms = sim.sliders[0].mass
    for i, leg in enumerate(sim.legs):
        o = 6 + 18 * i
        e += 0.5 * ms * v[o + 3] ** 2 - ms * gx * v[o]
        e += 0.5 * leg.mass * (v[o + 15] ** 2 + v[o + 16] ** 2) + 0.5 * leg.moment * v[o + 17] ** 2
        e -= leg.mass * (gx * v[o + 12] + gy * v[o + 13])
    return e


def excess_energy(sim: Any, before: list[float], after: list[float]) -> float:
    """Energy (J) a control step made from the body values ``before`` to ``after`` beyond the
    most the servos can have done: ``max_force`` times each slider's path, the longer of its
    travel and its mean speed times the control period (the simulation's own measure,
    ``planar3p_gym.sim.recovery.excess_energy``, written here on pymunk's bodies so that the
    script measures any version of the simulation alike)."""
    force = sim.servos[0].max_force
    work = 0.0
    for i in range(3):
        o = 6 + 18 * i
        travel = abs(after[o] - before[o])
        work += force * max(travel, 0.5 * (abs(before[o + 3]) + abs(after[o + 3])) * sim.dt)
    return _energy(sim, after) - _energy(sim, before) - work


def soak(
    env_id: str, policy: str, episodes: int, seed: int, energy: bool = False
) -> dict[str, Any]:
    """Run ``episodes`` episodes of ``policy`` on ``env_id`` (module docstring); the counts."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a deprecation notice
        env = gym.make(env_id)
    out: dict[str, Any] = {
        "id": env_id,
        "policy": policy,
        "episodes": episodes,
        "steps": 0,
        "end_reasons": dict.fromkeys(END_REASONS, 0),
        "stroke_violations": 0,
        "closure_violations": 0,
        "max_overshoot_mm": 0.0,
        "max_accepted_closure": 0.0,
        "recovered_steps": 0,
        "episodes_with_recovery": 0,
        "breakdown_seeds": [],
    }
    if energy:
        out["energy_steps_over"] = dict.fromkeys(map(str, ENERGY_LEVELS), 0)
        out["max_excess_energy"] = -math.inf
    unwrapped = env.unwrapped
    for k in range(episodes):
        s = seed + k
        env.reset(seed=s)
        env.action_space.seed(s)
        rng = np.random.default_rng(s)
        recovered = 0
        while True:
            a = env.action_space.sample() if policy == "random" else bang_bang(env, rng)
            before = unwrapped.sim.body_values() if energy else None
            _, _, terminated, truncated, info = env.step(a)
            out["steps"] += 1
            sim = unwrapped.sim
            recovered += bool(getattr(sim, "recovered", False))
            reason = end_reason(terminated, truncated, info)
            if info.get("termination_reason") != "physics_breakdown":
                state = sim.state
                rho = state.rho
                overshoot = max(-min(rho), max(rho) - unwrapped.design.stroke)
                out["stroke_violations"] += overshoot > STROKE_TOLERANCE
                out["closure_violations"] += not state.closure_error <= CLOSURE_TOLERANCE
                out["max_overshoot_mm"] = max(out["max_overshoot_mm"], 1e3 * overshoot)
                out["max_accepted_closure"] = max(out["max_accepted_closure"], state.closure_error)
                if before is not None:
                    x = excess_energy(sim, before, sim.body_values())
                    for level in ENERGY_LEVELS:
                        out["energy_steps_over"][str(level)] += x > level
                    out["max_excess_energy"] = max(out["max_excess_energy"], x)
            if reason is not None:
                out["end_reasons"][reason] += 1
                if reason == "physics_breakdown":
                    out["breakdown_seeds"].append(s)
                break
        out["recovered_steps"] += recovered
        out["episodes_with_recovery"] += recovered > 0
    env.close()
    out["breakdown_fraction"] = out["end_reasons"]["physics_breakdown"] / episodes
    return out


class Parser(argparse.ArgumentParser):
    """One line and exit status 2 for a bad flag."""

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"soak_physics.py: error: {message}\n")
        raise SystemExit(2)


def parse(argv: list[str] | None) -> argparse.Namespace:
    """The command line, checked (exit 2 with one line on a bad flag)."""
    p = Parser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
        allow_abbrev=False,
    )
    p.add_argument("--episodes", type=int, default=1000, help="episodes per id and policy")
    p.add_argument("--seed", type=int, default=DEFAULT_SEED, help="first reset seed (>= 0)")
    p.add_argument("--ids", nargs="+", default=list(IDS), metavar="ID", help="ids to soak")
    p.add_argument(
        "--policies", nargs="+", default=list(POLICIES), choices=POLICIES, help="policies"
    )
    p.add_argument("--jobs", type=int, default=1, help="worker processes (>= 1)")
    p.add_argument(
        "--energy", action="store_true", help="also count the steps that make energy (slower)"
    )
    p.add_argument("--json", type=Path, default=None, metavar="FILE", help="write the results")
    args = p.parse_args(argv)
    if args.episodes < 1:
        p.error(f"--episodes must be >= 1, got {args.episodes}")
    if args.seed < 0:
        p.error(f"--seed must be >= 0, got {args.seed}")
    if args.jobs < 1:
        p.error(f"--jobs must be >= 1, got {args.jobs}")
    unknown = [i for i in args.ids if i not in IDS]
    if unknown:
        p.error(f"--ids: unknown id {unknown[0]!r} (registered: {', '.join(IDS)})")
    if args.json is not None and (args.json.is_dir() or not args.json.parent.is_dir()):
        p.error(f"--json: cannot write {str(args.json)!r} (not a file in an existing directory)")
    return args


COLUMNS = (
    ("id", 26), ("policy", 9), ("episodes", 8), ("steps", 8), ("breakdown", 9),
    ("success", 7), ("crossing", 8), ("time_limit", 10), ("stroke", 6), ("closure", 7),
    ("recovered", 9), ("rec_eps", 7),
)  # fmt: skip


def row(values: list[str]) -> str:
    return " ".join(
        v.rjust(w) if i > 1 else v.ljust(w)
        for i, (v, (_, w)) in enumerate(zip(values, COLUMNS, strict=True))
    )


def table_row(r: dict[str, Any]) -> str:
    ends = r["end_reasons"]
    return row(
        [
            r["id"], r["policy"], str(r["episodes"]), str(r["steps"]),
            str(ends["physics_breakdown"]), str(ends["success"]),
            str(ends["singularity_crossing"]), str(ends["time_limit"]),
            str(r["stroke_violations"]), str(r["closure_violations"]),
            str(r["recovered_steps"]), str(r["episodes_with_recovery"]),
        ]
    )  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    tasks = [(i, p, args.episodes, args.seed, args.energy) for i in args.ids for p in args.policies]
    start = time.perf_counter()
    print(row([name for name, _ in COLUMNS]), flush=True)
    results = []
    if args.jobs == 1:
        for t in tasks:
            results.append(soak(*t))
            print(table_row(results[-1]), flush=True)
    else:
        with ProcessPoolExecutor(args.jobs) as pool:
            for r in pool.map(soak, *zip(*tasks, strict=True)):
                results.append(r)
                print(table_row(r), flush=True)
    seconds = time.perf_counter() - start
    worst = max(r["breakdown_fraction"] for r in results)
    if args.energy:
        print("energy beyond the servos' work, accepted steps above 1e-3 / 0.01 / 1 J | largest")
        for r in results:
            over = r["energy_steps_over"]
            print(
                f"{r['id']} {r['policy']} | {over['0.001']} / {over['0.01']} / {over['1.0']} | "
                f"{r['max_excess_energy']:.3g}"
            )
    print(
        f"largest breakdown share {100 * worst:.2f} %; stroke violations "
        f"{sum(r['stroke_violations'] for r in results)}, closure violations "
        f"{sum(r['closure_violations'] for r in results)} ({seconds:.0f} s)"
    )
    if args.json is not None:
        settings = {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()}
        payload = {"settings": settings, "seconds": seconds, "results": results}
        args.json.write_text(json.dumps(payload, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
