"""The straight line in slider space: which branch of the direct kinematics it follows, and the
detour pairs that ``TaskConfig.detour_fraction`` draws from it."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planar3p_gym import Design
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.slider_line import END_TOLERANCE, slider_line_end, slider_line_reaches
from planar3p_gym.tasks import sampling as task

DESIGN = Design.fig8()
MODE = (1, 1, -1)
#: Episodes 0 and 43 of the benchmark's fixed ``standard`` suite (seed 0): both have a
#: clear straight path in pose space; the slider line solves the first and carries the second
#: through the rail line to the target's mirror image.
SOLVED = (
    [-0.014130103980426634, 0.08874557796781271, 0.21442711562825648],
    [0.061531177825434324, 0.18644608444136282, -0.23570030702573236],
)
MIRRORED = (
    [0.009480837818433452, 0.048729024261743865, -0.4924771963937628],
    [0.03420279951514599, 0.15530796295690605, -0.29177022512262585],
)
#: DK poses are exact to about 1e-12 m away from parallel singularities.
POSE_TOL = 1e-9


def mirror(pose: np.ndarray) -> np.ndarray:
    return np.asarray(pose) * np.array([1.0, -1.0, -1.0])


def test_a_solved_pair_ends_at_the_target():
    start, target = map(np.array, SOLVED)
    end, followed = slider_line_end(DESIGN, start, target, MODE)
    assert followed.tolist() == [True]
    np.testing.assert_allclose(end[0], target, atol=POSE_TOL)
    assert slider_line_reaches(DESIGN, start, target, MODE).tolist() == [True]


def test_a_start_near_the_rail_line_ends_at_the_mirror_image():
    """The branch passes through the rail line: same travels as the target, other side."""
    start, target = map(np.array, MIRRORED)
    end, followed = slider_line_end(DESIGN, start, target[None, :], MODE)
    assert followed.tolist() == [True]
    np.testing.assert_allclose(end[0], mirror(target), atol=POSE_TOL)
    rho_end = kinematics.inverse(DESIGN, end[0], MODE).rho
    np.testing.assert_allclose(rho_end, kinematics.inverse(DESIGN, target, MODE).rho, atol=1e-9)
    assert slider_line_reaches(DESIGN, start, target, MODE).tolist() == [False]


def test_batches_match_single_pairs():
    start = np.array(SOLVED[0])
    targets = np.array([SOLVED[1], MIRRORED[1]])
    ends, followed = slider_line_end(DESIGN, start, targets, MODE)
    for k in range(2):
        one, ok = slider_line_end(DESIGN, start, targets[k], MODE)
        np.testing.assert_array_equal(one[0], ends[k])
        assert ok[0] == followed[k]


def _pairs(seed: int, n: int) -> list[tuple[np.ndarray, np.ndarray]]:
    cfg = task.TaskConfig()
    rng, sampler = np.random.default_rng(seed), task.PoseSampler(DESIGN, MODE, cfg)
    return [task.sample_pair(DESIGN, MODE, rng, cfg, sampler=sampler) for _ in range(n)]


@settings(max_examples=30)  # each example samples and follows three pairs
@given(st.integers(0, 2**32 - 1))
def test_mirrored_problems_have_mirrored_lines(seed):
    """Mirroring start and target about the rail line keeps every travel, so the line follows
    the mirror image of the same branch and ends at the mirror image of the same end."""
    for start, target in _pairs(seed, 3):
        end, followed = slider_line_end(DESIGN, start, target, MODE)
        m_end, m_followed = slider_line_end(DESIGN, mirror(start), mirror(target), MODE)
        assert m_followed[0] == followed[0]
        np.testing.assert_allclose(m_end[0], mirror(end[0]), atol=POSE_TOL)


@settings(max_examples=30)  # each example samples and follows three pairs
@given(st.integers(0, 2**32 - 1))
def test_a_solved_line_solves_the_way_back(seed):
    """The way back runs through the same travels on the same branch."""
    for start, target in _pairs(seed, 3):
        if slider_line_reaches(DESIGN, start, target, MODE)[0]:
            assert slider_line_reaches(DESIGN, target, start, MODE)[0]


def test_unreachable_ends_raise():
    with pytest.raises(ValueError, match="reachable"):
        slider_line_end(DESIGN, np.array([5.0, 5.0, 0.0]), np.array(SOLVED[1]), MODE)


# ------------------------------------------------------------------- detour training pairs
def test_detour_pairs_are_ordinary_pairs_the_slider_line_does_not_solve():
    """With detour_fraction = 1 every drawn pair meets the rules of an ordinary pair (acceptable
    ends, same assembly mode, min_distance apart, clear straight path in pose space) and the
    slider line misses its target."""
    cfg = task.TaskConfig(detour_fraction=1.0)
    rng, sampler = np.random.default_rng(7), task.PoseSampler(DESIGN, MODE, cfg)
    for _ in range(4):
        s, t = task.sample_pair(DESIGN, MODE, rng, cfg, sampler=sampler)
        ok, dets = task._acceptable(DESIGN, np.array([s, t]), np.asarray(MODE, float), cfg)
        assert ok.all() and dets[0] == dets[1]
        assert task.pose_distance(s, t, DESIGN.characteristic_length) >= cfg.min_distance
        assert task.path_is_clear(DESIGN, s, t[None, :], MODE, dets[0], cfg)[0]
        end, _ = slider_line_end(DESIGN, s, t, MODE)
        assert task.pose_distance(end[0], t, DESIGN.characteristic_length) > END_TOLERANCE


def test_detour_fraction_mixes_and_replays():
    """A fraction of 0.5 gives both kinds; the same seed the same pairs; 0 (the default)
    leaves the plain task's draws untouched."""
    cfg = task.TaskConfig(detour_fraction=0.5)

    def draws(c: task.TaskConfig, seed: int, n: int) -> np.ndarray:
        rng, sampler = np.random.default_rng(seed), task.PoseSampler(DESIGN, MODE, c)
        return np.array([task.sample_pair(DESIGN, MODE, rng, c, sampler=sampler) for _ in range(n)])

    pairs = draws(cfg, 3, 12)
    kinds = {bool(slider_line_reaches(DESIGN, s, t, MODE)[0]) for s, t in pairs}
    assert kinds == {True, False}
    np.testing.assert_array_equal(pairs, draws(cfg, 3, 12))
    np.testing.assert_array_equal(
        draws(task.TaskConfig(), 3, 3), draws(task.TaskConfig(detour_fraction=0.0), 3, 3)
    )


