#!/usr/bin/env python
"""Reset times of every registered id: ``env.reset(seed=s)`` for ``s`` in a range of seeds.

Prints, per id, the median, p99, p99.9 and maximum wall time of one seeded reset (ms), how
many of the interpreter's full garbage collections ran during the resets and the longest of
them (ms), and the seeds of the slowest resets.  A full collection traverses every object of the
process (about 100 ms once numba is loaded) and lands in whichever reset triggers it;
``--freeze-gc`` calls :func:`gc.freeze` after making the envs (and :func:`gc.unfreeze` at the
end), which leaves the objects alive then out of those traversals: the difference between the
two runs is what the collector, not the resets' own work, costs.  The target is a p99.9
below 100 ms over 10,000 seeds on a quiet machine; this script measures, it asserts
nothing (timings depend on the machine, so no test times anything).

Each id is made once with ``gym.make`` (the construction is not timed) and reset once unseeded
before the timed resets (first-use costs such as lazily built tables are not counted).

Usage::

    python scripts/bench_resets.py                        # every id, 10,000 seeds
    python scripts/bench_resets.py --seeds 500 --ids Planar3PModeChange-v0
    python scripts/bench_resets.py --ids Planar3PModeChange-v0 \\
        --kwargs '{"working_mode": "random"}'
    python scripts/bench_resets.py --ids Planar3PAssemblyChange-v0 --freeze-gc
    python scripts/bench_resets.py --clock cpu   # on a machine shared with other jobs

Library: tooling.throughput.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import time
from collections.abc import Callable, Sequence
from typing import Any

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import gymnasium as gym
import numpy as np

import planar3p_gym
from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError
from planar3p_gym.atomic_files import write_atomic
from planar3p_gym.envs.registry import ENV_SPECS
from tooling import script
from tooling.throughput import FullCollections, reset_summary, reset_times

ALL_IDS = tuple(row.id for row in ENV_SPECS)
#: How many of the slowest seeds are listed per id.
SLOWEST = 5
#: The clocks of ``--clock``.
CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def add_arguments(ap: CliParser) -> None:
    ap.add_argument("--seeds", type=int, default=10_000, help="number of seeded resets per id")
    ap.add_argument("--first-seed", type=int, default=0, help="the first seed of the range")
    ap.add_argument(
        "--ids",
        nargs="+",
        default=list(ALL_IDS),
        metavar="ID",
        help=f"environment ids to measure (default: all, {', '.join(ALL_IDS)})",
    )
    ap.add_argument(
        "--kwargs",
        default="{}",
        metavar="JSON",
        help="keyword arguments of gym.make for every id, a JSON object, e.g. "
        '\'{"working_mode": "random"}\'',
    )
    ap.add_argument(
        "--freeze-gc",
        action="store_true",
        help="call gc.freeze() once the envs are made (the objects alive then, numba's compiler "
        "state among them, are left out of later full garbage collections)",
    )
    ap.add_argument(
        "--clock",
        choices=tuple(CLOCKS),
        default="wall",
        help="what is timed: wall time, or the process's CPU time (time.process_time: the "
        "resets' own work, without the waits a loaded machine adds)",
    )
    ap.add_argument("--json", metavar="PATH", help="also write the figures as JSON to PATH")


def check(args: argparse.Namespace) -> None:
    """Validate the arguments before any environment is made (one line naming the flag)."""
    if args.seeds < 1:
        raise UsageError(f"--seeds must be >= 1, got {args.seeds}")
    if args.first_seed < 0:
        raise UsageError(f"--first-seed must be >= 0, got {args.first_seed}")
    checks.known("--ids", args.ids, ALL_IDS, "id")
    try:
        kwargs = json.loads(args.kwargs)
    except json.JSONDecodeError as exc:
        raise UsageError(f"--kwargs: not JSON ({exc})") from None
    if not isinstance(kwargs, dict):
        raise UsageError(f"--kwargs must be a JSON object, got {args.kwargs}")
    args.kwargs = kwargs
    if args.json is not None:
        checks.output_file("--json", args.json)


def make_envs(ids: list[str], kwargs: dict[str, Any]) -> dict[str, gym.Env]:
    """Every id made with ``kwargs`` (before anything is measured); a rejected ``--kwargs``
    exits with status 2 and one line."""
    envs = {}
    for env_id in ids:
        try:
            envs[env_id] = gym.make(env_id, **kwargs)
        except (ValueError, TypeError) as exc:
            for env in envs.values():
                env.close()
            message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise UsageError(f"--kwargs: {env_id}: {message}") from None
    return envs


def summary(times: np.ndarray, seeds: range) -> dict[str, Any]:
    """Median, p99, p99.9, max (ms) and the slowest seeds."""
    return reset_summary(times, seeds, SLOWEST)


def run(args: argparse.Namespace) -> int:
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    envs = make_envs(args.ids, args.kwargs)
    if args.freeze_gc:
        gc.freeze()
    print(
        f"python {platform.python_version()}, gymnasium {gym.__version__}, "
        f"planar3p_gym {planar3p_gym.__version__}, {os.cpu_count()} CPUs, "
        f"load average {os.getloadavg()[0]:.2f}; seeds {seeds.start}..{seeds.stop - 1}"
        + (f", kwargs {args.kwargs}" if args.kwargs else "")
        + (", gc.freeze() after making the envs" if args.freeze_gc else "")
        + (", CPU time" if args.clock == "cpu" else "")
    )
    print(
        f"{'id':<28} {'resets':>7} {'median':>8} {'p99':>8} {'p99.9':>8} {'max':>8} "
        f"{'full GCs':>9} {'longest':>8}  slowest seeds (ms)"
    )
    results = {}
    try:
        for env_id, env in envs.items():
            results[env_id] = _measure(env_id, env, seeds, CLOCKS[args.clock])
    finally:
        if args.freeze_gc:
            gc.unfreeze()
    print(f"(times in ms; load average {os.getloadavg()[0]:.2f} at the end)")
    if args.json is not None:
        record = {
            "seeds": [seeds.start, seeds.stop],
            "kwargs": args.kwargs,
            "freeze_gc": args.freeze_gc,
            "clock": args.clock,
            **results,
        }
        write_atomic(args.json, json.dumps(record, indent=2) + "\n")
    return 0


def _measure(
    env_id: str, env: gym.Env, seeds: range, clock: Callable[[], float] = time.perf_counter
) -> dict[str, Any]:
    """Time the resets of one env by ``clock``, print its line and return its figures (the env
    is closed)."""
    try:
        with FullCollections() as full:
            times = reset_times(env, seeds, clock)
    finally:
        env.close()
    fig = summary(times, seeds)
    fig["full_collections"] = len(full.times)
    fig["longest_full_collection_ms"] = 1e3 * max(full.times, default=0.0)
    slow = ", ".join(f"{s}: {t:g}" for s, t in fig["slowest"])
    print(
        f"{env_id:<28} {fig['resets']:>7} {fig['median_ms']:>8.2f} {fig['p99_ms']:>8.2f} "
        f"{fig['p99.9_ms']:>8.2f} {fig['max_ms']:>8.2f} {fig['full_collections']:>9} "
        f"{fig['longest_full_collection_ms']:>8.2f}  {slow}",
        flush=True,
    )
    return fig


def main(argv: Sequence[str] | None = None) -> int:
    """Run the script with ``argv`` (default: the process's arguments); the exit status."""
    return script.main(__name__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
