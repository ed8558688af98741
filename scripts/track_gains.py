#!/usr/bin/env python
"""The feed-forward tracking controller with other feedback gains on the fixed tracking suites.

The same episodes as `planar3p benchmark --suites track-segments,track-figure-eight` with the
same --seed; per suite and gain: the median and worst episode RMS pose error and the failures.

example:
  python scripts/track_gains.py --gains 6,12,25 --episodes 100

Library: tooling.track_gains (gain_sweep).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError
from tooling import script


def add_arguments(p: CliParser) -> None:
    from tooling.track_gains import TRACK_SUITES

    p.add_argument("--gains", default="6,12,25", help="feedback gains k (1/s), comma-separated")
    p.add_argument("--episodes", type=int, default=100, help="episodes per suite")
    p.add_argument("--seed", type=int, default=0, help="seed of the suites")
    p.add_argument(
        "--suites", default=",".join(TRACK_SUITES), help="tracking suites, comma-separated"
    )


def check(args: argparse.Namespace) -> None:
    from tooling.track_gains import TRACK_SUITES

    try:
        args.gains = [float(g) for g in checks.split_list("--gains", args.gains)]
    except ValueError:
        raise UsageError(f"--gains must be comma-separated numbers, got {args.gains!r}") from None
    for k in args.gains:
        if not (math.isfinite(k) and k > 0):
            raise UsageError(f"--gains must be finite and > 0 (1/s), got {k:g}")
    checks.at_least("--episodes", args.episodes, 1)
    checks.at_least("--seed", args.seed, 0)
    args.suites = checks.split_list("--suites", args.suites)
    checks.known("--suites", args.suites, TRACK_SUITES, "suite")


def run(args: argparse.Namespace) -> int:
    from tooling.track_gains import gain_sweep

    rows = gain_sweep(args.gains, args.episodes, args.seed, args.suites)
    print("| suite | gain k 1/s | n | failures | RMS error median mm | RMS error worst mm |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['suite']} | {r['gain']:g} | {r['episodes']} | {r['failures']} | "
            f"{1e3 * r['rms_median']:.3f} | {1e3 * r['rms_worst']:.3f} |"
        )
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run this script with ``argv`` (default: the process's arguments); the exit status."""
    return script.main(__name__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
