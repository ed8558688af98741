#!/usr/bin/env python
"""Throughput of every id against Reacher-v5 and CartPole, and the targets, in one run.

Sections (``--sections``, all by default), each measured in interleaved rounds (every
configuration once per round, the order rotated; ratios are medians of per-round ratios to
the reference measured in the same round):

  single    steps/s of each id and Reacher-v5 made with gym.make (Gymnasium's benchmark_step:
            random actions, resets included; beside it with pre-sampled actions), and of an
            env that does nothing with Planar3P-v0's spaces (the ceiling of any env's ratio)
  vector    total env steps/s of each id's vector env (native where the id has one, else
            SyncVectorEnv) at each of --sizes envs, against Reacher-v5 single and in
            SyncVectorEnv and CartPole-v1's native vector env of as many envs
  resets    seeded reset times (us): median, p99, p99.9, max; unseeded: median, p99.9
  floor     the median full step beside pymunk's own step alone (cpSpaceStep on the env's own
            space, as many substeps), and a profile of one Planar3P-v0 step
  startup   a fresh process with an empty numba cache (first-call compile), then one with that
            cache (cached start-up): import, gym.make, reset, one step of each id
  ppo       PPO training steps/s with the project's recipe (ppo.yml, native vector env) against
            the same PPO on Reacher-v5 through DummyVecEnv (needs the train extra)

Then the targets table: each target of the issue, the measured value, met or not.  Ten
minutes or so (--quick: a few).  Timings depend on the machine and its load; no test
times anything.

Library: tooling.throughput.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from planar3p_agents.commands import checks
from planar3p_agents.commands.parser import CliParser, UsageError
from planar3p_gym.envs.registry import ENV_ID, ENV_SPECS
from tooling import script

ALL_IDS = tuple(row.id for row in ENV_SPECS)
REACHER, CARTPOLE = "Reacher-v5", "CartPole-v1"
SECTIONS = ("single", "vector", "resets", "floor", "startup", "ppo")
#: Defaults of the run-length options: (full run, --quick).
DEFAULTS = {
    "rounds": (5, 3),
    "duration": (1.0, 0.2),
    "resets": (400, 100),
    "steps": (1_000, 200),
    "ppo_steps": (8_192, 4_096),
    "ppo_rounds": (3, 1),
}

#: The vector env size of the vector targets.
TARGET_SIZE = 256
#: The throughput targets: (what, bound, kind) with kind ``"min"`` (a ratio that must be at
#: least the bound) or ``"max"`` (at most); ``vector_v0`` is ``Planar3P-v0``'s own.
TARGETS = {
    "single": ("single env (gym.make), resets included, x Reacher-v5", 2.0, "min"),
    "floor": ("full step / pymunk's own step", 5.0, "max"),
    "vector": (
        f"native vector env x{TARGET_SIZE} / Reacher-v5 SyncVectorEnv x{TARGET_SIZE}",
        8.0,
        "min",
    ),
    "vector_v0": (
        f"native vector env x{TARGET_SIZE} / Reacher-v5 SyncVectorEnv x{TARGET_SIZE}",
        20.0,
        "min",
    ),
}


def add_arguments(p: CliParser) -> None:
    def default(name: str) -> str:
        full, quick = DEFAULTS[name]
        return f"(default: {full:g}, {quick:g} with --quick)"

    p.add_argument("--quick", action="store_true", help="short run (a few minutes)")
    p.add_argument(
        "--ids",
        default=",".join(ALL_IDS),
        metavar="ID,...",
        help="ids to measure, comma-separated (default: every id)",
    )
    p.add_argument(
        "--sizes",
        default="1,16,64,256",
        metavar="N,...",
        help="vector env sizes, comma-separated (default: 1,16,64,256)",
    )
    p.add_argument(
        "--sections",
        default=",".join(SECTIONS),
        metavar="NAME,...",
        help=f"sections to run, comma-separated (default: all, {','.join(SECTIONS)})",
    )
    p.add_argument("--rounds", type=int, help=f"interleaved rounds {default('rounds')}")
    p.add_argument(
        "--duration",
        type=float,
        help=f"seconds per steps/s measurement per round {default('duration')}",
    )
    p.add_argument("--resets", type=int, help=f"seeded resets per id per round {default('resets')}")
    p.add_argument(
        "--steps", type=int, help=f"timed steps per id per round of the floor {default('steps')}"
    )
    p.add_argument("--ppo-steps", type=int, help=f"PPO timesteps per run {default('ppo_steps')}")
    p.add_argument("--ppo-rounds", type=int, help=f"PPO rounds {default('ppo_rounds')}")
    p.add_argument("--seed", type=int, default=0, help="seed of the environments and actions")
    p.add_argument("--json", type=Path, metavar="PATH", help="also write the results as JSON")


def check(args: argparse.Namespace) -> None:
    if args.json is not None:
        checks.output_file("--json", args.json)
    for name, (full, quick) in DEFAULTS.items():
        if getattr(args, name) is None:
            setattr(args, name, quick if args.quick else full)
    args.ids = checks.split_list("--ids", args.ids)
    checks.known("--ids", args.ids, ALL_IDS, "id")
    sizes = []
    for text in checks.split_list("--sizes", args.sizes):
        try:
            n = int(text)
        except ValueError:
            raise UsageError(f"--sizes: {text!r} is not an integer") from None
        checks.in_range("--sizes", n, 1, 4096)
        sizes.append(n)
    args.sizes = sorted(set(sizes))
    args.sections = checks.split_list("--sections", args.sections)
    checks.known("--sections", args.sections, SECTIONS, "section")
    checks.at_least("--rounds", args.rounds, 1)
    checks.in_range("--duration", args.duration, 0, 3600, low_open=True, high_open=True, unit="s")
    checks.at_least("--resets", args.resets, 1)
    checks.at_least("--steps", args.steps, 1)
    checks.at_least("--ppo-steps", args.ppo_steps, 1)
    checks.at_least("--ppo-rounds", args.ppo_rounds, 1)
    checks.at_least("--seed", args.seed, 0)


def mujoco_available() -> bool:
    """True when Reacher-v5 can be made (mujoco importable)."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


