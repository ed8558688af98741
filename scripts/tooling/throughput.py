"""Throughput measurements of the environments (the logic of ``python scripts/bench_env.py``).

Every measurement is interleaved: a round measures each configuration of a section once, in
an order rotated from round to round, so that a load drifting on a shared machine affects
all alike; ratios are taken per round against the reference measured in the same round
(paired) and the median of those ratios is reported (:func:`paired_ratio`).

* :func:`interleave`: the rounds of a section (any measurement functions).
* :func:`single_env_rates`: steps/s of single envs made with ``gym.make`` (their registered
  wrappers included), each measured by Gymnasium's own
  :func:`gymnasium.utils.performance.benchmark_step` (random actions, resets included), and
  beside it with pre-sampled actions (:func:`single_rate`, no action sampling in the loop);
  :data:`NOOP`, an env that does nothing with ``Planar3P-v0``'s spaces and time limit, shows
  the ceiling of any env's ratio there (the action sampling and the wrappers are left).
* :func:`make_vector_env`, :func:`vector_rate`, :func:`single_rate`: total env steps/s of a
  vector env (the id's native one, ``SyncVectorEnv`` where it has none) or of a single env
  with pre-sampled actions, for a fixed duration.
* :func:`reset_times`, :func:`reset_summary`: wall times of seeded resets;
  :class:`FullCollections`: the interpreter's full garbage collections during a block.
* :func:`step_and_floor_us`: the median full step beside the median of pymunk's own step
  alone (``cpSpaceStep`` on the env's own space, the same number of substeps).
* :func:`profile_step`: median time per step of the parts of a ``Planar3PEnv`` step.
* :func:`startup_times`: the first-call compile time (a fresh process, an empty numba cache)
  and the cached start-up time (a fresh process, that cache).
* :func:`ppo_rate`: PPO training steps/s with the project's recipe (``ppo.yml``) on an id or
  the same settings on ``Reacher-v5`` (needs the ``train`` extra).
* :func:`write_json_atomic`: results written to a temporary file, then renamed.
"""

from __future__ import annotations

import gc
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils.performance import benchmark_step

from planar3p_gym.atomic_files import write_atomic
from planar3p_gym.envs.registry import ENV_ID, ENV_SPECS

__all__ = [
    "CARTPOLE",
    "NOOP",
    "REACHER",
    "FullCollections",
    "NoOpEnv",
    "interleave",
    "make_env",
    "make_vector_env",
    "paired_ratio",
    "ppo_rate",
    "profile_step",
    "reset_summary",
    "reset_times",
    "single_env_rates",
    "single_rate",
    "startup_times",
    "step_and_floor_us",
    "vector_kind",
    "vector_rate",
    "write_json_atomic",
]

#: The references: MuJoCo's ``Reacher-v5`` (single and ``SyncVectorEnv``) and CartPole's
#: native vector env.
REACHER, CARTPOLE = "Reacher-v5", "CartPole-v1"
#: The id of :class:`NoOpEnv` (registered by :func:`make_env` when first asked for).
NOOP = "planar3p-bench/NoOp-v0"
_NATIVE = {row.id: row.vector_entry_point is not None for row in ENV_SPECS}


class NoOpEnv(gym.Env):
    """An environment that does no work, with ``Planar3P-v0``'s action and observation spaces:
    ``step`` returns the same observation, reward 0 and never ends (the time limit, which
    :data:`NOOP`'s registration takes from ``Planar3P-v0``, ends its episodes).  Under
    ``benchmark_step`` what it costs is the action sampling, the registered wrappers and the
    loop: its ratio to ``Reacher-v5`` is the most any environment can reach there."""

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(self) -> None:
        from planar3p_gym.envs.core import Planar3PEnv

        env = Planar3PEnv()
        self.action_space, self.observation_space = env.action_space, env.observation_space
        env.close()
        self._obs = np.zeros(self.observation_space.shape, dtype=self.observation_space.dtype)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        return self._obs.copy(), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        return self._obs.copy(), 0.0, False, False, {}


