"""Reward terms of ``Planar3P-v0``: each a small function, weighted and summed.

``reward = - w_pose * pose_error - w_precision * (1 - exp(-pose_distance / precision_scale))
- w_singularity * singularity - w_action * effort + w_success * [success]
- w_failure * [singularity crossing or physics breakdown]``

The precision term is a bounded, sharp companion of the linear pose error: its slope at the
target is ``1 / precision_scale`` per metre (about 60 times that of the linear term on the
default design), which tells an agent to close the last millimetres.  Every per-step term is
<= 0, so reaching the target (which ends the episode) always pays.

Every term is computed from the state after the physics step and reported in ``info``
(``info["reward_terms"]`` holds the weighted terms, which sum to the reward).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numba import njit

from planar3p_gym.checks import as_finite_float

__all__ = [
    "MAX_WEIGHT",
    "RewardWeights",
    "barrier",
    "reward_terms",
    "weighted_terms",
]

#: The singularity penalty of one margin is capped at this value (it stays finite at 0).
BARRIER_CAP = 100.0
#: Largest allowed weight.  Per step ``|reward| <= MAX_WEIGHT * (e + 1 + 2 BARRIER_CAP + 3)``
#: (pose error ``e``, precision term < 1, two capped barriers, effort <= 1, one success or
#: failure flag); ``e = |dp| / L_ref + |dtheta| <= span / L_ref + pi`` is bounded by the
#: design's size, so rewards stay far inside even float32's range (SB3 stores float32), and so
#: do returns over millions of steps.
MAX_WEIGHT = 1e6
#: The fields of :class:`RewardWeights` that are weights (the others are scales and margins).
WEIGHT_NAMES = ("pose", "precision", "singularity", "action", "success", "failure")
#: Names of the weighted terms, in the order of :func:`weighted_terms`.
TERM_NAMES = WEIGHT_NAMES


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the reward terms and the margins at which the singularity penalty starts.

    Attributes:
        pose: weight of the dimensionless pose error (per step).
        precision: weight of the bounded precision term (per step).
        precision_scale: pose distance ``|dp| + L_ref |dtheta|`` at which the precision term
            reaches ``1 - 1/e`` of its cap (m).
        singularity: weight of the singularity penalty (per step).
        action: weight of the action effort, mean of squared normalised actions (per step).
        success: bonus on the step that reaches the target.
        failure: penalty on a step that ends the episode by crossing a parallel singularity or
            by physics breakdown (large enough that ending early never pays).
        parallel_margin_ref: parallel margin below which the penalty starts (dimensionless).
        serial_margin_ref: serial margin below which the penalty starts (dimensionless).
    """

    pose: float = 1.0
    precision: float = 0.5
    precision_scale: float = 0.005
    singularity: float = 0.05
    action: float = 0.01
    success: float = 10.0
    failure: float = 300.0
    parallel_margin_ref: float = 0.03
    serial_margin_ref: float = 0.1

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            number = as_finite_float(value)
            if number is None or number < 0:
                raise ValueError(
                    f"reward weight {name} must be a finite number >= 0, got {value!r}"
                )
            if name in WEIGHT_NAMES and number > MAX_WEIGHT:
                raise ValueError(
                    f"reward weight {name} must be <= {MAX_WEIGHT:g} (larger weights can make "
                    f"rewards overflow to -inf), got {value!r}"
                )
            object.__setattr__(self, name, number)  # plain floats (NumPy scalars accepted)
        if self.precision_scale <= 0:
            raise ValueError(f"precision_scale must be > 0 (m), got {self.precision_scale!r}")
        for name in ("parallel_margin_ref", "serial_margin_ref"):
            if not 0 < getattr(self, name) <= 1:
                raise ValueError(f"{name} must be in (0, 1], got {getattr(self, name)!r}")
        array = np.array(
            [
                self.pose, self.precision, self.precision_scale, self.singularity, self.action,
                self.success, self.failure, self.parallel_margin_ref, self.serial_margin_ref,
            ]
        )  # fmt: skip
        array.flags.writeable = False
        object.__setattr__(self, "_array", array)

    def as_array(self) -> np.ndarray:
        """The fields in the order :func:`weighted_terms` reads them (read-only float64)."""
        return self._array  # type: ignore[attr-defined]


@njit(cache=True)
def barrier(margin: float, ref: float) -> float:
    """Singularity barrier of one margin (dimensionless): 0 at or above ``ref``, ``ref/margin -
    1`` below it, capped at :data:`BARRIER_CAP` (reached at ``margin = ref / (cap + 1)``)."""
    if margin >= ref:
        return 0.0
    if margin <= ref / (BARRIER_CAP + 1.0):
        return BARRIER_CAP
    return ref / margin - 1.0


@njit(cache=True)
def weighted_terms(
    w: np.ndarray,
    position_error: float, orientation_error: float, length: float,
    parallel_margin: float, serial_margin: float,
    a0: float, a1: float, a2: float, success: bool, failure: bool,
) -> tuple[float, float, float, float, float, float]:  # fmt: skip
    """The weighted terms ``(pose, precision, singularity, action, success, failure)`` of one
    step: the one definition of the reward, which :func:`reward_terms` and the compiled step
    outputs (:mod:`planar3p_gym.tasks.reach_step`, single env and vector env) call.

    ``w`` is :meth:`RewardWeights.as_array`; the errors are in m and rad, ``length`` is the
    design's characteristic length (m); a margin of 1 switches its barrier off.
    """
    distance = position_error + length * abs(orientation_error)
    return (
        -w[0] * (distance / length),
        -w[1] * (1.0 - math.exp(-distance / w[2])),
        -w[3] * (barrier(parallel_margin, w[7]) + barrier(serial_margin, w[8])),
        -w[4] * ((a0 * a0 + a1 * a1 + a2 * a2) / 3.0),
        w[5] if success else 0.0,
        -w[6] if failure else 0.0,
    )


def reward_terms(
    weights: RewardWeights,
    *,
    position_error: float,
    orientation_error: float,
    length: float,
    parallel_margin: float,
    serial_margin: float,
    action: tuple[float, float, float],
    success: bool,
    failure: bool,
) -> dict[str, float]:
    """The weighted terms by name (:data:`TERM_NAMES`); their sum is the reward.

    ``position_error`` (m) and ``orientation_error`` (rad) are the errors to the target,
    ``length`` the characteristic length (m); pass a margin of 1 to switch its barrier off.
    """
    values = weighted_terms(
        weights.as_array(),
        float(position_error),
        float(orientation_error),
        float(length),
        float(parallel_margin),
        float(serial_margin),
        float(action[0]),
        float(action[1]),
        float(action[2]),
        bool(success),
        bool(failure),
    )
    return dict(zip(TERM_NAMES, values, strict=True))