def _median(values: list[float]) -> float:
    return float(statistics.median(values))


def _ratios(rates: dict[str, list[float]], reference: str) -> dict[str, float]:
    """Median per-round ratio of every entry of ``rates`` to ``rates[reference]``."""
    from tooling.throughput import paired_ratio

    if reference not in rates:
        return {}
    return {k: paired_ratio(v, rates[reference]) for k, v in rates.items()}


def _x(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.2f}" if value >= 0.1 else f"{value:.2g}"


def _table(
    header: list[str],
    rows: list[list[str]],
    widths: list[int],
    show_header: bool = True,
    left: int = 1,
) -> None:
    """Rows of cells in columns of ``widths``, the first ``left`` ones left-aligned."""

    def line(cells: list[str]) -> str:
        return " " + "".join(
            f" {c:<{w}}" if n < left else f" {c:>{w}}"
            for n, (c, w) in enumerate(zip(cells, widths, strict=True))
        )

    if show_header:
        print(line(header))
    for row in rows:
        print(line(row))


# ---------------------------------------------------------------------------- sections


def single_section(args: argparse.Namespace, refs: list[str]) -> dict[str, Any]:
    from tooling import throughput

    ids = args.ids + refs + ([throughput.NOOP] if REACHER in refs else [])
    print(
        f"\nsingle env: steps/s (gym.make, benchmark_step, resets included), "
        f"{args.duration:g} s x {args.rounds} rounds"
    )
    pre: dict[str, list[float]] = {}
    rates = throughput.single_env_rates(ids, args.rounds, args.duration, args.seed, pre)
    ratio, pre_ratio = _ratios(rates, REACHER), _ratios(pre, REACHER)
    rows = [
        [e, f"{_median(rates[e]):,.0f}", _x(ratio.get(e))]
        + [f"{_median(pre[e]):,.0f}", _x(pre_ratio.get(e))]
        for e in ids
    ]
    header = ["id", "steps/s", f"x {REACHER}", "pre-sampled", f"x {REACHER}"]
    _table(header, rows, [26, 10, 13, 12, 13])
    if throughput.NOOP in ids:
        print(f"  ({throughput.NOOP}: an env that does nothing; its ratio is the ceiling here)")
    return {
        "rates": rates,
        "median": {e: _median(rates[e]) for e in ids},
        "x_reacher": ratio,
        "presampled": {
            "rates": pre,
            "median": {e: _median(pre[e]) for e in ids},
            "x_reacher": pre_ratio,
        },
    }


def _vector_envs(n: int, ids: list[str], refs: list[str]) -> dict[str, Any]:
    """The vector envs of ``n`` copies of each id, and the references of the same size."""
    from tooling import throughput as T

    envs: dict[str, Any] = {}
    try:
        for e in ids:
            envs[e] = T.make_vector_env(e, n)
        if REACHER in refs:
            envs[f"{REACHER} single"] = T.make_env(REACHER)
            envs[f"{REACHER} sync"] = T.make_vector_env(REACHER, n, "sync")
        envs[f"{CARTPOLE} native"] = T.make_vector_env(CARTPOLE, n, "native")
    except BaseException:
        for env in envs.values():
            env.close()
        raise
    return envs


