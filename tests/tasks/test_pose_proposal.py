"""The region the samplers propose poses from (:mod:`planar3p_gym.tasks.pose_proposal`): it
holds every pose of the search box reachable in the working mode within the travel band, and
:func:`propose` is uniform over it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.tasks import sampling as task
from planar3p_gym.tasks.pose_proposal import BINS, pose_proposal, propose

MODES = [tuple(int(m) for m in row) for row in kinematics.ALL_MODES.tolist()]


def box_poses(design: Design, n: int, rng: np.random.Generator) -> np.ndarray:
    """Uniform poses of the search box: the rectangle's ``x``, ``0 <= y <= h``, any angle."""
    x0, x1, y0, y1 = design.search_rectangle
    return np.column_stack(
        [rng.uniform(x0, x1, n), rng.uniform(y0, y1, n), rng.uniform(-math.pi, math.pi, n)]
    )


def inside(proposal, poses: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """Whether each pose lies in the box of its angle's bin, faces widened by ``tol`` (m)
    (an angle on an edge belongs to both bins)."""
    edges, boxes = proposal.edges, proposal.boxes
    b = np.clip(np.searchsorted(edges, poses[:, 2], side="right") - 1, 0, BINS - 1)
    ok = np.zeros(len(poses), dtype=bool)
    for bins in (b, np.clip(b - 1, 0, BINS - 1)):  # an angle on an edge: either bin
        box = boxes[bins]
        ok |= (
            (poses[:, 0] >= box[:, 0] - tol)
            & (poses[:, 0] <= box[:, 1] + tol)
            & (poses[:, 1] >= box[:, 2] - tol)
            & (poses[:, 1] <= box[:, 3] + tol)
        )
    return ok


@settings(max_examples=40, deadline=None)
@given(
    legs=st.tuples(*[st.floats(0.12, 0.3)] * 3),
    spacings=st.tuples(st.floats(0.05, 0.15), st.floats(0.05, 0.15), st.floats(0.0, 0.15)),
    origins=st.tuples(*[st.floats(-0.05, 0.05)] * 3),
    mode=st.sampled_from(MODES),
    margin=st.floats(0.0, 0.2),
    seed=st.integers(0, 2**32 - 1),
)
def test_the_region_holds_every_reachable_pose(legs, spacings, origins, mode, margin, seed):
    """No pose of the search box that closes in ``mode`` with its travels in the band lies
    outside the region (the bounds are exact interval arithmetic, rounding aside: poses on a
    box's face, within 1e-12 m, count as inside)."""
    try:
        design = Design(leg_lengths=legs, spacings=spacings, rail_origins=origins)
    except ValueError:  # a design that cannot close: nothing to hold
        return
    lo, hi = design.travel_band(margin)
    proposal = pose_proposal(design, mode, lo, hi)
    poses = box_poses(design, 20000, np.random.default_rng(seed))
    rho = kinematics.inverse(design, poses, mode).rho
    reachable = ((rho >= lo) & (rho <= hi)).all(axis=-1)
    held = inside(proposal, poses, tol=1e-12)
    assert held[reachable].all()
    assert 0.0 < proposal.fraction <= 1.0 or not reachable.any()


def test_proposals_are_uniform_over_the_region():
    """Each pose lies in its bin's box, and the share of poses per bin is the bin's share of
    the volume: within 5 standard deviations of the binomial count (100,000 poses, fixed
    seed)."""
    design = Design.fig8()
    proposal = pose_proposal(design, (1, 1, -1), *design.travel_band(0.03))
    n = 100_000
    poses = propose(proposal, np.random.default_rng(0).random((n, 3)))
    assert inside(proposal, poses).all()
    counts = np.histogram(poses[:, 2], bins=proposal.edges)[0]
    share = np.diff(proposal.cumulative) / proposal.volume
    assert (counts[share == 0.0] == 0).all()  # a bin no pose can occupy is never drawn
    sigma = np.sqrt(n * share * (1.0 - share))
    assert (np.abs(counts - n * share) <= 5.0 * sigma + 1e-9).all()
    # within a bin, x and y are uniform over its box: their means sit at its centre
    b = np.searchsorted(proposal.edges, poses[:, 2], side="right") - 1
    big = int(np.argmax(counts))
    box = proposal.boxes[big]
    mine = poses[b == big]
    for axis, (a0, a1) in ((0, box[:2]), (1, box[2:])):
        sd = (a1 - a0) / math.sqrt(12.0 * len(mine))
        assert abs(mine[:, axis].mean() - 0.5 * (a0 + a1)) <= 5.0 * sd


def test_the_region_is_a_small_part_of_the_box_and_batches_keep_their_yield():
    """For the paper's design the region is 5-13 % of the search box, so a batch of
    :func:`sample_poses` draws that share of 4096 poses for the same expected yield."""
    design = Design.fig8()
    cfg = task.TaskConfig()
    for mode in MODES:
        proposal = pose_proposal(design, mode, *design.travel_band(cfg.travel_margin))
        assert 0.04 <= proposal.fraction <= 0.14, mode
        assert proposal.boxes.flags.writeable is False


def test_an_empty_band_is_refused():
    with pytest.raises(ValueError, match="travel band"):
        pose_proposal(Design.fig8(), (1, 1, 1), 0.2, 0.1)


def test_bad_modes_and_numbers_are_refused():
    design = Design.fig8()
    with pytest.raises(ValueError, match="mode"):
        pose_proposal(design, (1, 0, 1), 0.0, 0.1)
    proposal = pose_proposal(design, (1, 1, -1), 0.0, 0.1)
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        propose(proposal, np.zeros((4, 2)))
