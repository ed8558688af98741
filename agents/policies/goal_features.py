"""Goal-error features for SB3 policies on the goal ids (``Planar3PGoal-v0``,
``Planar3PGoalDense-v0``).

The flat observation of ``Planar3P-v0`` hands a policy the pose error to its target twice, in
metres and on a millimetre scale (``fine_error``, ``tanh`` of the error over 1 cm), so that the
last millimetres are as visible as the first decimetres.  The goal envs' ``Dict`` observation
holds no error: ``achieved_goal`` and ``desired_goal`` separately, and an MLP on their
normalised values has to subtract them itself at a resolution of a few millimetres.
:class:`GoalErrorExtractor` computes those error entries from the two goals inside the
policy (the environment and its observation are unchanged, so HER's relabelling stays exact).

The goals must reach it unnormalised (in m and unit cos/sin): train with ``VecNormalize`` on the
``observation`` key only (``normalize: "dict(norm_obs_keys=['observation'])"``).
"""

from __future__ import annotations

import math

import gymnasium as gym
import torch as th
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.observation import FINE_ERROR_SCALE

__all__ = ["GoalErrorExtractor"]

#: Error entries appended: ``dx, dy`` (m), ``dtheta`` (rad) and ``tanh`` of ``(dx, dy,
#: L dtheta) / FINE_ERROR_SCALE`` (1).
ERROR_FEATURES = 6


class GoalErrorExtractor(BaseFeaturesExtractor):
    """``[observation, achieved_goal, desired_goal, dx, dy, dtheta, tanh((dx, dy, L dtheta) /
    1 cm)]`` from a goal env's ``Dict`` observation (goals ``(x, y, cos, sin, v)`` in m, 1,
    m/s).

    Args:
        observation_space: the goal env's ``Dict`` space (``observation``, ``achieved_goal``,
            ``desired_goal``).
        length: characteristic length ``L`` (m) that scales the angle error in the fine block
            (default: the default design's, as in the flat observation).
    """

    def __init__(self, observation_space: gym.spaces.Dict, length: float | None = None) -> None:
        keys = ("observation", "achieved_goal", "desired_goal")
        if not isinstance(observation_space, gym.spaces.Dict) or not set(keys) <= set(
            observation_space.spaces
        ):
            raise ValueError(f"GoalErrorExtractor needs a Dict space with {', '.join(keys)}")
        goal = observation_space["desired_goal"].shape
        if goal != observation_space["achieved_goal"].shape or goal[-1] < 4:
            raise ValueError(f"goals must be (x, y, cos, sin, ...) of equal shape, got {goal}")
        size = sum(int(observation_space[k].shape[-1]) for k in keys) + ERROR_FEATURES
        super().__init__(observation_space, features_dim=size)
        self.length = float(length if length is not None else Design().characteristic_length)
        if not (self.length > 0 and math.isfinite(self.length)):
            raise ValueError(f"length must be a positive number of metres, got {length!r}")

    def forward(self, observations: dict[str, th.Tensor]) -> th.Tensor:
        """The features of a batch of observations, ``(n, features_dim)``."""
        achieved = observations["achieved_goal"]
        desired = observations["desired_goal"]
        err = desired[:, :2] - achieved[:, :2]
        d_theta = th.atan2(desired[:, 3], desired[:, 2]) - th.atan2(achieved[:, 3], achieved[:, 2])
        d_theta = th.remainder(d_theta + math.pi, 2.0 * math.pi) - math.pi
        fine = th.tanh(th.cat([err, self.length * d_theta[:, None]], dim=1) / FINE_ERROR_SCALE)
        return th.cat(
            [observations["observation"], achieved, desired, err, d_theta[:, None], fine], dim=1
        )
