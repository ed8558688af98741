"""Reward terms of ``Planar3P-v0``: each a small function, weighted and summed.

``reward = - w_pose * pose_error - w_singularity * singularity - w_action * effort
+ w_success * [success] - w_failure * [singularity crossing or physics breakdown]``

Every term is computed from the state after the physics step and reported in ``info``
(``info["reward_terms"]`` holds the weighted terms, which sum to the reward).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

__all__ = [
    "RewardWeights",
    "action_effort",
    "pose_error",
    "reward_terms",
    "singularity_penalty",
]

#: The singularity penalty of one margin is capped at this value (it stays finite at 0).
BARRIER_CAP = 100.0


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the reward terms and the margins at which the singularity penalty starts.

    Attributes:
        pose: weight of the dimensionless pose error (per step).
        singularity: weight of the singularity penalty (per step).
        action: weight of the action effort, mean of squared normalised actions (per step).
        success: bonus on the step that reaches the target.
        failure: penalty on a step that ends the episode by crossing a parallel singularity or
            by physics breakdown (large enough that ending early never pays).
        parallel_margin_ref: parallel margin below which the penalty starts (dimensionless).
        serial_margin_ref: serial margin below which the penalty starts (dimensionless).
    """

    pose: float = 1.0
    singularity: float = 0.05
    action: float = 0.01
    success: float = 10.0
    failure: float = 200.0
    parallel_margin_ref: float = 0.03
    serial_margin_ref: float = 0.1

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"reward weight {name} must be finite and >= 0, got {value!r}")
        for name in ("parallel_margin_ref", "serial_margin_ref"):
            if not 0 < getattr(self, name) <= 1:
                raise ValueError(f"{name} must be in (0, 1], got {getattr(self, name)!r}")


def pose_error(position_error: float, orientation_error: float, length: float) -> float:
    """``(|position error| + length * |orientation error|) / length``, dimensionless.

    Args:
        position_error: distance from ``G`` to the target point (m).
        orientation_error: angle to the target orientation (rad).
        length: characteristic length of the design (m).
    """
    return (position_error + length * abs(orientation_error)) / length


def _barrier(margin: float, ref: float) -> float:
    if margin >= ref:
        return 0.0
    if margin <= ref / (BARRIER_CAP + 1.0):
        return BARRIER_CAP
    return ref / margin - 1.0


def singularity_penalty(
    parallel_margin: float, serial_margin: float, parallel_ref: float, serial_ref: float
) -> float:
    """``(ref/m - 1)`` for each margin ``m`` below its reference, capped: 0 far from
    singularities, rising like ``1/m`` as a margin shrinks to 0."""
    return _barrier(parallel_margin, parallel_ref) + _barrier(serial_margin, serial_ref)


def action_effort(action: tuple[float, float, float]) -> float:
    """Mean of the squared normalised actions, in ``[0, 1]``."""
    return (action[0] ** 2 + action[1] ** 2 + action[2] ** 2) / 3.0


def reward_terms(
    weights: RewardWeights,
    *,
    pose_err: float,
    parallel_margin: float,
    serial_margin: float,
    action: tuple[float, float, float],
    success: bool,
    failure: bool,
) -> dict[str, float]:
    """The weighted terms; their sum is the reward."""
    return {
        "pose": -weights.pose * pose_err,
        "singularity": -weights.singularity
        * singularity_penalty(
            parallel_margin,
            serial_margin,
            weights.parallel_margin_ref,
            weights.serial_margin_ref,
        ),
        "action": -weights.action * action_effort(action),
        "success": weights.success if success else 0.0,
        "failure": -weights.failure if failure else 0.0,
    }