def _vector_measures(
    envs: dict[str, Any], duration: float, seed: int
) -> dict[str, Callable[[int], float]]:
    """One steps/s measurement per env and round (after a warm-up of each env); a vector
    env's round is at least its id's time limit of batch steps (:func:`vector_rate`)."""
    import gymnasium as gym

    from tooling import throughput as T

    out = {}
    for k, env in envs.items():
        env.reset(seed=seed)
        if isinstance(env, gym.vector.VectorEnv):
            T.vector_rate(env, min(0.05, duration), seed)  # warm-up: first-call caches
            limit = env.spec.max_episode_steps or 1  # a time limit's steps
            out[k] = lambda r, env=env, limit=limit: T.vector_rate(
                env, duration, seed + r, min_steps=limit
            )
        else:
            T.single_rate(env, min(0.05, duration), seed)
            out[k] = lambda r, env=env: T.single_rate(env, duration, seed + r)
    return out


def vector_section(args: argparse.Namespace, refs: list[str]) -> dict[str, Any]:
    from tooling import throughput as T

    print(
        f"\nvector envs: total env steps/s, {args.duration:g} s x {args.rounds} rounds per size; "
        "ratios to the references of the same size"
    )
    ref_single, ref_sync, ref_cart = f"{REACHER} single", f"{REACHER} sync", f"{CARTPOLE} native"
    header = ["n   id", "kind", "steps/s", "x Reacher", "x ReacherSync", "x CartPole"]
    widths = [30, 7, 11, 10, 14, 11]
    _table(header, [], widths)
    out: dict[str, Any] = {}
    for n in args.sizes:
        envs = _vector_envs(n, args.ids, refs)
        try:
            rates = T.interleave(_vector_measures(envs, args.duration, args.seed), args.rounds)
        finally:
            for env in envs.values():
                env.close()
        x = {ref: _ratios(rates, ref) for ref in (ref_single, ref_sync, ref_cart)}
        kinds = {e: T.vector_kind(e) for e in args.ids}
        kinds.update({ref_single: "single", ref_sync: "sync", ref_cart: "native"})
        rows = []
        for k in rates:
            name = k if k in args.ids else k.rsplit(" ", 1)[0]
            rows.append(
                [f"{n:<4}{name}", kinds[k], f"{_median(rates[k]):,.0f}"]
                + [_x(x[ref].get(k)) for ref in (ref_single, ref_sync, ref_cart)]
            )
        _table(header, rows, widths, show_header=False)
        out[str(n)] = {
            "rates": rates,
            "kind": {k: kinds[k] for k in rates},
            "median": {k: _median(v) for k, v in rates.items()},
            "x_reacher_single": x[ref_single],
            "x_reacher_sync": x[ref_sync],
            "x_cartpole_native": x[ref_cart],
        }
    return out


def resets_section(args: argparse.Namespace, refs: list[str]) -> dict[str, Any]:
    import numpy as np

    from tooling import throughput as T

    ids = args.ids + refs
    k = args.resets
    print(
        f"\nresets (us): env.reset(seed=s), {k} new seeds per id per round x {args.rounds} "
        "rounds; then as many unseeded resets (median, p99.9)"
    )
    envs = {e: T.make_env(e) for e in ids}

    def measure(env: Any) -> Callable[[int], tuple[Any, Any]]:
        def one_round(r: int) -> tuple[Any, Any]:
            seeded = T.reset_times(env, range(args.seed + r * k, args.seed + (r + 1) * k))
            return seeded, T.reset_times(env, [None] * k)

        return one_round

    try:
        parts = T.interleave({e: measure(env) for e, env in envs.items()}, args.rounds)
    finally:
        for env in envs.values():
            env.close()
    seeds = range(args.seed, args.seed + args.rounds * k)
    out = {}
    rows = []
    for e in ids:
        fig = T.reset_summary(np.concatenate([s for s, _ in parts[e]]), seeds)
        us = {key.replace("_ms", "_us"): 1e3 * fig[key] for key in fig if key.endswith("_ms")}
        free = T.reset_summary(np.concatenate([u for _, u in parts[e]]), seeds)
        unseeded = {q.replace("_ms", "_us"): 1e3 * free[q] for q in ("median_ms", "p99.9_ms")}
        out[e] = {"resets": fig["resets"], **us, "slowest_seeds_ms": fig["slowest"]}
        out[e]["unseeded"] = unseeded
        rows.append(
            [e, str(fig["resets"])]
            + [f"{us[q]:,.0f}" for q in ("median_us", "p99_us", "p99.9_us", "max_us")]
            + [f"{unseeded[q]:,.0f}" for q in ("median_us", "p99.9_us")]
        )
    header = ["id", "resets", "median", "p99", "p99.9", "max", "unseeded", "p99.9"]
    _table(header, rows, [26, 7, 8, 8, 10, 10, 9, 10])
    return out


