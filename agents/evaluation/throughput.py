"""Throughput measurements of the environments (the logic of ``scripts/bench_env.py``).

* :func:`single_env_rates`: steps/s of single envs made with ``gym.make`` (their registered
  wrappers included), each measured by Gymnasium's own
  :func:`gymnasium.utils.performance.benchmark_step` (random actions, resets included) for a
  fixed duration; the envs are interleaved across repeats with a rotating order, so that a
  load drifting on a shared machine affects all alike, and ratios are taken per repeat
  (paired) before the median.
* :func:`best_block_rates`: the envs (single ones and vector envs) stepped in short blocks,
  round-robin, many times; each env's fastest blocks estimate its speed on an idle machine
  (load only ever slows a block down), which makes ratios between envs reproducible on a
  busy shared machine where rates of whole runs vary several-fold.
* :func:`median_step_us`: the median wall time of single steps, each timed on its own
  (ignores the steps during which a busy machine preempted the process).
* :func:`vector_rates`: total env steps/s of a vector env: the native one
  (``gym.make_vec``'s default for the ids that register it), ``SyncVectorEnv`` or
  ``AsyncVectorEnv``.
* :func:`profile_step`: median time per step of the parts of a ``Planar3PEnv`` step.
* :func:`ppo_rates`: PPO training steps/s with the native SB3 adapter, ``DummyVecEnv`` and
  ``SubprocVecEnv`` (needs the ``train`` extra).
* :func:`write_json_atomic`: results written to a temporary file, then renamed.
"""

from __future__ import annotations

import json
import os
import statistics
import time
import warnings
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils.performance import benchmark_step

from planar3p_gym.atomic_files import write_atomic

__all__ = [
    "best_block_rates",
    "make_env",
    "median_step_us",
    "paired_ratio",
    "ppo_rates",
    "profile_step",
    "single_env_rates",
    "vector_rates",
    "write_json_atomic",
]


def make_env(env_id: str, **kwargs: Any) -> gym.Env:
    """``gym.make`` without Gymnasium's warnings (e.g. that v0 has a newer version)."""
    with warnings.catch_warnings():  # e.g. "Planar3P-v0 is out of date"
        warnings.simplefilter("ignore")
        return gym.make(env_id, **kwargs)


def single_env_rates(
    env_ids: list[str], repeats: int, duration: float, seed: int
) -> dict[str, list[float]]:
    """``{env_id: [steps/s of each repeat]}``, interleaved (module docstring)."""
    envs = {e: make_env(e) for e in env_ids}
    rates: dict[str, list[float]] = {e: [] for e in env_ids}
    try:
        for env in envs.values():  # warm-up: first-call caches, lazy imports
            benchmark_step(env, target_duration=min(0.2, duration), seed=seed)
        for r in range(repeats):
            order = env_ids[r % len(env_ids) :] + env_ids[: r % len(env_ids)]
            for e in order:
                envs[e].action_space.seed(seed + r)
                rates[e].append(benchmark_step(envs[e], target_duration=duration, seed=seed))
    finally:
        for env in envs.values():
            env.close()
    return rates


