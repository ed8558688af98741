"""Stable-Baselines3's ``predict`` convention, written once for the project's own policies.

SB3 calls a policy as ``predict(observation, state=None, episode_start=None,
deterministic=True) -> (action, state)``, on one observation ``(d,)`` or a batch ``(n, d)``.
SB3's own ``BasePolicy`` is a torch module built on observation and action spaces, so it does
not serve the NumPy controllers here; these two small bases do:

* :class:`BatchPolicy` checks the observation, turns it into a float64 batch with one
  episode-start flag per row and calls :meth:`BatchPolicy.act`; a single observation gets a
  single action back.
* :class:`PolicyAdapter` rewrites the observation (:meth:`PolicyAdapter.adapt`) and hands the
  call to the policy it wraps.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_gym.machine.design import Design

__all__ = ["BatchPolicy", "PolicyAdapter", "episode_starts", "observation_batch"]


def observation_batch(
    observation: ArrayLike, size: int | None = None, exact: bool = False, expected: str = ""
) -> tuple[NDArray[np.float64], bool]:
    """``observation`` as a float64 batch ``(n, m)`` and whether it was a single ``(m,)`` one.

    ``ValueError`` ("observation must have shape ``expected``, got ...") unless it is ``(m,)``
    or ``(n, m)`` with ``m == size`` (``exact``) or ``m >= size``; ``size=None`` accepts any
    ``m``.  ``expected`` defaults to a description of that rule.
    """
    obs = np.asarray(observation)
    single = obs.ndim == 1
    obs2 = obs[None, :] if single else obs
    ok = obs2.ndim == 2 and (
        size is None or (obs2.shape[1] == size if exact else obs2.shape[1] >= size)
    )
    if not ok:
        if not expected:
            if size is None:
                expected = "(d,) or (n, d)"
            elif exact:
                expected = f"({size},) or (n, {size})"
            else:
                expected = f"(m,) or (n, m) with m >= {size}"
        raise ValueError(f"observation must have shape {expected}, got {obs.shape}")
    return obs2.astype(np.float64, copy=False), single


def episode_starts(episode_start: ArrayLike | None, n: int) -> NDArray[np.bool_]:
    """SB3's ``episode_start`` as one bool per environment (``None``: no new episode; one flag
    applies to all); ``ValueError`` unless it holds 1 or ``n`` flags."""
    if episode_start is None:
        return np.zeros(n, dtype=bool)
    starts = np.asarray(episode_start, dtype=bool).reshape(-1)
    if starts.size == 1:
        return np.full(n, bool(starts[0]))
    if starts.shape != (n,):
        raise ValueError(f"episode_start must hold one flag per observation ({n})")
    return starts


class BatchPolicy:
    """SB3's ``predict`` over single or batched flat observations; subclasses write
    :meth:`act`.

    Class attributes: ``obs_size`` (entries an observation must have, ``None``: any),
    ``obs_exact`` (exactly ``obs_size``, else at least) and ``obs_expected`` (the shape named
    in the error message, default from the other two).
    """

    obs_size: int | None = None
    obs_exact: bool = True
    obs_expected: str = ""

    def _use_design(self, design: Any) -> None:
        """Set :attr:`design`: ``design``, or ``Design.fig8()`` for ``None``; ``ValueError``
        unless it is a :class:`~planar3p_gym.machine.design.Design`."""
        if design is None:
            design = Design.fig8()
        if not isinstance(design, Design):
            raise ValueError(f"design must be a planar3p_gym.Design, got {type(design).__name__}")
        self.design = design

    def _use_observation_size(self, observation_size: Any) -> None:
        """Accept observations of ``observation_size`` entries instead of the class's
        ``obs_size`` (``None``: keep it); ``ValueError`` unless it is an int (not a bool) of at
        least the class's ``obs_size``, the entries the policy reads."""
        if observation_size is None:
            return
        least = int(type(self).obs_size or 0)
        if not (
            isinstance(observation_size, (int, np.integer))
            and not isinstance(observation_size, bool)
            and observation_size >= least
        ):
            raise ValueError(
                f"observation_size must be an int >= {least}, got {observation_size!r}"
            )
        self.obs_size = int(observation_size)

    def predict(
        self,
        observation: ArrayLike,
        state: Any = None,
        episode_start: ArrayLike | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """Action(s) and the new recurrent state for observation(s) ``(d,)`` or ``(n, d)``.
        ``episode_start`` flags the environments that begin a new episode; ``deterministic``
        is passed to :meth:`act`."""
        obs, single = observation_batch(
            observation, self.obs_size, self.obs_exact, self.obs_expected
        )
        starts = episode_starts(episode_start, obs.shape[0])
        actions, new_state = self.act(obs, state, starts, deterministic)
        return (actions[0] if single else actions), new_state

    def act(
        self, obs: NDArray[np.float64], state: Any, starts: NDArray[np.bool_], deterministic: bool
    ) -> tuple[np.ndarray, Any]:
        """Actions ``(n, a)`` and the new state for the batch ``obs`` ``(n, d)``, ``starts``
        one flag per row."""
        raise NotImplementedError


class PolicyAdapter:
    """A policy (SB3-style ``predict``) called on rewritten observations.

    Args:
        policy: anything with ``predict(observation, state, episode_start, deterministic)``.
    """

    def __init__(self, policy: Any) -> None:
        if not callable(getattr(policy, "predict", None)):
            raise ValueError(f"policy must have a predict method, got {policy!r}")
        self.policy = policy

    def reset(self, seed: Any = None) -> None:
        """Reset the wrapped policy's memory, if it has one (with ``seed`` when one is given
        and the policy takes it, e.g. a random policy)."""
        reset = getattr(self.policy, "reset", None)
        if not callable(reset):
            return
        if seed is None:
            reset()
            return
        try:
            reset(seed=seed)
        except TypeError:
            reset()

    def adapt(self, observation: Any) -> Any:
        """The observation the wrapped policy is given."""
        raise NotImplementedError

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: ArrayLike | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """The wrapped policy's ``predict`` on :meth:`adapt` of ``observation``."""
        return self.policy.predict(
            self.adapt(observation),
            state=state,
            episode_start=episode_start,
            deterministic=deterministic,
        )