def floor_section(args: argparse.Namespace) -> dict[str, Any]:
    from tooling import throughput as T

    print(
        f"\nfloor: median full step (gym.make) and pymunk's own step alone (cpSpaceStep on the "
        f"env's space), {args.steps} steps x {args.rounds} rounds (us)"
    )
    envs = {e: T.make_env(e) for e in args.ids}
    try:
        for env in envs.values():  # warm-up
            T.step_and_floor_us(env, min(50, args.steps), args.seed)
        got = T.interleave(
            {
                e: (lambda r, env=env: T.step_and_floor_us(env, args.steps, args.seed + r))
                for e, env in envs.items()
            },
            args.rounds,
        )
        substeps = {e: env.unwrapped.sim.substeps for e, env in envs.items()}
    finally:
        for env in envs.values():
            env.close()
    out: dict[str, Any] = {}
    rows = []
    for e in args.ids:
        full, floor = [f for f, _ in got[e]], [p for _, p in got[e]]
        ratio = _median([f / p for f, p in got[e]])
        out[e] = {
            "step_us": full,
            "floor_us": floor,
            "substeps": substeps[e],
            "step_median_us": _median(full),
            "floor_median_us": _median(floor),
            "step_over_floor": ratio,
        }
        rows.append(
            [e, str(substeps[e]), f"{_median(full):.1f}", f"{_median(floor):.1f}", f"{ratio:.2f}"]
        )
    _table(["id", "substeps", "step", "pymunk", "step/pymunk"], rows, [26, 9, 8, 8, 12])
    if ENV_ID in args.ids:
        prof = T.profile_step(ENV_ID, max(args.steps, 200), args.seed)
        out["profile_us"] = {ENV_ID: prof}
        keys = ("physics", "outputs", "other", "env_step", "wrapped_step")
        parts = ", ".join(f"{k} {prof[k]:.1f}" for k in keys)
        print(f"  profile of one {ENV_ID} step (us): {parts}")
    return out


def startup_section(args: argparse.Namespace) -> dict[str, Any]:
    from tooling import throughput as T

    print(
        "\nstart-up: fresh processes, import planar3p_gym, then gym.make(id), reset, one step "
        "per id (s)"
    )
    got = T.startup_times(args.ids)
    rows = []
    for key, label in (("cold", "first call (empty numba cache)"), ("warm", "cached")):
        g = got[key]
        first = g["ids_s"][args.ids[0]]
        rows.append(
            [label, f"{g['process_s']:.2f}", f"{g['import_s']:.2f}", f"{first:.2f}"]
            + [f"{sum(g['ids_s'].values()) - first:.2f}"]
        )
    _table(["process", "whole", "import", f"{args.ids[0]}", "other ids"], rows, [31, 7, 7, 22, 10])
    got["compile_s"] = got["cold"]["total_s"] - got["warm"]["total_s"]
    print(f"  compile time (cold - cached, in the process): {got['compile_s']:.2f} s")
    return got


def ppo_section(args: argparse.Namespace, refs: list[str]) -> dict[str, Any]:
    from tooling import throughput as T

    print(
        f"\nPPO: training steps/s, {args.ppo_steps} timesteps x {args.ppo_rounds} rounds, "
        f"ppo.yml's {ENV_ID} recipe, torch 1 thread"
    )
    runs: dict[str, Callable[[int], float]] = {
        f"{ENV_ID} recipe (native)": lambda r: T.ppo_rate(ENV_ID, args.ppo_steps, args.seed + r),
        f"{ENV_ID} DummyVecEnv": lambda r: T.ppo_rate(
            ENV_ID, args.ppo_steps, args.seed + r, "dummy"
        ),
    }
    if REACHER in refs:
        runs[f"{REACHER} DummyVecEnv"] = lambda r: T.ppo_rate(
            REACHER, args.ppo_steps, args.seed + r, "dummy"
        )
    rates = T.interleave(runs, args.ppo_rounds)
    ratio = _ratios(rates, f"{REACHER} DummyVecEnv")
    rows = [[k, f"{_median(v):,.0f}", _x(ratio.get(k))] for k, v in rates.items()]
    _table(["run", "steps/s", f"x {REACHER}"], rows, [30, 9, 13])
    return {"rates": rates, "median": {k: _median(v) for k, v in rates.items()}, "x_reacher": ratio}