def best_block_rates(
    makers: dict[str, Any], block_steps: int, blocks: int, seed: int, quantile: float = 0.9
) -> dict[str, float]:
    """Env steps/s of each env at the ``quantile`` of its block rates (0.9: the fastest
    tenth), blocks of ``block_steps`` env steps (a vector env's block: ``block_steps //
    num_envs`` batch steps) interleaved round-robin ``blocks`` times.  ``makers`` maps
    a label to a zero-argument function making the env (single or vector); random actions
    are sampled up front; resets are included."""
    envs = {k: make() for k, make in makers.items()}
    runners = {}
    for k, env in envs.items():
        env.action_space.seed(seed)
        vector = isinstance(env, gym.vector.VectorEnv)
        # Blocks of about the same duration: a vector env's block has block_steps env steps.
        n_batch = max(1, block_steps // env.num_envs) if vector else block_steps
        actions = [env.action_space.sample() for _ in range(n_batch)]
        env.reset(seed=seed)
        runners[k] = (env, actions, env.num_envs if vector else 1, vector)
    rates: dict[str, list[float]] = {k: [] for k in envs}
    clock = time.perf_counter
    try:
        for _ in range(blocks + 1):  # the first round warms up
            for k, (env, actions, n, vector) in runners.items():
                step, reset = env.step, env.reset
                t0 = clock()
                if vector:
                    for a in actions:
                        step(a)
                else:
                    for a in actions:
                        _, _, terminated, truncated, _ = step(a)
                        if terminated or truncated:
                            reset()
                rates[k].append(n * len(actions) / (clock() - t0))
    finally:
        for env in envs.values():
            env.close()
    return {k: float(np.quantile(v[1:], quantile)) for k, v in rates.items()}


def paired_ratio(a: list[float], b: list[float]) -> float:
    """Median of the per-repeat ratios ``a[r] / b[r]``."""
    return statistics.median(x / y for x, y in zip(a, b, strict=True))


def median_step_us(env_id: str, n_steps: int, seed: int) -> float:
    """Median wall time (us) of one ``gym.make(env_id)`` step over ``n_steps`` random-action
    steps (resets not timed)."""
    env = make_env(env_id)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(n_steps)]
    env.reset(seed=seed)
    clock = time.perf_counter_ns
    times = np.empty(n_steps, dtype=np.int64)
    for n, a in enumerate(actions):
        t0 = clock()
        _, _, terminated, truncated, _ = env.step(a)
        times[n] = clock() - t0
        if terminated or truncated:
            env.reset()
    env.close()
    return float(np.median(times)) / 1e3


def vector_rates(
    env_id: str,
    kind: str,
    num_envs: int,
    n_steps: int,
    repeats: int,
    seed: int,
    reference: str | None = None,
) -> list[float] | tuple[list[float], list[float]]:
    """Total env steps/s of a ``kind`` vector env (``"native"``, ``"native-numpy"``: the
    native one with ``batch="numpy"``, ``"sync"`` or ``"async"``) of ``num_envs`` copies of
    ``env_id``, ``n_steps`` batch steps per repeat.  With
    ``reference`` (an env id), also the single-env steps/s of that id measured right before
    each repeat, as many env steps with actions sampled up front, for paired ratios."""
    modes = {
        "native": "vector_entry_point",
        "native-numpy": "vector_entry_point",
        "sync": "sync",
        "async": "async",
    }
    if kind not in modes:
        raise ValueError(f"kind must be one of {sorted(modes)}, got {kind!r}")
    extra = {"batch": "numpy"} if kind == "native-numpy" else {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        venv = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode=modes[kind], **extra)
    try:
        venv.action_space.seed(seed)
        actions = [venv.action_space.sample() for _ in range(n_steps)]
        venv.reset(seed=seed)
        for a in actions[: min(50, n_steps)]:  # warm-up
            venv.step(a)
        ref_env = make_env(reference) if reference else None
        if ref_env is not None:  # pre-sampled too: the same loop structure as the vector env
            ref_env.action_space.seed(seed)
            ref_actions = [ref_env.action_space.sample() for _ in range(num_envs * n_steps)]
            ref_env.reset(seed=seed)
        out, ref = [], []
        for _ in range(repeats):
            if ref_env is not None:
                t0 = time.perf_counter()
                for a in ref_actions:
                    _, _, terminated, truncated, _ = ref_env.step(a)
                    if terminated or truncated:
                        ref_env.reset()
                ref.append(len(ref_actions) / (time.perf_counter() - t0))
            venv.reset(seed=seed)
            t0 = time.perf_counter()
            for a in actions:
                venv.step(a)
            out.append(num_envs * n_steps / (time.perf_counter() - t0))
        if ref_env is not None:
            ref_env.close()
            return out, ref
        return out
    finally:
        venv.close()


