#!/usr/bin/env python
"""Train a PPO, SAC or TD3 agent on Planar3P-v0 (or any registered variant) with SB3.

Examples::

    python scripts/train.py --algo sac --timesteps 300000 --seed 1
    python scripts/train.py --algo ppo --n-envs 8 --env-kwargs working_mode='[1,1,-1]'
    python scripts/train.py --algo sac --run-dir runs/sac-s1 --resume

Hyperparameters come from ``agents/training/hyperparams/<algo>.yml`` (rl-zoo3 format, keyed by the
environment id) unless ``--hyperparams`` names another file.  Every run writes a
self-contained directory (see :mod:`planar3p_agents.training.config`); ``--resume`` continues from its last
checkpoint.  Everything is validated before the run directory is created (bad input: exit 2
with one line).  The work is done by :func:`planar3p_agents.training.run.plan_run` and
:func:`planar3p_agents.training.run.execute` (also usable from Python).
"""

from __future__ import annotations

import argparse
import shlex
import sys
from dataclasses import fields
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from planar3p_agents.policies.factory import TRUSTED_FILES_NOTE  # noqa: E402
from planar3p_agents.training.config import ALGORITHMS  # noqa: E402
from planar3p_agents.training.run import VEC_ENVS, RunOptions, execute, plan_run  # noqa: E402


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__,
        epilog=f"--kickstart and --resume load model and statistics files: {TRUSTED_FILES_NOTE}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--algo", required=True, help=f"one of {', '.join(ALGORITHMS)}")
    p.add_argument("--env", default="Planar3P-v0", help="registered environment id")
    p.add_argument("--timesteps", type=float, default=None, help="total environment steps")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--n-envs", type=int, default=None, help="parallel environments")
    p.add_argument("--vec-env", default="auto", choices=VEC_ENVS, help="vectorised env class")
    p.add_argument("--env-kwargs", nargs="*", default=[], metavar="KEY=JSON")
    p.add_argument("--hyperparams", default=None, help="YAML file (rl-zoo3 format)")
    p.add_argument(
        "--params", nargs="*", default=[], metavar="KEY=YAML", help="override hyperparameters"
    )
    p.add_argument(
        "--run-dir", default=None, help="output directory (default runs/<algo>-<env>-s<seed>)"
    )
    p.add_argument("--resume", action="store_true", help="continue the run in --run-dir")
    p.add_argument("--eval-freq", type=int, default=10_000, help="steps between evaluations")
    p.add_argument("--eval-episodes", type=int, default=20)
    p.add_argument("--final-eval-episodes", type=int, default=100)
    p.add_argument("--checkpoint-freq", type=int, default=50_000, help="steps between saves")
    p.add_argument("--threads", type=int, default=1, help="torch threads")
    p.add_argument("--no-progress-bar", action="store_true")
    p.add_argument("--verbose", type=int, default=0)
    p.add_argument(
        "--kickstart",
        default=None,
        metavar="POLICY",
        help="PPO only: behaviour-clone this teacher (e.g. analytic-simultaneous) before RL",
    )
    p.add_argument("--kickstart-steps", type=int, default=20_000, help="teacher env steps")
    p.add_argument("--kickstart-epochs", type=int, default=40)
    p.add_argument(
        "--kickstart-log-std",
        type=float,
        default=-1.5,
        help="log standard deviation of the exploration noise after kick-starting",
    )
    return p.parse_args(argv)


def options_from(args: argparse.Namespace) -> RunOptions:
    """The run options given on the command line (each option has its field's name)."""
    names = {f.name for f in fields(RunOptions)} - {"progress_bar"}
    return RunOptions(
        progress_bar=not args.no_progress_bar, **{name: getattr(args, name) for name in names}
    )


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    algo = args.algo.lower()
    run_dir = args.run_dir or ROOT / "runs" / f"{algo}-{args.env}-s{args.seed}"
    command = " ".join(shlex.quote(a) for a in (sys.argv if argv is None else ["train.py", *argv]))
    try:
        plan = plan_run(
            algo,
            args.env,
            args.seed,
            run_dir=run_dir,
            timesteps=args.timesteps,
            n_envs=args.n_envs,
            env_kwargs=args.env_kwargs,
            hyperparams=args.hyperparams,
            params=args.params,
            resume=args.resume,
            options=options_from(args),
            command=command,
        )
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    metrics = execute(plan)
    final = metrics["final_evaluation"]
    print(
        f"{plan.cfg.algo.upper()} seed {plan.cfg.seed}: {metrics['timesteps']} steps in "
        f"{metrics['wall_time_s']:.0f} s ({metrics['steps_per_s']:.0f} steps/s); "
        f"success {final['success_rate']:.2%} over {final['episodes']} episodes; "
        f"run directory {plan.run_dir}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
