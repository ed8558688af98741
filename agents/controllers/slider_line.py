"""The straight line in slider space, synchronised and saturating (baseline ``slider-line``).

Each slider is driven to the travel of the target pose in the episode's working mode
(inverse kinematics; the target pose and the leg angles are in the observation, the working
mode is ``sign cos alpha_i`` of the first observation of the episode).  The travel errors
``e = rho_target - rho`` are commanded as one synchronised motion, ``rho_dot = e * min(k,
v_max / max_i |e_i|)``: far from the target the slider with the largest travel saturates at
``v_max`` and the others move in proportion (every slider arrives together, the travels follow
the straight line), near it the proportional gain ``k`` (1/s) takes over.

The line need not bring the gripper to the target: where it passes a parallel singularity or
folds onto the target's mirror image the branch of the direct kinematics ends elsewhere
(:func:`planar3p_gym.machine.slider_line.slider_line_reaches` predicts which pairs it solves).
:class:`planar3p_agents.controllers.certified.CertifiedPlanner` uses it only where the
kinematics certifies it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from planar3p_agents.controllers.base import BatchPolicy
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

__all__ = [
    "DEFAULT_TRAVEL_GAIN",
    "SliderLineController",
    "observed_modes",
    "observed_poses",
    "target_travels",
]

#: Proportional gain on the travel error near the end of the line (1/s).
DEFAULT_TRAVEL_GAIN = 15.0

FloatArray = NDArray[np.float64]


def observed_modes(obs: FloatArray) -> FloatArray:
    """Working modes ``(n, 3)`` (``sign cos alpha_i``, +1 at 0) of flat observations ``(n, d)``."""
    cos_a = obs[:, SLICES["legs"]][:, 0::2]
    return np.where(cos_a >= 0.0, 1.0, -1.0)


def observed_poses(obs: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Gripper poses and target poses ``(n, 3)`` (m, m, rad) of flat observations ``(n, d)``."""
    pos, ori = obs[:, SLICES["position"]], obs[:, SLICES["orientation"]]
    tpos, tori = obs[:, SLICES["target_position"]], obs[:, SLICES["target_orientation"]]
    pose = np.column_stack([pos, np.arctan2(ori[:, 1], ori[:, 0])])
    target = np.column_stack([tpos, np.arctan2(tori[:, 1], tori[:, 0])])
    return pose, target


def target_travels(design: Design, obs: FloatArray, modes: FloatArray) -> FloatArray:
    """Travels ``(n, 3)`` (m) of the observed target poses in working modes ``modes`` (NaN
    where a leg cannot close)."""
    return kinematics.inverse(design, observed_poses(obs)[1], modes).rho


def line_rates(error: FloatArray, gain: float, max_speed: float) -> FloatArray:
    """Slider rates ``(n, 3)`` (m/s) of the synchronised line for travel errors ``(n, 3)``:
    ``error * min(gain, max_speed / max_i |error_i|)`` (zero where ``error`` is not finite)."""
    peak = np.max(np.abs(error), axis=1, keepdims=True)
    scale = np.minimum(gain, max_speed / np.maximum(peak, 1e-12))
    rates = error * scale
    return np.where(np.isfinite(rates).all(axis=1, keepdims=True), rates, 0.0)


class SliderLineController(BatchPolicy):
    """Synchronised, saturating straight line in slider space to the target's travels.

    Args:
        design: the machine; default ``Design.fig8()``.
        gain: ``k`` (1/s), the proportional gain on the travel error near the end.
        speed_fraction: the fastest slider's rate as a fraction of ``max_speed``.
        observation_size: length of the flat observations :meth:`predict` accepts (at least
            the 31 entries of ``Planar3P-v0``, the ones read).

    State: the working mode of each environment, read at its first observation (or at
    ``episode_start``), so the target's travels stay those of the episode's mode.
    """

    obs_size = OBS_SIZE

    def __init__(
        self,
        design: Design | None = None,
        *,
        gain: float = DEFAULT_TRAVEL_GAIN,
        speed_fraction: float = 1.0,
        observation_size: int | None = None,
    ) -> None:
        self._use_design(design)
        if not (np.isfinite(gain) and gain > 0):
            raise ValueError(f"gain must be finite and > 0 (1/s), got {gain!r}")
        if not 0 < speed_fraction <= 1:
            raise ValueError(f"speed_fraction must be in (0, 1], got {speed_fraction!r}")
        self.gain = float(gain)
        self.speed_fraction = float(speed_fraction)
        self._use_observation_size(observation_size)
        self._modes: FloatArray | None = None

    def reset(self, seed: Any = None) -> None:
        """Forget the working modes (the next observation starts an episode)."""
        self._modes = None

    def act(
        self, obs: FloatArray, state: Any, starts: NDArray[np.bool_], deterministic: bool
    ) -> tuple[np.ndarray, Any]:
        """Actions ``(n, 3)`` in ``[-1, 1]``: the line's rates over ``max_speed``."""
        o = np.nan_to_num(obs, nan=0.0, posinf=0.0, neginf=0.0)
        seen = observed_modes(o)
        if self._modes is None or self._modes.shape != seen.shape:
            self._modes = seen
        self._modes[starts] = seen[starts]
        error = target_travels(self.design, o, self._modes) - o[:, SLICES["rho"]]
        vmax = self.speed_fraction * self.design.max_speed
        rates = line_rates(error, self.gain, vmax)
        return np.clip(rates / self.design.max_speed, -1.0, 1.0).astype(np.float32), None

    def __repr__(self) -> str:
        return f"SliderLineController(gain={self.gain}, speed_fraction={self.speed_fraction})"
