"""The environment a model is played in: its suite's, with the model's observation arguments
and action encoding.

A model trained with an argument that changes the observation
(:data:`planar3p_gym.envs.core.OBSERVATION_ARGUMENTS`, e.g. ``travel_goal=True``) only fits an
environment made with it, and so does a model trained with the on-off motors written as one
index (``action_type="on-off-discrete"``, for DQN) on a suite of three commands
(``"on-off"``), or the other way round (:data:`planar3p_gym.envs.actuation.ON_OFF_ACTION_TYPES`:
the same motors, only the action's encoding differs).  The benchmark plays such a model in a
copy of the suite's environment (same registered id and arguments) with those arguments added;
every other training argument (tolerances, reward weights, the mix of training pairs, a
continuous machine for an on-off one) stays the suite's, so all policies are judged alike.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym

from planar3p_gym.envs.actuation import ON_OFF_ACTION_TYPES
from planar3p_gym.envs.core import OBSERVATION_ARGUMENTS

__all__ = ["PlayEnvs", "observation_kwargs", "play_kwargs"]


def observation_kwargs(env_kwargs: Mapping[str, Any] | None) -> dict[str, Any]:
    """The entries of ``env_kwargs`` (a training run's environment arguments, or ``None``)
    that change the observation."""
    return {k: env_kwargs[k] for k in OBSERVATION_ARGUMENTS if k in (env_kwargs or {})}


def play_kwargs(env_kwargs: Mapping[str, Any] | None, env: Any) -> dict[str, Any]:
    """What of a training run's ``env_kwargs`` a model needs in the environment ``env`` it is
    played in: its observation arguments, and its on-off action type where ``env`` has the
    other on-off action type."""
    wanted = observation_kwargs(env_kwargs)
    trained = (env_kwargs or {}).get("action_type")
    own = getattr(env.unwrapped, "action_type", None)
    if trained in ON_OFF_ACTION_TYPES and own in ON_OFF_ACTION_TYPES:
        wanted["action_type"] = trained
    return wanted


class PlayEnvs:
    """Environments for playing models, each made once per (suite environment, observation
    arguments) and closed by :meth:`close`."""

    def __init__(self) -> None:
        self._made: dict[tuple[int, tuple[tuple[str, Any], ...]], Any] = {}
        self._bases: list[Any] = []  # kept alive: their ids key ``_made``

    def get(self, env: Any, env_kwargs: Mapping[str, Any] | None) -> Any:
        """``env`` itself if ``env_kwargs`` holds no argument of :func:`play_kwargs` that
        differs from ``env``'s own, else a new environment of ``env``'s registration with
        them."""
        wanted = play_kwargs(env_kwargs, env)
        base = env.unwrapped
        changed = {k: v for k, v in wanted.items() if getattr(base, k, None) != v}
        if not changed:
            return env
        if env.spec is None:
            raise ValueError(
                f"cannot make a variant with {changed} of an environment not made by gym.make"
            )
        key = (id(env), tuple(sorted(changed.items())))
        if key not in self._made:
            self._bases.append(env)
            self._made[key] = gym.make(env.spec, **changed)
        return self._made[key]

    def close(self) -> None:
        """Close the environments made here."""
        for made in self._made.values():
            made.close()
        self._made.clear()
        self._bases.clear()
