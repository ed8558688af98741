"""Throughput of ``Planar3P-v0`` and ``Planar3P-v0`` against ``Reacher-v5`` and ``Pendulum-v1``.

Prints, from one run (the logic is :mod:`planar3p_agents.evaluation.throughput`):

* single-env steps/s of each id made with ``gym.make`` (Gymnasium's ``benchmark_step``, which
  samples each random action inside the timed loop; resets included), interleaved over
  ``--repeats`` with medians, and the ratios to ``Reacher-v5`` and ``Pendulum-v1`` (medians of
  per-repeat ratios);
* the median time of single steps;
* the native vector env (``gym.make_vec(id, num_envs=--num-envs)``) of v0 and v1 (v1 also with
  ``batch="numpy"``: projection and outputs in numpy over the batch), total env steps/s,
  against Reacher's single-env rate measured in the same repeats (actions sampled up front
  for both); ``SyncVectorEnv`` for comparison;
* the fastest-block rates (:func:`planar3p_agents.evaluation.throughput.best_block_rates`: single and vector
  envs in short round-robin blocks, actions sampled up front): the ratios that hold on a busy
  shared machine, where whole-run rates vary several-fold;
* a profile of one step of each id;
* with ``--ppo``: PPO training steps/s through the native SB3 adapter, ``DummyVecEnv`` and
  ``SubprocVecEnv`` (needs the ``train`` extra).

``Reacher-v5`` is skipped when mujoco is not importable.

Usage::

    .venv/bin/python scripts/bench_env.py            # a few minutes
    .venv/bin/python scripts/bench_env.py --quick    # about 20 s
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import warnings
from pathlib import Path
from typing import Any

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import gymnasium as gym

import planar3p_gym
from planar3p_agents.evaluation import throughput

V0, V1 = planar3p_gym.ENV_ID, planar3p_gym.ENV_ID
REACHER, PENDULUM = "Reacher-v5", "Pendulum-v1"


def mujoco_available() -> bool:
    """True when ``Reacher-v5`` can be made (mujoco importable)."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, status 2
        print(f"bench_env.py: error: {message}", file=sys.stderr)
        raise SystemExit(2)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """Parse and validate the arguments; a bad value exits with status 2 and one line, before
    any work is done."""
    ap = _Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="short run")
    ap.add_argument("--duration", type=float, help="seconds per single-env measurement")
    ap.add_argument("--steps", type=int, help="steps per vector / per-step / profile run")
    ap.add_argument("--repeats", type=int, help="interleaved repeats")
    ap.add_argument("--num-envs", type=int, default=16, help="native vector env size")
    ap.add_argument("--blocks", type=int, help="round-robin blocks of the fastest-block rates")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--ppo", action="store_true", help="also PPO steps/s per vec env type")
    ap.add_argument("--ppo-steps", type=int, default=8192, help="PPO timesteps per vec env")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    args = ap.parse_args(argv)
    quick = args.quick
    args.duration = args.duration if args.duration is not None else (0.5 if quick else 2.0)
    args.steps = args.steps if args.steps is not None else (1_000 if quick else 5_000)
    args.repeats = args.repeats if args.repeats is not None else (3 if quick else 7)
    args.blocks = args.blocks if args.blocks is not None else (10 if quick else 60)
    problems = [
        (not (args.duration > 0 and args.duration < 3600), "--duration must be in (0, 3600) s"),
        (args.steps < 1, "--steps must be >= 1"),
        (args.repeats < 1, "--repeats must be >= 1"),
        (args.blocks < 1, "--blocks must be >= 1"),
        (args.num_envs < 1, "--num-envs must be >= 1"),
        (args.seed < 0, "--seed must be >= 0"),
        (args.ppo_steps < 1, "--ppo-steps must be >= 1"),
    ]
    if args.json is not None:
        parent = Path(args.json).resolve().parent
        problems.append((not parent.is_dir(), f"--json: directory {parent} does not exist"))
        problems.append((Path(args.json).is_dir(), f"--json: {args.json} is a directory"))
    for bad, message in problems:
        if bad:
            ap.error(message)
    return args