def profile_step(env_id: str, n_steps: int, seed: int) -> dict[str, float]:
    """Median time per step (us) of the parts of a ``Planar3PEnv`` step, measured on a second
    env stepped in lockstep with the whole step (same actions, so the same states):
    ``wrapped_step`` (``gym.make(...).step``), ``env_step`` (unwrapped), ``physics``
    (``Planar3PSim.step_unchecked``: pymunk, and the projection where it is on),
    ``outputs`` (configuration measures, observation, errors, termination and reward terms:
    the fused :class:`planar3p_gym.tasks.reach_step.ReachStep` where the env uses it, else the
    general step's pieces); ``other`` is the rest of ``env_step`` (action parsing, ``info``)."""
    rng = np.random.default_rng(seed)
    actions = rng.uniform(-1.0, 1.0, size=(n_steps, 3)).astype(np.float32)
    wrapped, raw, parts = make_env(env_id), make_env(env_id).unwrapped, make_env(env_id).unwrapped
    vmax = parts.design.max_speed
    keys = ("wrapped_step", "env_step", "physics", "outputs")
    samples = np.zeros((n_steps, len(keys)), dtype=np.int64)
    clock = time.perf_counter_ns
    for env in (wrapped, raw, parts):
        env.reset(seed=seed)
    fused = parts._reach_step
    for n, a in enumerate(actions):
        t0 = clock()
        _, _, terminated, truncated, _ = wrapped.step(a)
        t1 = clock()
        raw.step(a)
        t2 = clock()
        act = (float(a[0]), float(a[1]), float(a[2]))
        state = parts.sim.step_unchecked(act[0] * vmax, act[1] * vmax, act[2] * vmax)
        t3 = clock()
        if fused is not None:
            geometry, target = parts.sim.geometry, parts._target
            fused.outputs(state, geometry, target, parts._target_cs, parts._assembly, act)
        else:
            measures = parts._kin.measures(state.pose, state.rho)
            parts._observe(state, measures)
            errors = parts._errors(state.pose)
            parts.task.termination(state, measures, errors, parts._assembly)
            parts.task.reward_terms(
                errors=errors, measures=measures, action=act, success=False, failure=False
            )
        t4 = clock()
        samples[n] = (t1 - t0, t2 - t1, t3 - t2, t4 - t3)
        if terminated or truncated:
            for env in (wrapped, raw, parts):
                env.reset()
    wrapped.close()
    med = np.median(samples, axis=0) / 1e3
    out = {k: float(v) for k, v in zip(keys, med, strict=True)}
    out["other"] = out["env_step"] - out["physics"] - out["outputs"]
    return out


def ppo_rates(env_id: str, n_envs: int, timesteps: int, seed: int) -> dict[str, float]:
    """PPO training steps/s (``model.learn(timesteps)``, SB3 defaults but ``n_steps`` sized to
    the rollout) on ``n_envs`` copies of ``env_id`` through each vec env: ``native``
    (:mod:`planar3p_agents.training.vec_adapter`), ``dummy`` (``DummyVecEnv``) and ``subproc``
    (``SubprocVecEnv``, one process per env)."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from planar3p_agents.training.vec_adapter import make_native_vec_env

    torch.set_num_threads(1)
    n_steps = max(16, timesteps // (2 * n_envs))
    out = {}
    for kind in ("native", "dummy", "subproc"):
        if kind == "native":
            venv = make_native_vec_env(env_id, n_envs=n_envs, seed=seed)
        else:
            cls = DummyVecEnv if kind == "dummy" else SubprocVecEnv
            venv = make_vec_env(f"planar3p_gym:{env_id}", n_envs, seed=seed, vec_env_cls=cls)
        model = PPO("MlpPolicy", venv, n_steps=n_steps, batch_size=n_steps, seed=seed, n_epochs=4)
        t0 = time.perf_counter()
        model.learn(timesteps)
        out[kind] = model.num_timesteps / (time.perf_counter() - t0)
        venv.close()
    return out


def write_json_atomic(path: str | os.PathLike, data: Any) -> None:
    """Write ``data`` as JSON to ``path`` atomically (:func:`planar3p_gym.atomic_files.
    write_atomic`): a reader never sees a partial file, and a failure (also data that is not
    JSON) leaves the old file as it was."""
    write_atomic(path, json.dumps(data, indent=2))
