"""Run policies written for the flat observation of ``Planar3P-v0`` (e.g. the analytic
controller) on the goal-conditioned envs (``Planar3PGoal-v0``, ``Planar3PGoalDense-v0``).

:func:`planar3p_agents.policies.factory.load_policy` puts every built-in baseline that plays a
goal id behind this adapter; the analytic controller's measurements there are in
the repository script ``scripts/goal_track_baselines.py``."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from planar3p_agents.controllers.base import PolicyAdapter
from planar3p_gym.envs.goal import flat_observation

__all__ = ["GoalAdapter"]


class GoalAdapter(PolicyAdapter):
    """SB3-style ``predict`` on ``Dict`` goal observations, by rebuilding the 31-entry flat
    observation (:func:`planar3p_gym.envs.goal.flat_observation`) and calling ``policy``.

    Args:
        policy: anything with ``predict(observation, state, episode_start, deterministic)``
            on flat observations.
        length: the design's characteristic length (m), which scales the ``fine_error``
            block.
    """

    def __init__(self, policy: Any, length: float) -> None:
        super().__init__(policy)
        if not length > 0:
            raise ValueError(f"length must be > 0 (m), got {length!r}")
        self.length = float(length)

    def adapt(self, observation: dict[str, ArrayLike]) -> np.ndarray:
        """The flat observation(s) of a goal observation (single or batched ``Dict``
        entries)."""
        if not isinstance(observation, dict) or not {"observation", "desired_goal"} <= set(
            observation
        ):
            raise ValueError("observation must be a goal env's dict (observation, desired_goal)")
        return flat_observation(observation, self.length)
