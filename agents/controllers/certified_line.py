"""The slider line wherever the kinematics certifies it from where the machine is, with the
servo's lag predicted (baseline ``certified-line``).

At every step the straight line in slider space from the observed travels to the target's is
certified (:func:`planar3p_gym.tasks.joint_paths.certify_lines`); where it is, the controller
drives the line on the travel error predicted one control period ahead at the deadbeat gain,
else the simultaneous simple motions.  It keeps no state, so it serves as the base of
:class:`planar3p_agents.controllers.residual.ResidualLinePolicy`.  Why the prediction, and what
it gains on the suites: docs/controllers.md, "How the controller modules work".

* :class:`CertifiedLineController`: the controller (SB3's ``predict``);
* :data:`DEFAULT_POINTS`: the points each line is checked at.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planar3p_agents.controllers.analytic import AnalyticController
from planar3p_agents.controllers.base import BatchPolicy
from planar3p_agents.controllers.certified import DEFAULT_CARTESIAN_GAIN, DEFAULT_LIMITS
from planar3p_agents.controllers.slider_line import (
    line_rates,
    observed_modes,
    observed_poses,
    target_travels,
)
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.joint_paths import PathLimits, certify_lines
from planar3p_gym.tasks.observation import OBS_SIZE, SLICES

__all__ = ["DEFAULT_POINTS", "CertifiedLineController"]

#: Points at which the line from the current state is checked (see the module docstring).
DEFAULT_POINTS = 32

FloatArray = NDArray[np.float64]


class CertifiedLineController(BatchPolicy):
    """Slider line where certified from the observed state, else the simple motions.

    Args:
        design: the machine; default ``Design.fig8()``.
        dt: the control period (s): the lead of the travel prediction.
        gain: the line's proportional gain on the predicted travel error near the end (1/s);
            default ``1 / dt`` (deadbeat).
        cartesian_gain: position and orientation gain of the simple motions (1/s).
        limits: what the line must respect (the planner's limits, checked at
            :data:`DEFAULT_POINTS` points, by default).
        observation_size: length of the flat observations :meth:`predict` accepts (at least
            the 31 entries of ``Planar3P-v0``, the ones read); default 31.

    Stateless: :meth:`predict` depends on the observation only.  :attr:`line_steps` and
    :attr:`steps` count the rows given the line and all rows since construction.
    """

    obs_size = OBS_SIZE

    def __init__(
        self,
        design: Design | None = None,
        *,
        dt: float = 0.02,
        gain: float | None = None,
        cartesian_gain: float = DEFAULT_CARTESIAN_GAIN,
        limits: PathLimits | None = None,
        observation_size: int | None = None,
    ) -> None:
        self._use_design(design)
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be finite and > 0 (s), got {dt!r}")
        if gain is None:
            gain = 1.0 / dt
        for name, value in (("gain", gain), ("cartesian_gain", cartesian_gain)):
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0 (1/s), got {value!r}")
        if limits is not None and not isinstance(limits, PathLimits):
            raise ValueError(f"limits must be a PathLimits, got {type(limits).__name__}")
        self._use_observation_size(observation_size)
        self.dt = float(dt)
        self.gain = float(gain)
        self.cartesian_gain = float(cartesian_gain)
        if limits is None:
            limits = replace(DEFAULT_LIMITS, points=DEFAULT_POINTS)
        self.limits = limits
        self.cartesian = AnalyticController(
            self.design, position_gain=cartesian_gain, orientation_gain=cartesian_gain
        )
        self.line_steps = 0
        self.steps = 0

    @classmethod
    def from_env(cls, env: Any, **kwargs: Any) -> CertifiedLineController:
        """The controller for the design and control period of ``env``."""
        base = env.unwrapped
        return cls(base.design, dt=float(base.dt), **kwargs)

    def certified(self, obs: FloatArray) -> tuple[NDArray[np.bool_], FloatArray]:
        """Mask ``(n,)`` of the observations ``(n, d)`` whose slider line to the target is
        certified, and the target travels ``(n, 3)`` (m; NaN where a leg cannot close)."""
        rho = obs[:, SLICES["rho"]]
        rho_target = target_travels(self.design, obs, observed_modes(obs))
        pose, target = observed_poses(obs)
        ok = certify_lines(self.design, rho, rho_target, pose, target, self.limits)
        return ok, rho_target

    def act(
        self, obs: FloatArray, state: Any, starts: NDArray[np.bool_], deterministic: bool
    ) -> tuple[np.ndarray, Any]:
        """Actions ``(n, 3)`` in ``[-1, 1]`` (fractions of ``max_speed``)."""
        o = np.nan_to_num(obs[:, :OBS_SIZE], nan=0.0, posinf=0.0, neginf=0.0)
        line, rho_target = self.certified(o)
        actions = self.cartesian.predict(o)[0].astype(np.float64)
        if line.any():
            ahead = o[line][:, SLICES["rho"]] + self.dt * o[line][:, SLICES["rho_dot"]]
            error = rho_target[line] - ahead
            rates = line_rates(error, self.gain, self.design.max_speed)
            actions[line] = np.clip(rates / self.design.max_speed, -1.0, 1.0)
        self.line_steps += int(line.sum())
        self.steps += len(o)
        return actions.astype(np.float32), None

    def __repr__(self) -> str:
        return (
            f"CertifiedLineController(dt={self.dt}, gain={self.gain}, "
            f"cartesian_gain={self.cartesian_gain}, points={self.limits.points})"
        )
