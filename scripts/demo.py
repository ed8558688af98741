#!/usr/bin/env python
"""The main job: shipped learned policies against the analytic controller, on quick suites.

1. Reach, on ``Planar3P-v0``: ``scripts/benchmark.py --quick`` on the shipped residual reach
   policy (``pretrained:ppo_reach_residual``: PPO's learned correction to the analytic
   controller, faster to the target) and the paper's simultaneous simple-motion controller.
2. Working-mode change, where the simple motions fail by construction (they never pass the
   serial singularity a leg must cross): the shipped ``ppo_mode_change`` policy against the
   simple motions and the certified travel-space planner, on the quick ``mode-change`` suite.

Each part records one episode of the learned and of the analytic policy as animated GIFs (the
same start and target for both) and prints where everything is.  Trains nothing; about a
minute or two on a laptop-class CPU.

    python scripts/demo.py [--out results/demo] [--policy pretrained:NAME]
                           [--mode-change-policy pretrained:NAME] [--seed 0]
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("MPLBACKEND", "Agg")

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import gymnasium as gym  # noqa: E402

import planar3p_gym  # noqa: E402
from planar3p_agents.evaluation import reach_suites as su  # noqa: E402
from planar3p_agents.evaluation.episode_gif import record_gif  # noqa: E402
from planar3p_agents.evaluation.task_suites import TASK_SUITES, make_task_suite  # noqa: E402
from planar3p_agents.policies.factory import (  # noqa: E402
    TRUSTED_FILES_NOTE,
    PolicyError,
    load_policy,
    policy_label,
)

ANALYTIC = "analytic-simultaneous"
MODE_CHANGE = "mode-change"
MODE_CHANGE_POLICY = "pretrained:ppo_mode_change"
#: The shipped reach policy the demo plays by default, and the id it was trained on.
REACH_POLICY = "pretrained:ppo_reach_residual"
REACH_ENV = planar3p_gym.ENV_ID


def _benchmark_main():
    import importlib.util

    spec = importlib.util.spec_from_file_location("benchmark", ROOT / "scripts" / "benchmark.py")
    module = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(module)
    return module.main


def _maker(spec: str, suite: str | None, seed: int):
    """``env -> policy`` for a GIF (:func:`load_policy` for the GIF's environment)."""
    return lambda env: load_policy(spec, env=env, seed=seed)


def _part(title, bench_args, policies, env_id, episode, suite, out, seed) -> dict | None:
    """Benchmark ``policies`` (``bench_args`` picks the suites) into ``out/benchmark`` and
    record ``episode`` with each policy; ``None`` if the benchmark failed."""
    print(f"{title}: benchmarking {', '.join(policies)} ...", flush=True)
    argv = [*bench_args, "--quick", "--policies", ",".join(policies), "--seed", str(seed)]
    # --force: the demo's own directory, a rerun replaces its results.
    if _benchmark_main()([*argv, "--out", str(out / "benchmark"), "--force"]) != 0:
        return None
    gifs = {}
    for spec in policies[:2]:
        path = out / f"{policy_label(spec).replace(':', '_').replace('/', '_')}.gif"
        outcome = record_gif(env_id, _maker(spec, suite, seed), episode.reset_options(), path, seed)
        gifs[spec] = (path, outcome)
    return gifs


def _print(out: Path, gifs: dict) -> None:
    print(f"  report:        {out / 'benchmark' / 'report.md'}")
    print(f"  per episode:   {out / 'benchmark' / 'episodes.csv'}")
    print(f"  plots:         {out / 'benchmark'}/*.png")
    for spec, (path, outcome) in gifs.items():
        print(
            f"  animation:     {path}  ({spec}: {outcome['reason']} after "
            f"{outcome['steps']} steps, final error {outcome['position_error_mm']:.1f} mm)"
        )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=TRUSTED_FILES_NOTE,
    )
    p.add_argument("--out", type=Path, default=ROOT / "results" / "demo")
    p.add_argument("--policy", default=REACH_POLICY, help=f"learned reach policy ({REACH_ENV})")
    p.add_argument("--mode-change-policy", default=MODE_CHANGE_POLICY, help="learned policy")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)

    learned = args.policy
    mc_env = TASK_SUITES[MODE_CHANGE].env_id
    try:
        load_policy(learned, env=gym.make(REACH_ENV))
        load_policy(args.mode_change_policy, env=gym.make(mc_env))
    except PolicyError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2

    reach = _part(
        "Reach",
        ["--suites", ",".join(su.SUITE_NAMES)],
        [learned, ANALYTIC],
        REACH_ENV,
        su.make_suite("standard", 1, args.seed).episodes[0],
        None,
        args.out / "reach",
        args.seed,
    )
    if reach is None:
        return 1
    mode_change = _part(
        "Working-mode change",
        ["--suites", MODE_CHANGE],
        [args.mode_change_policy, ANALYTIC, "planner"],
        mc_env,
        make_task_suite(MODE_CHANGE, 1, args.seed).episodes[0],
        MODE_CHANGE,
        args.out / "mode-change",
        args.seed,
    )
    if mode_change is None:
        return 1
    print("\nDone.\nReach:")
    _print(args.out / "reach", reach)
    print("Working-mode change (the simple motions cannot pass the serial singularity):")
    _print(args.out / "mode-change", mode_change)
    return 0


if __name__ == "__main__":
    sys.exit(main())
