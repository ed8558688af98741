"""Throughput of Planar3P-v0 against Reacher-v5 and Pendulum-v1 (single env, vector envs, PPO).

Prints, from one run:

  single env      steps/s of each id made with gym.make (Gymnasium's benchmark_step, which
                  samples each random action inside the timed loop; resets included),
                  interleaved over --repeats with medians, the median time of single steps,
                  and the ratios to Reacher-v5 and Pendulum-v1 (medians of per-repeat ratios)
  vector envs     the native vector env (gym.make_vec(id, num_envs=--num-envs); also with
                  batch="numpy") and SyncVectorEnv, total env steps/s, against Reacher's
                  single-env rate measured in the same repeats
  fastest blocks  single and vector envs in short round-robin blocks: the ratios that hold
                  on a busy shared machine, where whole-run rates vary several-fold
  profile         the parts of one step
  --ppo           PPO training steps/s through the native SB3 adapter, DummyVecEnv and
                  SubprocVecEnv (needs the train extra)

Reacher-v5 is skipped when mujoco is not importable.  A few minutes (--quick: about 20 s).

Library: planar3p_agents.evaluation.throughput.
"""

from __future__ import annotations

import argparse
import os
import statistics
from pathlib import Path
from typing import Any

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser

ENV_ID = "Planar3P-v0"
REACHER, PENDULUM = "Reacher-v5", "Pendulum-v1"
#: Defaults of the run-length options: (full run, --quick).
DEFAULTS = {"duration": (2.0, 0.5), "steps": (5_000, 1_000), "repeats": (7, 3), "blocks": (60, 10)}


def add_arguments(p: CliParser) -> None:
    def default(name: str) -> str:
        full, quick = DEFAULTS[name]
        return f"(default: {full:g}, {quick:g} with --quick)"

    p.add_argument("--quick", action="store_true", help="short run (about 20 s)")
    p.add_argument(
        "--duration", type=float, help=f"seconds per single-env measurement {default('duration')}"
    )
    p.add_argument(
        "--steps", type=int, help=f"steps per vector / per-step / profile run {default('steps')}"
    )
    p.add_argument("--repeats", type=int, help=f"interleaved repeats {default('repeats')}")
    p.add_argument("--num-envs", type=int, default=16, help="native vector env size")
    p.add_argument(
        "--blocks",
        type=int,
        help=f"round-robin blocks of the fastest-block rates {default('blocks')}",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the environments and actions")
    p.add_argument("--ppo", action="store_true", help="also PPO steps/s per vec env type")
    p.add_argument("--ppo-steps", type=int, default=8192, help="PPO timesteps per vec env")
    p.add_argument("--json", type=Path, metavar="PATH", help="also write the results as JSON")


def check(args: argparse.Namespace) -> None:
    for name, (full, quick) in DEFAULTS.items():
        if getattr(args, name) is None:
            setattr(args, name, quick if args.quick else full)
    checks.in_range("--duration", args.duration, 0, 3600, low_open=True, high_open=True, unit="s")
    checks.at_least("--steps", args.steps, 1)
    checks.at_least("--repeats", args.repeats, 1)
    checks.at_least("--blocks", args.blocks, 1)
    checks.at_least("--num-envs", args.num_envs, 1)
    checks.at_least("--seed", args.seed, 0)
    checks.at_least("--ppo-steps", args.ppo_steps, 1)
    if args.json is not None:
        checks.output_file("--json", args.json)


def mujoco_available() -> bool:
    """True when Reacher-v5 can be made (mujoco importable)."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


def _rates(values: list[float]) -> str:
    med, lo, hi = statistics.median(values), min(values), max(values)
    return f"{med:10,.0f} steps/s  (min {lo:,.0f}, max {hi:,.0f})"


def run(args: argparse.Namespace) -> int:
    import platform
    import warnings

    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import gymnasium as gym

    import planar3p_gym
    from planar3p_agents.evaluation import throughput

    warnings.filterwarnings("ignore", message=".*out of date.*")
    env_ids = [ENV_ID, PENDULUM] + ([REACHER] if mujoco_available() else [])
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
    for other in (REACHER, PENDULUM):
        if other in rates:
            key = f"{ENV_ID}/{other}"
            ratios[key] = throughput.paired_ratio(rates[ENV_ID], rates[other])
            print(
                f"  ratio {key}: {ratios[key]:.3f} (paired rates), "
                f"{step_us[other] / step_us[ENV_ID]:.3f} (median step times)"
            )
    results["ratios"] = ratios

    n = args.num_envs
    vec_repeats = max(1, args.repeats // 2)
    vec_steps = max(1, args.steps // n)
    print(f"\nvector envs, {n} envs x {vec_steps} steps x {vec_repeats} repeats (total steps/s):")
    ref = REACHER if REACHER in rates else None
    results["vector"] = {}
    for kind in ("native", "native-numpy", "sync"):
        got = throughput.vector_rates(ENV_ID, kind, n, vec_steps, vec_repeats, args.seed, ref)
        v, extra = (got[0], "") if ref else (got, "")
        if ref:
            ratio = throughput.paired_ratio(got[0], got[1])
            extra = f"  {ratio:.2f}x Reacher-v5 single (paired)"
            results["vector"][f"{ENV_ID}/{kind}/reacher_ratio"] = ratio
        results["vector"][f"{ENV_ID}/{kind}"] = v
        print(f"  {ENV_ID} {kind:<12} {_rates(v)}{extra}")

    print(f"\nfastest blocks ({args.blocks} blocks of 200 steps, round-robin; 90th percentile):")
    makers = {e: (lambda e=e: throughput.make_env(e)) for e in env_ids}
    makers[f"{ENV_ID} x{n}"] = lambda: gym.make_vec(ENV_ID, num_envs=n)
    best = throughput.best_block_rates(makers, 200, args.blocks, args.seed)
    results["best_blocks"] = best
    for k, rate in best.items():
        extra = f"  {rate / best[REACHER]:.2f}x Reacher-v5" if REACHER in best else ""
        print(f"  {k:<16} {rate:10,.0f} steps/s{extra}")

    n_prof = max(args.steps, 200)
    print(f"\nprofile of one step, median over {n_prof} random-action steps (us):")
    prof = throughput.profile_step(ENV_ID, n_prof, args.seed)
    results["profile_us"] = {ENV_ID: prof}
    parts = "  ".join(
        f"{k} {prof[k]:.1f}" for k in ("physics", "outputs", "other", "env_step", "wrapped_step")
    )
    print(f"  {ENV_ID}: {parts}")

    if args.ppo:
        print(f"\nPPO on {ENV_ID}, {n} envs, {args.ppo_steps} timesteps (training steps/s):")
        ppo = throughput.ppo_rates(ENV_ID, n, args.ppo_steps, args.seed)
        results["ppo_steps_per_s"] = ppo
        for kind, rate in ppo.items():
            print(f"  {kind:<8} {rate:10,.0f}  ({rate / ppo['dummy']:.2f}x DummyVecEnv)")

    if args.json:
        throughput.write_json_atomic(args.json, results)
    return 0
