"""Throughput benchmark of ``Planar3P-v0`` against Gymnasium's ``Pendulum-v1`` and ``Reacher-v5``.

Measures, in one run:

* single-env steps/s of each env made with ``gym.make`` (its registered wrappers included), random
  actions sampled up front, no rendering, resets done (and timed) whenever an episode ends; the
  envs are interleaved across repeats (their order rotates) and the medians are reported, with
  the ratios Planar3P/Reacher and Planar3P/Pendulum as medians of the per-repeat ratios (paired
  measurements are robust to the load drifting on a shared machine);
* vectorised throughput of ``Planar3P-v0``: ``SyncVectorEnv`` and ``AsyncVectorEnv`` with 2
  workers, total env steps/s;
* a profile of one ``Planar3P-v0`` step: time in the physics substeps, the state readout, the
  kinematic measures, the observation, reward and info, the rest of ``Planar3PEnv.step``
  (validation, termination logic) and the ``gym.make`` wrappers; ``--cprofile`` adds cProfile's
  top functions.

``Reacher-v5`` is skipped when mujoco is not importable.

Usage::

    .venv/bin/python scripts/bench_env.py            # about a minute
    .venv/bin/python scripts/bench_env.py --quick    # a few seconds
"""

from __future__ import annotations

import argparse
import cProfile
import inspect
import io
import json
import math
import os
import platform
import pstats
import statistics
import sys
import time
import warnings
from typing import Any

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import gymnasium as gym
import numpy as np

import planar3p_gym
from planar3p_gym import rewards
from planar3p_gym.rewards import pose_error, reward_terms

PLANAR = planar3p_gym.ENV_ID
PENDULUM = "Pendulum-v1"
REACHER = "Reacher-v5"


