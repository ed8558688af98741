"""Floor references: a uniformly random policy and a zero (do-nothing) policy.

Both follow Stable-Baselines3's ``predict`` convention and accept single observations
``(obs_dim,)`` or batches ``(n, obs_dim)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["RandomPolicy", "ZeroPolicy"]


def _batch(observation: ArrayLike) -> tuple[int, bool]:
    obs = np.asarray(observation)
    if obs.ndim not in (1, 2):
        raise ValueError(f"observation must have shape (d,) or (n, d), got {obs.shape}")
    return (1, True) if obs.ndim == 1 else (obs.shape[0], False)


class RandomPolicy:
    """Actions drawn uniformly from ``[low, high]`` (default the ``Box(-1, 1, (3,))`` actions).

    Reproducible: every number comes from its own ``numpy`` generator, seeded by ``seed`` and
    re-seeded by :meth:`reset` (the benchmark does so at the start of every episode).
    ``deterministic`` is ignored: this policy is random by definition.
    """

    def __init__(
        self,
        action_space: Any = None,
        seed: int | None = None,
    ) -> None:
        if action_space is None:
            low, high = -np.ones(3), np.ones(3)
        else:
            low = np.asarray(action_space.low, dtype=np.float64)
            high = np.asarray(action_space.high, dtype=np.float64)
        if low.shape != high.shape or not (np.isfinite(low).all() and np.isfinite(high).all()):
            raise ValueError("action bounds must be finite and of equal shape")
        self.low, self.high = low, high
        self.rng = np.random.default_rng(seed)

    def reset(self, seed: int | np.random.SeedSequence | None = None) -> None:
        """Re-seed the generator."""
        self.rng = np.random.default_rng(seed)

    def predict(
        self,
        observation: ArrayLike,
        state: Any = None,
        episode_start: ArrayLike | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        n, single = _batch(observation)
        action = self.rng.uniform(self.low, self.high, size=(n, *self.low.shape))
        action = action.astype(np.float32)
        return (action[0] if single else action), None


class ZeroPolicy:
    """Always commands zero slider velocity: the machine holds still (against gravity)."""

    def __init__(self, action_dim: int = 3) -> None:
        self.action_dim = int(action_dim)

    def predict(
        self,
        observation: ArrayLike,
        state: Any = None,
        episode_start: ArrayLike | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        n, single = _batch(observation)
        action = np.zeros((n, self.action_dim), dtype=np.float32)
        return (action[0] if single else action), None
