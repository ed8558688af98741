"""Hindsight experience replay that keeps only the part of ``info`` relabelling reads.

SB3's :class:`~stable_baselines3.HerReplayBuffer` with ``copy_info_dict=True`` stores every
step's whole ``info`` dict and deep-copies one per relabelled sample before it calls the env's
``compute_reward``.  A Planar3P goal step's ``info`` has some twenty entries (poses, forces, the
reward terms), so those copies are a large share of a SAC + HER gradient step on the goal ids
(the profile: docs/training.md, "Hindsight relabelling").  The goal env's ``compute_reward``
reads two keys only (:data:`planar3p_gym.tasks.goal.RELABEL_INFO_KEYS`), so the buffer below
stores those (and ``TimeLimit.truncated``) and nothing else: the relabelled rewards are the
same numbers, at a small fraction of the cost.

Why a subclass rather than SB3's buffer with ``copy_info_dict=False``: with empty infos the
failure penalty of a relabelled failing transition would be lost (see
:mod:`planar3p_gym.tasks.goal`).

The kept infos are :class:`KeptInfo` dicts, which SB3's per-sample ``copy.deepcopy`` returns as
they are instead of copying entry by entry (SB3 copies so that a ``compute_reward`` that
writes into its ``info`` cannot change the buffer; the goal env's only reads, and the kept
values are immutable ``bool``/``float``): one call per relabelled sample instead of seven.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from stable_baselines3 import HerReplayBuffer

from planar3p_gym.tasks.goal import RELABEL_INFO_KEYS

__all__ = ["KEPT_INFO_KEYS", "CompactHerReplayBuffer", "KeptInfo"]

#: What :class:`CompactHerReplayBuffer` keeps of each step's ``info``.
KEPT_INFO_KEYS = (*RELABEL_INFO_KEYS, "TimeLimit.truncated")


class KeptInfo(dict):
    """The kept part of one step's ``info``, read-only by contract: ``copy.deepcopy`` returns
    it unchanged (module docstring)."""

    def __deepcopy__(self, memo: dict[int, Any]) -> KeptInfo:
        return self


class CompactHerReplayBuffer(HerReplayBuffer):
    """:class:`~stable_baselines3.HerReplayBuffer` that stores, when ``copy_info_dict`` is
    on, only :data:`KEPT_INFO_KEYS` of each ``info`` (the keys a step lacks stay absent).
    Constructor arguments are SB3's."""

    def add(  # type: ignore[override]
        self,
        obs: dict[str, np.ndarray],
        next_obs: dict[str, np.ndarray],
        action: np.ndarray,
        reward: np.ndarray,
        done: np.ndarray,
        infos: list[dict[str, Any]],
    ) -> None:
        """Store a transition of every env (SB3's ``add``), then replace the stored infos by
        their kept keys."""
        pos = self.pos
        super().add(obs, next_obs, action, reward, done, infos)
        if self.copy_info_dict:
            for env_idx, info in enumerate(infos):
                self.infos[pos, env_idx] = KeptInfo(
                    (k, info[k]) for k in KEPT_INFO_KEYS if k in info
                )