@pytest.mark.parametrize("value", [1.5, -0.1, float("nan"), True])
def test_bad_detour_fraction_raises(value):
    with pytest.raises(ValueError, match="detour_fraction"):
        task.TaskConfig(detour_fraction=value)


def _follow_reference(design, start, targets, mode, steps):
    """The branch following as it was written in NumPy (the reference of the compiled one)."""
    m = np.asarray(mode, dtype=np.float64)
    r0 = kinematics.inverse(design, start, m).rho
    r1 = kinematics.inverse(design, targets, m).rho
    t = np.linspace(0.0, 1.0, steps + 1)[1:, None]
    solutions = kinematics.forward_batch(design, r0 + t[None] * (r1 - r0)[:, None, :])
    n = len(targets)
    rows = np.arange(n)
    pose = np.broadcast_to(start, (n, 3)).copy()
    previous = pose.copy()
    followed = np.ones(n, dtype=bool)
    for k in range(steps):
        predicted = 2.0 * pose - previous
        candidates = solutions.poses[:, k]
        distance = kinematics.pose_distance(
            predicted[:, None, :], candidates, design.characteristic_length
        )
        distance = np.where(solutions.valid[:, k], distance, np.inf)
        nearest = np.argmin(distance, axis=1)
        followed &= np.isfinite(distance[rows, nearest])
        previous, pose = pose, np.where(followed[:, None], candidates[rows, nearest], pose)
    return pose, followed


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), steps=st.sampled_from([8, 64]))
def test_the_compiled_branch_following_is_the_numpy_one_to_the_bit(seed, steps):
    """The compiled loop decides and ends exactly as the NumPy loop it replaced, on pairs of
    acceptable poses (targets of either assembly mode: lost branches included)."""
    cfg = task.TaskConfig()
    sampler = task.PoseSampler(DESIGN, MODE, cfg)
    rng = np.random.default_rng(seed)
    start, _ = sampler.draw(rng)
    targets = np.array([sampler.draw(rng)[0] for _ in range(12)])
    end, followed = slider_line_end(DESIGN, start, targets, MODE, steps)
    ref_end, ref_followed = _follow_reference(DESIGN, start, targets, MODE, steps)
    np.testing.assert_array_equal(followed, ref_followed)
    np.testing.assert_array_equal(end, ref_end)
