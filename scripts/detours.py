#!/usr/bin/env python
"""Which reach pairs a certified slider path reaches at the speed bound: the straight line and
two-segment paths through a grid of waypoints.

Per pair of the suites' first --episodes episodes: whether the straight slider line is
certified, where its branch ends, and the smallest time over the speed bound of a certified
two-segment path through the waypoints rho_start + f (rho_target - rho_start), f from
--fractions per slider.  Prints one summary row per suite; --csv writes one row per pair.

example:
  python scripts/detours.py --suite-file docs/benchmark/strongest-baselines/suites.json \
      --suites standard,hard --episodes 100

Library: tooling.detours.
"""

from __future__ import annotations

import argparse
import csv
import io
import math
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError
from tooling import script

#: The benchmark's suite file in the repository (found from this file, not from the working
#: directory).
DEFAULT_SUITE_FILE = (
    Path(__file__).resolve().parents[1]
    / "docs"
    / "benchmark"
    / "strongest-baselines"
    / "suites.json"
)


def add_arguments(p: CliParser) -> None:
    from tooling.detours import DEFAULT_FRACTIONS, DEFAULT_POINTS

    p.add_argument(
        "--suite-file",
        default=str(DEFAULT_SUITE_FILE),
        help="benchmark suite file (planar3p benchmark --suite-file); default: the "
        "repository's docs/benchmark/strongest-baselines/suites.json",
    )
    p.add_argument("--suites", default="standard,hard", help="reach suites, comma-separated")
    p.add_argument("--episodes", type=int, default=100, help="first episodes of each suite")
    p.add_argument(
        "--fractions",
        default=",".join(f"{f:g}" for f in DEFAULT_FRACTIONS),
        help="waypoint fractions of each slider's travel, comma-separated",
    )
    p.add_argument("--points", type=int, default=DEFAULT_POINTS, help="points per segment")
    p.add_argument("--csv", default=None, help="write one row per pair to this CSV file")


def check(args: argparse.Namespace) -> None:
    from planar3p_agents.evaluation.reach_suites import load_suites

    checks.at_least("--episodes", args.episodes, 1)
    checks.at_least("--points", args.points, 2)
    try:
        args.fractions = [float(f) for f in checks.split_list("--fractions", args.fractions)]
    except ValueError:
        raise UsageError(
            f"--fractions must be comma-separated numbers, got {args.fractions!r}"
        ) from None
    if not all(math.isfinite(f) for f in args.fractions):
        raise UsageError(f"--fractions must be finite, got {args.fractions}")
    path = checks.input_file("--suite-file", args.suite_file)
    try:
        args.loaded, args.design = load_suites(path)
    except ValueError as exc:
        raise UsageError(f"--suite-file: {exc}") from None
    args.suites = checks.split_list("--suites", args.suites)
    reach = [n for n, s in args.loaded.items() if s.episodes and s.episodes[0].target is not None]
    checks.known("--suites", args.suites, reach, "reach suite")
    if args.csv is not None:
        args.csv = checks.output_file("--csv", args.csv, parents=True)


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from planar3p_agents.controllers.certified import DEFAULT_LIMITS
    from planar3p_gym import atomic_files
    from tooling.detours import pair_detours, suite_summary

    limits = replace(DEFAULT_LIMITS, points=args.points)
    print(
        "| suite | pairs | straight line certified | its branch ends at another pose | "
        "some surveyed path certified | best time / speed bound p10 / median / p90 |"
    )
    print("|---|---|---|---|---|---|")
    table = []
    for name in args.suites:
        rows = [
            pair_detours(args.design, ep, args.fractions, limits)
            for ep in args.loaded[name].episodes[: args.episodes]
        ]
        s = suite_summary(rows)
        print(
            f"| {name} | {s['pairs']} | {s['straight']} | {s['other_solution']} | "
            f"{s['reachable']} | {s['ratio_p10']:.2f} / {s['ratio_median']:.2f} / "
            f"{s['ratio_p90']:.2f} |",
            flush=True,
        )
        table += [{"suite": name, **asdict(r)} for r in rows]
    if args.csv is not None:
        text = io.StringIO()
        writer = csv.DictWriter(text, fieldnames=list(table[0]))
        writer.writeheader()
        writer.writerows(table)
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        atomic_files.write_atomic(args.csv, text.getvalue())
        print(f"per pair: {args.csv}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run this script with ``argv`` (default: the process's arguments); the exit status."""
    return script.main(__name__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
