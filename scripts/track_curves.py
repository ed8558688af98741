#!/usr/bin/env python
"""Learning curves of residual tracking policies in tracking error: every checkpoint of every
run played on the benchmark's fixed tracking suites; per seed the median episode RMS pose
error, across seeds its IQM with a 95 % stratified-bootstrap interval.

    python scripts/track_curves.py runs/T-track-s1 runs/T-track-s2 ... \\
        --episodes 20 --out docs/figures/learning_curves_track.png

Model files are code: only the named runs' checkpoints are loaded (no statistics: the tracking
recipe normalises rewards only).  Bad input: exit 2 with one line.  The work is
:mod:`planar3p_agents.studies.track_curves`.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main(argv: list[str] | None = None) -> int:
    from planar3p_agents.evaluation.benchmark import training_seed
    from planar3p_agents.studies.track_curves import (
        SuitePlayer,
        checkpoints,
        plot_curves,
        run_curve,
        seed_curves,
    )
    from planar3p_agents.studies.track_gains import TRACK_SUITES

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run directories of scripts/train.py")
    parser.add_argument("--episodes", type=int, default=20, help="episodes per suite")
    parser.add_argument("--seed", type=int, default=0, help="seed of the suites")
    parser.add_argument("--out", type=Path, default=Path("docs/figures/learning_curves_track.png"))
    parser.add_argument("--json", type=Path, help="also write the curves (m) here")
    args = parser.parse_args(argv)
    try:
        if args.episodes < 1:
            raise ValueError(f"--episodes must be >= 1, got {args.episodes}")
        if args.out.is_dir():
            raise ValueError(f"--out {args.out} is a directory (give a .png file)")
        seeds = {}
        for run in args.runs:
            checkpoints(run)  # every run is usable before anything is played
            seed = training_seed(run / "model.zip")
            if seed is None or seed in seeds:
                raise ValueError(f"{run}: no training seed in config.json, or seed given twice")
            seeds[seed] = run
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    players = [SuitePlayer(name, args.episodes, args.seed) for name in TRACK_SUITES]
    curves = {s: run_curve(run, players) for s, run in sorted(seeds.items())}
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
        args.json.write_text(json.dumps({str(s): c for s, c in curves.items()}, indent=2))
    print(f"\nlearning curves written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