def make_env(env_id: str, **kwargs: Any) -> gym.Env:
    """``gym.make`` without Gymnasium's warnings (e.g. that v0 has a newer version); makes
    :data:`NOOP` too."""
    if env_id == NOOP and NOOP not in gym.registry:
        limit = next(row for row in ENV_SPECS if row.id == ENV_ID).max_episode_steps
        gym.register(NOOP, entry_point=NoOpEnv, max_episode_steps=limit)
    with warnings.catch_warnings():  # e.g. "Planar3P-v0 is out of date"
        warnings.simplefilter("ignore")
        return gym.make(env_id, **kwargs)


def single_env_rates(
    env_ids: list[str],
    repeats: int,
    duration: float,
    seed: int,
    presampled: dict[str, list[float]] | None = None,
) -> dict[str, list[float]]:
    """``{env_id: [steps/s of each repeat]}`` by ``benchmark_step``, interleaved (module
    docstring); with a dict ``presampled``, each round also measures each env with
    pre-sampled actions (:func:`single_rate`, right after its ``benchmark_step``) into it."""
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
                if presampled is not None:
                    presampled.setdefault(e, []).append(single_rate(envs[e], duration, seed + r))
    finally:
        for env in envs.values():
            env.close()
    return rates


def paired_ratio(a: list[float], b: list[float]) -> float:
    """Median of the per-repeat ratios ``a[r] / b[r]``."""
    return statistics.median(x / y for x, y in zip(a, b, strict=True))


def profile_step(env_id: str, n_steps: int, seed: int) -> dict[str, float]:
    """Median time per step (us) of the parts of a ``Planar3PEnv`` step, measured on a second
    env stepped in lockstep with the whole step (same actions, so the same states):
    ``wrapped_step`` (``gym.make(...).step``), ``env_step`` (unwrapped), ``physics``
    (``Planar3PSim.step_unchecked``: pymunk, and the projection where it is on),
    ``outputs`` (the task's kernel, :mod:`planar3p_gym.tasks.kernel`: configuration measures,
    observation, errors, termination, reward terms and ``info``); ``other`` is the rest of
    ``env_step`` (the actuation, the observation delay)."""
    rng = np.random.default_rng(seed)
    actions = rng.uniform(-1.0, 1.0, size=(n_steps, 3)).astype(np.float32)
    wrapped, raw, parts = make_env(env_id), make_env(env_id).unwrapped, make_env(env_id).unwrapped
    vmax = parts.design.max_speed
    keys = ("wrapped_step", "env_step", "physics", "outputs")
    samples = np.zeros((n_steps, len(keys)), dtype=np.int64)
    clock = time.perf_counter_ns
    for env in (wrapped, raw, parts):
        env.reset(seed=seed)
    for n, a in enumerate(actions):
        t0 = clock()
        _, _, terminated, truncated, _ = wrapped.step(a)
        t1 = clock()
        raw.step(a)
        t2 = clock()
        act = (float(a[0]), float(a[1]), float(a[2]))
        state = parts.sim.step_unchecked(act[0] * vmax, act[1] * vmax, act[2] * vmax)
        t3 = clock()
        parts.episode.steps += 1  # (the task's kernel, as the env calls it)
        parts.kernel.step(parts.episode, state, parts.sim.state_array, act, parts.np_random)
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


def write_json_atomic(path: str | os.PathLike, data: Any) -> None:
    """Write ``data`` as JSON to ``path`` atomically (:func:`planar3p_gym.atomic_files.
    write_atomic`): a reader never sees a partial file, and a failure (also data that is not
    JSON) leaves the old file as it was."""
    write_atomic(path, json.dumps(data, indent=2))


def interleave(measures: dict[str, Callable[[int], Any]], rounds: int) -> dict[str, list[Any]]:
    """``{label: [result of each round]}``: round ``r`` calls every ``measures[label](r)`` once,
    the order rotated by ``r`` (the first round starts with the first label)."""
    labels = list(measures)
    out: dict[str, list[Any]] = {k: [] for k in labels}
    for r in range(rounds):
        s = r % len(labels) if labels else 0
        for k in labels[s:] + labels[:s]:
            out[k].append(measures[k](r))
    return out


