"""Benchmark policies on fixed evaluation suites of Planar3P-v0 and of the task ids.

Every policy plays exactly the same episodes, generated from --seed: the reach suites standard,
hard and far (planar3p_agents.evaluation.reach_suites) and the task suites goal, goal-dense,
track-segments, track-figure-eight, mode-change and assembly-change
(planar3p_agents.evaluation.task_suites; each with its own baselines).  Writes into --out:

  report.md     the results table (success rate with its 95% Wilson interval, IQM return with
                its 95% bootstrap interval, median final errors, time to success, margins,
                failure counts, saturation, energy), the suites, why episodes failed, the plots
  episodes.csv  one row per episode and policy (with the policy's training seed, if known)
  summary.json  the aggregates and the run's settings
  suites.json   the suite definition (replay it with --suite-file)
  success_rate.png, errors.png, trajectories.png

examples:
  planar3p benchmark --quick
  planar3p benchmark --policies baselines,runs/a/model.zip:stats=runs/a/vecnormalize.pkl
  planar3p benchmark --policies pretrained:ppo_reach_residual --suites standard,hard
  planar3p benchmark --suites goal,track-segments,mode-change --out res/tasks

Exit status: 0 done; 2 bad input (unknown policy or suite, missing or corrupt model, an --out
holding earlier results without --force, a bad option), found before anything is written; 1 a
policy failed while running (the results finished so far are written first); 130 interrupted.
Library: planar3p_agents.evaluation.benchmark.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError

DEFAULT_EPISODES = 100
QUICK_EPISODES = 20
DEFAULT_BOOTSTRAP = 2000
QUICK_BOOTSTRAP = 500


def add_arguments(p: CliParser) -> None:
    from planar3p_agents.evaluation import benchmark as bm
    from planar3p_agents.evaluation import reach_suites as su
    from planar3p_agents.evaluation.task_suites import TASK_SUITES
    from planar3p_agents.policies.factory import TRUSTED_FILES_NOTE

    p.note(f"Trusted files only: {TRUSTED_FILES_NOTE}")
    task_only = sorted(bm.TASK_BASELINE_NAMES - set(bm.REACH_BASELINES))
    p.add_argument(
        "--policies",
        default="baselines",
        help="comma-separated: baselines (each suite's: on reach suites "
        f"{', '.join(bm.REACH_BASELINES)}; on task suites the task's own), those names, "
        f"{', '.join(task_only)} (task suites), an analytic name with :gain=K (its feedback "
        "gains K 1/s instead of 6; reach suites), pretrained:NAME, or paths to SB3 model .zip "
        "files (optionally prefixed ppo:, sac:, td3:, a2c:, ddpg:; suffixed :stats=STATS.pkl "
        "to name their VecNormalize statistics, :stats=none to go without). Model and "
        "statistics files are code: see below",
    )
    p.add_argument(
        "--suites",
        default=",".join(su.SUITE_NAMES),
        help=f"comma-separated reach suites among {', '.join(su.SUITE_NAMES)} and task suites "
        f"among {', '.join(TASK_SUITES)}",
    )
    p.add_argument(
        "--episodes",
        type=int,
        default=None,
        help=f"episodes per suite (default: {DEFAULT_EPISODES}, {QUICK_EPISODES} with --quick)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the suites and of the policies")
    p.add_argument("--out", default="results/benchmark", help="output directory")
    p.add_argument("--force", action="store_true", help="overwrite the results in --out")
    p.add_argument(
        "--quick",
        action="store_true",
        help=f"{QUICK_EPISODES} episodes per suite and {QUICK_BOOTSTRAP} bootstrap resamples "
        "(about a minute)",
    )
    p.add_argument("--suite-file", default=None, help="replay the suites of a saved suites.json")
    p.add_argument(
        "--working-mode",
        default=None,
        help="working mode of every generated reach suite, e.g. 1,1,-1 (default: per suite, "
        f"{su.DEFAULT_SUITE_MODES})",
    )
    p.add_argument(
        "--hard-end-margin",
        type=float,
        default=None,
        help="parallel margin of the ends of hard pairs (default: the environment's 0.04)",
    )
    p.add_argument(
        "--hold-force-fraction",
        type=float,
        default=0.25,
        help="hard/far ends need at most this fraction of max_force to be held against gravity",
    )
    p.add_argument(
        "--bootstrap",
        type=int,
        default=None,
        help=f"bootstrap resamples (default: {DEFAULT_BOOTSTRAP}, {QUICK_BOOTSTRAP} with --quick)",
    )
    p.add_argument("--device", default="cpu", help="torch device of SB3 models")
    p.add_argument("--no-plots", action="store_true", help="skip the plots")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def parse_mode(flag: str, text: str | None) -> tuple[int, int, int] | None:
    """A working mode written ``1,1,-1``, or ``None``."""
    if text is None:
        return None
    try:
        mode = tuple(int(v) for v in checks.split_list(flag, text))
    except (ValueError, UsageError):
        mode = ()
    if len(mode) != 3 or any(m not in (1, -1) for m in mode):
        raise UsageError(f"{flag} must be three of +1/-1 like 1,1,-1, got {text!r}")
    return mode  # type: ignore[return-value]


def check(args: argparse.Namespace) -> None:
    from planar3p_agents.evaluation import reach_suites as su
    from planar3p_agents.evaluation.task_suites import TASK_SUITES

    quick = args.quick
    if args.episodes is None:
        args.episodes = QUICK_EPISODES if quick else DEFAULT_EPISODES
    if args.bootstrap is None:
        args.bootstrap = QUICK_BOOTSTRAP if quick else DEFAULT_BOOTSTRAP
    checks.at_least("--episodes", args.episodes, 1)
    checks.at_least("--bootstrap", args.bootstrap, 10)
    checks.at_least("--seed", args.seed, 0)
    checks.in_range("--hold-force-fraction", args.hold_force_fraction, 0, 1, low_open=True)
    if args.hard_end_margin is not None:
        checks.in_range(
            "--hard-end-margin", args.hard_end_margin, 0, 1, low_open=True, high_open=True
        )
    args.suites = checks.split_list("--suites", args.suites)
    if args.suite_file is None:
        checks.known("--suites", args.suites, (*su.SUITE_NAMES, *TASK_SUITES), "suite")
    else:
        checks.input_file("--suite-file", args.suite_file)
    args.working_mode = parse_mode("--working-mode", args.working_mode)
    args.policies = checks.split_list("--policies", args.policies)
    checks.output_dir("--out", args.out)


@dataclass
class Job:
    """A benchmark checked and ready to run: its suites, environments and loaded policies
    (:func:`prepare`); nothing written yet.  :meth:`close` releases the environments."""

    out: Path
    names: list[str]
    env: Any
    envs: dict[str, Any]
    suites: dict[str, Any]
    per_suite: dict[str, dict[str, Any]]
    meta: dict[str, tuple[str, int | None]]
    play_envs: Any
    seed: int
    bootstrap: int
    command: str
    closed: bool = field(default=False, repr=False)

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            _close(self.env, self.envs, self.play_envs)


def _close(env: Any, envs: dict[str, Any], play_envs: Any) -> None:
    """Close the play environments and every environment once."""
    play_envs.close()
    for e in {id(e): e for e in (env, *envs.values())}.values():
        e.close()


def prepare(
    policies: Sequence[str],
    suites: Sequence[str],
    *,
    episodes: int,
    seed: int,
    out: str | Path,
    command: str,
    force: bool = False,
    suite_file: str | None = None,
    working_mode: tuple[int, int, int] | None = None,
    hard_end_margin: float | None = None,
    hold_force_fraction: float = 0.25,
    bootstrap: int = DEFAULT_BOOTSTRAP,
    device: str = "cpu",
    warn: Callable[[str], None] | None = None,
) -> Job:
    """Check a benchmark through and load its policies and suites, writing nothing:
    :class:`~planar3p_agents.commands.parser.UsageError` for an --out holding earlier results
    (unless ``force``), an unknown or unloadable policy, or suites that cannot be made.
    ``warn`` receives the loader's notes (default: a ``warning:`` line on stderr each)."""
    import gymnasium as gym

    import planar3p_gym
    from planar3p_agents.evaluation import benchmark as bm
    from planar3p_agents.evaluation.task_suites import TASK_SUITES, make_task_env
    from planar3p_agents.policies.play_envs import PlayEnvs

    env = gym.make(planar3p_gym.ENV_ID)
    envs: dict[str, Any] = {}
    play_envs = PlayEnvs()
    try:
        target = bm.check_output_dir(out, force)
        envs = {n: make_task_env(n) if n in TASK_SUITES else env for n in suites}
        notes = {} if warn is None else {"warn": warn}
        per_suite, meta = bm.load_suite_policies(
            list(policies),
            list(suites),
            envs,
            seed=seed,
            device=device,
            play_envs=play_envs,
            **notes,
        )
        built = bm.build_suites(
            list(suites),
            episodes,
            seed,
            env.unwrapped.design,
            suite_file=suite_file,
            envs=envs,
            working_mode=working_mode,
            end_parallel_margin=hard_end_margin,
            hold_force_fraction=hold_force_fraction,
        )
    except (ValueError, OSError) as exc:  # PolicyError is a ValueError
        _close(env, envs, play_envs)
        raise UsageError(str(exc)) from exc
    return Job(
        target, list(suites), env, envs, built, per_suite, meta, play_envs, seed, bootstrap, command
    )


