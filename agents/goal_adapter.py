"""Run policies written for the flat observation of ``Planar3P-v0`` (e.g. the analytic
controller) on the goal-conditioned envs (``Planar3PGoal-v0``, ``Planar3PGoalDense-v0``)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from agents.analytic import AnalyticController
from agents.policy_base import PolicyAdapter
from planar3p_gym.goal_env import flat_observation

__all__ = ["GoalAdapter", "goal_baseline"]


class GoalAdapter(PolicyAdapter):
    """SB3-style ``predict`` on ``Dict`` goal observations, by rebuilding the 31-entry flat
    observation (:func:`planar3p_gym.goal_env.flat_observation`) and calling ``policy``.

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

    @classmethod
    def analytic(cls, env: Any, mode: str = "simultaneous", **kwargs: Any) -> GoalAdapter:
        """The analytic controller for the design of ``env`` (a goal env, possibly wrapped)."""
        design = env.unwrapped.design
        return cls(AnalyticController(design, mode, **kwargs), design.characteristic_length)

    def adapt(self, observation: dict[str, ArrayLike]) -> np.ndarray:
        """The flat observation(s) of a goal observation (single or batched ``Dict``
        entries)."""
        if not isinstance(observation, dict) or not {"observation", "desired_goal"} <= set(
            observation
        ):
            raise ValueError("observation must be a goal env's dict (observation, desired_goal)")
        return flat_observation(observation, self.length)


def goal_baseline(env_id: str, episodes: int, seed: int) -> dict[str, float]:
    """Success rate, mean steps of the successful episodes and mean return of the analytic
    controller (through :class:`GoalAdapter`) on a goal id, over ``episodes`` episodes
    (reset with ``seed`` once, then unseeded)."""
    import gymnasium as gym

    if not (isinstance(episodes, int) and episodes >= 1):
        raise ValueError(f"episodes must be an integer >= 1, got {episodes!r}")
    env = gym.make(env_id)
    ctrl = GoalAdapter.analytic(env)
    obs, _ = env.reset(seed=seed)
    wins, steps, returns = 0, [], []
    for _ in range(episodes):
        ctrl.reset()
        total, n = 0.0, 0
        while True:
            obs, reward, terminated, truncated, info = env.step(ctrl.predict(obs)[0])
            total += reward
            n += 1
            if terminated or truncated:
                break
        if info["is_success"]:
            wins += 1
            steps.append(n)
        returns.append(total)
        obs, _ = env.reset()
    return {
        "episodes": episodes,
        "success_rate": wins / episodes,
        "steps_to_success_mean": float(np.mean(steps)) if steps else float("nan"),
        "return_mean": float(np.mean(returns)),
    }