def vector_kind(env_id: str) -> str:
    """``"native"`` where ``env_id`` registers a native vector env (the package's ids with a
    vector entry point, CartPole), else ``"sync"``."""
    if env_id in _NATIVE:
        return "native" if _NATIVE[env_id] else "sync"
    return "native" if gym.spec(env_id).vector_entry_point is not None else "sync"


def make_vector_env(env_id: str, num_envs: int, kind: str | None = None) -> gym.vector.VectorEnv:
    """``gym.make_vec(env_id, num_envs)``: the native vector env (``kind="native"``) or
    ``SyncVectorEnv`` (``"sync"``); by default :func:`vector_kind`."""
    kind = kind or vector_kind(env_id)
    modes = {"native": "vector_entry_point", "sync": "sync"}
    if kind not in modes:
        raise ValueError(f"kind must be one of {sorted(modes)}, got {kind!r}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gym.make_vec(env_id, num_envs=num_envs, vectorization_mode=modes[kind])


def _actions(space: gym.Space, seed: int, n: int) -> list[Any]:
    space.seed(seed)
    return [space.sample() for _ in range(n)]


def vector_rate(
    venv: gym.vector.VectorEnv, duration: float, seed: int, pool: int = 16, min_steps: int = 1
) -> float:
    """Total env steps/s of ``venv`` stepped for ``duration`` seconds and at least
    ``min_steps`` batch steps, with ``pool`` pre-sampled batch actions in turn; the vector
    env's autoreset (resets included).  A batch's episodes start together, and those that run
    to the time limit end together: ``min_steps`` of a time limit puts every env's resets in
    the measure in proportion, which a shorter window can miss altogether."""
    actions = _actions(venv.action_space, seed, pool)
    step, clock, n = venv.step, time.perf_counter, 0
    t0 = clock()
    end = t0 + duration
    while True:
        step(actions[n % pool])
        n += 1
        t = clock()
        if t >= end and n >= min_steps:
            break
    return venv.num_envs * n / (t - t0)


def single_rate(env: gym.Env, duration: float, seed: int, pool: int = 256) -> float:
    """Steps/s of a single env stepped for ``duration`` seconds with ``pool`` pre-sampled
    actions in turn, reset when an episode ends (resets included): the loop of
    :func:`vector_rate` for one env."""
    actions = _actions(env.action_space, seed, pool)
    step, reset, clock, n = env.step, env.reset, time.perf_counter, 0
    t0 = clock()
    end = t0 + duration
    while True:
        _, _, terminated, truncated, _ = step(actions[n % pool])
        n += 1
        if terminated or truncated:
            reset()
        t = clock()
        if t >= end:
            break
    return n / (t - t0)


class FullCollections:
    """Counts CPython's full (generation-2) garbage collections inside a ``with`` block and
    their wall times (s), through :data:`gc.callbacks`.

    A full collection traverses every object the process tracks (some 120,000 once numba's
    compiler state is loaded, about 100 ms on the reference machine), so it shows as a single
    slow reset or step; pymunk's bodies and constraints are each in a reference cycle with
    their cffi handle and are freed only by the collector, which is what triggers them."""

    def __init__(self) -> None:
        self.times: list[float] = []
        self._start = 0.0

    def _callback(self, phase: str, info: dict[str, Any]) -> None:
        if info.get("generation") != 2:
            return
        if phase == "start":
            self._start = time.perf_counter()
        else:
            self.times.append(time.perf_counter() - self._start)

    def __enter__(self) -> FullCollections:
        gc.callbacks.append(self._callback)
        return self

    def __exit__(self, *exc: object) -> None:
        gc.callbacks.remove(self._callback)


def reset_times(
    env: gym.Env, seeds: Sequence[int | None], clock: Callable[[], float] = time.perf_counter
) -> np.ndarray:
    """Times (s, of ``clock``: wall time by default) of ``env.reset(seed=s)`` for each seed, in
    order (after one unseeded reset, so that first-use costs are not counted); a seed ``None``
    is an unseeded reset (the env's generator goes on, as between a vector env's episodes)."""
    env.reset()
    out = np.empty(len(seeds))
    for k, seed in enumerate(seeds):
        t0 = clock()
        env.reset(seed=seed)
        out[k] = clock() - t0
    return out


def reset_summary(times: np.ndarray, seeds: Sequence[int], slowest: int = 5) -> dict[str, Any]:
    """Median, p99, p99.9, max (ms) of reset ``times`` (s) and the ``slowest`` seeds."""
    ms = 1e3 * np.asarray(times)
    slow = np.argsort(ms)[::-1][:slowest]
    return {
        "resets": int(ms.size),
        "median_ms": float(np.median(ms)),
        "p99_ms": float(np.percentile(ms, 99)),
        "p99.9_ms": float(np.percentile(ms, 99.9)),
        "max_ms": float(ms.max()),
        "slowest": [[int(seeds[i]), round(float(ms[i]), 2)] for i in slow],
    }


def _pymunk_floor(sim: Any) -> Callable[[], int]:
    """A function running ``sim.substeps`` of pymunk's own step on ``sim``'s space (Chipmunk's
    ``cpSpaceStep`` directly where the sim does, else ``Space.step``) and returning its wall
    time (ns)."""
    from planar3p_gym.sim import chipmunk

    h, substeps, clock = sim.dt / sim.substeps, sim.substeps, time.perf_counter_ns
    link = sim.batch_link()
    if link is not None:
        from pymunk._chipmunk_cffi import lib  # Chipmunk's C API, as the simulation calls it

        cp_step, space = lib.cpSpaceStep, link.space
    else:  # pragma: no cover - pymunk builds without the batch API
        cp_step, space = (lambda _s, dt: sim.space.step(dt)), None

    def run() -> int:
        # Compiled code that ran before (a reset's) can leave the vector registers' upper
        # halves dirty, which slows Chipmunk several times over until they are cleared.
        chipmunk.clear_upper()
        t0 = clock()
        for _ in range(substeps):
            cp_step(space, h)
        return clock() - t0

    return run


def step_and_floor_us(env: gym.Env, n_steps: int, seed: int) -> tuple[float, float]:
    """``(full, floor)``: the median wall time (us) of ``env.step`` (``env`` as ``gym.make``
    made it; resets not timed) over ``n_steps`` random-action steps, and the median of
    pymunk's own step alone on the env's own space (``substeps`` calls of ``cpSpaceStep``
    (:class:`~planar3p_gym.sim.physics.Planar3PSim`), the drives set to the
    same commands untimed) over as many steps, from the same seeded reset.  The floor leaves
    the env's simulation off its constraint manifold: the env is reset after it."""
    actions = _actions(env.action_space, seed, n_steps)
    limit = env.spec.max_episode_steps if env.spec and env.spec.max_episode_steps else 250
    clock = time.perf_counter_ns
    full = np.empty(n_steps, dtype=np.int64)
    env.reset(seed=seed)
    step = env.step
    for n, a in enumerate(actions):
        t0 = clock()
        _, _, terminated, truncated, _ = step(a)
        full[n] = clock() - t0
        if terminated or truncated:
            env.reset()
    floor = np.empty(n_steps, dtype=np.int64)
    raw = env.unwrapped
    env.reset(seed=seed)
    vmax = raw.sim.design.max_speed
    run, k = _pymunk_floor(raw.sim), 0
    for n, a in enumerate(actions):
        if k == limit:  # an episode's length, as the full step's resets
            env.reset()
            run, k = _pymunk_floor(raw.sim), 0
        for drive, v in zip(raw.sim.drives, a.tolist(), strict=True):
            drive.velocity = (v * vmax, 0.0)
        floor[n] = run()
        k += 1
    env.reset(seed=seed)
    return float(np.median(full)) / 1e3, float(np.median(floor)) / 1e3


#: What a fresh process runs for :func:`startup_times`; argv[1]: the ids, comma-separated.
_STARTUP = """\
import json, sys, time
t0 = time.perf_counter()
import gymnasium as gym
import planar3p_gym
t1 = time.perf_counter()
ids = {}
for env_id in sys.argv[1].split(","):
    t = time.perf_counter()
    env = gym.make(env_id)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    ids[env_id] = time.perf_counter() - t
    env.close()
print(json.dumps({"import_s": t1 - t0, "ids_s": ids, "total_s": time.perf_counter() - t0}))
"""


def startup_times(env_ids: Sequence[str], timeout: float = 900.0) -> dict[str, Any]:
    """Start-up times (s) of fresh Python processes running ``import planar3p_gym``, then for
    each id in turn ``gym.make(id)``, ``reset(seed=0)`` and one step: ``"cold"`` with an empty
    numba cache (``NUMBA_CACHE_DIR``, a new temporary directory: every compiled function is
    compiled on its first call), then ``"warm"`` in a second process with that cache.  Each
    has ``import_s``, ``ids_s`` (per id, in order: later ids reuse what earlier ones
    compiled), ``total_s`` (in the process) and ``process_s`` (the whole process, interpreter
    start-up included, from outside)."""
    out: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="planar3p-numba-") as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache, "SDL_VIDEODRIVER": "dummy"}
        env.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
        env.setdefault("PYTHONWARNINGS", "ignore")
        for key in ("cold", "warm"):
            t0 = time.perf_counter()
            done = subprocess.run(
                [sys.executable, "-c", _STARTUP, ",".join(env_ids)],
                env=env,
                capture_output=True,
                text=True,
                timeout=timeout,
                check=False,
            )
            wall = time.perf_counter() - t0
            if done.returncode != 0:
                tail = (done.stderr.strip().splitlines() or ["?"])[-1]
                raise RuntimeError(f"start-up process failed ({done.returncode}): {tail}")
            out[key] = {**json.loads(done.stdout.strip().splitlines()[-1]), "process_s": wall}
    return out


