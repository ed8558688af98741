"""Success (or a continuous metric) across training seeds from a benchmark's episodes.csv.

Policies whose labels differ only by the run's seed token (-s<n>) are pooled; each training
seed gives one success rate per suite (--metric: or the median over the suite's episodes of a
continuous metric such as tracking_rms_error); the table shows them, their interquartile mean
and its 95 % stratified-bootstrap interval (rliable's method).

examples:
  planar3p benchmark --suites standard,hard,far --out results/ppo-seeds \\
      --policies runs/ppo-s1/model.zip:stats=runs/ppo-s1/vecnormalize.pkl,...
  planar3p seed-report results/ppo-seeds/episodes.csv --out results/ppo-seeds/seeds.md
  planar3p seed-report results/track/episodes.csv --metric tracking_rms_error

Library: planar3p_agents.evaluation.seed_statistics.
"""

from __future__ import annotations

import argparse

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError


def add_arguments(p: CliParser) -> None:
    from planar3p_agents.evaluation import seed_statistics

    p.add_argument("episodes_csv", help="episodes.csv written by `planar3p benchmark`")
    p.add_argument("--out", help="also write the markdown table here (atomically)")
    p.add_argument("--resamples", type=int, default=2000, help="bootstrap resamples")
    p.add_argument("--seed", type=int, default=0, help="seed of the resampling")
    p.add_argument(
        "--metric",
        default="success",
        help=f"score per seed and suite: {', '.join(seed_statistics.METRICS)}",
    )


def check(args: argparse.Namespace) -> None:
    from planar3p_agents.evaluation import seed_statistics

    if args.metric not in seed_statistics.METRICS:
        raise UsageError(
            f"--metric: unknown metric {args.metric!r}; choose from "
            f"{', '.join(seed_statistics.METRICS)}"
        )
    checks.at_least("--resamples", args.resamples, 1)
    checks.at_least("--seed", args.seed, 0)
    checks.input_file("episodes_csv", args.episodes_csv)
    if args.out:
        checks.output_file("--out", args.out)


def run(args: argparse.Namespace) -> int:
    from planar3p_agents.evaluation import seed_statistics
    from planar3p_gym.atomic_files import write_atomic

    try:
        groups = seed_statistics.from_csv(args.episodes_csv, args.metric)
        if not groups:
            raise ValueError(f"{args.episodes_csv} has no rows with a training seed")
        rows = seed_statistics.seed_table(groups, n_resamples=args.resamples, seed=args.seed)
    except ValueError as exc:
        raise UsageError(str(exc)) from exc
    text = seed_statistics.markdown(rows, args.metric)
    print(text)
    if args.out:
        write_atomic(args.out, text + "\n")
    return 0
