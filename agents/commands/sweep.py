"""Run training sweeps as Ray Tune trials: seeds x configurations, or an Optuna search.

Each trial is one `planar3p train` run (same code: planar3p_agents.training.run) with one
CPU and one torch thread; the results land in one table (<out>/results.csv and .md, one row
per trial with its training seed; planar3p_agents.training.sweep).  Every trial is planned and
checked, and --out must be new (or empty) and writable, before Ray starts; an interrupt (Ctrl-C
or SIGTERM) stops the trials and the Ray processes this command started.

examples:
  # 5 seeds of the shipped PPO settings, on this machine (local Ray, one trial per core)
  planar3p sweep --algo ppo --seeds 0 1 2 3 4 --timesteps 1e6 --out sweeps/ppo
  # seeds x configurations from a YAML file: {name: {params: {...}, env_kwargs: {...}}}
  planar3p sweep --algo ppo --seeds 0 1 2 --grid grid.yml --out sweeps/grid
  # Optuna search (Ray Tune's OptunaSearch): {learning_rate: {loguniform: [1e-5, 1e-3]}}
  planar3p sweep --algo sac --seeds 0 --search space.yml --num-samples 20 --out s
  # on a running Ray cluster (ray start --head on one node, ray start --address=... on others)
  planar3p sweep --algo ppo --seeds 0 1 2 3 4 --address auto --out sweeps/ppo
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError

#: Most configurations an Optuna search may draw.
MAX_SAMPLES = 10_000


def add_arguments(p: CliParser) -> None:
    from planar3p_agents.commands.train import VEC_ENV_HELP
    from planar3p_agents.training.config import ALGORITHMS
    from planar3p_agents.training.run import VEC_ENVS

    p.add_argument("--algo", required=True, help=f"algorithm: {', '.join(ALGORITHMS)}")
    p.add_argument("--env", default="Planar3P-v0", help="registered environment id")
    p.add_argument("--seeds", type=int, nargs="+", required=True, help="training seeds")
    p.add_argument(
        "--timesteps",
        type=float,
        default=None,
        help="environment steps per trial (default: n_timesteps of the hyperparameter entry)",
    )
    p.add_argument("--out", type=Path, required=True, help="output directory, new or empty")
    p.add_argument("--grid", type=Path, help="YAML: configuration name -> settings")
    p.add_argument("--params", nargs="*", default=[], metavar="KEY=YAML", help="one configuration")
    p.add_argument(
        "--n-envs",
        type=int,
        default=None,
        help="parallel envs per trial (default: n_envs of the hyperparameter entry, else 1)",
    )
    p.add_argument(
        "--hyperparams",
        default=None,
        help="YAML file in rl-zoo3 format (default: agents/training/hyperparams/<algo>.yml)",
    )
    p.add_argument("--search", type=Path, help="YAML: hyperparameter -> distribution")
    p.add_argument(
        "--num-samples",
        type=int,
        default=8,
        help=f"configurations an Optuna search draws (1 to {MAX_SAMPLES}; with --search)",
    )
    p.add_argument(
        "--metric",
        default="final_success_rate",
        choices=("final_success_rate", "final_mean_return"),
        help="what a search maximises",
    )
    p.add_argument("--search-seed", type=int, default=0, help="seed of Optuna's sampler")
    p.add_argument(
        "--address", default=None, help="Ray cluster address (default: start a local Ray)"
    )
    p.add_argument(
        "--num-cpus", type=int, default=None, help="CPUs of the local Ray (default: all)"
    )
    p.add_argument("--eval-freq", type=int, default=10_000, help="steps between evaluations")
    p.add_argument("--eval-episodes", type=int, default=20, help="episodes per evaluation")
    p.add_argument(
        "--final-eval-episodes", type=int, default=100, help="episodes of the final evaluation"
    )
    p.add_argument("--checkpoint-freq", type=int, default=50_000, help="steps between saves")
    p.add_argument(
        "--vec-env",
        choices=VEC_ENVS,
        default="auto",
        help=VEC_ENV_HELP.replace("vectorised env class", "vectorised env class of each trial"),
    )


def spec_from(args: argparse.Namespace) -> Any:
    """The :class:`~planar3p_agents.training.sweep.SweepSpec` the command line describes
    (``ValueError`` on bad input)."""
    from planar3p_agents.training.config import parse_overrides
    from planar3p_agents.training.run import RunOptions
    from planar3p_agents.training.sweep import SweepSpec, load_spec_file

    if args.grid and args.search:
        raise ValueError("give --grid or --search, not both")
    if args.grid and args.params:
        raise ValueError("--params applies without --grid (put them in the grid file)")
    if args.grid and args.n_envs is not None:
        raise ValueError("--n-envs applies without --grid (put n_envs in the grid file)")
    if args.grid:
        grid = load_spec_file(args.grid)
    else:
        grid = {"default": {"params": parse_overrides(args.params), "n_envs": args.n_envs}}
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


def check(args: argparse.Namespace) -> None:
    from planar3p_agents.training.config import ALGORITHMS, MAX_SEED

    if args.algo.lower() not in ALGORITHMS:
        raise UsageError(
            f"--algo: unknown algorithm {args.algo!r}; choose from {', '.join(ALGORITHMS)}"
        )
    for seed in args.seeds:
        checks.in_range("--seeds", seed, 0, MAX_SEED)
    if len(set(args.seeds)) != len(args.seeds):
        raise UsageError(f"--seeds must be distinct, got {args.seeds}")
    checks.in_range("--num-samples", args.num_samples, 1, MAX_SAMPLES)
    checks.at_least("--search-seed", args.search_seed, 0)
    if args.num_cpus is not None:
        checks.at_least("--num-cpus", args.num_cpus, 1)
    if args.timesteps is not None:
        checks.in_range("--timesteps", args.timesteps, 0, 1e12, low_open=True)
    for flag, path in (("--grid", args.grid), ("--search", args.search)):
        if path is not None:
            checks.input_file(flag, path)
    checks.output_dir("--out", args.out)
    try:
        args.spec = spec_from(args)
    except ValueError as exc:
        raise UsageError(str(exc)) from exc
    check_extra()


#: The top-level modules of the ``sweep`` extra (Ray Tune runs the trials, Optuna searches).
SWEEP_MODULES = ("ray", "optuna")


def check_extra() -> None:
    """:class:`UsageError` naming the ``sweep`` extra if one of its modules is not installed
    (looked up, not imported: importing Ray takes about a second)."""
    missing = [m for m in SWEEP_MODULES if importlib.util.find_spec(m) is None]
    if missing:
        raise UsageError(
            f"{', '.join(missing)} not installed: the sweep needs the 'sweep' extra "
            "(pip install 'planar3p-gym[sweep]')"
        )


@contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """SIGTERM raises ``KeyboardInterrupt`` (as Ctrl-C does) while inside, so that cleanup
    code runs on either (Python's default for SIGTERM ends the process without any)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt(f"signal {signum}")

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def run(args: argparse.Namespace) -> int:
    # SIGTERM must reach Python, so that the sweep's cleanup (ray.shutdown) runs: before Ray
    # starts, terminate_as_interrupt raises KeyboardInterrupt; once it runs, ray.init's own
    # handler raises SystemExit.  Ray's crash handler (C++) would take the signal first and
    # abort the process, skipping the cleanup.
    os.environ.setdefault("RAY_DISABLE_FAILURE_SIGNAL_HANDLER", "1")
    import ray

    from planar3p_agents.training import sweep

    ray_was_up = ray.is_initialized()
    try:
        with terminate_as_interrupt():
            rows = sweep.run_sweep(
                args.spec,
                args.out,
                address=args.address,
                num_cpus=args.num_cpus,
                command=args.command_line,
            )
    except BaseException as exc:
        if not ray_was_up:  # also a Ray interrupted while it was starting
            ray.shutdown()
        if isinstance(exc, ValueError):  # the sweep's own checks, before any trial
            raise UsageError(str(exc)) from exc
        raise
    print((args.out / "results.md").read_text())
    failed = [r for r in rows if r["status"] != "ok"]
    print(f"{len(rows)} trials, {len(failed)} failed; table: {args.out / 'results.csv'}")
    return 1 if failed else 0
