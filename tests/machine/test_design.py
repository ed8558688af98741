"""Design: presets, derived quantities, validation of every field, closability."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planar3p_gym import Design
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import closing_pose


# ------------------------------------------------------------------------------ presets
def test_default_is_fig8_with_the_longest_stroke():
    d = Design()
    assert d == Design.fig8()
    assert d.leg_lengths == (0.17, 0.18, 0.19)
    assert d.spacings == (0.10, 0.10, 0.10)
    assert d.stroke == 0.30
    assert d.rail_origins == (0.0, 0.0, 0.0)
    assert Design.fig8(stroke=0.1).stroke == 0.1
    assert Design.fig8(gravity=0.0).gravity == 0.0


def test_fig7():
    d = Design.fig7()
    assert d.leg_lengths == (2.5, 2.5, 2.5)
    assert d.spacings == (0.5, 0.5, 0.5)
    assert d.stroke == 1.0


def test_derived_quantities():
    d = Design(spacings=(0.1, 0.05, 0.02), leg_lengths=(0.2, 0.18, 0.15), stroke=0.3)
    assert d.joint_offsets == pytest.approx((0.17, 0.07, 0.02))
    assert d.L_iG == d.joint_offsets
    assert d.platform_length == pytest.approx(0.17)
    assert d.characteristic_length == pytest.approx(0.17)
    assert d.with_(reference_length=0.5).characteristic_length == 0.5
    # h = min_i (L_iG + L_i), the search rectangle is [min a - h, max a + L + h] x [0, h]
    assert d.search_height == pytest.approx(min(0.37, 0.25, 0.17))
    assert d.h == d.search_height
    d2 = d.with_(rail_origins=(-0.1, 0.0, 0.2))
    h = d2.search_height
    assert d2.search_rectangle == pytest.approx((-0.1 - h, 0.2 + 0.3 + h, 0.0, h))
    assert d.shortest_leg == 0.15


def test_immutable_hashable_and_normalised():
    d = Design(leg_lengths=[0.17, 0.18, 0.19], spacings=np.array([0.1, 0.1, 0.1]), stroke=1)
    assert d.leg_lengths == (0.17, 0.18, 0.19) and isinstance(d.leg_lengths, tuple)
    assert isinstance(d.spacings[0], float) and isinstance(d.stroke, float)
    assert hash(d) == hash(Design(stroke=1.0))
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.stroke = 0.2  # type: ignore[misc]


def test_dict_round_trip_and_with():
    d = Design.fig7(rail_origins=(0.0, 0.5, 1.0), reference_length=1.5, gravity=0.0)
    data = d.to_dict()
    assert data["leg_lengths"] == [2.5, 2.5, 2.5]
    assert Design.from_dict(data) == d
    with pytest.raises(ValueError, match=r"unknown Design fields: \['legs'\]"):
        Design.from_dict({**data, "legs": 1})
    with pytest.raises(ValueError, match="stroke"):
        Design.from_dict({**data, "stroke": -1.0})
    assert d.with_(stroke=2.0).stroke == 2.0
    with pytest.raises(ValueError, match="max_speed"):
        d.with_(max_speed=0.0)


# ------------------------------------------------------------------------------ validation
TRIPLE_FIELDS = ("leg_lengths", "spacings", "rail_origins")
SCALAR_FIELDS = ("stroke", "slider_mass", "leg_mass", "platform_mass", "max_force", "max_speed")


@pytest.mark.parametrize("name", TRIPLE_FIELDS)
@pytest.mark.parametrize(
    "value",
    [
        (0.1, 0.2),
        (0.1, 0.2, 0.3, 0.4),
        (),
        0.2,
        None,
        "abc",
        "123",
        (0.1, "0.2", 0.3),
        (0.1, True, 0.3),
        (0.1, None, 0.3),
        (0.1, math.nan, 0.3),
        (0.1, math.inf, 0.3),
        (0.1, -math.inf, 0.3),
    ],
)
def test_bad_triples(name, value):
    with pytest.raises(ValueError, match=rf"Design\.{name}"):
        Design(**{name: value})


@pytest.mark.parametrize("i", [0, 1, 2])
@pytest.mark.parametrize("value", [0.0, -0.1])
def test_leg_lengths_must_be_positive(i, value):
    legs = [0.17, 0.18, 0.19]
    legs[i] = value
    with pytest.raises(ValueError, match=rf"Design.leg_lengths\[{i}\] must be > 0"):
        Design(leg_lengths=tuple(legs))


@pytest.mark.parametrize(("i", "label"), [(0, "d_12"), (1, "d_23"), (2, "d_3G")])
def test_spacings(i, label):
    sp = [0.1, 0.1, 0.1]
    sp[i] = -0.01
    with pytest.raises(ValueError, match=rf"Design.spacings\[{i}\] \({label}\)"):
        Design(spacings=tuple(sp))
    sp[i] = 0.0
    if i < 2:  # two platform joints at one place
        with pytest.raises(ValueError, match=rf"Design.spacings\[{i}\] \({label}\) must be > 0"):
            Design(spacings=tuple(sp))
    else:  # the gripper may sit on C_3
        assert Design(spacings=tuple(sp)).joint_offsets[2] == 0.0


@pytest.mark.parametrize("name", SCALAR_FIELDS)
@pytest.mark.parametrize("value", [0.0, -1.0, math.nan, math.inf, "1.0", None, True, (1.0,)])
def test_bad_positive_scalars(name, value):
    with pytest.raises(ValueError, match=rf"Design\.{name}"):
        Design(**{name: value})


@pytest.mark.parametrize("value", [-9.81, math.nan, math.inf, "9.81", None])
def test_bad_gravity(value):
    with pytest.raises(ValueError, match=r"Design\.gravity"):
        Design(gravity=value)
    assert Design(gravity=0).gravity == 0.0


@pytest.mark.parametrize("value", [0.0, -0.3, math.nan, math.inf, "0.3"])
def test_bad_reference_length(value):
    with pytest.raises(ValueError, match=r"Design\.reference_length"):
        Design(reference_length=value)
    assert Design(reference_length=None).reference_length is None


def test_numpy_scalars_are_accepted():
    d = Design(stroke=np.float32(0.25), leg_lengths=np.array([0.17, 0.18, 0.19]), max_force=40)
    assert d.stroke == pytest.approx(0.25) and type(d.stroke) is float


# ------------------------------------------------------------------------------ closability
def unchecked_design(**changes) -> Design:
    """A Design instance built without validation (to probe designs that are rejected)."""
    probe = object.__new__(Design)
    for key, value in {**Design().to_dict(), **changes}.items():
        object.__setattr__(probe, key, tuple(value) if isinstance(value, list | tuple) else value)
    return probe


def reachable_by_sampling(design: Design, n: int, seed: int = 0) -> bool:
    """Whether random poses (uniform over a box that holds every closing pose, all working
    modes) hit the workspace: a sufficient test of closability."""
    rng = np.random.default_rng(seed)
    k, L = np.array(design.joint_offsets), np.array(design.leg_lengths)
    reach = float((k + L).max())
    x0, x1 = min(design.rail_origins) - reach, max(design.rail_origins) + design.stroke + reach
    poses = np.stack(
        [rng.uniform(x0, x1, n), rng.uniform(-reach, reach, n), rng.uniform(-np.pi, np.pi, n)],
        axis=-1,
    )
    ik = kinematics.inverse(design, poses[:, None, :], kinematics.ALL_MODES)
    return bool(ik.reachable.any())


@pytest.mark.parametrize(
    "design",
    [Design.fig8(stroke=s) for s in (0.1, 0.15, 0.2, 0.25, 0.3)] + [Design.fig7()],
    ids=lambda d: f"legs{d.leg_lengths}-stroke{d.stroke}",
)
def test_the_paper_designs_close(design):
    pose, mode = closing_pose(design)
    ik = kinematics.inverse(design, pose, mode)
    assert ik.reachable
    assert reachable_by_sampling(design, 2000)


@pytest.mark.parametrize(
    ("changes", "why"),
    [
        # legs far too short for the platform: the joints cannot all be near the rails
        (dict(leg_lengths=(0.01, 0.01, 0.01), spacings=(1.0, 1.0, 1.0), stroke=0.01), "gross"),
        # rails far apart
        (dict(rail_origins=(0.0, 5.0, 10.0)), "rails"),
        # the previous check (platform lying on the rail line, each joint within L_i of its
        # stroke segment's hull) accepted this one, yet no pose closes: on the rail line a leg
        # needs |C_ix - b_i| = L_i exactly, and elsewhere the travels spread over >= 0.15 m
        (dict(spacings=(0.2, 0.2, 0.2), stroke=0.05), "old check"),
        # fig8 needs a stroke of about 0.030 m: the three travels of any pose spread that much
        (dict(stroke=0.025), "short stroke"),
    ],
)
def test_a_platform_that_cannot_close_is_rejected(changes, why):
    with pytest.raises(ValueError, match="Design cannot close"):
        Design.fig8(**changes)
    # an independent, sufficient test agrees: no sampled pose is reachable
    assert not reachable_by_sampling(unchecked_design(**changes), 20000), why


def test_closability_threshold_on_fig8():
    """Just above the least stroke the design closes and the witness pose is reachable."""
    d = Design.fig8(stroke=0.0305)
    pose, mode = closing_pose(d)
    rho, ok = kinematics.inverse(d, pose, mode)
    assert ok and (rho.max() - rho.min()) <= 0.0305
    with pytest.raises(ValueError, match=r"span at least about 0\.03"):
        Design.fig8(stroke=0.029)


@settings(max_examples=60)
@given(
    legs=st.tuples(*[st.floats(0.02, 0.4)] * 3),
    spacings=st.tuples(st.floats(0.01, 0.3), st.floats(0.01, 0.3), st.floats(0.0, 0.3)),
    stroke=st.floats(0.005, 0.5),
    origins=st.tuples(*[st.floats(-0.3, 0.3)] * 3),
)
def test_closability_decision_is_consistent(legs, spacings, stroke, origins):
    """Either the design is built and its witness pose is reachable, or it is rejected and
    random sampling finds no reachable pose either."""
    try:
        d = Design(leg_lengths=legs, spacings=spacings, stroke=stroke, rail_origins=origins)
    except ValueError as exc:
        assert "cannot close" in str(exc)
        probe = unchecked_design(
            leg_lengths=legs, spacings=spacings, stroke=stroke, rail_origins=origins
        )
        assert not reachable_by_sampling(probe, 3000)
    else:
        pose, mode = closing_pose(d)
        assert kinematics.inverse(d, pose, mode).reachable


def test_travel_band_keeps_the_margin_free_and_refuses_bad_margins():
    d = Design.fig8()
    assert d.travel_band(0.0) == (0.0, d.stroke)
    lo, hi = d.travel_band(0.1)
    assert lo == pytest.approx(0.1 * d.stroke) and hi == pytest.approx(0.9 * d.stroke)
    for bad in (-0.1, 0.5, 0.7, math.nan, "0.1", True):
        with pytest.raises(ValueError, match="travel margin"):
            d.travel_band(bad)
