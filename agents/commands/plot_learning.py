"""Plot learning curves of training runs (evaluations.npz written by `planar3p train`).

Runs are grouped by name (the directory without -s<seed>); for each group the IQM over seeds
of the evaluation success rate and return is drawn against environment steps, with its 95 %
bootstrap interval shaded.  Also prints a table of every run (steps, wall time, steps/s, final
success rate) as markdown.

example:
  planar3p plot-learning runs/sac-s1 runs/ppo-s1 --out results/learning.png

Library: planar3p_agents.evaluation.learning_curves.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError


def add_arguments(p: CliParser) -> None:
    p.add_argument("runs", nargs="+", type=Path, help="run directories")
    p.add_argument(
        "--out",
        type=Path,
        default=Path("docs/figures/learning_curves.png"),
        help="the figure (PNG; missing directories are made)",
    )


def check(args: argparse.Namespace) -> None:
    for run in args.runs:
        checks.input_dir("runs", run)
    checks.output_file("--out", args.out, parents=True)


def run(args: argparse.Namespace) -> int:
    import matplotlib

    matplotlib.use("Agg")
    from planar3p_agents.evaluation.learning_curves import load_run, plot, table

    try:
        runs = [load_run(path) for path in args.runs]
    except ValueError as exc:
        raise UsageError(str(exc)) from exc
    plot(runs, args.out)
    print(table(runs))
    print(f"\nlearning curves written to {args.out}")
    return 0
