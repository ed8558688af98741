"""The references of :mod:`planar3p_gym.tasks.track`: their JSON form, checked
(:func:`parse_reference`), and the pose and velocity they prescribe at a time
(:func:`reference_at`).  Random segments follow the minimum-jerk time law
(:func:`planar3p_gym.tasks.motions.minimum_jerk`) between waypoints; the figure-eight is
``x = cx + ax sin phi``, ``y = cy + ay sin 2 phi``, ``theta = ctheta + atheta sin phi`` with a
smooth ramp of the phase from rest.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from planar3p_gym import checks
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.tasks.base import Task, pose_list
from planar3p_gym.tasks.motions import minimum_jerk

__all__ = [
    "CHECK_POINTS",
    "MIN_DURATION",
    "REFERENCE_KINDS",
    "eight_curve",
    "figure_eight",
    "parse_reference",
    "reference_at",
    "reference_samples",
    "reference_values",
]

#: Reference kinds.
REFERENCE_KINDS = ("segments", "figure_eight")
#: Points at which a segment or the figure-eight is checked and its rates bounded.
CHECK_POINTS = 65
#: Shortest segment or period (s).
MIN_DURATION = 0.5
#: Most waypoints a requested segments reference may have (a budget on its checks).
MAX_WAYPOINTS = 10_000


def figure_eight(
    centre: np.ndarray, amp: np.ndarray, phi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Poses ``(n, 3)`` of the figure-eight at phases ``phi`` ``(n,)`` and their derivatives
    with respect to the phase."""
    s, c = np.sin(phi), np.cos(phi)
    s2, c2 = np.sin(2.0 * phi), np.cos(2.0 * phi)
    pose = centre + np.column_stack([amp[0] * s, amp[1] * s2, amp[2] * s])
    dpose = np.column_stack([amp[0] * c, 2.0 * amp[1] * c2, amp[2] * c])
    return pose, dpose


def parse_reference(ref: Any) -> dict[str, Any]:
    """A reference dict checked for form (not feasibility), as plain JSON data."""
    if not isinstance(ref, dict) or ref.get("kind") not in REFERENCE_KINDS:
        raise ValueError(
            f"reference must be a dict with kind in {REFERENCE_KINDS}, got {ref!r:.200}"
        )
    if ref["kind"] == "segments":
        if set(ref) != {"kind", "waypoints", "durations"}:
            raise ValueError("a segments reference has keys kind, waypoints, durations")
        if isinstance(ref["waypoints"], (str, bytes, dict)) or isinstance(
            ref["durations"], (str, bytes, dict)
        ):
            raise ValueError("reference waypoints and durations must be lists")
        try:
            waypoints, durations = list(ref["waypoints"]), list(ref["durations"])
        except TypeError as exc:
            raise ValueError("reference waypoints and durations must be lists") from exc
        if len(waypoints) > MAX_WAYPOINTS:
            raise ValueError(f"a segments reference has at most {MAX_WAYPOINTS} waypoints")
        wps = [Task.finite_pose(w, "reference waypoint") for w in waypoints]
        dur = [checks.number(d, "reference duration", unit="s") for d in durations]
        if len(wps) < 2 or len(dur) != len(wps) - 1:
            raise ValueError(
                "a segments reference needs >= 2 waypoints and one duration per segment"
            )
        if not all(math.isfinite(d) and d >= MIN_DURATION * 0.5 for d in dur):
            raise ValueError(f"reference durations must be >= {MIN_DURATION * 0.5} s")
        return {
            "kind": "segments",
            "waypoints": [pose_list(w) for w in wps],
            "durations": dur,
        }
    if set(ref) != {"kind", "centre", "amplitude", "period", "ramp"}:
        raise ValueError("a figure_eight reference has keys kind, centre, amplitude, period, ramp")
    centre = Task.finite_pose(ref["centre"], "reference centre")
    amp = Task.finite_pose(ref["amplitude"], "reference amplitude")
    period = checks.number(ref["period"], "reference period", low=MIN_DURATION, unit="s")
    ramp = checks.number(ref["ramp"], "reference ramp", low=0.0, high=60.0, low_open=True, unit="s")
    return {
        "kind": "figure_eight",
        "centre": pose_list(centre),
        "amplitude": pose_list(amp),
        "period": period,
        "ramp": ramp,
    }


