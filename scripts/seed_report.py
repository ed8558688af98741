"""Success (or a continuous metric) across training seeds from a benchmark's ``episodes.csv``
(rliable's method).

Examples::

    python scripts/benchmark.py --suites standard,hard,far --out results/ppo-seeds \
        --policies runs/ppo-v1-s1/model.zip:stats=runs/ppo-v1-s1/vecnormalize.pkl,...
    python scripts/seed_report.py results/ppo-seeds/episodes.csv --out results/ppo-seeds/seeds.md
    python scripts/seed_report.py results/track/episodes.csv --metric tracking_rms_error

Policies whose labels differ only by the run's seed token (``-s<n>``) are pooled; each training
seed gives one success rate per suite (``--metric``: or the median over the suite's episodes of
a continuous metric such as ``tracking_rms_error``); the table shows them, their interquartile
mean and its 95 % stratified-bootstrap interval (:mod:`planar3p_agents.evaluation.seed_statistics`).  Bad input:
exit 2 with one line, nothing written.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from planar3p_agents.evaluation import seed_statistics
from planar3p_gym.atomic_files import write_atomic


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("episodes_csv", help="episodes.csv written by scripts/benchmark.py")
    parser.add_argument("--out", help="write the markdown table here (atomically)")
    parser.add_argument("--resamples", type=int, default=2000, help="bootstrap resamples")
    parser.add_argument("--seed", type=int, default=0, help="seed of the resampling")
    parser.add_argument(
        "--metric",
        default="success",
        help=f"score per seed and suite: {', '.join(seed_statistics.METRICS)} (default success)",
    )
    args = parser.parse_args(argv)
    try:
        if args.resamples < 1:
            raise ValueError(f"--resamples must be at least 1, got {args.resamples}")
        if args.seed < 0:
            raise ValueError(f"--seed must be >= 0, got {args.seed}")
        if args.out and not Path(args.out).resolve().parent.is_dir():
            raise ValueError(f"--out: directory {Path(args.out).resolve().parent} does not exist")
        groups = seed_statistics.from_csv(args.episodes_csv, args.metric)
        if not groups:
            raise ValueError(f"{args.episodes_csv} has no rows with a training seed")
        rows = seed_statistics.seed_table(groups, n_resamples=args.resamples, seed=args.seed)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    text = seed_statistics.markdown(rows, args.metric)
    print(text)
    if args.out:
        write_atomic(args.out, text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