def mujoco_available() -> bool:
    """True when ``Reacher-v5`` can be made (mujoco importable)."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


# ---------------------------------------------------------------------------- single env
class SingleEnvRunner:
    """One ``gym.make`` env with its actions sampled up front; :meth:`run` times ``n`` steps."""

    def __init__(self, env_id: str, n_steps: int, seed: int) -> None:
        self.env_id = env_id
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self.env = gym.make(env_id)
        self.env.action_space.seed(seed)
        self.actions = [self.env.action_space.sample() for _ in range(n_steps)]
        self.seed = seed
        self.env.reset(seed=seed)
        self.run(min(200, n_steps))  # warm-up: first-call caches, lazy imports

    def run(self, n: int | None = None) -> tuple[float, int]:
        """Steps/s over ``n`` steps (all sampled actions by default) and the resets done."""
        env, actions = self.env, self.actions if n is None else self.actions[:n]
        step, reset = env.step, env.reset
        resets = 0
        reset(seed=self.seed)
        t0 = time.perf_counter()
        for a in actions:
            _, _, terminated, truncated, _ = step(a)
            if terminated or truncated:
                reset()
                resets += 1
        elapsed = time.perf_counter() - t0
        return len(actions) / elapsed, resets

    def median_step_us(self) -> float:
        """Median wall time of one step (us) over the sampled actions, each step timed on its
        own: unlike a rate, it ignores the steps during which the process was preempted."""
        env, clock = self.env, time.perf_counter_ns
        env.reset(seed=self.seed)
        times = np.empty(len(self.actions), dtype=np.int64)
        for n, a in enumerate(self.actions):
            t0 = clock()
            _, _, terminated, truncated, _ = env.step(a)
            times[n] = clock() - t0
            if terminated or truncated:
                env.reset()
        return float(np.median(times)) / 1e3

    def close(self) -> None:
        self.env.close()


def bench_single(env_ids: list[str], n_steps: int, repeats: int, seed: int) -> dict[str, Any]:
    """Interleaved single-env rates: ``{env_id: [rate per repeat]}`` plus resets."""
    runners = {e: SingleEnvRunner(e, n_steps, seed) for e in env_ids}
    rates: dict[str, list[float]] = {e: [] for e in env_ids}
    medians: dict[str, list[float]] = {e: [] for e in env_ids}
    resets: dict[str, int] = {e: 0 for e in env_ids}
    for r in range(repeats):
        order = env_ids[r % len(env_ids) :] + env_ids[: r % len(env_ids)]  # rotate the order
        for e in order:
            rate, n_resets = runners[e].run()
            rates[e].append(rate)
            resets[e] += n_resets
        if r < 3:  # a few passes of per-step timing, interleaved too
            for e in order:
                medians[e].append(runners[e].median_step_us())
    for runner in runners.values():
        runner.close()
    return {"rates": rates, "resets": resets, "median_step_us": medians}


# ---------------------------------------------------------------------------- vectorised
def _make_planar() -> gym.Env:
    return gym.make(PLANAR)


def bench_vector(kind: str, n_envs: int, n_steps: int, repeats: int, seed: int) -> list[float]:
    """Total env steps/s of a ``kind`` ("sync" or "async") vector env of ``Planar3P-v0``."""
    cls = gym.vector.SyncVectorEnv if kind == "sync" else gym.vector.AsyncVectorEnv
    venv = cls([_make_planar] * n_envs)
    try:
        venv.action_space.seed(seed)
        per_env = max(1, n_steps // n_envs)
        actions = [venv.action_space.sample() for _ in range(per_env)]
        venv.reset(seed=seed)
        for a in actions[:50]:  # warm-up
            venv.step(a)
        out = []
        for _ in range(repeats):
            venv.reset(seed=seed)
            t0 = time.perf_counter()
            for a in actions:  # autoreset (next-step mode) is part of the vector env
                venv.step(a)
            out.append(n_envs * len(actions) / (time.perf_counter() - t0))
        return out
    finally:
        venv.close()


# ---------------------------------------------------------------------------- profile
_REWARD_PARAMS = set(inspect.signature(reward_terms).parameters)


def _reward_kwargs(env: Any, pos_err: float, ang_err: float, measures: Any, action) -> dict:
    """Keyword arguments of ``reward_terms`` as ``Planar3PEnv.step`` builds them (only those
    the installed version takes)."""
    w, length = env.reward_weights, env._length
    kw: dict[str, Any] = {
        "pose_err": pose_error(pos_err, ang_err, length),
        "parallel_margin": measures.parallel_margin,
        "serial_margin": measures.serial_margin,
        "action": action,
        "success": False,
        "failure": False,
    }
    if "precision_err" in _REWARD_PARAMS:
        kw["precision_err"] = rewards.precision_penalty(pos_err, ang_err, length, w.precision_scale)
    return {k: v for k, v in kw.items() if k in _REWARD_PARAMS}


class _StubEnv(gym.Env):
    """An env with Planar3P-v0's spaces that does nothing: isolates the wrappers' cost."""

    def __init__(self, like: gym.Env) -> None:
        self.observation_space = like.observation_space
        self.action_space = like.action_space
        self._obs = like.observation_space.sample()

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        return self._obs.copy(), {}

    def step(self, action):
        return self._obs.copy(), 0.0, False, False, {}


def wrapper_cost(n_steps: int, seed: int) -> float:
    """Time (us) that ``gym.make``'s wrappers of ``Planar3P-v0`` add to one step, measured
    around a do-nothing env with the same spaces (same wrapper classes as ``gym.make``)."""
    made = gym.make(PLANAR)
    stub = _StubEnv(made.unwrapped)
    layers = []
    env: gym.Env = made
    while isinstance(env, gym.Wrapper):
        layers.append(env)
        env = env.env
    wrapped: gym.Env = stub
    for layer in reversed(layers):
        if isinstance(layer, gym.wrappers.TimeLimit):
            wrapped = gym.wrappers.TimeLimit(wrapped, max_episode_steps=10**9)
        else:
            wrapped = type(layer)(wrapped)
    actions = np.random.default_rng(seed).uniform(-1, 1, (n_steps, 3)).astype(np.float32)
    clock = time.perf_counter_ns
    wrapped.reset(seed=seed)
    stub.reset(seed=seed)
    costs = []
    for _ in range(3):
        t0 = clock()
        for a in actions:
            wrapped.step(a)
        t1 = clock()
        for a in actions:
            stub.step(a)
        t2 = clock()
        costs.append(((t1 - t0) - (t2 - t1)) / n_steps / 1e3)
    made.close()
    return statistics.median(costs)


def profile_components(n_steps: int, seed: int, passes: int = 3) -> dict[str, float]:
    """Median time per step (microseconds) of each part of a ``Planar3P-v0`` step.

    Three identical envs are stepped in lockstep on the same random actions (the simulation is
    deterministic, so they go through the same states), and each step of the loop times, back
    to back so that load drifts on a shared machine affect all alike: a whole
    ``gym.make(...).step`` (``wrapped_step``), a whole ``env.unwrapped.step`` (``env_step``),
    and the parts of ``Planar3PEnv.step`` called one by one on the third env: ``physics`` =
    the substeps plus impulse bookkeeping (``step_unchecked`` minus one readout), ``readout`` =
    building the ``SimState`` from the bodies, ``measures`` = scalar margins and assembly mode,
    ``observation``, ``reward_info`` = reward terms and the info dict.  The remainder of
    ``env_step`` (``env_step_other``) is action validation and termination logic.  Each value
    is the median of the per-step times over ``passes`` measured passes (after a warm-up
    pass): medians, unlike means, ignore the steps during which a busy shared machine
    preempted the process.  ``wrappers`` is measured separately (:func:`wrapper_cost`).
    Resets of the wrapped env (when its episodes end) are timed too: median, mean, and
    amortised per step (``reset_per_step``), with the mean ``episode_length``.
    """
    rng = np.random.default_rng(seed)
    actions = rng.uniform(-1.0, 1.0, size=(n_steps, 3)).astype(np.float32)
    clock = time.perf_counter_ns
    wrapped = gym.make(PLANAR)
    raw = gym.make(PLANAR).unwrapped
    comp = gym.make(PLANAR).unwrapped
    vmax = comp.design.max_speed
    keys = (
        "wrapped_step",
        "env_step",
        "physics",
        "readout",
        "measures",
        "observation",
        "reward_info",
    )
    samples = np.zeros((passes, n_steps, len(keys)), dtype=np.int64)
    reset_times: list[int] = []

    def reset_all(**kw: Any) -> None:
        for env in (wrapped, raw, comp):
            env.reset(**kw)

    for p in range(passes + 1):  # pass 0 warms up
        reset_all(seed=seed)
        for n, a in enumerate(actions):
            t0 = clock()
            _, _, terminated, truncated, _ = wrapped.step(a)
            t1 = clock()
            raw.step(a)
            t2 = clock()
            sim = comp.sim
            state = sim.step_unchecked(float(a[0]) * vmax, float(a[1]) * vmax, float(a[2]) * vmax)
            t3 = clock()
            sim._read()
            t4 = clock()
            measures = comp._kin.measures(state.pose, state.rho)
            t5 = clock()
            comp._observe(state, measures)
            t6 = clock()
            pos_err, ang_err = comp._errors(state.pose)
            action = (float(a[0]), float(a[1]), float(a[2]))
            terms = reward_terms(
                comp.reward_weights, **_reward_kwargs(comp, pos_err, ang_err, measures, action)
            )
            sum(terms.values())
            comp._info(state, measures, None, terms, False, (pos_err, ang_err))
            t7 = clock()
            if p > 0:
                samples[p - 1, n] = (
                    t1 - t0,
                    t2 - t1,
                    (t3 - t2) - (t4 - t3),
                    t4 - t3,
                    t5 - t4,
                    t6 - t5,
                    t7 - t6,
                )
            if terminated or truncated:
                t8 = clock()
                wrapped.reset()
                if p > 0:
                    reset_times.append(clock() - t8)
                raw.reset()
                comp.reset()
    wrapped.close()
    med = np.median(samples.reshape(-1, len(keys)), axis=0) / 1e3
    out = {k: float(v) for k, v in zip(keys, med, strict=True)}
    parts = sum(out[k] for k in ("physics", "readout", "measures", "observation", "reward_info"))
    out["env_step_other"] = out["env_step"] - parts
    out["wrappers"] = wrapper_cost(n_steps, seed)
    out["reset_median"] = float(np.median(reset_times)) / 1e3 if reset_times else math.nan
    out["reset_mean"] = float(np.mean(reset_times)) / 1e3 if reset_times else math.nan
    out["reset_per_step"] = float(np.sum(reset_times)) / (passes * n_steps) / 1e3
    out["episode_length"] = passes * n_steps / max(len(reset_times), 1)
    return out


def cprofile_top(n_steps: int, seed: int, top: int = 15) -> str:
    """cProfile's ``top`` functions by internal time over ``n_steps`` wrapped steps."""
    env = gym.make(PLANAR)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(n_steps)]
    env.reset(seed=seed)
    prof = cProfile.Profile()
    prof.enable()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    prof.disable()
    env.close()
    buf = io.StringIO()
    pstats.Stats(prof, stream=buf).sort_stats("tottime").print_stats(top)
    return buf.getvalue()