def _rates(values: list[float]) -> str:
    med, lo, hi = statistics.median(values), min(values), max(values)
    return f"{med:10,.0f} steps/s  (min {lo:,.0f}, max {hi:,.0f})"


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    warnings.filterwarnings("ignore", message=".*out of date.*")
    env_ids = [V0, V1, PENDULUM] + ([REACHER] if mujoco_available() else [])
    print(
        f"python {platform.python_version()}, gymnasium {gym.__version__}, "
        f"planar3p_gym {planar3p_gym.__version__}, {os.cpu_count()} CPUs, "
        f"load average {os.getloadavg()[0]:.2f}"
    )
    print(f"single env: {args.duration:g} s x {args.repeats} interleaved repeats\n")
    rates = throughput.single_env_rates(env_ids, args.repeats, args.duration, args.seed)
    step_us = {e: throughput.median_step_us(e, args.steps, args.seed) for e in env_ids}
    results: dict[str, Any] = {"single_env_rates": rates, "median_step_us": step_us}
    for e in env_ids:
        print(f"  {e:<12} {_rates(rates[e])}   median step {step_us[e]:7.2f} us")
    if REACHER not in env_ids:
        print(f"  {REACHER:<12} skipped (mujoco not importable)")
    ratios = {}
    for mine in (V0, V1):
        for other in (REACHER, PENDULUM):
            if other in rates:
                ratios[f"{mine}/{other}"] = throughput.paired_ratio(rates[mine], rates[other])
                print(
                    f"  ratio {mine}/{other}: {ratios[f'{mine}/{other}']:.3f} (paired rates), "
                    f"{step_us[other] / step_us[mine]:.3f} (median step times)"
                )
    results["ratios"] = ratios

    n = args.num_envs
    vec_repeats = max(1, args.repeats // 2)
    vec_steps = max(1, args.steps // n)
    print(f"\nvector envs, {n} envs x {vec_steps} steps x {vec_repeats} repeats (total steps/s):")
    ref = REACHER if REACHER in rates else None
    results["vector"] = {}
    kinds = ((V0, "native"), (V0, "sync"), (V1, "native"), (V1, "native-numpy"), (V1, "sync"))
    for e, kind in kinds:
        got = throughput.vector_rates(e, kind, n, vec_steps, vec_repeats, args.seed, ref)
        v, extra = (got[0], "") if ref else (got, "")
        if ref:
            ratio = throughput.paired_ratio(got[0], got[1])
            extra = f"  {ratio:.2f}x Reacher-v5 single (paired)"
            results["vector"][f"{e}/{kind}/reacher_ratio"] = ratio
        results["vector"][f"{e}/{kind}"] = v
        print(f"  {e} {kind:<12} {_rates(v)}{extra}")

    print(f"\nfastest blocks ({args.blocks} blocks of 200 steps, round-robin; 90th percentile):")
    makers = {e: (lambda e=e: throughput.make_env(e)) for e in env_ids}
    for e in (V0, V1):
        makers[f"{e} x{n}"] = lambda e=e: gym.make_vec(e, num_envs=n)
    best = throughput.best_block_rates(makers, 200, args.blocks, args.seed)
    results["best_blocks"] = best
    for k, rate in best.items():
        extra = f"  {rate / best[REACHER]:.2f}x Reacher-v5" if REACHER in best else ""
        print(f"  {k:<16} {rate:10,.0f} steps/s{extra}")

    n_prof = max(args.steps, 200)
    print(f"\nprofile of one step, median over {n_prof} random-action steps (us):")
    results["profile_us"] = {}
    for e in (V0, V1):
        prof = throughput.profile_step(e, n_prof, args.seed)
        results["profile_us"][e] = prof
        parts = "  ".join(
            f"{k} {prof[k]:.1f}"
            for k in ("physics", "outputs", "other", "env_step", "wrapped_step")
        )
        print(f"  {e}: {parts}")

    if args.ppo:
        print(f"\nPPO on {V1}, {n} envs, {args.ppo_steps} timesteps (training steps/s):")
        ppo = throughput.ppo_rates(V1, n, args.ppo_steps, args.seed)
        results["ppo_steps_per_s"] = ppo
        for kind, rate in ppo.items():
            print(f"  {kind:<8} {rate:10,.0f}  ({rate / ppo['dummy']:.2f}x DummyVecEnv)")

    if args.json:
        throughput.write_json_atomic(args.json, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
