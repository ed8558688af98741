"""The analytic controller with the reference velocity fed forward, for ``Planar3PTrack-v0``.

Resolved-rate tracking: the commanded twist is the reference twist (the ``reference_velocity``
entries the tracking task appends, 31-33:
:data:`planar3p_agents.controllers.layout.TASK_EXTRA_FIELDS`) plus the analytic controller's
proportional feedback on the errors to the reference pose,
``twist = (x_dot_ref + k_p e_x, y_dot_ref + k_p e_y, theta_dot_ref + k_theta e_theta)``,
mapped to slider rates with the paper's simple-motion formula, with the same uniform
saturation and serial-singularity brake as
:class:`planar3p_agents.controllers.analytic.AnalyticController`.  Its measurements on the
tracking id are in the repository script ``scripts/goal_track_baselines.py``; by name it is the
baseline ``analytic-feedforward`` of :func:`planar3p_agents.policies.factory.load_policy`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planar3p_agents.controllers.analytic import AnalyticController, FloatArray
from planar3p_agents.controllers.layout import extra_slice, task_observation_size
from planar3p_gym.machine.design import Design

__all__ = ["TRACK_OBS_SIZE", "TrackingController"]

#: Length of the tracking observation: the 31 entries of ``Planar3P-v0`` and the reference
#: velocity.
TRACK_OBS_SIZE = task_observation_size("track")
#: The reference velocity ``(x_dot, y_dot, theta_dot)`` in the tracking observation.
REFERENCE_VELOCITY = extra_slice("track", "reference_velocity")


class TrackingController(AnalyticController):
    """:class:`AnalyticController` (simultaneous mode) with velocity feed-forward.

    Args:
        design: the machine; default ``Design.fig8()``.
        feedforward: scale of the fed-forward reference twist (1 = full, 0 = feedback only,
            the plain analytic controller).
        **kwargs: gains and limits of :class:`AnalyticController`.
    """

    obs_size = TRACK_OBS_SIZE

    def __init__(
        self, design: Design | None = None, *, feedforward: float = 1.0, **kwargs: Any
    ) -> None:
        if "mode" in kwargs and kwargs["mode"] != "simultaneous":
            raise ValueError("TrackingController works in the simultaneous mode only")
        kwargs.pop("mode", None)
        super().__init__(design, "simultaneous", **kwargs)
        if not (np.isfinite(feedforward) and 0.0 <= feedforward <= 2.0):
            raise ValueError(f"feedforward must be in [0, 2], got {feedforward!r}")
        self.feedforward = float(feedforward)

    @classmethod
    def from_env(cls, env: Any, mode: str = "simultaneous", **kwargs: Any) -> TrackingController:
        """A controller for the design of ``env`` (a ``Planar3PTrackEnv``, possibly wrapped);
        ``ValueError`` if its observation has no reference velocity."""
        from planar3p_agents.controllers.layout import observation_layout

        layout = observation_layout(env)
        if "reference_velocity" not in layout.names:
            raise ValueError(
                f"TrackingController needs the reference velocity of Planar3PTrack-v0's "
                f"observation; {layout.env_id} has none"
            )
        return cls(env.unwrapped.design, mode=mode, **kwargs)

    def _feedforward(self, obs: FloatArray) -> FloatArray | None:
        return self.feedforward * obs[:, REFERENCE_VELOCITY]