# ---------------------------------------------------------------------------- main
def _fmt_rates(values: list[float]) -> str:
    med, lo, hi = statistics.median(values), min(values), max(values)
    return f"{med:10,.0f} steps/s  (min {lo:,.0f}, max {hi:,.0f})"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="short run (a few seconds)")
    parser.add_argument("--steps", type=int, default=None, help="steps per measurement")
    parser.add_argument("--repeats", type=int, default=None, help="interleaved repeats")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-vector", action="store_true", help="skip the vector envs")
    parser.add_argument("--cprofile", action="store_true", help="also print cProfile's top")
    parser.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    args = parser.parse_args(argv)
    steps = args.steps or (2_000 if args.quick else 20_000)
    repeats = args.repeats or (3 if args.quick else 7)
    if steps < 1 or repeats < 1:
        parser.error("--steps and --repeats must be >= 1")

    env_ids = [PLANAR, PENDULUM] + ([REACHER] if mujoco_available() else [])
    print(
        f"python {platform.python_version()}, gymnasium {gym.__version__}, "
        f"planar3p_gym {planar3p_gym.__version__}, {os.cpu_count()} CPUs, "
        f"load average {os.getloadavg()[0]:.2f}"
    )
    print(f"single env: {steps} steps x {repeats} interleaved repeats, random actions\n")
    single = bench_single(env_ids, steps, repeats, args.seed)
    rates = single["rates"]
    step_us = {e: statistics.median(v) for e, v in single["median_step_us"].items()}
    for e in env_ids:
        print(f"  {e:<12} {_fmt_rates(rates[e])}   resets {single['resets'][e]}")
    print("  median time of one step (steps timed one by one; ignores preempted steps):")
    for e in env_ids:
        print(f"  {e:<12} {step_us[e]:8.2f} us  (= {1e6 / step_us[e]:,.0f} steps/s unpreempted)")
    if REACHER not in env_ids:
        print(f"  {REACHER:<12} skipped (mujoco not importable)")
    results: dict[str, Any] = {
        "steps": steps,
        "repeats": repeats,
        "single_env_steps_per_s": {e: statistics.median(rates[e]) for e in env_ids},
        "single_env_rates": rates,
        "median_step_us": step_us,
    }
    ratios: dict[str, float] = {}
    for other in (REACHER, PENDULUM):
        if other in rates:
            paired = [p / o for p, o in zip(rates[PLANAR], rates[other], strict=True)]
            ratios[other] = statistics.median(paired)
            by_median = step_us[other] / step_us[PLANAR]
            print(
                f"  ratio Planar3P/{other.split('-')[0]:<9} {ratios[other]:.3f} "
                f"(median of per-repeat rate ratios; from median step times {by_median:.3f})"
            )
    results["ratios"] = ratios

    if not args.no_vector:
        vec_steps = max(steps // 2, 200)
        vec_repeats = max(1, repeats // 2)
        print(f"\nvectorised Planar3P-v0, 2 workers, {vec_steps} total steps x {vec_repeats}:")
        results["vector_steps_per_s"] = {}
        for kind in ("sync", "async"):
            v = bench_vector(kind, 2, vec_steps, vec_repeats, args.seed)
            results["vector_steps_per_s"][kind] = statistics.median(v)
            print(f"  {kind + 'VectorEnv':<16} {_fmt_rates(v)}")

    n_prof = max(steps // 2, 500)
    prof = profile_components(n_prof, args.seed)
    results["profile_us"] = prof
    total = prof["wrapped_step"]
    print(f"\nprofile of one Planar3P-v0 step ({n_prof} random-action steps), median per step:")
    labels = (
        ("physics", "physics substeps (pymunk)"),
        ("readout", "state readout"),
        ("measures", "kinematic measures"),
        ("observation", "observation"),
        ("reward_info", "reward terms + info"),
        ("env_step_other", "rest of env.step"),
        ("wrappers", "gym.make wrappers"),
    )
    for key, label in labels:
        share = 100.0 * prof[key] / total if total > 0 else math.nan
        print(f"  {label:<28} {prof[key]:8.2f} us  {share:5.1f} %")
    print(f"  {'whole gym.make(...).step':<28} {total:8.2f} us  ({1e6 / total:,.0f} steps/s)")
    print(f"  {'whole env.unwrapped.step':<28} {prof['env_step']:8.2f} us")
    print(
        f"  reset: median {prof['reset_median']:.0f} us, mean {prof['reset_mean']:.0f} us, "
        f"every {prof['episode_length']:.0f} steps on average = {prof['reset_per_step']:.2f} us "
        "per step amortised (not in the medians above; included in the steps/s rates)"
    )
    print("  (medians of per-step times; parts timed one by one in lockstep with whole steps;")
    print("   wrappers timed around a do-nothing env; shares are of the whole wrapped step)")

    if args.cprofile:
        print("\ncProfile, top functions by internal time:")
        print(cprofile_top(n_prof, args.seed))

    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(results, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
