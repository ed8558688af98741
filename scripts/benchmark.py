#!/usr/bin/env python
"""Benchmark policies on fixed evaluation suites of ``Planar3P-v0`` and of the task ids.

Every policy plays exactly the same episodes, generated from ``--seed``: the reach suites
``standard``, ``hard``, ``far`` (``agents/evaluation/reach_suites.py``) and the task suites ``goal``,
``goal-dense``, ``track-segments``, ``track-figure-eight``, ``mode-change``,
``assembly-change`` (``agents/evaluation/task_suites.py``; each with its own baselines).  Writes into
``--out``:

* ``report.md``: the results table (success rate with its 95% Wilson interval, IQM return with
  its 95% bootstrap interval, median final errors, time to success, margins, failure counts,
  saturation, energy), the suites, a breakdown of why episodes failed, and the plots;
* ``episodes.csv``: one row per episode and policy (with the policy's training seed, if known);
* ``summary.json``: the aggregates and the run's settings;
* ``suites.json``: the suite definition (replay it with ``--suite-file``);
* ``success_rate.png``, ``errors.png``, ``trajectories.png``.

Examples::

    python scripts/benchmark.py --quick
    python scripts/benchmark.py --policies baselines,runs/a/model.zip:stats=runs/a/vecnormalize.pkl
    python scripts/benchmark.py --policies pretrained:ppo_reach_residual --suites standard,hard
    python scripts/benchmark.py --suites goal,track-segments,mode-change --out res/tasks

The logic lives in ``planar3p_agents.evaluation.benchmark`` (this file parses, validates and prints).  Exit status:
0 on success; 2 for bad input (unknown policy or suite, missing or corrupt model, an ``--out``
holding earlier results without ``--force``, bad option), detected before anything is written;
1 if a policy fails while running (the results already finished are written first); 130 if
interrupted.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # running from a checkout without installing
    sys.path.insert(0, str(ROOT))

import gymnasium as gym  # noqa: E402

import planar3p_gym  # noqa: E402
from planar3p_agents.evaluation import benchmark as bm  # noqa: E402
from planar3p_agents.evaluation import reach_suites as su  # noqa: E402
from planar3p_agents.evaluation.task_suites import TASK_SUITES, make_task_env  # noqa: E402
from planar3p_agents.policies.factory import TRUSTED_FILES_NOTE  # noqa: E402
from planar3p_agents.policies.play_envs import PlayEnvs  # noqa: E402

DEFAULT_EPISODES = 100
QUICK_EPISODES = 20


class InputError(Exception):
    """Bad command-line input (exit status 2)."""


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description="Benchmark policies on fixed evaluation suites (Planar3P-v0, task ids).",
        epilog=f"Trusted files only: {TRUSTED_FILES_NOTE}",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    p.add_argument(
        "--policies",
        default="baselines",
        help="comma-separated: baselines (each suite's: on reach suites "
        f"{', '.join(bm.REACH_BASELINES)}; on task suites the task's own), those names, "
        f"{', '.join(sorted(bm.TASK_BASELINE_NAMES - set(bm.REACH_BASELINES)))} (task suites), "
        "an analytic name with :gain=K (its feedback gains K 1/s instead of 6; reach suites), "
        "pretrained:NAME, or paths to SB3 model .zip files (optionally prefixed ppo:, sac:, "
        "td3:, a2c:, ddpg:; suffixed :stats=STATS.pkl to name their VecNormalize statistics, "
        ":stats=none to go without). Model and statistics files are code: see below",
    )
    p.add_argument(
        "--suites",
        default=",".join(su.SUITE_NAMES),
        help=f"comma-separated reach suites among {', '.join(su.SUITE_NAMES)} (--reach-env) "
        f"and task suites among {', '.join(TASK_SUITES)}",
    )
    p.add_argument(
        "--episodes",
        type=int,
        default=None,
        help=f"episodes per suite (default {DEFAULT_EPISODES}, {QUICK_EPISODES} with --quick)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the suites and of the policies")
    p.add_argument("--out", default="results/benchmark", help="output directory")
    p.add_argument("--force", action="store_true", help="overwrite the results in --out")
    p.add_argument(
        "--quick",
        action="store_true",
        help=f"{QUICK_EPISODES} episodes per suite and 500 bootstrap resamples (about a minute)",
    )
    p.add_argument("--suite-file", default=None, help="replay the suites of a saved suites.json")
    p.add_argument(
        "--working-mode",
        default=None,
        help="override the working mode of every generated reach suite, e.g. 1,1,-1 "
        f"(default per suite: {su.DEFAULT_SUITE_MODES})",
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
    p.add_argument("--bootstrap", type=int, default=None, help="bootstrap resamples (2000)")
    p.add_argument("--device", default="cpu", help="torch device of SB3 models")
    p.add_argument("--no-plots", action="store_true", help="skip the plots")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p.parse_args(argv)


def _split(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def _parse_mode(text: str | None) -> tuple[int, int, int] | None:
    if text is None:
        return None
    try:
        mode = tuple(int(v) for v in _split(text))
    except ValueError:
        mode = ()
    if len(mode) != 3 or any(m not in (1, -1) for m in mode):
        raise InputError(f"--working-mode must be three of +1/-1 like 1,1,-1, got {text!r}")
    return mode  # type: ignore[return-value]


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    given = list(argv) if argv is not None else sys.argv[1:]
    command = ("python scripts/benchmark.py " + shlex.join(given)).strip()
    try:
        return _run(args, command)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


def _run(args: argparse.Namespace, command: str) -> int:
    # ---- validate everything before writing anything
    default = QUICK_EPISODES if args.quick else DEFAULT_EPISODES
    episodes = args.episodes if args.episodes is not None else default
    if episodes < 1:
        raise InputError(f"--episodes must be >= 1, got {episodes}")
    n_boot = args.bootstrap if args.bootstrap is not None else (500 if args.quick else 2000)
    if n_boot < 10:
        raise InputError(f"--bootstrap must be >= 10, got {n_boot}")
    names = _split(args.suites)
    known = (*su.SUITE_NAMES, *TASK_SUITES)
    unknown = [s for s in names if s not in known]
    if not names or (unknown and args.suite_file is None):
        raise InputError(f"unknown suite(s) {unknown}; known: {', '.join(known)}")
    mode = _parse_mode(args.working_mode)
    if not _split(args.policies):
        raise InputError("--policies is empty")
    env = gym.make(planar3p_gym.ENV_ID)
    design = env.unwrapped.design
    try:
        out = bm.check_output_dir(args.out, args.force)
        envs = {n: make_task_env(n) if n in TASK_SUITES else env for n in names}
        play_envs = PlayEnvs()
        per_suite, meta = bm.load_suite_policies(
            _split(args.policies),
            names,
            envs,
            seed=args.seed,
            device=args.device,
            play_envs=play_envs,
        )
        suites = bm.build_suites(
            names,
            episodes,
            args.seed,
            design,
            suite_file=args.suite_file,
            envs=envs,
            working_mode=mode,
            end_parallel_margin=args.hard_end_margin,
            hold_force_fraction=args.hold_force_fraction,
        )
        out.mkdir(parents=True, exist_ok=True)
    except (ValueError, OSError) as exc:  # PolicyError is a ValueError
        raise InputError(str(exc)) from exc
    # ---- run
    settings = {
        "command": command,
        "suites": names,
        "policies": {k: text for k, (text, _) in meta.items()},
    }
    run = bm.run_benchmark(
        env,
        {},
        suites,
        out,
        settings=settings,
        seed=args.seed,
        n_resamples=n_boot,
        plots=not args.no_plots,
        progress=not args.no_progress,
        training_seeds={k: s for k, (_, s) in meta.items()},
        envs=envs,
        suite_policies=per_suite,
        play_envs=play_envs,
    )
    play_envs.close()
    if run.error:
        print(f"\nerror: {run.error}; wrote the results finished so far to {out}", file=sys.stderr)
    print(run.table)
    print(f"\nreport: {out / 'report.md'}  ({run.settings['elapsed_s']:.0f} s)")
    return run.status


if __name__ == "__main__":
    sys.exit(main())
