"""Which reach pairs can be reached at their speed bound: the straight slider line and the
two-segment slider paths through a grid of waypoints, certified (the logic of
``scripts/detours.py``: why the ``hard`` suite's time target is out of reach).

The speed bound of an episode, ``max_i |rho_i(target) - rho_i(start)| / max_speed``, is the
time of every slider path on which each slider moves monotonically and the one with the
largest travel at full speed: the straight line, and the two-segment paths through waypoints in
the box between the start's and the target's travels on which that slider leads both segments.
A path through a waypoint ``w`` takes at least ``(max|w - rho_s| + max|rho_t - w|) /
max_speed``, its *time ratio* over the bound (>= 1 by the triangle inequality, = 1 inside that
family).  For every pair this survey certifies
(:func:`planar3p_gym.tasks.joint_paths.certify_joint_path`: the direct-kinematics branch
followed unambiguously from the start pose, the parallel margin and holding forces kept, the
target pose reached) the straight line and the paths through the waypoints ``rho_s + f *
(rho_t - rho_s)``, ``f`` on a grid per slider, and reports the smallest time ratio of a
certified path.

It is a survey of path families, not a proof: a pair with no certified path here may have one
of more segments.  What it shows is where the bound is not reachable by the paths a fast
controller would take.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planar3p_agents.controllers.certified import DEFAULT_LIMITS
from planar3p_agents.evaluation.reach_suites import EpisodeSpec
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks.joint_paths import PathLimits, certify_joint_path, track_segment

__all__ = [
    "DEFAULT_FRACTIONS",
    "DEFAULT_POINTS",
    "PairDetours",
    "pair_detours",
    "suite_summary",
    "time_ratios",
    "waypoint_fractions",
]

FloatArray = NDArray[np.float64]

#: Fractions of each slider's travel at which the waypoints are put (per slider: a grid of
#: 7 ** 3 = 343 waypoints, in the box between the travels and a quarter of the travel beyond).
DEFAULT_FRACTIONS = (-0.25, 0.0, 0.25, 0.5, 0.75, 1.0, 1.25)
#: Points checked per segment (those of the ``certified-line`` baseline's certificate).
DEFAULT_POINTS = 32


@dataclass(frozen=True)
class PairDetours:
    """The survey of one pair.

    Attributes:
        index: the episode's index in its suite.
        straight: :func:`certify_joint_path`'s reason for the straight slider line (``"ok"``
            when certified).
        end_gap: ``pose_distance`` (m, rotation weighed by the characteristic length) between
            the pose the straight line's branch ends at and the target; NaN if the branch is
            lost on the way.
        tried: two-segment paths tried (waypoints in the stroke).
        certified: of them, certified.
        best_ratio: the smallest time ratio over the speed bound of a certified path (1.0 when
            the straight line is certified; ``inf`` when no path is).
    """

    index: int
    straight: str
    end_gap: float
    tried: int
    certified: int
    best_ratio: float


def waypoint_fractions(fractions: Sequence[float]) -> FloatArray:
    """Every combination of ``fractions`` for the three sliders, ``(len ** 3, 3)``;
    ``ValueError`` if one is not finite or none is given."""
    f = np.asarray(list(fractions), dtype=np.float64)
    if f.ndim != 1 or not f.size or not np.isfinite(f).all():
        raise ValueError(f"fractions must be finite numbers, at least one, got {fractions!r}")
    return np.array(list(itertools.product(f, f, f)))


def time_ratios(rho_start: ArrayLike, waypoints: ArrayLike, rho_target: ArrayLike) -> FloatArray:
    """Time ratio over the speed bound of the two-segment paths through ``waypoints``
    ``(n, 3)`` (m): ``(max|w - rho_start| + max|rho_target - w|) / max|rho_target -
    rho_start|``, ``(n,)``; ``ValueError`` if the start and target travels are equal."""
    rs, rt = np.asarray(rho_start, dtype=np.float64), np.asarray(rho_target, dtype=np.float64)
    w = np.asarray(waypoints, dtype=np.float64).reshape(-1, 3)
    bound = float(np.abs(rt - rs).max())
    if not bound > 0:
        raise ValueError("the start and target travels are equal: the speed bound is 0")
    return (np.abs(w - rs).max(axis=1) + np.abs(rt - w).max(axis=1)) / bound


def pair_detours(
    design: Design,
    episode: EpisodeSpec,
    fractions: Sequence[float] = DEFAULT_FRACTIONS,
    limits: PathLimits | None = None,
) -> PairDetours:
    """The survey of one reach pair (see the module docstring); ``limits`` default to the
    certified planner's with :data:`DEFAULT_POINTS` points per segment."""
    if limits is None:
        limits = replace(DEFAULT_LIMITS, points=DEFAULT_POINTS)
    if episode.target is None:
        raise ValueError(f"episode {episode.index} of {episode.suite} has no target pose")
    grid = waypoint_fractions(fractions)
    start, target = np.asarray(episode.start), np.asarray(episode.target)
    mode = np.asarray(episode.working_mode, dtype=np.float64)
    rs = kinematics.inverse(design, start, mode).rho
    rt = kinematics.inverse(design, target, mode).rho
    if not (np.isfinite(rs).all() and np.isfinite(rt).all()):
        raise ValueError(f"episode {episode.index} of {episode.suite}: a pose is not reachable")
    _, straight = certify_joint_path(design, np.stack([rs, rt]), start, target, limits)
    followed = track_segment(design, rs, rt, start, limits.points)
    end_gap = (
        math.nan
        if followed is None
        else float(kinematics.pose_distance(followed[1][-1], target, design.characteristic_length))
    )
    if straight == "ok":
        return PairDetours(episode.index, straight, end_gap, 0, 0, 1.0)
    waypoints = rs + grid * (rt - rs)
    ratios = time_ratios(rs, waypoints, rt)
    tried = certified = 0
    best = math.inf
    for w, ratio in zip(waypoints, ratios.tolist(), strict=True):
        path, reason = certify_joint_path(design, np.stack([rs, w, rt]), start, target, limits)
        if reason == "stroke":
            continue
        tried += 1
        if path is not None:
            certified += 1
            best = min(best, ratio)
    return PairDetours(episode.index, straight, end_gap, tried, certified, best)


def suite_summary(rows: Iterable[PairDetours]) -> dict[str, float | int]:
    """Counts over a suite's pairs: ``pairs``; ``straight`` (the straight line certified);
    ``other_solution`` (its branch ends at another pose of the same travels: an
    ``end_pose`` failure); ``reachable`` (some surveyed path certified); the 10th, 50th and
    90th percentiles of the best time ratio over the reachable pairs (NaN if none)."""
    rows = list(rows)
    best = np.array([r.best_ratio for r in rows if math.isfinite(r.best_ratio)])
    p10, p50, p90 = np.percentile(best, [10, 50, 90]) if best.size else (math.nan,) * 3
    return {
        "pairs": len(rows),
        "straight": sum(r.straight == "ok" for r in rows),
        "other_solution": sum(r.straight == "end_pose" for r in rows),
        "reachable": int(best.size),
        "ratio_p10": float(p10),
        "ratio_median": float(p50),
        "ratio_p90": float(p90),
    }
