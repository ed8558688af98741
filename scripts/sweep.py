#!/usr/bin/env python
"""Run training sweeps as Ray Tune trials: seeds x configurations, or an Optuna search.

Each trial is one ``scripts/train.py`` run (same code: :mod:`planar3p_agents.training.run`) with one CPU
and one torch thread; the results land in one table (``<out>/results.csv`` / ``.md``, one row
per trial with its training seed; see :mod:`planar3p_agents.training.sweep`).

Examples::

    # 5 seeds of the shipped PPO settings, on this machine (local Ray, one trial per core)
    python scripts/sweep.py --algo ppo --seeds 0 1 2 3 4 --timesteps 1e6 --out sweeps/ppo
    # seeds x configurations from a YAML file: {name: {params: {...}, env_kwargs: {...}}}
    python scripts/sweep.py --algo ppo --seeds 0 1 2 --grid grid.yml --out sweeps/grid
    # Optuna search (Ray Tune's OptunaSearch): {learning_rate: {loguniform: [1e-5, 1e-3]}}
    python scripts/sweep.py --algo sac --seeds 0 --search space.yml --num-samples 20 --out s
    # on a running Ray cluster (ray start --head on one node, ray start --address=... on others)
    python scripts/sweep.py --algo ppo --seeds 0 1 2 3 4 --address auto --out sweeps/ppo
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from planar3p_agents.training.config import ALGORITHMS, parse_overrides  # noqa: E402
from planar3p_agents.training.run import VEC_ENVS, RunOptions  # noqa: E402
from planar3p_agents.training.sweep import SweepSpec, load_spec_file, run_sweep  # noqa: E402


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--algo", required=True, help=f"one of {', '.join(ALGORITHMS)}")
    p.add_argument("--env", default="Planar3P-v0", help="registered environment id")
    p.add_argument("--seeds", type=int, nargs="+", required=True, help="training seeds")
    p.add_argument("--timesteps", type=float, default=None, help="env steps per trial")
    p.add_argument("--out", type=Path, required=True, help="new output directory")
    p.add_argument("--grid", type=Path, help="YAML: configuration name -> settings")
    p.add_argument("--params", nargs="*", default=[], metavar="KEY=YAML", help="one configuration")
    p.add_argument("--n-envs", type=int, default=None, help="parallel envs per trial")
    p.add_argument("--hyperparams", default=None, help="YAML file (rl-zoo3 format)")
    p.add_argument("--search", type=Path, help="YAML: hyperparameter -> distribution")
    p.add_argument("--num-samples", type=int, default=8, help="configurations to search")
    p.add_argument(
        "--metric",
        default="final_success_rate",
        choices=("final_success_rate", "final_mean_return"),
    )
    p.add_argument("--search-seed", type=int, default=0, help="seed of Optuna's sampler")
    p.add_argument("--address", default=None, help="Ray cluster address (default: local Ray)")
    p.add_argument("--num-cpus", type=int, default=None, help="local Ray's CPUs (default all)")
    p.add_argument("--eval-freq", type=int, default=10_000)
    p.add_argument("--eval-episodes", type=int, default=20)
    p.add_argument("--final-eval-episodes", type=int, default=100)
    p.add_argument("--checkpoint-freq", type=int, default=50_000)
    p.add_argument(
        "--vec-env",
        choices=VEC_ENVS,
        default="auto",
        help="vectorised env class of each trial (native: all envs in the trial's one process)",
    )
    return p.parse_args(argv)


def spec_from(args: argparse.Namespace) -> SweepSpec:
    """The sweep described by the command line (``ValueError`` on bad input)."""
    if args.grid and args.search:
        raise ValueError("give --grid or --search, not both")
    if args.grid and args.params:
        raise ValueError("--params applies without --grid (put them in the grid file)")
    if args.grid and args.n_envs is not None:
        raise ValueError("--n-envs applies without --grid (put n_envs in the grid file)")
    grid = load_spec_file(args.grid) if args.grid else {"default": {}}
    if not args.grid:
        grid = {"default": {"params": parse_overrides(args.params), "n_envs": args.n_envs}}
    if args.num_cpus is not None and args.num_cpus < 1:
        raise ValueError(f"--num-cpus must be at least 1, got {args.num_cpus}")
    return SweepSpec(
        algo=args.algo.lower(),
        seeds=list(args.seeds),
        env_id=args.env,
        timesteps=args.timesteps,
        grid=grid,
        search=load_spec_file(args.search) if args.search else None,
        num_samples=args.num_samples,
        metric=args.metric,
        search_seed=args.search_seed,
        hyperparams=args.hyperparams,
        options=RunOptions(
            eval_freq=args.eval_freq,
            eval_episodes=args.eval_episodes,
            final_eval_episodes=args.final_eval_episodes,
            checkpoint_freq=args.checkpoint_freq,
            progress_bar=False,
            vec_env=args.vec_env,
        ),
    )


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    command = " ".join(shlex.quote(a) for a in (sys.argv if argv is None else ["sweep.py", *argv]))
    try:
        spec = spec_from(args)
        rows = run_sweep(
            spec, args.out, address=args.address, num_cpus=args.num_cpus, command=command
        )
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print((args.out / "results.md").read_text())
    failed = [r for r in rows if r["status"] != "ok"]
    print(f"{len(rows)} trials, {len(failed)} failed; table: {args.out / 'results.csv'}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
