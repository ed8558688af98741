"""The on-off command in flight as part of a policy's observation.

On the machine as built a command executes one step after it is sent
(:mod:`planar3p_gym.envs.latency`), so the observation alone does not say what the motors will do
next.  A policy class that declares ``observed_commands = 1`` sees its observation followed by
the one-hot of the command it sent last (a stop at an episode's start); SB3 and the environment
have no such observation, so it is built here once for both uses:

* :func:`command_one_hot`: the encoding (motor ``i``'s command ``c`` at ``3 i + c``);
* :class:`VecCommandMemory`: the training environments' wrapper (SB3 has frame stacks of
  observations, not of actions);
* :func:`with_command_memory`: the same observation built while playing, from the command the
  policy returned as its recurrent ``state`` (the benchmark and ``play`` hand it back).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import ArrayLike, NDArray
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvWrapper

__all__ = [
    "COMMAND_ENTRIES",
    "VecCommandMemory",
    "command_one_hot",
    "observed_commands",
    "with_command_memory",
]

#: Entries of the one-hot of a ``MultiDiscrete([3, 3, 3])`` command.
COMMAND_ENTRIES = 9
_MOTORS = 3


def observed_commands(policy_class: Any) -> int:
    """How many commands in flight a policy class (or an SB3 alias string: none) observes."""
    return int(getattr(policy_class, "observed_commands", 0) or 0)


def command_one_hot(commands: ArrayLike) -> NDArray[np.float32]:
    """One-hot ``(n, 9)`` of motor commands ``(n, 3)`` (each 0 stop, 1 forward, 2 backward)."""
    digits = np.asarray(commands, dtype=np.int64).reshape(-1, _MOTORS)
    if digits.size and (digits.min() < 0 or digits.max() > 2):
        raise ValueError(f"motor commands must be 0, 1 or 2, got {digits.tolist()}")
    out = np.zeros((digits.shape[0], COMMAND_ENTRIES), dtype=np.float32)
    out[np.arange(digits.shape[0])[:, None], 3 * np.arange(_MOTORS) + digits] = 1.0
    return out


def _extended_space(space: gym.spaces.Box) -> gym.spaces.Box:
    low = np.concatenate([space.low, np.zeros(COMMAND_ENTRIES, dtype=space.dtype)])
    high = np.concatenate([space.high, np.ones(COMMAND_ENTRIES, dtype=space.dtype)])
    return gym.spaces.Box(low, high, dtype=space.dtype)


class VecCommandMemory(VecEnvWrapper):
    """Appends to each observation the one-hot of the command sent at the previous step (a
    stop after a reset), also to the ``terminal_observation`` of an ended episode.

    Args:
        venv: SB3 vector environment of ``MultiDiscrete([3, 3, 3])`` actions and flat
            ``Box`` observations.
    """

    def __init__(self, venv: VecEnv) -> None:
        action, obs = venv.action_space, venv.observation_space
        if action != gym.spaces.MultiDiscrete([3] * _MOTORS):
            raise ValueError(f"VecCommandMemory needs MultiDiscrete([3, 3, 3]), got {action}")
        if not isinstance(obs, gym.spaces.Box):
            raise ValueError(f"VecCommandMemory needs a Box observation, got {obs}")
        super().__init__(venv, observation_space=_extended_space(venv.observation_space))
        self._sent = np.zeros((venv.num_envs, _MOTORS), dtype=np.int64)

    def reset(self) -> np.ndarray:
        obs = self.venv.reset()
        self._sent[:] = 0
        return self._extend(obs, self._sent)

    def step_async(self, actions: np.ndarray) -> None:
        self._sent = np.asarray(actions, dtype=np.int64).reshape(self.num_envs, _MOTORS).copy()
        self.venv.step_async(actions)

    def step_wait(self) -> Any:
        obs, rewards, dones, infos = self.venv.step_wait()
        for i in np.flatnonzero(dones):
            last = infos[i].get("terminal_observation")
            if last is not None:
                infos[i]["terminal_observation"] = self._extend(last[None], self._sent[i])[0]
        self._sent[np.asarray(dones, dtype=bool)] = 0
        return self._extend(obs, self._sent), rewards, dones, infos

    @staticmethod
    def _extend(obs: np.ndarray, sent: np.ndarray) -> np.ndarray:
        one_hot = command_one_hot(sent).astype(obs.dtype)
        return np.concatenate([obs, one_hot], axis=1)


def with_command_memory(
    observation: ArrayLike, state: Any, episode_start: ArrayLike | None
) -> tuple[np.ndarray, bool]:
    """The observation(s) ``(d,)`` or ``(n, d)`` followed by the one-hot of the commands in
    ``state`` (``(n, 3)``, as :func:`with_command_memory`'s caller returned them; ``None`` or an
    episode start: a stop), as a batch ``(n, d + 9)``, and whether ``observation`` was single."""
    obs = np.asarray(observation, dtype=np.float32)
    single = obs.ndim == 1
    batch = obs[None] if single else obs
    n = batch.shape[0]
    sent = np.zeros((n, _MOTORS), dtype=np.int64)
    if state is not None:
        sent = np.asarray(state, dtype=np.int64).reshape(n, _MOTORS).copy()
    if episode_start is not None:
        starts = np.asarray(episode_start, dtype=bool).reshape(-1)
        sent[np.broadcast_to(starts, (n,))] = 0
    return np.concatenate([batch, command_one_hot(sent)], axis=1), single
