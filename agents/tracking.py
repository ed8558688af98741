"""The analytic controller with the reference velocity fed forward, for ``Planar3PTrack-v0``.

Resolved-rate tracking: the commanded twist is the reference twist (observation entries 31-33)
plus the analytic controller's proportional feedback on the errors to the reference pose,
``twist = (x_dot_ref + k_p e_x, y_dot_ref + k_p e_y, theta_dot_ref + k_theta e_theta)``,
mapped to slider rates with the paper's simple-motion formula, with the same uniform
saturation and serial-singularity brake as :class:`agents.analytic.AnalyticController`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.analytic import AnalyticController, FloatArray
from planar3p_gym.design import Design
from planar3p_gym.observation import OBS_SIZE

__all__ = [
    "TRACKING_BASELINES",
    "TRACK_OBS_SIZE",
    "TrackingController",
    "run_tracking_episodes",
    "summarize_tracking",
    "tracking_baselines",
]

#: Length of the tracking observation: the 31 entries of ``Planar3P-v0`` and the reference
#: velocity.
TRACK_OBS_SIZE = OBS_SIZE + 3


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
        """A controller for the design of ``env`` (a ``Planar3PTrackEnv``, possibly wrapped)."""
        return cls(env.unwrapped.design, mode=mode, **kwargs)

    def _feedforward(self, obs: FloatArray) -> FloatArray | None:
        return self.feedforward * obs[:, OBS_SIZE:TRACK_OBS_SIZE]


def run_tracking_episodes(
    env: Any, controller: Any, episodes: int, seed: int
) -> list[dict[str, Any]]:
    """Run ``controller`` for ``episodes`` episodes of a tracking env (reset with ``seed``
    once, then unseeded); the last ``info`` metrics of each episode plus its length, its end
    (``termination_reason``, None at the time limit) and its spec."""
    if not (isinstance(episodes, int) and episodes >= 1):
        raise ValueError(f"episodes must be an integer >= 1, got {episodes!r}")
    out = []
    obs, info = env.reset(seed=seed)
    for _ in range(episodes):
        spec = info["episode_spec"]
        if callable(getattr(controller, "reset", None)):
            controller.reset()
        steps = 0
        while True:
            action, _ = controller.predict(obs)
            obs, _, terminated, truncated, info = env.step(action)
            steps += 1
            if terminated or truncated:
                break
        row = {k: info[k] for k in info if k.startswith("tracking_")}
        row.update(steps=steps, termination_reason=info["termination_reason"], spec=spec)
        out.append(row)
        obs, info = env.reset()
    return out


def summarize_tracking(rows: list[dict[str, Any]]) -> dict[str, float]:
    """Mean, median and worst episode RMS / max pose error (m) and failures of ``rows``."""
    rms = np.array([r["tracking_rms_error"] for r in rows])
    mx = np.array([r["tracking_max_error"] for r in rows])
    rms_p = np.array([r["tracking_rms_position_error"] for r in rows])
    rms_o = np.array([r["tracking_rms_orientation_error"] for r in rows])
    return {
        "episodes": len(rows),
        "failures": sum(r["termination_reason"] is not None for r in rows),
        "rms_error_mean": float(rms.mean()),
        "rms_error_median": float(np.median(rms)),
        "rms_error_worst": float(rms.max()),
        "max_error_mean": float(mx.mean()),
        "max_error_worst": float(mx.max()),
        "rms_position_error_mean": float(rms_p.mean()),
        "rms_orientation_error_mean": float(rms_o.mean()),
    }


#: Controllers compared on the tracking id: label -> feed-forward scale.
TRACKING_BASELINES = {"analytic (feedback)": 0.0, "analytic + feed-forward": 1.0}


def tracking_baselines(
    episodes: int, seed: int, kinds: tuple[str, ...] = ("segments", "figure_eight")
) -> dict[str, dict[str, float]]:
    """:func:`summarize_tracking` of each of :data:`TRACKING_BASELINES` on
    ``Planar3PTrack-v0`` per reference kind, keyed ``"<kind>/<label>"``."""
    import gymnasium as gym

    import planar3p_gym

    out = {}
    for kind in kinds:
        for label, ff in TRACKING_BASELINES.items():
            env = gym.make(planar3p_gym.TRACK_ENV_ID, reference=kind)
            ctrl = TrackingController.from_env(env, feedforward=ff)
            out[f"{kind}/{label}"] = summarize_tracking(
                run_tracking_episodes(env, ctrl, episodes, seed)
            )
    return out
