#!/usr/bin/env python
"""Plot learning curves of training runs (``evaluations.npz`` written by ``scripts/train.py``).

Runs are grouped by name (the directory without ``-s<seed>``); for each group the mean over
seeds of the evaluation success rate and return is drawn against environment steps, with the
range over seeds shaded.  Also prints a table of every run (steps, wall time, steps/s, final
success rate) as markdown.  The work is done by :mod:`planar3p_agents.evaluation.learning_curves`.

    python scripts/plot_learning.py runs/sac-s1 runs/ppo-s1 --out results/learning.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from planar3p_agents.evaluation.learning_curves import load_run, plot, table  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("runs", nargs="+", type=Path, help="run directories")
    p.add_argument("--out", type=Path, default=Path("docs/figures/learning_curves.png"))
    args = p.parse_args(argv)
    if args.out.is_dir():
        print(f"error: --out {args.out} is a directory (give a .png file)", file=sys.stderr)
        return 2
    try:
        runs = [load_run(path) for path in args.runs]
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    plot(runs, args.out)
    print(table(runs))
    print(f"\nlearning curves written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
