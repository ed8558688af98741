"""Train a PPO, SAC, TD3, TQC or DQN agent (Stable-Baselines3 / sb3-contrib) on a registered id.

Hyperparameters come from agents/training/hyperparams/<algo>.yml (rl-zoo3 format, keyed by
the environment id) unless --hyperparams names another file; --params overrides single
entries.  Every run writes a self-contained directory (config.json, metrics.json, the model,
its VecNormalize statistics, checkpoints, evaluations.npz, TensorBoard logs); --resume
continues a run from its last checkpoint.  Everything, the run directory included, is checked
before the directory is created (bad input: exit 2, one line).

examples:
  planar3p train --algo sac --timesteps 300000 --seed 1
  planar3p train --algo ppo --n-envs 8 --env-kwargs working_mode='[1,1,-1]'
  planar3p train --algo sac --run-dir runs/sac-s1 --resume

Library: planar3p_agents.training.run (plan_run, execute).
"""

from __future__ import annotations

import argparse
from dataclasses import fields
from pathlib import Path

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError

#: Where a run goes without --run-dir (relative to the working directory).
DEFAULT_RUN_DIR = "runs/<algo>-<env>-s<seed>"
#: What --vec-env picks, by choice.
VEC_ENV_HELP = (
    "vectorised env class: auto = native where the id has a native vector env, else "
    "SubprocVecEnv when --n-envs > 1, else DummyVecEnv; dummy = DummyVecEnv; subproc = "
    "SubprocVecEnv; native = all envs in this process through the native vector env (ids with "
    "a native vector entry point: Planar3P-v0 and the flat-observation task ids)"
)


def add_arguments(p: CliParser) -> None:
    from planar3p_agents.policies.factory import TRUSTED_FILES_NOTE
    from planar3p_agents.training.config import ALGORITHMS
    from planar3p_agents.training.run import VEC_ENVS

    p.note(f"--kickstart and --resume load model and statistics files: {TRUSTED_FILES_NOTE}")
    p.add_argument("--algo", required=True, help=f"algorithm: {', '.join(ALGORITHMS)}")
    p.add_argument("--env", default="Planar3P-v0", help="registered environment id")
    p.add_argument(
        "--timesteps",
        type=float,
        default=None,
        help="total environment steps (default: n_timesteps of the hyperparameter entry)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the run")
    p.add_argument(
        "--n-envs",
        type=int,
        default=None,
        help="parallel environments (default: n_envs of the hyperparameter entry, else 1)",
    )
    p.add_argument("--vec-env", default="auto", choices=VEC_ENVS, help=VEC_ENV_HELP)
    p.add_argument(
        "--env-kwargs", nargs="*", default=[], metavar="KEY=JSON", help="environment arguments"
    )
    p.add_argument(
        "--hyperparams",
        default=None,
        help="YAML file in rl-zoo3 format (default: agents/training/hyperparams/<algo>.yml)",
    )
    p.add_argument(
        "--params", nargs="*", default=[], metavar="KEY=YAML", help="override hyperparameters"
    )
    p.add_argument(
        "--run-dir",
        default=None,
        help=f"output directory, new or empty (default: {DEFAULT_RUN_DIR} in the working "
        "directory)",
    )
    p.add_argument("--resume", action="store_true", help="continue the run in --run-dir")
    p.add_argument("--eval-freq", type=int, default=10_000, help="steps between evaluations")
    p.add_argument("--eval-episodes", type=int, default=20, help="episodes per evaluation")
    p.add_argument(
        "--final-eval-episodes", type=int, default=100, help="episodes of the final evaluation"
    )
    p.add_argument("--checkpoint-freq", type=int, default=50_000, help="steps between saves")
    p.add_argument("--threads", type=int, default=1, help="torch threads")
    p.add_argument("--no-progress-bar", action="store_true", help="no progress bar")
    p.add_argument("--verbose", type=int, default=0, help="SB3 verbosity (0, 1 or 2)")
    p.add_argument(
        "--kickstart",
        default=None,
        metavar="POLICY",
        help="PPO only: behaviour-clone this teacher (e.g. analytic-simultaneous) before RL",
    )
    p.add_argument("--kickstart-steps", type=int, default=20_000, help="teacher env steps")
    p.add_argument("--kickstart-epochs", type=int, default=40, help="behaviour-cloning epochs")
    p.add_argument(
        "--kickstart-log-std",
        type=float,
        default=-1.5,
        help="log standard deviation of the exploration noise after kick-starting",
    )


def run_dir(args: argparse.Namespace) -> Path:
    """--run-dir, or the default run directory of the algorithm, id and seed."""
    if args.run_dir is not None:
        return Path(args.run_dir)
    return Path("runs") / f"{args.algo}-{args.env}-s{args.seed}"


def check(args: argparse.Namespace) -> None:
    from planar3p_agents.training.config import ALGORITHMS, MAX_SEED

    args.algo = args.algo.lower()
    if args.algo not in ALGORITHMS:
        raise UsageError(
            f"--algo: unknown algorithm {args.algo!r}; choose from {', '.join(ALGORITHMS)}"
        )
    checks.in_range("--seed", args.seed, 0, MAX_SEED)
    checks.in_range("--verbose", args.verbose, 0, 2)
    out = run_dir(args)
    checks.output_dir("--run-dir", out)
    if args.resume:
        checks.input_dir("--run-dir", out)  # --resume continues an existing run
    if args.hyperparams is not None:
        checks.input_file("--hyperparams", args.hyperparams)


def options(args: argparse.Namespace):  # -> RunOptions
    """The run options given on the command line (each option has its field's name)."""
    from planar3p_agents.training.run import RunOptions

    names = {f.name for f in fields(RunOptions)} - {"progress_bar"}
    return RunOptions(
        progress_bar=not args.no_progress_bar, **{name: getattr(args, name) for name in names}
    )


def _status(text: str) -> None:
    """A status line of the run, at once, on stdout (stderr keeps bad input to one line)."""
    print(f"planar3p train: {text}", flush=True)


def run(args: argparse.Namespace) -> int:
    _status(
        f"{args.algo.upper()} on {args.env}, seed {args.seed}: checking the hyperparameters, "
        "the environments and the model ..."
    )
    from planar3p_agents.training.run import execute, plan_run

    try:
        plan = plan_run(
            args.algo,
            args.env,
            args.seed,
            run_dir=run_dir(args),
            timesteps=args.timesteps,
            n_envs=args.n_envs,
            env_kwargs=args.env_kwargs,
            hyperparams=args.hyperparams,
            params=args.params,
            resume=args.resume,
            options=options(args),
            command=args.command_line,
        )
    except ValueError as exc:
        raise UsageError(str(exc)) from exc
    metrics = execute(plan, status=_status)
    final = metrics["final_evaluation"]
    print(
        f"{plan.cfg.algo.upper()} seed {plan.cfg.seed}: {metrics['timesteps']} steps in "
        f"{metrics['wall_time_s']:.0f} s ({metrics['steps_per_s']:.0f} steps/s); "
        f"success {final['success_rate']:.2%} over {final['episodes']} episodes; "
        f"run directory {plan.run_dir}"
    )
    return 0
