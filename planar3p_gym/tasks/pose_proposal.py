"""Where the task samplers propose poses: a region of ``(x, y, theta)`` that holds every pose
reachable in a working mode with its travels in a band, far smaller than the search box.

Rejection sampling keeps a uniform distribution over the acceptable poses whatever uniform
region it draws from, provided the region contains them all; this one, a stack of boxes over
bins of ``theta`` bounded with the machine's own inverse kinematics, holds 5 to 13 % of the
search box on the paper's design (the bounds, and why not a library: docs/environments.md,
"How the task modules work").

* :func:`pose_proposal`, :class:`PoseProposal`: the region of a working mode and travel band;
* :func:`propose`: uniform numbers to poses uniform over it.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numba import njit

from planar3p_gym.machine.design import Design

__all__ = ["BINS", "PoseProposal", "pose_proposal", "propose"]

#: Bins of ``theta`` over ``[-pi, pi)`` (a multiple of 4: edges on every multiple of pi / 2).
BINS = 64


class PoseProposal(NamedTuple):
    """A stack of boxes over bins of ``theta`` (:func:`pose_proposal`).

    Attributes:
        edges: ``(BINS + 1,)`` bin edges of ``theta`` (rad), ``-pi`` to ``pi``.
        boxes: ``(BINS, 4)``: ``x_lo, x_hi, y_lo, y_hi`` (m) of each bin; a bin no pose can
            occupy has a box of zero width.
        cumulative: ``(BINS + 1,)`` the volume of the boxes up to each edge (m^2 rad).
        volume: the whole region's volume (m^2 rad).
        fraction: ``volume`` over the search box's volume.
    """

    edges: np.ndarray
    boxes: np.ndarray
    cumulative: np.ndarray
    volume: float
    fraction: float


@lru_cache(maxsize=64)
def pose_proposal(design: Design, mode: tuple[int, int, int], lo: float, hi: float) -> PoseProposal:
    """The region holding every pose of the search box that is reachable in working ``mode``
    (``sigma_i`` of +-1) with every travel in ``[lo, hi]`` (m); read-only arrays, kept per
    design and mode.  ``ValueError`` if the band is empty."""
    if not lo <= hi:
        raise ValueError(f"the travel band [{lo}, {hi}] (m) is empty")
    if len(mode) != 3 or any(m not in (1, -1) for m in mode):
        raise ValueError(f"mode must be three entries of +1 or -1, got {mode!r}")
    x0, x1, y0, y1 = design.search_rectangle
    k = np.asarray(design.joint_offsets)
    legs = np.asarray(design.leg_lengths)
    origins = np.asarray(design.rail_origins)
    sigma = np.asarray(mode, dtype=np.float64)
    edges = np.linspace(-math.pi, math.pi, BINS + 1)
    edges[BINS // 4 :: BINS // 4] = (-0.5 * math.pi, 0.0, 0.5 * math.pi, math.pi)  # exact
    s_edge, c_edge = np.sin(edges), np.cos(edges)
    s_lo = np.minimum(s_edge[:-1], s_edge[1:])[:, None]  # (BINS, 1): monotonic in a bin
    s_hi = np.maximum(s_edge[:-1], s_edge[1:])[:, None]
    c_lo = np.minimum(c_edge[:-1], c_edge[1:])[:, None]
    c_hi = np.maximum(c_edge[:-1], c_edge[1:])[:, None]
    y_lo = np.maximum((-legs - k * s_hi).max(axis=1), y0)
    y_hi = np.minimum((legs - k * s_lo).min(axis=1), y1)
    # |C_iy| over the bin's y interval and theta: the extremes of w_i.
    cy_lo = y_lo[:, None] + k * s_lo
    cy_hi = y_hi[:, None] + k * s_hi
    abs_max = np.maximum(np.abs(cy_lo), np.abs(cy_hi))
    straddles = (cy_lo <= 0.0) & (cy_hi >= 0.0)
    abs_min = np.where(straddles, 0.0, np.minimum(np.abs(cy_lo), np.abs(cy_hi)))
    w_lo = np.sqrt(np.maximum(legs * legs - abs_max * abs_max, 0.0))
    w_hi = np.sqrt(np.maximum(legs * legs - abs_min * abs_min, 0.0))
    sw_lo = np.where(sigma > 0, w_lo, -w_hi)
    sw_hi = np.where(sigma > 0, w_hi, -w_lo)
    x_lo = np.maximum((origins + lo + sw_lo - k * c_hi).max(axis=1), x0)
    x_hi = np.minimum((origins + hi + sw_hi - k * c_lo).min(axis=1), x1)
    empty = (x_hi <= x_lo) | (y_hi <= y_lo)
    boxes = np.column_stack([x_lo, x_hi, y_lo, y_hi])
    boxes[empty] = np.column_stack([x_lo, x_lo, y_lo, y_lo])[empty]
    areas = (boxes[:, 1] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 2])
    cumulative = np.concatenate([[0.0], np.cumsum(areas * np.diff(edges))])
    volume = float(cumulative[-1])
    for arr in (edges, boxes, cumulative):
        arr.setflags(write=False)
    return PoseProposal(
        edges, boxes, cumulative, volume, volume / ((x1 - x0) * (y1 - y0) * 2.0 * math.pi)
    )


def propose(proposal: PoseProposal, u: np.ndarray) -> np.ndarray:
    """Poses ``(N, 3)`` uniform over the proposal's region from uniform numbers ``u`` ``(N, 3)``
    in ``[0, 1)``: ``u[:, 2]`` picks ``theta``, ``u[:, 0]`` and ``u[:, 1]`` place ``x`` and ``y``
    in its bin's box."""
    u = np.ascontiguousarray(u, dtype=np.float64)
    if u.ndim != 2 or u.shape[1] != 3:
        raise ValueError(f"u must have shape (N, 3), got shape {u.shape}")
    edges, boxes, cumulative, volume, _ = proposal
    return _propose(edges, boxes, cumulative, volume, u)


@njit(cache=True)
def _propose(
    edges: np.ndarray, boxes: np.ndarray, cumulative: np.ndarray, volume: float, u: np.ndarray
) -> np.ndarray:
    """:func:`propose`'s loop, compiled (a refill proposes a few hundred poses)."""
    out = np.empty((u.shape[0], 3))
    last = edges.shape[0] - 2
    for j in range(u.shape[0]):
        v = u[j, 2] * volume
        b = min(np.searchsorted(cumulative, v, side="right") - 1, last)
        width = boxes[b, 1] - boxes[b, 0]
        height = boxes[b, 3] - boxes[b, 2]
        out[j, 0] = boxes[b, 0] + width * u[j, 0]
        out[j, 1] = boxes[b, 2] + height * u[j, 1]
        area = width * height  # (0 only where u * volume rounded up to volume, in an empty
        # last bin: a pose on its box, which the samplers' checks reject)
        step = (v - cumulative[b]) / area if area > 0.0 else 0.0
        out[j, 2] = min(edges[b] + step, edges[b + 1])
    return out
