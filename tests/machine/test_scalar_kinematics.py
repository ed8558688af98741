"""The scalar (per-configuration, plain-float) measures agree with the vectorised reference
kinematics, on random configurations and near and at parallel singularities.

Tolerance on the parallel margin ``m``: ``1e-7 + 1e-6 m``.  The margin is only compared with
thresholds of order 1e-2 (sampling margins, the reward barrier's references; the barrier is
capped below ``ref / 101 ~ 3e-4``) and fed to the agent in float32; a 1e-6 relative error
changes the barrier ``ref/m - 1`` by less than 1e-6 of itself, and margins below 1e-7 are
indistinguishable to every consumer.  (Measured: up to ~2e-7 relative on closing
configurations when ``A_bar`` has two small singular values, and an absolute floor of
~1.2e-8 where ``A_bar`` is rank-deficient by two, e.g. the platform along the rail line at
``theta = pi``: the eigenvalue route resolves the smallest singular value only to
~sqrt(eps).)  The serial margin and leg angles are elementary formulas and must agree to a few
ulps; the sign of ``det A`` must agree wherever the margin is above rounding level (1e-13).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from planar3p_gym import Design
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.scalar_kinematics import ScalarKinematics

DESIGNS = {
    "fig8": Design.fig8(),
    "fig7": Design.fig7(),
    "offset_rails": Design.fig8(rail_origins=(0.0, 0.05, -0.1), reference_length=0.2),
    "gripper_at_C3": Design.fig8(spacings=(0.1, 0.05, 0.0)),
}


def assert_agree(design: Design, pose, rho) -> None:
    p = np.asarray(pose, dtype=float)
    r = np.asarray(rho, dtype=float)
    m = ScalarKinematics(design).measures(tuple(p.tolist()), tuple(r.tolist()))
    pm = float(kinematics.parallel_margin(design, p, r))
    sm = float(kinematics.serial_margin(design, p, r))
    u = kinematics.leg_vectors(design, p, r)
    assert 0.0 <= m.parallel_margin <= 1.0 + 1e-12
    assert abs(m.parallel_margin - pm) <= 1e-7 + 1e-6 * pm, (m.parallel_margin, pm)
    assert m.serial_margin == pytest.approx(sm, abs=1e-14)
    np.testing.assert_allclose(m.leg_angles, np.arctan2(u[:, 1], u[:, 0]), atol=1e-14)
    if pm > 1e-13:
        assert m.det_sign == int(kinematics.assembly_mode(design, p, r))
    assert m.det_sign in (-1, 0, 1)


@st.composite
def closing_configurations(draw):
    """A design, a pose in its search rectangle (either side of the rails, any angle), a
    working mode, and the travels that close the legs (stroke ignored)."""
    name = draw(st.sampled_from(sorted(DESIGNS)))
    d = DESIGNS[name]
    x0, x1, _, h = d.search_rectangle
    unit = st.floats(0.0, 1.0, allow_nan=False)
    pose = np.array(
        [
            x0 + (x1 - x0) * draw(unit),
            h * (2.0 * draw(unit) - 1.0),
            math.pi * (2.0 * draw(unit) - 1.0),
        ]
    )
    mode = draw(st.sampled_from(kinematics.ALL_MODES.tolist()))
    rho = kinematics.inverse(d, pose, mode).rho
    return d, pose, rho


@given(closing_configurations())
def test_agreement_on_random_closing_configurations(cfg):
    d, pose, rho = cfg
    if np.isfinite(rho).all():
        assert_agree(d, pose, rho)


@given(
    st.sampled_from(sorted(DESIGNS)),
    st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=6, max_size=6),
)
def test_agreement_on_arbitrary_configurations(name, u):
    """Pose and travels unrelated (legs not closing): the measures are still the same
    matrix functions."""
    d = DESIGNS[name]
    x0, x1, _, h = d.search_rectangle
    pose = (0.5 * (x0 + x1) + 0.5 * (x1 - x0) * u[0], h * u[1], math.pi * u[2])
    rho = tuple(d.stroke * (0.5 + v) for v in u[3:])
    # Exclude a leg of zero length (B_i = C_i, impossible for a closing configuration), where
    # the vectorised serial margin is 0/0 = NaN and the scalar one 0.
    assume(np.linalg.norm(kinematics.leg_vectors(d, pose, rho), axis=-1).min() > 1e-9)
    assert_agree(d, pose, rho)


def _parallel_legs_configuration(design: Design, alpha: float, x: float = 0.2):
    """A configuration with all three legs parallel (angle ``alpha``): exactly singular.

    ``C_iy = L_i sin alpha`` for all legs fixes ``y`` and ``sin theta`` from legs 1 and 2; on
    the default design leg 3 then agrees too (its ``L_i`` and ``L_iG`` are in arithmetic
    progression)."""
    k, legs = np.array(design.joint_offsets), np.array(design.leg_lengths)
    sa = math.sin(alpha)
    s = (legs[0] - legs[1]) * sa / (k[0] - k[1])
    y = legs[0] * sa - k[0] * s
    pose = np.array([x, y, math.asin(s)])
    c = pose[:2, None] + k * np.array([[math.cos(pose[2])], [math.sin(pose[2])]])
    rho = c[0] - np.array(design.rail_origins) - legs * math.cos(alpha)
    return pose, rho


@pytest.mark.parametrize("alpha", [0.0, *np.linspace(0.2, 2.9, 7).tolist(), math.pi])
@pytest.mark.parametrize("eps", [0.0, 1e-12, 1e-9, 1e-6, 1e-3])
def test_agreement_near_and_at_parallel_legs(alpha, eps):
    d = DESIGNS["fig8"]
    pose, rho = _parallel_legs_configuration(d, alpha)
    assert np.abs(kinematics.loop_residual(d, pose, rho)).max() < 1e-15
    pose = pose + np.array([0.0, 0.0, eps])
    assert_agree(d, pose, rho)
    m = ScalarKinematics(d).measures(tuple(pose), tuple(rho))
    if eps == 0.0:
        assert m.parallel_margin < 1e-7


@pytest.mark.parametrize("theta0", [0.0, math.pi])
def test_agreement_near_the_rail_line(theta0):
    """Platform nearly along the rail line (``y ~ 0``, ``theta ~ 0`` or ``pi``), travels in
    the stroke: ``A_bar`` is close to rank one, two singular values are small.  Deterministic
    sample of such reachable configurations of the default design."""
    d = DESIGNS["fig8"]
    rng = np.random.default_rng(1)
    n = 20000
    x0, x1, _, _ = d.search_rectangle
    poses = np.column_stack(
        [
            rng.uniform(x0, x1, n),
            10.0 ** rng.uniform(-6, -2, n) * rng.choice([-1.0, 1.0], n),
            theta0 + 10.0 ** rng.uniform(-6, -2, n) * rng.choice([-1.0, 1.0], n),
        ]
    )
    modes = kinematics.ALL_MODES[rng.integers(0, 8, n)]
    rho, reachable = kinematics.inverse(d, poses, modes)
    poses, rho = poses[reachable], rho[reachable]
    assert len(poses) > 100
    failures = []
    for p, r in zip(poses, rho, strict=True):
        try:
            assert_agree(d, p, r)
        except AssertionError as exc:
            failures.append(f"pose {p.tolist()} rho {r.tolist()}: {exc}")
    assert not failures, f"{len(failures)} of {len(poses)} disagree, e.g. " + failures[0]


def _bisect_singular(design, mode, a, b, steps):
    rho = lambda p: kinematics.inverse(design, p, mode).rho  # noqa: E731
    sa = kinematics.assembly_mode(design, a, rho(a))
    for _ in range(steps):
        m = 0.5 * (a + b)
        if kinematics.assembly_mode(design, m, rho(m)) == sa:
            a = m
        else:
            b = m
    return a, b


def test_agreement_across_det_a_zero_on_motion_paths():
    """Bisect det A = 0 between sampled poses of opposite assembly modes of one working mode:
    agreement holds on both sides at every distance from the singularity."""
    d = DESIGNS["fig8"]
    mode = (1, 1, 1)
    rng = np.random.default_rng(0)
    x0, x1, _, h = d.search_rectangle
    poses = np.column_stack(
        [rng.uniform(x0, x1, 4000), rng.uniform(0, h, 4000), rng.uniform(-np.pi, np.pi, 4000)]
    )
    rho, ok = kinematics.inverse(d, poses, mode)
    poses, rho = poses[ok], rho[ok]
    det = kinematics.assembly_mode(d, poses, rho)
    pos, neg = poses[det > 0][:6], poses[det < 0][:6]
    checked = 0
    for a, b in zip(pos, neg, strict=False):
        path = a + np.linspace(0, 1, 64)[:, None] * (b - a)
        r = kinematics.inverse(d, path, mode).rho
        if not np.isfinite(r).all():
            continue
        s = kinematics.assembly_mode(d, path, r)
        j = int(np.flatnonzero(np.diff(s))[0])
        for steps in (5, 15, 30, 60):
            lo, hi = _bisect_singular(d, mode, path[j].copy(), path[j + 1].copy(), steps)
            for p in (lo, hi):
                assert_agree(d, p, kinematics.inverse(d, p, mode).rho)
        lo, hi = _bisect_singular(d, mode, path[j].copy(), path[j + 1].copy(), 60)
        assert kinematics.parallel_margin(d, lo, kinematics.inverse(d, lo, mode).rho) < 1e-8
        checked += 1
    assert checked >= 3


def test_degenerate_inputs():
    d = DESIGNS["fig8"]
    sk = ScalarKinematics(d)
    # A leg exactly vertical: serial margin 0.
    pose = (0.2, 0.1, 0.0)
    k = d.joint_offsets
    rho = (0.2 + k[0], 0.1, 0.1)
    m = sk.measures(pose, rho)
    assert m.serial_margin == 0.0
    assert_agree(d, pose, rho)
    # theta = 0 and pi (sin theta = 0) and a leg of zero length.
    for th in (0.0, math.pi, -math.pi):
        assert_agree(d, (0.1, 0.12, th), (0.05, 0.15, 0.25))
    m = sk.measures((0.0, 0.0, 0.0), (k[0], 0.1, 0.2))
    assert all(map(math.isfinite, (m.parallel_margin, m.serial_margin)))