def ppo_rate(env_id: str, timesteps: int, seed: int, kind: str = "recipe") -> float:
    """PPO training steps/s (``model.learn(timesteps)``, construction not timed; torch one
    thread) with the hyperparameters of ``ppo.yml``'s ``Planar3P-v0`` entry (the recipe
    ``planar3p train --algo ppo`` uses: its envs, ``VecNormalize``, network, rollout), built
    by the training code.  ``kind``: ``"recipe"`` (``env_id``'s own entry on the native vector
    env adapter, as the recipe trains), ``"dummy"`` (the same settings on ``DummyVecEnv``,
    ``env_id`` made with ``gym.make``: also ``Reacher-v5``)."""
    import dataclasses

    import torch
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from planar3p_agents.training import config, run

    torch.set_num_threads(1)
    recipe = env_id if kind == "recipe" else "Planar3P-v0"
    entry = config.load_hyperparams(run.HYPERPARAMS_DIR / "ppo.yml", recipe, "ppo")
    cfg = config.resolve("ppo", recipe, seed, entry, n_timesteps=timesteps)
    cfg = dataclasses.replace(cfg, env_id=env_id)
    if kind == "recipe":
        venv, eval_env = run.make_envs(cfg, "native", None)
        eval_env.close()
    elif kind == "dummy":
        factory = config.EnvFactory(env_id, cfg.env_kwargs)
        venv = make_vec_env(factory, n_envs=cfg.n_envs, seed=seed, vec_env_cls=DummyVecEnv)
        if cfg.normalize is not None:
            venv = VecNormalize(venv, gamma=cfg.algo_kwargs.get("gamma", 0.99), **cfg.normalize)
    else:
        raise ValueError(f"kind must be 'recipe' or 'dummy', got {kind!r}")
    try:
        model = run.algo_class("ppo")(
            config.policy_class(cfg.policy), venv, seed=seed, **run.model_kwargs(cfg, venv)
        )
        t0 = time.perf_counter()
        model.learn(timesteps)
        return model.num_timesteps / (time.perf_counter() - t0)
    finally:
        venv.close()
