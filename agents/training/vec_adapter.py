"""SB3 ``VecEnv`` over the native vector env (:class:`planar3p_gym.envs.vector.Planar3PVectorEnv`).

``make_native_vec_env("Planar3P-v0", n_envs=16, seed=0)`` is a drop-in replacement for SB3's
``make_vec_env(..., vec_env_cls=DummyVecEnv)``: all environments step in this process, in one
call, without ``gym.make``'s wrappers.  SB3's conventions are kept: an ended episode is reset
within the same step (the vector env's ``SAME_STEP`` autoreset).

What ``step`` passes as ``infos`` (a list of ``num_envs`` dicts, as SB3's ``VecEnv``
requires), built without a per-environment dict for the episodes that go on:

- an environment whose episode goes on gets an empty dict ``{}`` (a new one each step), or,
  for the goal ids, a dict of the entries hindsight relabelling reads
  (:data:`planar3p_gym.tasks.goal.RELABEL_INFO_KEYS`);
- an environment whose episode ended in the step gets the core entries of the single env's
  last ``info`` (the vector env's ``info_keys``, ``is_success`` among them, as
  Python scalars), ``"terminal_observation"`` (its last observation), ``"TimeLimit.truncated"``
  (the time limit ended it and nothing else did) and ``"episode"`` (``r``: return, ``l``:
  length, ``t``: seconds since the adapter was made), as SB3's ``Monitor`` would add them, so
  ``ep_rew_mean`` and success rates are logged without a Monitor wrapper.

That is every key SB3 reads (``VecNormalize``, the on- and off-policy rollouts, the
success-rate buffer, ``EvalCallback``, ``evaluate_policy``): they read infos only where an
episode ended.  The step's entries of **every** environment are passed through as the vector
env returned them, Gymnasium's layout of arrays over the batch: ``NativeVecEnv.batch_infos``
(``batch_infos["position_error"][i]``, ...), replaced at each ``step`` and ``reset``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.envs.registration import load_env_creator
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices

from planar3p_gym.envs.vector import INFO_KEYS, Planar3PVectorEnv

__all__ = ["NativeVecEnv", "make_native_vec_env"]


def make_native_vec_env(
    env_id: str,
    n_envs: int = 1,
    seed: int | None = None,
    env_kwargs: dict[str, Any] | None = None,
) -> NativeVecEnv:
    """An SB3 ``VecEnv`` of ``n_envs`` copies of the registered ``env_id`` (an id whose
    vector entry point is a :class:`Planar3PVectorEnv`: every registered id), with its time
    limit; ``seed`` seeds env ``i`` with
    ``seed + i`` at the first reset (as SB3's ``make_vec_env`` does)."""
    spec = gym.spec(env_id)
    entry = spec.vector_entry_point
    cls = load_env_creator(entry) if isinstance(entry, str) else entry
    if not (isinstance(cls, type) and issubclass(cls, Planar3PVectorEnv)):
        raise ValueError(f"{env_id} has no native vector env; use DummyVecEnv/SubprocVecEnv")
    kwargs = {**spec.kwargs, **(env_kwargs or {})}
    venv = cls(
        num_envs=n_envs,
        max_episode_steps=spec.max_episode_steps,
        autoreset_mode=AutoresetMode.SAME_STEP,
        **kwargs,
    )
    out = NativeVecEnv(venv)
    if seed is not None:
        out.seed(seed)
    return out


class NativeVecEnv(VecEnv):
    """SB3 ``VecEnv`` interface of a :class:`Planar3PVectorEnv` in ``SAME_STEP`` autoreset mode
    (module docstring)."""

    def __init__(self, venv: Planar3PVectorEnv) -> None:
        if venv.metadata["autoreset_mode"] != AutoresetMode.SAME_STEP:
            raise ValueError("NativeVecEnv needs a Planar3PVectorEnv with SAME_STEP autoreset")
        self.venv = venv
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        self._actions: np.ndarray | None = None
        self._returns = np.zeros(self.num_envs, dtype=np.float64)
        self._lengths = np.zeros(self.num_envs, dtype=np.int64)
        self._t0 = time.time()
        #: The last ``step``'s (or ``reset``'s) info entries of every environment as the vector
        #: env returned them: a dict of arrays over the batch with ``"_key"`` masks (module
        #: docstring).
        self.batch_infos: dict[str, Any] = {}
        #: The entries every environment's info carries at every step (the goal ids'
        #: relabelling entries; none for the other ids).
        self.step_keys = tuple(k for k in venv.info_keys if k not in INFO_KEYS)

    def reset(self) -> np.ndarray:
        seeds = self._seeds if any(s is not None for s in self._seeds) else None
        options = self._options[0] if self._options and self._options[0] else None
        if any(o != self._options[0] for o in self._options):
            raise ValueError("NativeVecEnv resets every env with the same options")
        obs, infos = self.venv.reset(seed=seeds, options=options)
        self.batch_infos = infos
        self.reset_infos = [self._info(infos, i, self.venv.info_keys) for i in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        assert self._actions is not None, "step_async first"
        obs, rewards, terminated, truncated, infos = self.venv.step(self._actions)
        self.batch_infos = infos
        dones = terminated | truncated
        self._returns += rewards
        self._lengths += 1
        out: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for key in self.step_keys:  # (Python scalars, as in a single env's info)
            for info, value in zip(out, infos[key].tolist(), strict=True):
                info[key] = value
        ended = np.flatnonzero(dones).tolist()
        if ended:
            final, final_obs = infos["final_info"], infos["final_obs"]
            t = round(time.time() - self._t0, 6)
            for i in ended:
                info = out[i] = self._info(final, i, self.venv.info_keys)
                info["terminal_observation"] = final_obs[i]
                info["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
                info["episode"] = {
                    "r": float(self._returns[i]),
                    "l": int(self._lengths[i]),
                    "t": t,
                }
            self._returns[ended] = 0.0
            self._lengths[ended] = 0
        return obs, rewards.astype(np.float32), dones, out

    @staticmethod
    def _info(batch: dict[str, Any], i: int, keys: tuple[str, ...]) -> dict[str, Any]:
        return {key: batch[key][i].item() if hasattr(batch[key][i], "item") else batch[key][i]
                for key in keys}  # fmt: skip

    def close(self) -> None:
        self.venv.close()

    def _envs(self, indices: VecEnvIndices) -> list[Any]:
        return [self.venv.envs[i] for i in self._get_indices(indices)]

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        return [getattr(env, attr_name) for env in self._envs(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        for env in self._envs(indices):
            setattr(env, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **kwargs: Any
    ) -> list[Any]:
        return [getattr(env, method_name)(*method_args, **kwargs) for env in self._envs(indices)]

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None
    ) -> list[bool]:
        return [False for _ in self._envs(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None] * self.num_envs
