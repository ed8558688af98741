"""Helpers of planar3p_gym.tasks.base."""

from __future__ import annotations

import copy

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from planar3p_gym.tasks.base import copy_spec

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=5),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=4), inner, max_size=4)
    ),
    max_leaves=30,
)


def containers(value) -> list[int]:
    """The ids of every list and dict inside ``value``."""
    if isinstance(value, dict):
        return [id(value), *(i for v in value.values() for i in containers(v))]
    if isinstance(value, list):
        return [id(value), *(i for v in value for i in containers(v))]
    return []


@settings(max_examples=200, deadline=None)
@given(json_values)
def test_copy_spec_is_a_deep_copy_of_plain_data(value):
    copied = copy_spec(value)
    assert copied == value == copy.deepcopy(value)
    assert not set(containers(copied)) & set(containers(value))  # nothing shared


def test_copy_spec_deep_copies_anything_else():
    spec = {"start": np.array([0.1, 0.2, 0.3]), "modes": ((1, -1), [2])}
    copied = copy_spec(spec)
    copied["start"][0] = 9.0
    copied["modes"][1].append(3)
    assert spec["start"][0] == 0.1 and spec["modes"] == ((1, -1), [2])
