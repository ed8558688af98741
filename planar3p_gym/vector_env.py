"""A native Gymnasium vector environment: ``gym.make_vec("Planar3P-v1", num_envs=16)``.

:class:`Planar3PVectorEnv` steps ``num_envs`` simulations of the reach task in one process and
one call, with Gymnasium 1.x's next-step autoreset (an episode that ended in a step is reset
by the next ``step`` call, which returns its first observation with reward 0 and both flags
False) and the registered time limit applied in the batch (``truncated`` at
``max_episode_steps``).  Observations, rewards, flags and infos are written into batch numpy
arrays; infos are Gymnasium's vector layout (each key an array over the batch with a boolean
``"_key"`` mask), for the keys in :data:`INFO_KEYS`.

Why each environment is still stepped by :meth:`Planar3PEnv.step` rather than by numpy code
over the batch: the per-environment work is a pymunk step and a handful of 3x3 computations
(projection, margins, observation, reward), which plain-float Python does about as fast as
numpy at these batch sizes (numpy's per-call overhead of about a microsecond, times the many
array operations they need; measured: :func:`planar3p_gym.kinematics.margins` over 16
configurations took 0.86 of the time of 16 scalar ``ScalarKinematics.measures`` calls, with
different rounding), and sharing the
single environment's code keeps the trajectories bit-identical to ``num_envs`` single envs
(``tests/test_vector_env.py``).  What the vector env saves is the per-step overhead of
``gym.make``'s wrappers and of ``SyncVectorEnv`` (copies of observations, info merging key by
key and env by env).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from .env import Planar3PEnv

__all__ = ["INFO_KEYS", "Planar3PVectorEnv"]

#: ``info`` entries returned over the batch (as in the single env's ``info``).
INFO_KEYS = (
    "is_success",
    "termination_reason",
    "position_error",
    "orientation_error",
    "parallel_margin",
    "serial_margin",
    "assembly_mode",
    "closure_error",
)
_DTYPES = {"is_success": np.bool_, "termination_reason": object, "assembly_mode": np.int64}


class Planar3PVectorEnv(VectorEnv):
    """``num_envs`` copies of :class:`Planar3PEnv` stepped together (module docstring).

    Args:
        num_envs: number of environments (>= 1).
        max_episode_steps: time limit in steps (``None`` or -1: none); ``gym.make_vec`` passes
            the registered one.
        autoreset_mode: ``AutoresetMode.NEXT_STEP`` (default, Gymnasium's) or
            ``AutoresetMode.SAME_STEP`` (an ended episode is reset within the same step: its
            last observation is in ``info["final_obs"]``, its last info entries in
            ``info["final_info"]``; what SB3's ``VecEnv`` expects, see
            :mod:`agents.vec_adapter`).
        **kwargs: :class:`Planar3PEnv` arguments, the same for every copy (``render_mode``
            is not supported here).
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        **kwargs: Any,
    ) -> None:
        if not (isinstance(num_envs, (int, np.integer)) and not isinstance(num_envs, bool)):
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if max_episode_steps is not None and max_episode_steps != -1:
            if not (isinstance(max_episode_steps, (int, np.integer)) and max_episode_steps >= 1):
                raise ValueError(
                    f"max_episode_steps must be an integer >= 1, -1 or None, "
                    f"got {max_episode_steps!r}"
                )
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            mode = None
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(
                f"autoreset_mode must be NEXT_STEP or SAME_STEP, got {autoreset_mode!r}"
            )
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        if kwargs.get("render_mode") is not None:
            raise ValueError("Planar3PVectorEnv does not render; use gym.make for rendering")
        self.num_envs = int(num_envs)
        self.envs = [Planar3PEnv(**kwargs) for _ in range(self.num_envs)]
        self.max_episode_steps = (
            None if max_episode_steps in (None, -1) else int(max_episode_steps)  # type: ignore[arg-type]
        )
        first = self.envs[0]
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.render_mode = None
        self._obs = np.zeros(self.observation_space.shape, dtype=np.float32)
        self._elapsed = np.zeros(self.num_envs, dtype=np.int64)
        self._autoreset = np.zeros(self.num_envs, dtype=np.bool_)

    def reset(
        self,
        *,
        seed: int | list[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every environment: ``seed`` an int (env ``i`` gets ``seed + i``, as
        ``SyncVectorEnv`` does), a list of seeds, or None; ``options`` go to every env."""
        if seed is None or isinstance(seed, (int, np.integer)):
            seeds = [None if seed is None else int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"expected {self.num_envs} seeds, got {len(seeds)}")
        if seed is not None:
            self._np_random, self._np_random_seed = gym.utils.seeding.np_random(
                seeds[0] if isinstance(seed, list) else int(seed)
            )
        infos = []
        for i, (env, s) in enumerate(zip(self.envs, seeds, strict=True)):
            obs, info = env.reset(seed=s, options=options)
            self._obs[i] = obs
            infos.append(info)
        self._elapsed[:] = 0
        self._autoreset[:] = False
        return self._obs.copy(), self._batch_infos(infos)

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        a = np.asarray(actions, dtype=np.float64)
        if a.shape != self.action_space.shape:
            raise ValueError(f"actions must have shape {self.action_space.shape}, got {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError("actions must be finite")
        n = self.num_envs
        rewards, terminated, truncated = [0.0] * n, [False] * n, [False] * n
        infos = []
        limit = self.max_episode_steps if self.max_episode_steps is not None else -1
        obs_out = self._obs
        # Plain lists in the loop: numpy scalar indexing costs more than the bookkeeping.
        elapsed, autoreset = self._elapsed.tolist(), self._autoreset.tolist()
        same_step = self.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
        final: dict[int, tuple[np.ndarray, dict[str, Any]]] = {}
        for i, env in enumerate(self.envs):
            if autoreset[i]:
                obs, info = env.reset()
                elapsed[i] = 0
            else:
                obs, reward, term, _, info = env.step(a[i])
                steps = elapsed[i] = elapsed[i] + 1
                trunc = 0 < limit <= steps
                rewards[i], terminated[i], truncated[i] = reward, term, trunc
                if same_step and (term or trunc):
                    final[i] = (obs, info)
                    obs, info = env.reset()
                    elapsed[i] = 0
            obs_out[i] = obs
            infos.append(info)
        self._elapsed[:] = elapsed
        terminated_a = np.array(terminated, dtype=np.bool_)
        truncated_a = np.array(truncated, dtype=np.bool_)
        if not same_step:
            np.logical_or(terminated_a, truncated_a, out=self._autoreset)
        out = self._batch_infos(infos)
        if final:
            final_obs = np.full(self.num_envs, None, dtype=object)
            done = np.zeros(self.num_envs, dtype=np.bool_)
            last = list(infos)
            for i, (obs, info) in final.items():
                final_obs[i], done[i], last[i] = obs, True, info
            out["final_obs"], out["_final_obs"] = final_obs, done
            final_info = self._batch_infos(last)
            for key in INFO_KEYS:
                final_info["_" + key] = done
            out["final_info"], out["_final_info"] = final_info, done
        return obs_out.copy(), np.array(rewards), terminated_a, truncated_a, out

    def _batch_infos(self, infos: list[dict[str, Any]]) -> dict[str, Any]:
        """Gymnasium's vector info layout for :data:`INFO_KEYS`."""
        out: dict[str, Any] = {}
        mask = np.ones(self.num_envs, dtype=np.bool_)
        for key in INFO_KEYS:
            out[key] = np.array([info[key] for info in infos], dtype=_DTYPES.get(key, np.float64))
            out["_" + key] = mask
        return out

    def close_extras(self, **kwargs: Any) -> None:
        for env in self.envs:
            env.close()

    def get_state(self) -> dict[str, Any]:
        """Snapshots of every environment and the batch bookkeeping (see
        :meth:`Planar3PEnv.get_state`)."""
        return {
            "envs": [env.get_state() for env in self.envs],
            "obs": self._obs.copy(),
            "elapsed": self._elapsed.copy(),
            "autoreset": self._autoreset.copy(),
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore a :meth:`get_state` snapshot."""
        if not isinstance(state, dict) or len(state.get("envs", ())) != self.num_envs:
            raise ValueError("state must be a snapshot from Planar3PVectorEnv.get_state()")
        for env, s in zip(self.envs, state["envs"], strict=True):
            env.set_state(s)
        self._obs[:] = state["obs"]
        self._elapsed[:] = state["elapsed"]
        self._autoreset[:] = state["autoreset"]
