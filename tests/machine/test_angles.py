"""The one angle wrap: its range, that it keeps the angle modulo a turn, and that its scalar,
array and torch forms agree."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from planar3p_gym.machine.angles import wrap_angle

ANGLES = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False)


@given(ANGLES)
def test_wrap_is_in_the_range_of_atan2_and_keeps_the_angle(angle: float) -> None:
    w = wrap_angle(angle)
    assert -math.pi < w <= math.pi
    # the same direction: the remainder's rounding is at most one ulp of the shifted angle
    turns = (angle - w) / (2.0 * math.pi)
    assert abs(turns - round(turns)) * 2.0 * math.pi <= 4.0 * math.ulp(abs(angle) + math.pi)


def test_the_ends_of_the_range() -> None:
    assert wrap_angle(math.pi) == math.pi
    assert wrap_angle(-math.pi) == math.pi
    assert wrap_angle(3.0 * math.pi) == math.pi
    assert wrap_angle(0.0) == 0.0
    # atan2's range is the same half-open interval
    assert wrap_angle(math.atan2(0.0, -1.0)) == math.atan2(0.0, -1.0)


@given(st.lists(ANGLES, min_size=1, max_size=20))
def test_an_array_is_wrapped_as_its_entries_are(angles: list[float]) -> None:
    a = np.array(angles)
    expected = [wrap_angle(x) for x in angles]
    assert wrap_angle(a).tolist() == expected
    # a strided view (as the pose arrays' angle column) too
    poses = np.zeros((len(angles), 3))
    poses[:, 2] = a
    assert wrap_angle(poses[:, 2]).tolist() == expected


@given(st.lists(st.floats(min_value=-20.0, max_value=20.0, allow_nan=False), min_size=1))
def test_the_torch_twin_agrees(angles: list[float]) -> None:
    th = pytest.importorskip("torch")
    from planar3p_agents.policies.goal_features import wrap_angle_torch

    a = np.array(angles)
    got = wrap_angle_torch(th.tensor(a, dtype=th.float64)).numpy()
    assert got.tolist() == wrap_angle(a).tolist()
    # in float32 (the policy's dtype) within float32 rounding of the shifted angle, away from
    # the ends of the range where either neighbour is right
    inside = np.abs(np.abs(wrap_angle(a)) - math.pi) > 1e-4
    got32 = wrap_angle_torch(th.tensor(a, dtype=th.float32)).numpy().astype(np.float64)
    ref32 = wrap_angle(a.astype(np.float32).astype(np.float64))
    assert np.all(np.abs(got32 - ref32)[inside] <= 4 * np.spacing(np.float32(20.0 + math.pi)))