def execute(job: Job, *, plots: bool = True, progress: bool = True) -> Any:
    """Run a prepared benchmark, write its results into ``job.out`` and close it; the
    :class:`~planar3p_agents.evaluation.benchmark.BenchmarkRun`."""
    from planar3p_agents.evaluation import benchmark as bm

    settings = {
        "command": job.command,
        "suites": job.names,
        "policies": {k: text for k, (text, _) in job.meta.items()},
    }
    try:
        return bm.run_benchmark(
            job.env,
            {},
            job.suites,
            job.out,
            settings=settings,
            seed=job.seed,
            n_resamples=job.bootstrap,
            plots=plots,
            progress=progress,
            training_seeds={k: s for k, (_, s) in job.meta.items()},
            envs=job.envs,
            suite_policies=job.per_suite,
            play_envs=job.play_envs,
        )
    finally:
        job.close()


def run(args: argparse.Namespace) -> int:
    job = prepare(
        args.policies,
        args.suites,
        episodes=args.episodes,
        seed=args.seed,
        out=args.out,
        command=args.command_line,
        force=args.force,
        suite_file=args.suite_file,
        working_mode=args.working_mode,
        hard_end_margin=args.hard_end_margin,
        hold_force_fraction=args.hold_force_fraction,
        bootstrap=args.bootstrap,
        device=args.device,
    )
    result = execute(job, plots=not args.no_plots, progress=not args.no_progress)
    if result.error:
        print(
            f"\nerror: {result.error}; wrote the results finished so far to {job.out}",
            file=sys.stderr,
        )
    print(result.table)
    print(f"\nreport: {job.out / 'report.md'}  ({result.settings['elapsed_s']:.0f} s)")
    return result.status
