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
import numpy as np
import torch as th
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.goal import poses_of_goals
from planar3p_gym.tasks.observation import (
    FINE_ERROR_SCALE,
    TRAVEL_GOAL_SIZE,
    travel_goal_entries,
)

__all__ = ["GoalErrorExtractor", "GoalTravelExtractor", "travel_features", "wrap_angle_torch"]


def wrap_angle_torch(angle: th.Tensor) -> th.Tensor:
    """``angle`` (rad) wrapped into ``(-pi, pi]``: the torch twin of
    :func:`planar3p_gym.machine.angles.wrap_angle` (same formula; tested against it), for the
    features computed inside a policy."""
    return math.pi - th.remainder(math.pi - angle, 2.0 * math.pi)


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
        d_theta = wrap_angle_torch(d_theta)
        fine = th.tanh(th.cat([err, self.length * d_theta[:, None]], dim=1) / FINE_ERROR_SCALE)
        return th.cat(
            [observations["observation"], achieved, desired, err, d_theta[:, None], fine], dim=1
        )


#: Joint-space entries :class:`GoalTravelExtractor` appends: the desired goal's slider travels
#: and ``tanh`` of their errors over ``FINE_ERROR_SCALE`` (the block of
#: :func:`planar3p_gym.tasks.observation.travel_goal_entries`), the errors in m, and whether
#: both goals closed in the working mode (1) or the block is zeros (0).
TRAVEL_FEATURES = TRAVEL_GOAL_SIZE + 3 + 1


class GoalTravelExtractor(GoalErrorExtractor):
    """:class:`GoalErrorExtractor`'s features and the goal in joint space: the slider travels
    (m) of the desired goal in the observed working mode, ``tanh`` of their errors to the
    achieved goal's travels over 1 cm, those errors (m), and a validity flag.

    The travels are the inverse kinematics of the two goal poses
    (:func:`planar3p_gym.machine.kinematics.inverse`, the one definition, run on the batch in
    numpy: the features of an observation need no gradient) in the working mode of the
    env's ``working_mode`` key (``Planar3PGoal-v0`` made with ``observe_working_mode=True``);
    the achieved goal's travels are the machine's own, the loop being closed.  Computing them
    here, from the goals, keeps HER's relabelling exact, which a joint-space goal in the
    environment's observation would not (it would describe the episode's goal, not the
    relabelled one).  Where either pose does not close in that mode (a relabelled goal from
    another working mode) the block is zeros and the flag 0.  Why it helps: the straight line
    in slider space already solves most of the ``goal`` suite (the ``slider-line`` baseline,
    docs/benchmark.md), a map a policy learns from these features almost linearly, while from
    Cartesian errors it must learn the inverse kinematics first.

    Args:
        observation_space: the goal env's ``Dict`` space with ``working_mode``.
        length: as :class:`GoalErrorExtractor`.
        design: the machine (default: the default design).
    """

    def __init__(
        self,
        observation_space: gym.spaces.Dict,
        length: float | None = None,
        design: Design | None = None,
    ) -> None:
        if not isinstance(observation_space, gym.spaces.Dict) or (
            "working_mode" not in observation_space.spaces
        ):
            raise ValueError(
                "GoalTravelExtractor needs the working_mode key: make the goal env with "
                "observe_working_mode=True"
            )
        base = gym.spaces.Dict(
            {k: v for k, v in observation_space.spaces.items() if k != "working_mode"}
        )
        super().__init__(base, length)
        self._observation_space = observation_space
        self._features_dim += TRAVEL_FEATURES
        self.design = design if design is not None else Design()

    def forward(self, observations: dict[str, th.Tensor]) -> th.Tensor:
        """The features of a batch of observations, ``(n, features_dim)``."""
        base = super().forward(observations)
        travel = travel_features(
            observations["achieved_goal"].detach().cpu().numpy(),
            observations["desired_goal"].detach().cpu().numpy(),
            observations["working_mode"].detach().cpu().numpy(),
            self.design,
        )
        return th.cat([base, th.as_tensor(travel, dtype=base.dtype, device=base.device)], dim=1)


def travel_features(
    achieved: np.ndarray, desired: np.ndarray, mode: np.ndarray, design: Design
) -> np.ndarray:
    """:class:`GoalTravelExtractor`'s joint-space block, float32 ``(n, TRAVEL_FEATURES)``, of
    goals ``(n, 5)`` ``(x, y, cos, sin, v)`` (m, m, 1, 1, m/s) and working modes ``(n, 3)``
    (signs; 0, a leg perpendicular to its rail, counts as +1)."""
    mode = np.where(np.asarray(mode) < 0.0, -1.0, 1.0)

    rho = kinematics.inverse(design, poses_of_goals(achieved), mode).rho
    target = kinematics.inverse(design, poses_of_goals(desired), mode).rho
    valid = np.isfinite(rho).all(axis=1) & np.isfinite(target).all(axis=1)
    rho = np.where(valid[:, None], rho, 0.0)
    target = np.where(valid[:, None], target, 0.0)
    return np.concatenate(
        [travel_goal_entries(rho, target), target - rho, valid[:, None]], axis=1
    ).astype(np.float32)
