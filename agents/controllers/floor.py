"""Floor references: a uniformly random policy and a zero (do-nothing) policy.

Both follow Stable-Baselines3's ``predict`` convention
(:class:`planar3p_agents.controllers.base.BatchPolicy`) and accept single observations
``(obs_dim,)`` or batches ``(n, obs_dim)`` of any length.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from planar3p_agents.controllers.base import BatchPolicy

__all__ = ["RandomPolicy", "ZeroPolicy"]


class RandomPolicy(BatchPolicy):
    """Actions drawn uniformly from ``[low, high]`` (default the ``Box(-1, 1, (3,))`` actions),
    or, on a ``MultiDiscrete`` action space (the on-off motors), integers drawn uniformly from
    ``[0, nvec)``.

    Reproducible: every number comes from its own ``numpy`` generator, seeded by ``seed`` and
    re-seeded by :meth:`reset` (the benchmark does so at the start of every episode).
    ``deterministic`` is ignored: this policy is random by definition.
    """

    def __init__(
        self,
        action_space: Any = None,
        seed: int | None = None,
    ) -> None:
        #: The number of values of each entry of a ``MultiDiscrete`` space, else ``None``.
        self.nvec = None
        if action_space is None:
            low, high = -np.ones(3), np.ones(3)
        elif hasattr(action_space, "nvec"):
            self.nvec = np.asarray(action_space.nvec, dtype=np.int64)
            low, high = np.zeros(self.nvec.shape), self.nvec - 1.0
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

    def act(
        self, obs: NDArray[np.float64], state: Any, starts: NDArray[np.bool_], deterministic: bool
    ) -> tuple[np.ndarray, Any]:
        """Uniform actions, one row per observation."""
        if self.nvec is not None:
            return self.rng.integers(self.nvec, size=(obs.shape[0], *self.nvec.shape)), None
        action = self.rng.uniform(self.low, self.high, size=(obs.shape[0], *self.low.shape))
        return action.astype(np.float32), None


class ZeroPolicy(BatchPolicy):
    """Always commands zero slider velocity: the machine holds still (against gravity).  On the
    on-off ids the zeros are the motors' "stop"."""

    def __init__(self, action_dim: int = 3) -> None:
        self.action_dim = int(action_dim)

    def act(
        self, obs: NDArray[np.float64], state: Any, starts: NDArray[np.bool_], deterministic: bool
    ) -> tuple[np.ndarray, Any]:
        """Zeros, one row per observation."""
        return np.zeros((obs.shape[0], self.action_dim), dtype=np.float32), None
