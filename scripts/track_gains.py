#!/usr/bin/env python
"""The feed-forward tracking controller with other feedback gains on the benchmark's fixed
tracking suites (same episodes as ``scripts/benchmark.py --suites track-segments,
track-figure-eight`` with the same ``--seed``): median and worst episode RMS pose error.

    python scripts/track_gains.py --gains 6,12,25 --episodes 100

Bad input: exit 2 with one line.  The work is :func:`planar3p_agents.studies.track_gains.gain_sweep`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main(argv: list[str] | None = None) -> int:
    from planar3p_agents.studies.track_gains import TRACK_SUITES, gain_sweep

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gains", default="6,12,25", help="comma-separated gains k (1/s)")
    parser.add_argument("--episodes", type=int, default=100, help="episodes per suite")
    parser.add_argument("--seed", type=int, default=0, help="seed of the suites")
    parser.add_argument("--suites", default=",".join(TRACK_SUITES), help="tracking suites")
    args = parser.parse_args(argv)
    try:
        try:
            gains = [float(g) for g in args.gains.split(",")]
        except ValueError:
            raise ValueError(
                f"--gains must be comma-separated numbers, got {args.gains!r}"
            ) from None
        if args.episodes < 1:
            raise ValueError(f"--episodes must be >= 1, got {args.episodes}")
        rows = gain_sweep(gains, args.episodes, args.seed, args.suites.split(","))
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print("| suite | gain k 1/s | n | failures | RMS error median mm | RMS error worst mm |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['suite']} | {r['gain']:g} | {r['episodes']} | {r['failures']} | "
            f"{1e3 * r['rms_median']:.3f} | {1e3 * r['rms_worst']:.3f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