# ---------------------------------------------------------------------------- targets


def targets(results: dict[str, Any], ids: list[str], sizes: list[int]) -> list[dict[str, Any]]:
    """Each target (:data:`TARGETS`) of each of ``ids``: what, id, the measured value
    (``None`` when its section or size did not run), the bound and whether it is met."""
    rows = []

    def add(key: str, env_id: str, value: float | None) -> None:
        what, bound, kind = TARGETS[key]
        met = None if value is None else (value >= bound if kind == "min" else value <= bound)
        rows.append(
            {
                "target": what,
                "id": env_id,
                "measured": value,
                "bound": bound,
                "kind": kind,
                "met": met,
            }
        )

    single = results.get("single", {}).get("x_reacher", {})
    size = str(TARGET_SIZE)
    vector = results.get("vector", {}).get(size, {}).get("x_reacher_sync", {})
    floor = results.get("floor", {})
    for e in ids:
        add("single", e, single.get(e))
        add("floor", e, floor.get(e, {}).get("step_over_floor"))
        x = vector.get(e) if TARGET_SIZE in sizes else None
        add("vector_v0" if e == ENV_ID else "vector", e, x)
    return rows


def print_targets(rows: list[dict[str, Any]]) -> None:
    print("\ntargets")
    table = []
    for t in rows:
        v, b = t["measured"], t["bound"]
        sign = ">=" if t["kind"] == "min" else "<="
        us = "(us)" in t["target"]
        measured = "-" if v is None else (f"{v:,.0f}" if us else f"{v:.2f}")
        bound = f"{sign} {b:,.0f}" if us else f"{sign} {b:g}"
        met = "-" if t["met"] is None else ("yes" if t["met"] else "NO")
        table.append([t["id"], t["target"], measured, bound, met])
    _table(["id", "target", "measured", "required", "met"], table, [25, 58, 10, 9, 4], left=2)


def run(args: argparse.Namespace) -> int:
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import gymnasium as gym

    import planar3p_gym
    from tooling import throughput

    warnings.filterwarnings("ignore", message=".*out of date.*")
    refs = [REACHER] if mujoco_available() else []
    meta = {
        "python": platform.python_version(),
        "gymnasium": gym.__version__,
        "planar3p_gym": planar3p_gym.__version__,
        "cpus": os.cpu_count(),
        "load_average_start": os.getloadavg()[0],
    }
    print(
        f"python {meta['python']}, gymnasium {meta['gymnasium']}, planar3p_gym "
        f"{meta['planar3p_gym']}, {meta['cpus']} CPUs, "
        f"load average {meta['load_average_start']:.2f}"
    )
    if not refs:
        print(f"{REACHER} skipped (mujoco not importable): no ratios to it")
    results: dict[str, Any] = {
        "meta": meta,
        "config": {
            "ids": args.ids,
            "sizes": args.sizes,
            "sections": args.sections,
            **{name: getattr(args, name) for name in DEFAULTS},
            "seed": args.seed,
        },
    }
    if "single" in args.sections:
        results["single"] = single_section(args, refs)
    if "vector" in args.sections:
        results["vector"] = vector_section(args, refs)
    if "resets" in args.sections:
        results["resets"] = resets_section(args, refs)
    if "floor" in args.sections:
        results["floor"] = floor_section(args)
    if "startup" in args.sections:
        results["startup"] = startup_section(args)
    if "ppo" in args.sections:
        try:
            import stable_baselines3  # noqa: F401
        except ImportError:
            print("\nPPO skipped (stable-baselines3 not importable: the train extra)")
        else:
            results["ppo"] = ppo_section(args, refs)
    results["targets"] = targets(results, args.ids, args.sizes)
    print_targets(results["targets"])
    results["meta"]["load_average_end"] = os.getloadavg()[0]
    print(f"(load average {results['meta']['load_average_end']:.2f} at the end)")
    if args.json:
        throughput.write_json_atomic(args.json, results)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run this script with ``argv`` (default: the process's arguments); the exit status."""
    return script.main(__name__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
