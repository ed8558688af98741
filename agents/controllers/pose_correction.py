"""A learned correction of the built machine's pose reading: the sensing bias as a linear
function of the readings.

On the machine as built the observed pose is leg 1's serial chain of the nominal design
(:mod:`planar3p_gym.sim.sensors`), so the manufacturing errors of the drawn machine bias it by
millimetres, and a controller that stops at the observed target may stop outside the true
tolerance.  The readings of the other legs (their travels and angles) are redundant with leg 1's
and carry part of that bias.  :class:`PoseCorrection` holds a least-squares fit of the bias:

* :data:`FEATURES`: the observation entries it reads (slider travels, pose, leg angles);
* ``bias = [features, 1] @ weights``: true minus observed ``(x, y, theta)`` (m, m, rad);
* :meth:`PoseCorrection.corrected`: the observation with the errors to the target corrected;
* :func:`fit_pose_correction`: the least-squares fit of samples (features and bias);
* :func:`correction_weights`, :func:`weights_in_kwargs`: a correction as a policy's argument
  (weights, a file read into them).

Fitted by :mod:`planar3p_agents.training.pose_correction` on simulated episodes of the
randomised machine (the bias needs the true pose, which only a simulation has).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_gym import atomic_files
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

__all__ = [
    "FEATURES",
    "PoseCorrection",
    "correction_weights",
    "fit_pose_correction",
    "pose_bias",
    "weights_in_kwargs",
]

#: Observation indices the correction reads: ``rho``, ``position``, ``orientation``, ``legs``.
FEATURES: tuple[int, ...] = tuple(
    i
    for name in ("rho", "position", "orientation", "legs")
    for i in range(SLICES[name].start, SLICES[name].stop)
)
_WEIGHT_SHAPE = (len(FEATURES) + 1, 3)
_POS = SLICES["position_error"]
_ANG = SLICES["orientation_error"].start


def _features(obs: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.concatenate([obs[:, FEATURES], np.ones((obs.shape[0], 1))], axis=1)


def pose_bias(obs: ArrayLike, true_pose: ArrayLike) -> NDArray[np.float64]:
    """True minus observed pose ``(n, 3)`` (m, m, rad, the angle wrapped) for observations
    ``(n, >= 31)`` and the true poses ``(n, 3)`` (``info["pose"]``)."""
    o = np.atleast_2d(np.asarray(obs, dtype=np.float64))
    p = np.atleast_2d(np.asarray(true_pose, dtype=np.float64))
    pos, ori = o[:, SLICES["position"]], o[:, SLICES["orientation"]]
    theta = np.arctan2(ori[:, 1], ori[:, 0])
    dth = wrap_angle(p[:, 2] - theta)
    return np.column_stack([p[:, 0] - pos[:, 0], p[:, 1] - pos[:, 1], dth])


class PoseCorrection:
    """Linear model of the pose reading's bias (module docstring).

    Args:
        weights: ``(len(FEATURES) + 1, 3)`` (the last row is the constant term), or a path
            to a JSON file of them (:meth:`save`).
    """

    def __init__(self, weights: ArrayLike | str | Path) -> None:
        if isinstance(weights, (str, Path)):
            weights = json.loads(Path(weights).read_text())["weights"]
        w = np.asarray(weights, dtype=np.float64)
        if w.shape != _WEIGHT_SHAPE or not np.isfinite(w).all():
            raise ValueError(f"weights must be finite with shape {_WEIGHT_SHAPE}, got {w.shape}")
        self.weights = w

    def bias(self, obs: ArrayLike) -> NDArray[np.float64]:
        """Predicted true minus observed pose ``(n, 3)`` for observations ``(n, >= 31)``."""
        o = np.atleast_2d(np.asarray(obs, dtype=np.float64))
        if o.shape[1] < OBS_SIZE:
            raise ValueError(f"observation must have at least {OBS_SIZE} entries, got {o.shape}")
        return _features(o) @ self.weights

    def corrected(self, obs: ArrayLike) -> NDArray[np.float64]:
        """A copy of the observations ``(n, d)`` whose ``position_error`` and
        ``orientation_error`` are corrected by the predicted bias (the target minus the
        corrected pose); every other entry is unchanged."""
        o = np.array(np.atleast_2d(obs), dtype=np.float64)
        b = self.bias(o)
        o[:, _POS] -= b[:, :2]
        o[:, _ANG] -= b[:, 2]
        return o

    def to_list(self) -> list[list[float]]:
        """The weights as nested lists (JSON, a policy's constructor arguments)."""
        return self.weights.tolist()

    def save(self, path: str | Path, **record: Any) -> None:
        """Write the weights, and ``record`` (how they were fitted), as JSON."""
        atomic_files.write_atomic(path, json.dumps({"weights": self.to_list(), **record}, indent=1))


def fit_pose_correction(obs: ArrayLike, bias: ArrayLike) -> PoseCorrection:
    """Least-squares fit of ``bias`` ``(n, 3)`` (:func:`pose_bias`) on the observations
    ``(n, >= 31)``; ``ValueError`` with fewer samples than weights per output."""
    o = np.atleast_2d(np.asarray(obs, dtype=np.float64))
    y = np.atleast_2d(np.asarray(bias, dtype=np.float64))
    if o.shape[0] != y.shape[0] or y.shape[1] != 3:
        raise ValueError(f"need n observations and n x 3 biases, got {o.shape} and {y.shape}")
    if o.shape[0] < _WEIGHT_SHAPE[0]:
        raise ValueError(f"need at least {_WEIGHT_SHAPE[0]} samples, got {o.shape[0]}")
    weights, *_ = np.linalg.lstsq(_features(o), y, rcond=None)
    return PoseCorrection(weights)


def correction_weights(correction: ArrayLike | str | Path | None) -> list[list[float]] | None:
    """A correction given as weights or its JSON file, checked and as nested lists (a
    policy's constructor argument); ``None`` stays ``None``."""
    return None if correction is None else PoseCorrection(correction).to_list()


def weights_in_kwargs(policy_kwargs: dict[str, Any]) -> dict[str, Any]:
    """``policy_kwargs`` with a ``correction`` named by its file replaced by its weights, so
    that a saved model (SB3 keeps the ``policy_kwargs`` it was made with) holds them and
    names no path."""
    correction = policy_kwargs.get("correction")
    if isinstance(correction, (str, Path)):
        return {**policy_kwargs, "correction": correction_weights(correction)}
    return dict(policy_kwargs)