def reference_at(ref: dict[str, Any], t: float) -> tuple[np.ndarray, np.ndarray]:
    """Pose and velocity (m, m, rad; m/s, m/s, rad/s) of the parsed reference ``ref`` at
    time ``t`` (s) from its start (:func:`reference_values` at one time)."""
    poses, velocities = reference_values(ref, np.array([float(t)]))
    return poses[0], velocities[0]


def _phase_time(t: float, ramp: float) -> tuple[float, float]:
    """The figure-eight's phase time ``g(t)`` (s) and its rate ``g'(t)``, with ``g' =
    smoothstep(t / ramp)``: from rest to full speed, C^1."""
    u = min(t / ramp, 1.0)
    return ramp * (u**3 - 0.5 * u**4) + max(t - ramp, 0.0), 3.0 * u * u - 2.0 * u**3


def reference_values(ref: dict[str, Any], times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Poses and velocities ``(m, 3)`` (m, m, rad; m/s, m/s, rad/s) of the parsed reference
    ``ref`` at the times ``times`` ``(m,)`` (s) from its start.  The time laws (the
    minimum-jerk progress of a segment, the phase time of the figure-eight) are evaluated
    time by time in plain floats, the rest elementwise: each time's numbers are the same
    floating-point operations whatever the other times."""
    m = times.shape[0]
    if ref["kind"] == "segments":
        wps = np.asarray(ref["waypoints"])
        poses, velocities = np.empty((m, 3)), np.empty((m, 3))
        rest = times.astype(np.float64)  # (a copy: the time into the current segment)
        todo = np.ones(m, dtype=np.bool_)
        for a, b, dur in zip(wps[:-1], wps[1:], ref["durations"], strict=True):
            here = todo & (rest < dur)
            if here.any():
                delta = b - a
                delta[2] = wrap_angle(delta[2])
                law = np.array([minimum_jerk(t, dur) for t in rest[here].tolist()])
                poses[here] = a + law[:, :1] * delta
                velocities[here] = law[:, 1:] * delta
                todo &= ~here
            rest[todo] -= dur
        poses[todo], velocities[todo] = wps[-1], 0.0
        return poses, velocities
    omega = 2.0 * math.pi / ref["period"]
    phase = np.array([_phase_time(t, ref["ramp"]) for t in times.tolist()]).reshape(m, 2)
    pose, dpose = figure_eight(
        np.asarray(ref["centre"]), np.asarray(ref["amplitude"]), omega * phase[:, 0]
    )
    return pose, dpose * omega * phase[:, 1:]


def reference_samples(ref: dict[str, Any], dt: float, start: int, stop: int) -> np.ndarray:
    """The reference ``ref`` at the control steps ``start`` to ``stop - 1`` (time ``step *
    dt``, ``dt`` in s) as rows of 8 float64: the pose ``(x, y, theta)`` (m, m, rad), ``cos
    theta``, ``sin theta`` and the velocity (m/s, m/s, rad/s); what a tracking episode's steps
    read (:meth:`planar3p_gym.tasks.track.TrackTask.sample`)."""
    poses, velocities = reference_values(ref, np.arange(start, stop) * dt)
    theta = poses[:, 2].tolist()
    cs = np.array([[math.cos(v) for v in theta], [math.sin(v) for v in theta]]).reshape(2, -1)
    return np.column_stack([poses, cs.T, velocities])


def eight_curve(ref: dict[str, Any]) -> np.ndarray:
    """Poses ``(4 CHECK_POINTS, 3)`` around the whole closed figure-eight ``ref``."""
    phi = np.linspace(0.0, 2.0 * math.pi, 4 * CHECK_POINTS)
    return figure_eight(np.asarray(ref["centre"]), np.asarray(ref["amplitude"]), phi)[0]
