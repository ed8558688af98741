"""How an episode ended, under one name everywhere, and snapshots of made environments.

Every episode ends for one of the reasons of :data:`END_REASONS`: ``"success"``,
``"singularity_crossing"`` and ``"physics_breakdown"`` end it as ``terminated`` (the
environment's own tests), ``"time_limit"`` as ``truncated``.  These are the names of
``info["termination_reason"]``, of the training runs' ``metrics.json`` and of the benchmark's
episode records; :func:`end_reason` gives the name of an episode's end from a step's outputs.

**Where a time-out is named (the Gymnasium way).**  The time limit is Gymnasium's own:
``gym.make`` wraps every id in ``gymnasium.wrappers.TimeLimit`` with the registered
``max_episode_steps`` or the one passed to ``gym.make``; that wrapper sets ``truncated`` and
never sees ``info``, and the environment inside is not told the limit (``gym.make`` keeps an
override in the wrapper only, and the native vector envs, ``gym.make_vec``, refuse ids with
additional wrappers).  So ``info["termination_reason"]`` names what the *environment* decided
(``None`` while the episode runs and on a time-out, in the single and the native vector
environments alike), and the time-out is accounted from the flags: :func:`end_reason` returns
``"time_limit"`` for ``truncated and not terminated``.  Code that wants the name in ``info``
itself wraps a made environment in :class:`EndReason` (outside the ``TimeLimit``), which sets
``info["termination_reason"] = "time_limit"`` on such a step.

**Snapshots of made environments.**  :meth:`planar3p_gym.envs.core.Planar3PEnv.set_state`
restores the environment; the ``TimeLimit`` wrapper of a made environment counts the steps of
the episode on its own.  :func:`restore_state` (and :meth:`EndReason.set_state`) restores both:
it sets every ``TimeLimit`` counter in the wrapper chain to the snapshot's step, so the
restored episode is truncated at the same step as the original.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
from gymnasium.utils import RecordConstructorArgs
from gymnasium.wrappers import TimeLimit

__all__ = [
    "END_REASONS",
    "TERMINATION_REASONS",
    "TIME_LIMIT",
    "EndReason",
    "end_reason",
    "restore_state",
]

#: Reasons an episode is ``terminated`` (``info["termination_reason"]``; a task uses a subset,
#: its ``termination_reasons``).
TERMINATION_REASONS = ("success", "singularity_crossing", "physics_breakdown")
#: The name of a ``truncated`` episode's end: the time limit.
TIME_LIMIT = "time_limit"
#: Every name of an episode's end.
END_REASONS = (*TERMINATION_REASONS, TIME_LIMIT)


def end_reason(terminated: Any, truncated: Any, info: dict[str, Any]) -> str | None:
    """The name of the end of an episode from a step's flags and ``info`` (one of
    :data:`END_REASONS`), or ``None`` if the step did not end it: the environment's
    ``info["termination_reason"]`` when ``terminated``, ``"time_limit"`` when only
    ``truncated``."""
    if terminated:
        return info.get("termination_reason")
    if truncated:
        return TIME_LIMIT
    return None


def restore_state(env: gym.Env, state: dict[str, Any]) -> None:
    """Restore a :meth:`Planar3PEnv.get_state` snapshot into ``env``, a made environment (or
    the environment itself): the unwrapped environment's ``set_state``, then the step counter
    of every ``TimeLimit`` in the wrapper chain set to the snapshot's step, so ``env``
    continues exactly as the environment the snapshot was taken from (``ValueError``, and
    nothing changed, if ``state`` is not a snapshot for this environment).  As for stepping,
    Gymnasium's wrappers want a made environment reset once before (``OrderEnforcing``)."""
    env.unwrapped.set_state(state)  # type: ignore[attr-defined]
    steps = int(state["episode"]["record"].steps)
    layer = env
    while isinstance(layer, gym.Wrapper):
        if isinstance(layer, TimeLimit):
            layer._elapsed_steps = steps  # gymnasium's counter (no public setter)
        layer = layer.env


class EndReason(gym.Wrapper, RecordConstructorArgs):
    """Names a time-out in ``info``: ``info["termination_reason"] = "time_limit"`` on a step
    that an inner ``TimeLimit`` truncated and the environment did not terminate.  Wrap a made
    environment: ``EndReason(gym.make(env_id))``.  :meth:`get_state` / :meth:`set_state` are
    the unwrapped environment's, with :func:`restore_state`'s step counters.  Observations,
    rewards and flags pass unchanged."""

    def __init__(self, env: gym.Env) -> None:
        RecordConstructorArgs.__init__(self)
        gym.Wrapper.__init__(self, env)

    def step(self, action: Any) -> tuple[Any, Any, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        if truncated and not terminated and info.get("termination_reason") is None:
            info["termination_reason"] = TIME_LIMIT
        return obs, reward, terminated, truncated, info

    def get_state(self) -> dict[str, Any]:
        """The unwrapped environment's snapshot (:meth:`Planar3PEnv.get_state`)."""
        return self.env.unwrapped.get_state()  # type: ignore[attr-defined]

    def set_state(self, state: dict[str, Any]) -> None:
        """:func:`restore_state` of the wrapped environment."""
        restore_state(self.env, state)
