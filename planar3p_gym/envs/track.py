"""``Planar3PTrack-v0``: follow a moving reference pose (:mod:`planar3p_gym.tasks.track`)."""

from __future__ import annotations

from typing import Any

from planar3p_gym.envs.core import Planar3PEnv
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.track import TrackTask

__all__ = ["Planar3PTrackEnv"]


class Planar3PTrackEnv(Planar3PEnv):
    """Trajectory tracking with a 3-PRR planar parallel manipulator simulated in pymunk.

    ## Description
    The machine of ``Planar3P-v0`` (registered on the projected physics, as ``Planar3P-v0``)
    must follow a moving reference pose: smooth random
    segments between reach-like waypoints (``reference="segments"``, default) or a
    figure-eight in the workspace (``reference="figure_eight"``).  The reference always stays
    within the stroke, away from the end stops and from singularities (checked along its whole
    length with the task's path margins), in the start's assembly mode, and needs at most
    ``speed_fraction`` of the slider speed limit, so a good controller can follow it without
    crossing a singularity.

    ## Action Space
    ``Box(-1, 1, (3,), float32)``: slider velocity commands as fractions of ``max_speed``.

    ## Observation Space
    ``Box((34,), float32)``: the 31 entries of ``Planar3P-v0``
    (:mod:`planar3p_gym.tasks.observation`) with the current reference pose as the target (entries
    19-22) and the errors to it (23-25, 28-30), then the reference velocity
    ``(x_dot, y_dot, theta_dot)`` (m/s, m/s, rad/s) at 31-33.

    ## Rewards
    Per step, against the reference: ``-w_pose e - w_precision (1 - exp(-d / s)) -
    w_singularity barrier - w_action effort - w_failure [failure]`` (the terms of
    :mod:`planar3p_gym.tasks.rewards`, no success bonus), ``d = |dp| + L_ref |dtheta|`` (m).

    ## Starting State
    At rest at the reference's initial pose (a waypoint or the figure-eight's centre).
    ``reset(options={"reference": ..., "start": ..., "working_mode": ...})`` sets any of them
    (validated, ``ValueError`` if infeasible); ``info["episode_spec"]`` replays an episode.

    ## Episode End
    ``terminated`` only by a singularity crossing or a physics breakdown
    (``info["termination_reason"]``); ``truncated`` by the registered time limit (500 steps,
    10 s).  Metrics in ``info``: ``tracking_error`` and the running RMS and maximum of the pose,
    position and orientation errors (``tracking_rms_error``, ``tracking_max_error``,
    ``tracking_rms_position_error``, ...; :data:`planar3p_gym.tasks.track.TRACKING_METRICS`);
    the last ``info`` of an episode holds the episode's values.

    ## Arguments
    ``reference`` (``"segments"`` or ``"figure_eight"``; ``"mixed"`` draws either per episode,
    a training aid), ``speed_fraction`` (default 0.5),
    ``duration`` of the random segments (s, default 10), and every argument of
    :class:`planar3p_gym.envs.core.Planar3PEnv` except ``task``.

    ## Version History
    - v0 (1.0.0): frozen, with the changes every id took in 1.0.0
      (:class:`~planar3p_gym.envs.core.Planar3PEnv`, Version History).
    - v0 (0.1.0): initial release.
    """

    def __init__(
        self,
        design: Design | dict | str | None = None,
        *,
        reference: str = "segments",
        speed_fraction: float = 0.5,
        duration: float = 10.0,
        **kwargs: Any,
    ) -> None:
        if "task" in kwargs:
            raise ValueError("Planar3PTrackEnv sets its own task; do not pass task=")
        super().__init__(design, task=TrackTask(reference, speed_fraction, duration), **kwargs)
