#!/usr/bin/env python
"""Learning curves of residual tracking policies in tracking error, over seeds.

Every checkpoint of every run is played on the benchmark's fixed tracking suites; per seed the
median episode RMS pose error, across seeds its IQM with a 95 % stratified-bootstrap interval.
Model files are code: only the named runs' checkpoints are loaded (no statistics: the tracking
recipe normalises rewards only).  Each run needs a JSON config.json with its training seed,
each seed once.

example:
  python scripts/track_curves.py runs/T-track-s1 runs/T-track-s2 --episodes 20 \\
      --out docs/figures/learning_curves_track.png

Library: tooling.track_curves.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError
from tooling import script


def add_arguments(p: CliParser) -> None:
    p.add_argument("runs", nargs="+", type=Path, help="run directories of `planar3p train`")
    p.add_argument("--episodes", type=int, default=20, help="episodes per suite")
    p.add_argument("--seed", type=int, default=0, help="seed of the suites")
    p.add_argument(
        "--out",
        type=Path,
        default=Path("docs/figures/learning_curves_track.png"),
        help="the figure (PNG; missing directories are made)",
    )
    p.add_argument("--json", type=Path, metavar="PATH", help="also write the curves (m) here")


def check(args: argparse.Namespace) -> None:
    from tooling.track_curves import checkpoints

    checks.at_least("--episodes", args.episodes, 1)
    checks.at_least("--seed", args.seed, 0)
    checks.output_file("--out", args.out, parents=True)
    if args.json is not None:
        checks.output_file("--json", args.json)
    args.seeds = {}
    for run in args.runs:
        checks.input_dir("runs", run)
        record = checks.json_file("runs", run / "config.json")
        seed = record.get("config", {}).get("seed") if isinstance(record, dict) else None
        if not isinstance(seed, int) or isinstance(seed, bool):
            raise UsageError(f"runs: {run / 'config.json'} has no training seed (config.seed)")
        if seed in args.seeds:
            raise UsageError(f"runs: {run} and {args.seeds[seed]} both have training seed {seed}")
        try:
            checkpoints(run)  # every run is usable before anything is played
        except ValueError as exc:
            raise UsageError(f"runs: {exc}") from exc
        args.seeds[seed] = run


def run(args: argparse.Namespace) -> int:
    import json

    import matplotlib

    matplotlib.use("Agg")
    from planar3p_gym.atomic_files import write_atomic
    from tooling.track_curves import (
        SuitePlayer,
        plot_curves,
        run_curve,
        seed_curves,
    )
    from tooling.track_gains import TRACK_SUITES

    players = [SuitePlayer(name, args.episodes, args.seed) for name in TRACK_SUITES]
    try:
        curves = {s: run_curve(run, players) for s, run in sorted(args.seeds.items())}
    finally:
        for player in players:
            player.close()
    baselines = {f"{n}/analytic-feedforward": c[n][0] for c in curves.values() for n in c}
    plot_curves(curves, baselines, args.out)
    print("| suite | steps | median RMS error mm per seed | IQM mm [95 % CI] |")
    print("|---|---|---|---|")
    for name, rows in seed_curves(curves).items():
        for step, iqm, lo, hi in rows:
            per_seed = " / ".join(f"{1e3 * c[name][step]:.3f}" for c in curves.values())
            ci = f"{1e3 * iqm:.3f} [{1e3 * lo:.3f}, {1e3 * hi:.3f}]"
            print(f"| {name} | {step} | {per_seed} | {ci} |")
    if args.json:
        write_atomic(args.json, json.dumps({str(s): c for s, c in curves.items()}, indent=2))
    print(f"\nlearning curves written to {args.out}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run this script with ``argv`` (default: the process's arguments); the exit status."""
    return script.main(__name__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
