"""Exact kinematics: IK, DK (all assembly modes), Jacobians, singularity measures, bad input.

Tolerances and where they come from
-----------------------------------
* Loop residual of every DK solution: ``< 1e-10 m`` (the solver accepts ``1e-11 x`` the longest
  leg, about ``2e-12 m`` on the default design; Newton polish leaves ~1e-16 m).
* Pose recovery (IK then DK).  Near a parallel singularity the DK is ill-conditioned: a pose
  that closes the loops to ``rho`` (~1e-16 m after polishing) lies ``~ rho / sigma_min(A)`` from
  the true one, and ``sigma_min`` is the parallel margin ``pm`` times ``sigma_max`` (order of the
  legs).  We require the original pose to be returned within

      ``tol(pm) = max(1e-9 m, min(1e-12 m / pm, 3e-5 x longest leg))``

  i.e. exact recovery (1e-9 m, orientation times ``L_1G``) wherever ``pm >= 1e-3``; the
  first-order bound with a factor ~1e3 of headroom down to ``pm ~ 1e-7``; and, at and next to a
  singularity (a double root, where the loop residual grows only quadratically or, on the
  default design's family of parallel-leg singularities, even more slowly along the free
  motion), 3e-5 of the leg length.  Measured worst cases are 30x (first-order regime) and 2x
  (at the singularity) inside these bounds.
* The ``fig7`` preset has three equal legs: with the platform horizontal and the legs parallel
  the mechanism is a parallelogram with a self-motion (infinitely many poses for one ``rho``),
  and nearby configurations have arbitrarily flat residual valleys.  Those architecture
  singularities are excluded from the exactness tests (only "no crash, no NaN, tiny
  residual" is asked there).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from planar3p_gym import Design
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.kinematics import ALL_MODES

FIG8 = Design.fig8()
# legs not in arithmetic progression with the joint offsets, offset rails, gripper near C3
GENERIC = Design(
    leg_lengths=(0.2, 0.15, 0.22),
    spacings=(0.07, 0.12, 0.05),
    stroke=0.4,
    rail_origins=(0.0, 0.03, -0.05),
)
FIG7 = Design.fig7()
DESIGNS = {"fig8": FIG8, "fig8_short": Design.fig8(stroke=0.1), "generic": GENERIC}
DESIGN_NAMES = tuple(sorted(DESIGNS))


# ------------------------------------------------------------------------------ helpers
def wrap(a):
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


def pose_error(design: Design, poses, target) -> np.ndarray:
    """``max(|dx|, |dy|, L_1G |dtheta|)`` (m) between poses ``(..., 3)`` and ``target``."""
    poses, target = np.asarray(poses), np.asarray(target)
    d = np.abs(poses[..., :2] - target[..., :2]).max(axis=-1)
    return np.maximum(
        d, design.characteristic_length * np.abs(wrap(poses[..., 2] - target[..., 2]))
    )


def recovery_error(design: Design, sol: kinematics.ForwardSolutions, target) -> np.ndarray:
    """Distance from ``target (..., 3)`` to the nearest returned pose (inf if none)."""
    err = pose_error(design, sol.poses, np.asarray(target)[..., None, :])
    return np.where(sol.valid, err, np.inf).min(axis=-1)


def recovery_tol(design: Design, pm) -> np.ndarray:
    with np.errstate(divide="ignore"):
        first_order = 1e-12 / np.asarray(pm)
    return np.maximum(1e-9, np.minimum(first_order, 3e-5 * max(design.leg_lengths)))


def random_poses(design: Design, n: int, rng: np.random.Generator) -> np.ndarray:
    """Poses in the search rectangle and its mirror, any orientation."""
    x0, x1, _, h = design.search_rectangle
    return np.stack(
        [rng.uniform(x0, x1, n), rng.uniform(-h, h, n), rng.uniform(-np.pi, np.pi, n)], axis=-1
    )


def check_solutions(design: Design, rho, sol: kinematics.ForwardSolutions) -> None:
    """Structural checks every DK answer must pass."""
    rho = np.asarray(rho)
    valid = sol.valid
    assert (sol.count <= 4).all()
    assert (sol.count == valid.sum(axis=-1)).all()
    # valid first, never NaN; invalid slots are NaN
    assert not np.isnan(sol.poses[valid]).any()
    assert np.isnan(sol.poses[~valid]).all()
    assert (valid[..., :-1] >= valid[..., 1:]).all()
    # every returned pose closes the loops
    res = np.abs(kinematics.loop_residual(design, np.nan_to_num(sol.poses), rho[..., None, :]))
    assert (res.max(axis=-1)[valid] < 1e-10).all()
    assert (sol.residual[valid] < 1e-10).all()
    # theta in (-pi, pi]; labels consistent
    th = sol.poses[..., 2][valid]
    assert ((th > -np.pi) & (th <= np.pi)).all()
    assert np.isin(sol.assembly[valid], (-1, 0, 1)).all()
    assert (sol.side[~valid] == 0).all() and (sol.assembly[~valid] == 0).all()
    y = sol.poses[..., 1]
    assert (sol.side[valid & (y > 1e-6)] == 1).all()
    assert (sol.side[valid & (y < -1e-6)] == -1).all()


def mirror(p):
    p = np.asarray(p, dtype=float)
    return np.stack([p[..., 0], -p[..., 1], -p[..., 2]], axis=-1)


# ------------------------------------------------------------------------------ brute force DK
def brute_force_dk(design: Design, rho, n_theta: int = 4001) -> np.ndarray:
    """Independent reference: scan theta, intersect the circles of two legs (every pair, both
    branches), bisect sign changes of the third leg's residual, polish with least-squares
    Newton, keep what closes the loops."""
    k = np.array(design.joint_offsets)
    L = np.array(design.leg_lengths)
    b = np.array(design.rail_origins) + np.asarray(rho, dtype=float)

    def branch(th, sgn, i=0, j=2, m=1):
        c, s = np.cos(th), np.sin(th)
        ox, oy = b[:, None] - k[:, None] * c, -k[:, None] * s
        dx, dy = ox[j] - ox[i], oy[j] - oy[i]
        d = np.hypot(dx, dy)
        with np.errstate(all="ignore"):
            a = (d * d + L[i] ** 2 - L[j] ** 2) / (2 * d)
            h = np.sqrt(L[i] ** 2 - a * a)
            gx = ox[i] + (a * dx - sgn * h * dy) / d
            gy = oy[i] + (a * dy + sgn * h * dx) / d
            r = np.hypot(gx - ox[m], gy - oy[m]) - L[m]
        return gx, gy, r

    th = np.linspace(-np.pi, np.pi, n_theta)
    found = []
    for (i, j, m), sgn in itertools.product(((0, 2, 1), (0, 1, 2), (1, 2, 0)), (1.0, -1.0)):
        _, _, r = branch(th, sgn, i, j, m)
        for t in np.nonzero(np.isfinite(r[:-1]) & np.isfinite(r[1:]) & (r[:-1] * r[1:] < 0))[0]:
            lo, hi, rlo = th[t], th[t + 1], r[t]
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                rm = branch(np.array([mid]), sgn, i, j, m)[2][0]
                lo, hi, rlo = (mid, hi, rm) if rm * rlo > 0 else (lo, mid, rlo)
            gx, gy, _ = branch(np.array([lo]), sgn, i, j, m)
            p = np.array([gx[0], gy[0], lo])
            for _ in range(5):
                c, s = math.cos(p[2]), math.sin(p[2])
                ux, uy = p[0] + k * c - b, p[1] + k * s
                F = 0.5 * (ux * ux + uy * uy - L * L)
                J = np.stack([ux, uy, k * (uy * c - ux * s)], axis=1)
                p = p - np.linalg.lstsq(J, F, rcond=None)[0]
            if np.abs(kinematics.loop_residual(design, p, rho)).max() < 1e-10:
                found.append(p)
    uniq: list[np.ndarray] = []
    for p in found:
        if all(pose_error(design, p, q) > 1e-7 for q in uniq):
            uniq.append(p)
    return np.array(uniq).reshape(-1, 3)


def singular_configurations(design: Design, n: int, seed: int):
    """Configurations on the parallel-singularity surface: from random poses walk along a
    random direction (fixed working mode) to the first sign change of ``det A``, bisected to
    rounding level.  Returns poses, their modes and the unit directions used."""
    rng = np.random.default_rng(seed)
    m = 40 * n
    p0 = random_poses(design, m, rng)
    mode = ALL_MODES[rng.integers(0, 8, m)]
    direction = rng.normal(size=(m, 3))
    direction[:, 2] /= design.characteristic_length
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)

    def det_sign(t, idx):
        q = p0[idx] + t[:, None] * direction[idx]
        rho = kinematics.inverse(design, q, mode[idx]).rho
        s = np.sign(np.linalg.det(kinematics.jacobians(design, q, np.nan_to_num(rho))[0]))
        return np.where(np.isnan(rho).any(axis=1), np.nan, s)

    ts = np.linspace(0.0, 0.05, 26)
    signs = np.stack([det_sign(np.full(m, t), np.arange(m)) for t in ts])
    change = signs[:-1] * signs[1:] < 0
    idx = np.nonzero(change.any(axis=0))[0][:n]
    first = np.argmax(change[:, idx], axis=0)
    lo, hi = ts[first], ts[first + 1]
    s_lo = signs[first, idx]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        s = det_sign(mid, idx)
        same = s == s_lo
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    return p0[idx] + lo[:, None] * direction[idx], mode[idx], direction[idx]


# ------------------------------------------------------------------------------ inverse kinematics
@st.composite
def configurations(draw, names=DESIGN_NAMES):
    """A design, a pose in the search rectangle or its mirror (any orientation) and a working
    mode (all 8 possible)."""
    name = draw(st.sampled_from(names))
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
    mode = np.array(draw(st.sampled_from(ALL_MODES.tolist())))
    return d, pose, mode


@given(configurations())
def test_inverse_closes_the_loops_in_the_requested_working_mode(cfg):
    d, pose, mode = cfg
    rho, reachable = kinematics.inverse(d, pose, mode)
    cy = pose[1] + np.array(d.joint_offsets) * math.sin(pose[2])
    closable = np.abs(cy) <= np.array(d.leg_lengths)
    assert (np.isfinite(rho) == closable).all()
    assume(closable.all())
    assert np.abs(kinematics.loop_residual(d, pose, rho)).max() < 1e-15 * 64
    u = kinematics.leg_vectors(d, pose, rho)
    wm = kinematics.working_mode(d, pose, rho)
    assert ((wm == mode) | (np.abs(u[:, 0]) < 1e-15)).all()
    assert bool(reachable) == bool(((rho >= 0) & (rho <= d.stroke)).all())


def test_inverse_broadcasts_poses_against_all_modes():
    rng = np.random.default_rng(1)
    poses = random_poses(FIG8, 50, rng)
    res = kinematics.inverse(FIG8, poses[:, None, :], ALL_MODES)
    assert res.rho.shape == (50, 8, 3) and res.reachable.shape == (50, 8)
    for j, m in enumerate(ALL_MODES):
        single = kinematics.inverse(FIG8, poses, m)
        np.testing.assert_array_equal(res.rho[:, j], single.rho)
        np.testing.assert_array_equal(res.reachable[:, j], single.reachable)
    # one pose, one mode: scalar-shaped results
    r = kinematics.inverse(FIG8, poses[0], (1, -1, 1))
    assert r.rho.shape == (3,) and r.reachable.shape == ()


# ------------------------------------------------------------------------------ direct kinematics
@settings(max_examples=150)
@given(configurations())
def test_ik_then_dk_returns_the_pose(cfg):
    d, pose, mode = cfg
    rho = kinematics.inverse(d, pose, mode).rho
    assume(np.isfinite(rho).all())
    sol = kinematics.forward_batch(d, rho)
    check_solutions(d, rho, sol)
    pm = float(kinematics.parallel_margin(d, pose, rho))
    assert recovery_error(d, sol, pose) <= recovery_tol(d, pm)
    # the list form agrees
    lst = kinematics.forward(d, rho)
    assert len(lst) == int(sol.count)
    for j, s in enumerate(lst):
        np.testing.assert_array_equal(s.pose, sol.poses[j])
        assert s.assembly == sol.assembly[j] and s.side == sol.side[j]
        np.testing.assert_array_equal(s.working_mode, kinematics.working_mode(d, s.pose, rho))


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_ik_then_dk_all_working_modes_batch(name):
    """2000 random poses x all 8 working modes in one call: every pose comes back (exactly
    where the parallel margin is at least 1e-3), solutions come in mirror pairs, and the two
    poses above the rails carry opposite signs of det A."""
    d = DESIGNS[name]
    rng = np.random.default_rng(7)
    poses = random_poses(d, 2000, rng)
    rho = kinematics.inverse(d, poses[:, None, :], ALL_MODES).rho  # (2000, 8, 3)
    ok = np.isfinite(rho).all(axis=-1)
    P = np.broadcast_to(poses[:, None, :], rho.shape)[ok]
    R = rho[ok]
    modes = np.broadcast_to(ALL_MODES, rho.shape)[ok]
    assert len(np.unique(modes, axis=0)) == 8
    sol = kinematics.forward_batch(d, R)
    check_solutions(d, R, sol)
    pm = kinematics.parallel_margin(d, P, R)
    err = recovery_error(d, sol, P)
    assert (err <= recovery_tol(d, pm)).all()
    assert (err[pm >= 1e-3] <= 1e-9).all()
    # a real root of the cubic gives a pose and its mirror image about the rail line
    assert (sol.count % 2 == 0).all()  # no pose here lies on the rail line with theta = 0, pi
    for j in range(4):
        v = sol.valid[:, j]
        mirrored = mirror(sol.poses[v, j])
        me = pose_error(d, sol.poses[v], mirrored[:, None, :])
        assert (np.where(sol.valid[v], me, np.inf).min(axis=1) < 1e-12).all()
    # the mirror has the same det A: above and below come in equal numbers per assembly mode
    # the two poses above the rails: opposite signs of det A (where not nearly singular)
    above = sol.valid & (sol.side == 1)
    two = above.sum(axis=1) == 2
    ppm = kinematics.parallel_margin(d, np.nan_to_num(sol.poses), R[:, None, :])
    clear = two & (np.where(above, ppm, np.inf).min(axis=1) > 1e-6)
    assert clear.mean() > 0.9
    asm_above = np.where(above, sol.assembly, 0)[clear]
    assert (asm_above.sum(axis=1) == 0).all() and (np.abs(asm_above).sum(axis=1) == 2).all()
    # the reported assembly mode is sign(det A) of the returned pose
    ok_lab = sol.valid & (ppm > 1e-9)
    am = kinematics.assembly_mode(d, np.nan_to_num(sol.poses), R[:, None, :])
    assert (am[ok_lab] == sol.assembly[ok_lab]).all()
    # ordering: above before below, then det A = +1 before -1
    key = np.where(sol.valid, (1 - sol.side) * 4 + (1 - sol.assembly), 99)
    assert (np.diff(key, axis=1) >= 0).all()


@pytest.mark.parametrize("name", ["fig8", "generic"])
def test_dk_agrees_with_brute_force_on_arbitrary_travels(name):
    """Travels not taken from IK (many have no pose): the same set of poses as an independent
    theta scan.  Rows where the scan itself is unreliable (a double root within 1e-6 of the
    parallel margin) are skipped."""
    d = DESIGNS[name]
    rng = np.random.default_rng(3)
    rho = rng.uniform(-0.1, 0.5, (40, 3))
    sol = kinematics.forward_batch(d, rho)
    check_solutions(d, rho, sol)
    checked = 0
    for i in range(len(rho)):
        ref = brute_force_dk(d, rho[i])
        ours = sol.poses[i][sol.valid[i]]
        both = np.concatenate([ours, ref])
        if len(both) and kinematics.parallel_margin(d, both, rho[i]).min() < 1e-6:
            continue
        checked += 1
        assert len(ref) == len(ours), (rho[i], ref, ours)
        for p in ref:
            assert pose_error(d, ours, p).min() < 1e-9
    assert checked >= 35
    assert (sol.count == 0).sum() >= 5 and (sol.count == 4).sum() >= 5


def test_dk_returns_at_most_four_poses_even_on_bad_rows():
    rng = np.random.default_rng(11)
    rho = rng.uniform(-1.0, 1.0, (3000, 3))
    rho[:500, 1] = rho[:500, 0]  # two sliders at one place
    rho[500:1000] = rho[500:1000, :1]  # all three at one place
    for d in (FIG8, GENERIC, FIG7):
        sol = kinematics.forward_batch(d, rho * max(d.leg_lengths) / 0.2)
        check_solutions(d, rho * max(d.leg_lengths) / 0.2, sol)


def test_dk_batch_shapes():
    rho = kinematics.inverse(FIG8, [[0.15, 0.05, 0.2], [0.1, 0.1, -0.2]], (1, 1, -1)).rho
    assert np.isfinite(rho).all()
    sol = kinematics.forward_batch(FIG8, rho.reshape(2, 1, 3))
    assert sol.poses.shape == (2, 1, 4, 3) and sol.count.shape == (2, 1)
    one = kinematics.forward_batch(FIG8, rho[0])
    assert one.poses.shape == (4, 3) and one.count.shape == ()
    empty = kinematics.forward_batch(FIG8, np.zeros((0, 3)))
    assert empty.poses.shape == (0, 4, 3)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(2, 400), st.booleans())
def test_dk_batch_row_does_not_depend_on_the_batch(seed, n, line):
    """A row's solutions are the same numbers, bit for bit, whatever rows are solved with it
    (the mode-change sampler certifies its first candidate alone and relies on this)."""
    rng = np.random.default_rng(seed)
    if line:  # a straight travel segment, as the joint-path certificates sample it
        a, b = rng.uniform(0.0, FIG8.stroke, (2, 3))
        rho = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
    else:
        rho = rng.uniform(0.0, FIG8.stroke, (n, 3))
    lo = int(rng.integers(0, n))
    hi = int(rng.integers(lo + 1, n + 1))
    whole = kinematics.forward_batch(FIG8, rho)
    part = kinematics.forward_batch(FIG8, rho[lo:hi])
    for name in whole._fields:
        np.testing.assert_array_equal(getattr(part, name), getattr(whole, name)[lo:hi], name)


@settings(max_examples=200, deadline=None)
@given(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(allow_nan=True, allow_infinity=True),
)
def test_the_compiled_clip_is_numpys(x, lo, hi):
    """The direct kinematics' compiled Newton clips its start as ``np.clip`` does, NaN
    included, so that its roots are the array formulation's to the bit."""
    expected = np.clip(np.array([x]), np.array([lo]), np.array([hi]))[0]
    got = kinematics._clip(x, lo, hi)
    assert (math.isnan(got) and math.isnan(expected)) or (
        np.float64(got).tobytes() == np.float64(expected).tobytes()  # (the sign of a zero too)
    )


# ------------------------------------------------------------------------------ hard DK cases
def test_dk_theta_near_zero_and_pi():
    """theta = 0, pi exactly and within 1e-12 .. 1e-1 of them, both signs, all working modes:
    the cubic in cos(theta) clusters its roots there, the solver must still recover."""
    rng = np.random.default_rng(5)
    offsets = np.concatenate([[0.0], 10.0 ** -np.arange(1, 13)])
    base = np.array([0.0, np.pi])
    th = (base[:, None, None] + np.array([1.0, -1.0])[None, :, None] * offsets).ravel()
    for d in (FIG8, GENERIC):
        x0, x1, _, h = d.search_rectangle
        n = th.size * 6
        poses = np.stack([rng.uniform(x0, x1, n), rng.uniform(-h, h, n), np.repeat(th, 6)], axis=-1)
        rho = kinematics.inverse(d, poses[:, None, :], ALL_MODES).rho
        ok = np.isfinite(rho).all(axis=-1)
        P, R = np.broadcast_to(poses[:, None, :], rho.shape)[ok], rho[ok]
        sol = kinematics.forward_batch(d, R)
        check_solutions(d, R, sol)
        pm = kinematics.parallel_margin(d, P, R)
        assert (recovery_error(d, sol, P) <= recovery_tol(d, pm)).all()


def test_dk_the_near_singular_example_of_the_issue():
    """Pose (0.3467, 0.0136, -0.0014) on fig8: theta near 0 and, in some working modes, a
    parallel margin ~1e-5 (the old solver returned no pose there)."""
    pose = np.array([0.3467, 0.0136, -0.0014])
    rho = kinematics.inverse(FIG8, pose, ALL_MODES).rho
    ok = np.isfinite(rho).all(axis=1)
    assert ok.sum() == 8
    pm = kinematics.parallel_margin(FIG8, pose, rho)
    assert pm.min() < 3e-5
    sol = kinematics.forward_batch(FIG8, rho)
    check_solutions(FIG8, rho, sol)
    assert (sol.count == 4).all()
    err = recovery_error(FIG8, sol, np.broadcast_to(pose, rho.shape))
    assert (err <= recovery_tol(FIG8, pm)).all()
    assert (err < 1e-9).all()  # in fact exact


@pytest.mark.parametrize("pair", [(0, 1), (0, 2), (1, 2)])
def test_dk_two_sliders_at_the_same_place(pair):
    """b_i = b_j makes the cubic's leading coefficient vanish (it becomes a quadratic).
    Random poses are moved along a random direction until b_i - b_j changes sign (bisection),
    then rho_j is set so that b_j equals b_i exactly."""
    i, j = pair
    rng = np.random.default_rng(17 + i + j)
    d = GENERIC.with_(rail_origins=(0.0, 0.0, 0.0))  # so that b_i = b_j is rho_i = rho_j
    p0 = random_poses(d, 4000, rng)
    mode = ALL_MODES[rng.integers(0, 8, 4000)]
    direction = rng.normal(size=(4000, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)

    def gap(t):
        r = kinematics.inverse(d, p0 + t[:, None] * direction, mode).rho
        return r[:, i] - r[:, j]

    lo, hi = np.zeros(4000), np.full(4000, 0.05)
    glo, ghi = gap(lo), gap(hi)
    use = np.isfinite(glo) & np.isfinite(ghi) & (glo * ghi < 0)
    assert use.sum() > 30
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        gm = gap(mid)
        same = np.sign(gm) == np.sign(glo)
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    P = (p0 + lo[:, None] * direction)[use]
    R = kinematics.inverse(d, P, mode[use]).rho
    R[:, j] = R[:, i]  # exactly the same place
    keep = np.isfinite(R).all(axis=1)
    P, R = P[keep], R[keep]
    sol = kinematics.forward_batch(d, R)
    check_solutions(d, R, sol)
    pm = kinematics.parallel_margin(d, P, R)
    # the pose moved by the last bisection step and the rounding of rho_j (~1e-16 m)
    assert (recovery_error(d, sol, P) <= recovery_tol(d, pm) + 1e-12 / pm).all()


def test_dk_singular_elimination_matrix():
    """``b_i`` affine in the joint offsets ``k_i`` makes the 3x3 elimination singular; then a
    root of the cubic is double and carries two poses with the same theta (both branches of
    the circle intersection).  Checked against the brute-force scan (generic design)."""
    d = GENERIC
    k = np.array(d.joint_offsets)
    rng = np.random.default_rng(23)
    checked = 0
    for _ in range(40):
        alpha, beta = rng.uniform(-0.2, 0.4), rng.uniform(-1.5, 1.5)
        rho = alpha + beta * k - np.array(d.rail_origins)
        sol = kinematics.forward_batch(d, rho)
        check_solutions(d, rho, sol)
        ref = brute_force_dk(d, rho)
        ours = sol.poses[sol.valid]
        if len(ours) and kinematics.parallel_margin(d, ours, rho).min() < 1e-6:
            continue
        checked += 1
        assert len(ours) == len(ref)
        for p in ref:
            assert pose_error(d, ours, p).min() < 1e-9
        if len(ours) == 4:  # a double root: two poses with the same cos(theta)
            above = ours[ours[:, 1] > 0]
            assert abs(math.cos(above[0, 2]) - math.cos(above[1, 2])) < 1e-9
    assert checked >= 30


@pytest.mark.parametrize("name", ["fig8", "generic"])
def test_dk_at_and_near_parallel_singularities(name):
    """Double roots: exactly at the singularity and 1e-9 .. 1e-2 away from it along the
    direction that reached it.  No crash, no NaN, something returned within the conditioning
    bound; exact recovery where the margin is at least 1e-3."""
    d = DESIGNS[name]
    P0, mode, direction = singular_configurations(d, 40, seed=29)
    assert len(P0) >= 30
    eps = np.array([0.0, -1e-9, -1e-7, -1e-5, -1e-3, -1e-2])
    P = (P0[:, None, :] + eps[None, :, None] * direction[:, None, :]).reshape(-1, 3)
    M = np.repeat(mode, len(eps), axis=0)
    R = kinematics.inverse(d, P, M).rho
    ok = np.isfinite(R).all(axis=1)
    P, R = P[ok], R[ok]
    sol = kinematics.forward_batch(d, R)
    check_solutions(d, R, sol)
    assert (sol.count >= 1).all()
    pm = kinematics.parallel_margin(d, P, R)
    assert (pm[np.tile(eps == 0, len(P0))[ok]] < 1e-12).all()
    err = recovery_error(d, sol, P)
    assert (err <= recovery_tol(d, pm)).all()
    assert (err[pm >= 1e-3] <= 1e-9).all()


def test_dk_fig7_architecture_singular_configurations_do_not_break_it():
    """fig7 (equal legs) at theta = 0 with parallel legs: a self-motion.  Only the contract
    is checked: no crash, no NaN in valid slots, every returned pose closes the loops."""
    rng = np.random.default_rng(31)
    x0, x1, _, h = FIG7.search_rectangle
    n = 300
    th = np.concatenate([np.zeros(100), np.full(100, np.pi), rng.normal(0, 1e-6, 100)])
    poses = np.stack([rng.uniform(x0, x1, n), rng.uniform(-h, h, n), th], axis=-1)
    mode = np.repeat(np.array([[1, 1, 1], [-1, -1, -1]]), n // 2, axis=0)
    rho = kinematics.inverse(FIG7, poses, mode).rho
    rho = rho[np.isfinite(rho).all(axis=1)]
    sol = kinematics.forward_batch(FIG7, rho)
    check_solutions(FIG7, rho, sol)
    # elsewhere fig7 is an ordinary design
    poses = random_poses(FIG7, 500, rng)
    rho = kinematics.inverse(FIG7, poses, ALL_MODES[rng.integers(0, 8, 500)]).rho
    ok = np.isfinite(rho).all(axis=1)
    sol = kinematics.forward_batch(FIG7, rho[ok])
    check_solutions(FIG7, rho[ok], sol)
    pm = kinematics.parallel_margin(FIG7, poses[ok], rho[ok])
    err = recovery_error(FIG7, sol, poses[ok])
    assert (err[pm >= 1e-3] <= 1e-9).all()


def test_dk_emits_no_warnings():
    import warnings

    rng = np.random.default_rng(2)
    rho = np.concatenate([rng.uniform(-1, 1, (500, 3)), np.zeros((5, 3)), np.ones((5, 3))])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for d in (FIG8, FIG7, GENERIC):
            kinematics.forward_batch(d, rho)


# ------------------------------------------------------------------------------ velocities
@st.composite
def regular_configurations(draw):
    d, pose, mode = draw(configurations())
    rho = kinematics.inverse(d, pose, mode).rho
    assume(np.isfinite(rho).all())
    m = kinematics.margins(d, pose, rho)
    assume(m.serial > 0.05 and m.parallel > 1e-3)
    twist = np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3)))
    assume(np.linalg.norm(twist) > 1e-3)
    twist /= np.linalg.norm(twist)  # unit speed of G and of the joints about G
    twist[2] /= d.characteristic_length
    return d, pose, mode, rho, twist


@given(regular_configurations())
def test_velocity_relation_matches_finite_differences_of_ik(cfg):
    """A p_dot = B rho_dot, with rho_dot from central differences of IK along a unit twist.
    With every leg at least acos(0.05) from vertical, the third derivative of the travels is
    at most ~L^2 / w^5 with w = L cos(alpha) >= 0.05 L, below ~1e9 m^-2 on these designs: the
    truncation error of the step h = 1e-7 is h^2 |rho'''| / 6 <~ 2e-6 m/s in the worst corner
    and far less typically, the rounding error eps |rho| / h ~ 1e-9 m/s; slider rates are
    O(1) to O(20) m/s, hence the 1e-6 relative tolerance."""
    d, pose, mode, rho, twist = cfg
    h = 1e-7
    rp = kinematics.inverse(d, pose + h * twist, mode).rho
    rm = kinematics.inverse(d, pose - h * twist, mode).rho
    rho_dot = (rp - rm) / (2 * h)
    A, B = kinematics.jacobians(d, pose, rho)
    lhs, rhs = A @ twist, B @ rho_dot
    scale = np.abs(A).max() * np.abs(twist).max()
    assert np.abs(lhs - rhs).max() <= 1e-6 * scale
    # B is diagonal with the legs' x components; the simple motions are B^-1 A p_dot
    u = kinematics.leg_vectors(d, pose, rho)
    np.testing.assert_array_equal(B, np.diag(u[:, 0]))
    sm = kinematics.simple_motion_rates(d, pose, rho, twist)
    np.testing.assert_allclose(sm, np.linalg.solve(B, lhs), rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(sm, rho_dot, rtol=1e-6, atol=1e-8)


def test_simple_motions():
    rng = np.random.default_rng(13)
    poses = random_poses(FIG8, 400, rng)
    rho = kinematics.inverse(FIG8, poses, ALL_MODES[rng.integers(0, 8, 400)]).rho
    ok = np.isfinite(rho).all(axis=1)
    poses, rho = poses[ok], rho[ok]
    v = rng.uniform(-0.3, 0.3, len(poses))
    zeros = np.zeros_like(v)
    # horizontal translation: every slider moves exactly with the gripper, no computation
    rates = kinematics.simple_motion_rates(FIG8, poses, rho, np.stack([v, zeros, zeros], -1))
    assert (rates == v[:, None]).all()
    u = kinematics.leg_vectors(FIG8, poses, rho)
    alpha = np.arctan2(u[..., 1], u[..., 0])
    # vertical translation: y_dot tan(alpha_i)
    rates = kinematics.simple_motion_rates(FIG8, poses, rho, np.stack([zeros, v, zeros], -1))
    np.testing.assert_allclose(rates, v[:, None] * np.tan(alpha), rtol=1e-12, atol=1e-15)
    # rotation about G: L_iG theta_dot sin(alpha_i - theta) / cos(alpha_i)
    rates = kinematics.simple_motion_rates(FIG8, poses, rho, np.stack([zeros, zeros, v], -1))
    k = np.array(FIG8.joint_offsets)
    expect = k * v[:, None] * np.sin(alpha - poses[:, 2:3]) / np.cos(alpha)
    np.testing.assert_allclose(rates, expect, rtol=1e-12, atol=1e-15)
    # from measured angles only: theta = beta + alpha_1 - pi, beta the angle at C_1
    tw = np.stack([v, -v, 2 * v], -1)
    from_angles = kinematics.simple_motion_rates_from_angles(FIG8, alpha, poses[:, 2], tw)
    np.testing.assert_array_equal(from_angles, kinematics.simple_motion_rates(FIG8, poses, rho, tw))
    # with a leg exactly perpendicular to its rail a motion that needs it is infinite
    r = kinematics.simple_motion_rates_from_angles(
        FIG8, [np.pi / 2, 1.0, 2.0], 0.3, [0.1, 0.2, 0.0]
    )
    assert abs(r[0]) > 1e15 and (np.abs(r[1:]) < 10).all()  # cos(pi / 2) is 6e-17
    r = kinematics.simple_motion_rates_from_angles(
        FIG8, [np.pi / 2, 1.0, 2.0], 0.3, [0.1, 0.0, 0.0]
    )
    assert (r == 0.1).all()


# ------------------------------------------------------------------------------ singularities
def test_margins_agree_with_the_separate_functions():
    rng = np.random.default_rng(19)
    poses = random_poses(GENERIC, 300, rng)
    rho = kinematics.inverse(GENERIC, poses, ALL_MODES[rng.integers(0, 8, 300)]).rho
    ok = np.isfinite(rho).all(axis=1)
    m = kinematics.margins(GENERIC, poses[ok], rho[ok])
    np.testing.assert_array_equal(
        m.parallel, kinematics.parallel_margin(GENERIC, poses[ok], rho[ok])
    )
    np.testing.assert_array_equal(m.serial, kinematics.serial_margin(GENERIC, poses[ok], rho[ok]))
    np.testing.assert_array_equal(m.assembly, kinematics.assembly_mode(GENERIC, poses[ok], rho[ok]))
    assert ((m.parallel >= 0) & (m.parallel <= 1)).all()
    assert ((m.serial >= 0) & (m.serial <= 1)).all()


def _linear_shrink(margin_at, ts=(1e-5, 1e-6, 1e-7, 1e-8)):
    """margin(t) / t is the same (within 2%) for every t: the margin is linear in the
    distance to the singular configuration."""
    ratios = np.array([margin_at(t) / t for t in ts])
    assert (ratios > 0).all()
    assert ratios.max() / ratios.min() < 1.02, ratios


@pytest.mark.parametrize("mode", [(1, 1, 1), (-1, -1, -1)])
def test_three_parallel_legs(mode):
    """Platform on the rail line (theta = 0), legs along the rails: the three legs are
    parallel, det A = 0 (the y column of A vanishes)."""
    d = GENERIC
    pose = np.array([0.15, 0.0, 0.0])
    rho = kinematics.inverse(d, pose, mode).rho
    u = kinematics.leg_vectors(d, pose, rho)
    assert (u[:, 1] == 0).all()
    rep = kinematics.classify_singularity(d, pose, rho)
    assert (rep.kind, rep.detail, rep.at_singularity) == ("parallel", "parallel legs", True)
    assert rep.parallel_margin < 1e-15 and rep.serial_margin == 1.0
    assert rep.meeting_point is None and rep.leg is None
    # moving the platform up in the same working mode: the margin grows linearly
    direction = np.array([0.3, 1.0, 0.5])

    def pm(t):
        q = pose + t * direction
        return float(kinematics.parallel_margin(d, q, kinematics.inverse(d, q, mode).rho))

    _linear_shrink(pm)


def test_three_parallel_legs_above_the_rails_on_fig8():
    """fig8's legs are in arithmetic progression with the joint offsets (L_i = 0.2 - 0.1 L_iG),
    so the three legs can be parallel off the rail line: C_iy = L_i sin(phi) for all i holds
    with sin(phi) = -10 sin(theta), y = -2 sin(theta)."""
    theta = 0.05
    s = math.sin(theta)
    sphi = -10 * s
    for cphi in (math.sqrt(1 - sphi**2), -math.sqrt(1 - sphi**2)):
        pose = np.array([0.2, -2 * s, theta])
        k, L = np.array(FIG8.joint_offsets), np.array(FIG8.leg_lengths)
        cx = pose[0] + k * math.cos(theta)
        rho = cx - L * cphi
        assert np.abs(kinematics.loop_residual(FIG8, pose, rho)).max() < 1e-15
        rep = kinematics.classify_singularity(FIG8, pose, rho)
        assert (rep.kind, rep.detail, rep.at_singularity) == ("parallel", "parallel legs", True)
        sol = kinematics.forward_batch(FIG8, rho)  # a double root of the DK
        check_solutions(FIG8, rho, sol)
        assert recovery_error(FIG8, sol, pose) < 3e-5 * 0.19


def test_three_leg_lines_through_one_point():
    """A hand-built design whose legs, at a chosen pose, all point at one point P."""
    pose = np.array([0.05, 0.12, 0.4])
    P = np.array([0.3, 0.5])
    spacings = (0.08, 0.1, 0.06)
    k = np.array([0.24, 0.16, 0.06])
    C = pose[:2] + k[:, None] * np.array([math.cos(pose[2]), math.sin(pose[2])])
    # B_i: where the line from P through C_i meets y = 0
    t = P[1] / (P[1] - C[:, 1])
    B = P + t[:, None] * (C - P)
    legs = np.linalg.norm(C - B, axis=1)
    origins = B[:, 0] - 0.1
    d = Design(leg_lengths=tuple(legs), spacings=spacings, stroke=0.3, rail_origins=tuple(origins))
    mode = tuple(int(v) for v in np.sign(C[:, 0] - B[:, 0]))
    rho = kinematics.inverse(d, pose, mode).rho
    np.testing.assert_allclose(rho, 0.1, atol=1e-15)
    rep = kinematics.classify_singularity(d, pose, rho)
    assert (rep.kind, rep.detail, rep.at_singularity) == ("parallel", "concurrent legs", True)
    np.testing.assert_allclose(rep.meeting_point, P, atol=1e-12)
    assert rep.parallel_margin < 1e-14
    assert kinematics.assembly_mode(d, pose, rho) in (-1, 0, 1)
    # (a translation along the rails keeps the legs concurrent: move across them)
    for direction in (np.array([0.0, 1.0, 0.0]), np.array([0.2, -0.5, 1.0])):

        def pm(t, direction=direction):
            q = pose + t * direction
            return float(kinematics.parallel_margin(d, q, kinematics.inverse(d, q, mode).rho))

        _linear_shrink(pm)
    # a little away it is still reported as the nearest singularity, but not "at" it
    q = pose + 1e-4 * np.array([0.0, 1.0, 0.0])
    rep = kinematics.classify_singularity(d, q, kinematics.inverse(d, q, mode).rho)
    assert rep.kind == "parallel" and not rep.at_singularity


@pytest.mark.parametrize("leg", [0, 1, 2])
def test_leg_perpendicular_to_its_rail(leg):
    """Leg i vertical (C_i straight above B_i): cos(alpha_i) = 0, det B = 0.  Approaching it
    along the leg angle, the serial margin is |cos alpha_i|, linear in the angle, and the
    slider rates needed for a vertical motion grow like 1 / cos(alpha_i)."""
    d = GENERIC  # on fig8 leg 2 is vertical only when all three are
    k, L = np.array(d.joint_offsets), np.array(d.leg_lengths)
    a = np.array(d.rail_origins)
    # an orientation where, with C_i at height L_i, the other two legs reach their rails
    for theta in np.linspace(-1.2, 1.2, 241):
        cy = L[leg] + (k - k[leg]) * math.sin(theta)
        if (np.abs(cy) <= 0.95 * L).sum() == 2:
            break
    else:  # pragma: no cover
        raise AssertionError("no orientation found")

    def config(t):
        # leg `leg` at angle pi/2 - t: C_iy = L_i cos(t); the other legs close in mode +1
        y = L[leg] * math.cos(t) - k[leg] * math.sin(theta)
        pose = np.array([0.2, y, theta])
        rho = kinematics.inverse(d, pose, (1, 1, 1)).rho
        rho[leg] = pose[0] + k[leg] * math.cos(theta) - a[leg] - L[leg] * math.sin(t)
        return pose, rho

    pose, rho = config(0.0)
    assert np.isfinite(rho).all()
    rep = kinematics.classify_singularity(d, pose, rho)
    assert (rep.kind, rep.leg, rep.detail, rep.at_singularity) == (
        "serial",
        leg,
        f"leg {leg + 1}",
        True,
    )
    assert rep.serial_margin < 1e-15
    _linear_shrink(lambda t: float(kinematics.serial_margin(d, *config(t))))
    rates = [
        abs(kinematics.simple_motion_rates(d, *config(t), (0.0, 0.1, 0.0))[leg])
        for t in (1e-3, 1e-5)
    ]
    assert rates[1] / rates[0] == pytest.approx(100.0, rel=1e-3)


def test_classify_singularity_far_from_singularities():
    pose = np.array([0.15, 0.05, 0.2])
    rho = kinematics.inverse(FIG8, pose, (1, -1, 1)).rho
    assert np.isfinite(rho).all()
    rep = kinematics.classify_singularity(FIG8, pose, rho)
    assert not rep.at_singularity
    assert rep.kind in ("serial", "parallel")
    m = kinematics.margins(FIG8, pose, rho)
    assert rep.parallel_margin == pytest.approx(float(m.parallel))
    assert rep.serial_margin == pytest.approx(float(m.serial))


# ------------------------------------------------------------------------------ bad input
GOOD_POSE = np.array([0.15, 0.05, 0.2])
GOOD_RHO = kinematics.inverse(FIG8, GOOD_POSE, (1, 1, 1)).rho


@pytest.mark.parametrize(
    ("value", "match"),
    [
        ([0.1, 0.2], r"pose must have shape \(\.\.\., 3\)"),
        (np.zeros((4, 2)), r"pose must have shape"),
        (0.3, r"pose must have shape"),
        ([0.1, np.nan, 0.2], "pose contains NaN or infinite"),
        ([0.1, 0.2, np.inf], "pose contains NaN or infinite"),
        (["a", "b", "c"], "pose must be an array of real numbers"),
        ([1 + 2j, 0, 0], "pose must be an array of real numbers"),
        ([True, False, True], "pose must be an array of real numbers"),
        ([[0.1, 0.2, 0.3], [0.1, 0.2]], "pose must be an array of real numbers"),
    ],
)
def test_bad_pose(value, match):
    with pytest.raises(ValueError, match=match):
        kinematics.inverse(FIG8, value)
    with pytest.raises(ValueError, match=match):
        kinematics.jacobians(FIG8, value, GOOD_RHO)


@pytest.mark.parametrize(
    ("value", "match"),
    [
        ([0.1, 0.2], r"rho must have shape"),
        ([0.1, np.nan, 0.2], "rho contains NaN or infinite"),
        ([-np.inf, 0.1, 0.2], "rho contains NaN or infinite"),
        ("abc", "rho must be an array of real numbers"),
    ],
)
def test_bad_rho(value, match):
    for fn in (
        kinematics.forward_batch,
        kinematics.forward,
        lambda d, r: kinematics.parallel_margin(d, GOOD_POSE, r),
        lambda d, r: kinematics.margins(d, GOOD_POSE, r),
        lambda d, r: kinematics.loop_residual(d, GOOD_POSE, r),
    ):
        with pytest.raises(ValueError, match=match):
            fn(FIG8, value)


@pytest.mark.parametrize(
    "mode", [(1, 0, 1), (2, 1, 1), (0.5, 1, -1), (1, 1), ((1, 1, 1, 1),), "abc", (True, True, True)]
)
def test_bad_working_mode(mode):
    with pytest.raises(ValueError, match="mode"):
        kinematics.inverse(FIG8, GOOD_POSE, mode)


def test_inputs_that_do_not_broadcast():
    with pytest.raises(ValueError, match=r"pose of shape \(2, 3\) and mode of shape \(3, 3\)"):
        kinematics.inverse(FIG8, np.zeros((2, 3)), ALL_MODES[:3])
    with pytest.raises(ValueError, match="do not broadcast"):
        kinematics.leg_vectors(FIG8, np.zeros((2, 3)), np.zeros((4, 3)))
    with pytest.raises(ValueError, match="do not broadcast"):
        kinematics.simple_motion_rates(
            FIG8, np.zeros((2, 3)) + GOOD_POSE, GOOD_RHO, np.ones((4, 3))
        )
    with pytest.raises(ValueError, match="do not broadcast"):
        kinematics.simple_motion_rates_from_angles(FIG8, np.zeros((2, 3)), np.zeros(4), [1, 0, 0])


def test_bad_design_and_other_arguments():
    with pytest.raises(ValueError, match=r"design must be a planar3p_gym\.Design"):
        kinematics.inverse({"leg_lengths": (1, 1, 1)}, GOOD_POSE)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="forward takes one rho of shape"):
        kinematics.forward(FIG8, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="one configuration"):
        kinematics.classify_singularity(FIG8, np.zeros((2, 3)), np.zeros((2, 3)))
    for tol in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="tol must be finite and > 0"):
            kinematics.classify_singularity(FIG8, GOOD_POSE, GOOD_RHO, tol=tol)
    with pytest.raises(ValueError, match="theta contains NaN"):
        kinematics.simple_motion_rates_from_angles(FIG8, [1.0, 1.0, 1.0], np.nan, [1, 0, 0])
    with pytest.raises(ValueError, match="twist contains NaN"):
        kinematics.simple_motion_rates(FIG8, GOOD_POSE, GOOD_RHO, [np.nan, 0, 0])
    with pytest.raises(ValueError, match="alpha must have shape"):
        kinematics.simple_motion_rates_from_angles(FIG8, [1.0, 1.0], 0.0, [1, 0, 0])


# ------------------------------------------------------------------------------ screening
def reference_screen(design, poses, mode, travel, min_parallel, min_serial, assembly):
    """What :func:`kinematics.screen_poses` must decide: inverse, then margins on the poses with
    every travel in the window."""
    rho = kinematics.inverse(design, poses, mode).rho
    p = np.broadcast_to(poses, rho.shape)
    lo, hi = (0.0, design.stroke) if travel is None else travel
    inside = np.all((rho >= lo) & (rho <= hi), axis=-1)
    ok = np.zeros(inside.shape, dtype=bool)
    asm = np.zeros(inside.shape, dtype=np.int8)
    if inside.any():
        pm, sm, det = kinematics.margins(design, p[inside], rho[inside])
        good = (pm >= min_parallel) & (sm >= min_serial)
        if assembly is not None:
            good &= det == assembly
        ok[inside] = good
        asm[inside] = np.where(good, det, 0)
    return ok, rho, asm


def assert_screen_matches(design, poses, mode, travel, min_parallel, min_serial, assembly):
    got = kinematics.screen_poses(
        design, poses, mode, travel, min_parallel, min_serial, assembly=assembly
    )
    ok, rho, asm = reference_screen(design, poses, mode, travel, min_parallel, min_serial, assembly)
    np.testing.assert_array_equal(got.ok, ok)
    np.testing.assert_array_equal(got.rho, rho)  # bit for bit, NaN where a leg cannot close
    np.testing.assert_array_equal(got.assembly, asm)
    return ok


def exact_margins(design, poses, mode):
    """Parallel margins (NaN where unreachable) of poses in one working mode."""
    rho, ok = kinematics.inverse(design, poses, mode)
    pm = np.full(len(poses), np.nan)
    if ok.any():
        pm[ok] = kinematics.margins(design, poses[ok], rho[ok]).parallel
    return pm


@settings(max_examples=60)
@given(
    name=st.sampled_from(DESIGN_NAMES),
    mode=st.sampled_from([tuple(m) for m in ALL_MODES.tolist()]),
    seed=st.integers(0, 2**32 - 1),
    min_parallel=st.floats(0.0, 0.5),
    min_serial=st.floats(0.0, 0.9),
    margin=st.floats(0.0, 0.2),
    assembly=st.sampled_from([None, 1, -1, 1.0]),
)
def test_screen_poses_decides_as_inverse_and_margins(
    name, mode, seed, min_parallel, min_serial, margin, assembly
):
    design = DESIGNS[name]
    poses = random_poses(design, 300, np.random.default_rng(seed))
    travel = (margin * design.stroke, (1.0 - margin) * design.stroke)
    assert_screen_matches(design, poses, mode, travel, min_parallel, min_serial, assembly)


@pytest.mark.parametrize("name", DESIGN_NAMES)
def test_screen_poses_is_exact_at_the_threshold(name):
    """Thresholds equal to (or one ulp beside) a pose's margin: the bounds cannot decide, and
    the answer is the SVD's."""
    design = DESIGNS[name]
    rng = np.random.default_rng(7)
    poses = random_poses(design, 2000, rng)
    for mode in ALL_MODES:
        pm = exact_margins(design, poses, mode)
        finite = pm[np.isfinite(pm)]
        for t in rng.choice(finite, size=min(4, finite.size), replace=False):
            for thr in (t, np.nextafter(t, 1.0), np.nextafter(t, 0.0), t + 5e-9, t - 5e-9):
                ok = assert_screen_matches(design, poses, mode, None, thr, 0.0, None)
                assert ok[pm == t].all() == (thr <= t)


def test_screen_poses_defaults_broadcasting_and_near_singular_poses():
    # broadcast poses (N, 1, 3) against all modes (8, 3)
    poses = random_poses(FIG8, 200, np.random.default_rng(3))[:, None, :]
    got = kinematics.screen_poses(FIG8, poses, ALL_MODES)
    assert got.ok.shape == (200, 8) and got.rho.shape == (200, 8, 3)
    ok, rho, asm = reference_screen(FIG8, poses, ALL_MODES, None, 0.0, 0.0, None)
    np.testing.assert_array_equal(got.ok, ok)
    np.testing.assert_array_equal(got.rho, rho)
    np.testing.assert_array_equal(got.assembly, asm)
    assert (got.assembly[got.ok] != 0).all() or not got.ok.any()
    # poses along a path through a parallel singularity (det A changes sign in mode
    # (1, 1, 1), margins down to 7e-6), at thresholds of the order of their margins
    start = np.array([0.20891875, 0.2787513, -1.65693655])
    end = np.array([0.25793576, 0.17352912, -1.38718248])
    path = start + np.linspace(0.0, 1.0, 4001)[:, None] * (end - start)
    for mode in ALL_MODES:
        pm = exact_margins(FIG8, path, mode)
        for thr in (
            0.0,
            1e-9,
            1e-6,
            1e-3,
            float(np.nanmedian(pm)) if np.isfinite(pm).any() else 0.1,
        ):
            for assembly in (None, 1, -1):
                assert_screen_matches(FIG8, path, mode, None, thr, 0.0, assembly)


def reference_paths(design, paths, mode, min_parallel, min_serial, assembly):
    rho, reachable = kinematics.inverse(design, paths, mode)
    ok = reachable.all(axis=-1)
    if ok.any():
        pm, sm, det = kinematics.margins(design, paths[ok], rho[ok])
        ok[ok] = (
            (pm >= min_parallel).all(-1) & (sm >= min_serial).all(-1) & (det == assembly).all(-1)
        )
    return ok


@settings(max_examples=60)
@given(
    name=st.sampled_from(DESIGN_NAMES),
    mode=st.sampled_from([tuple(m) for m in ALL_MODES.tolist()]),
    seed=st.integers(0, 2**32 - 1),
    min_parallel=st.floats(0.0, 0.2),
    min_serial=st.floats(0.0, 0.5),
    assembly=st.sampled_from([1, -1]),
    points=st.integers(2, 30),
)
def test_screen_paths_decides_as_inverse_and_margins(
    name, mode, seed, min_parallel, min_serial, assembly, points
):
    design = DESIGNS[name]
    rng = np.random.default_rng(seed)
    # short paths from reachable poses, so that many of them are reachable all along
    poses = random_poses(design, 1000, rng)
    starts = poses[kinematics.inverse(design, poses, mode).reachable][:60]
    ends = starts + rng.normal(scale=(0.02, 0.02, 0.3), size=starts.shape)
    paths = starts[:, None] + np.linspace(0.0, 1.0, points)[:, None] * (ends - starts)[:, None]
    got = kinematics.screen_paths(
        design, paths, mode, min_parallel=min_parallel, min_serial=min_serial, assembly=assembly
    )
    want = reference_paths(design, paths, mode, min_parallel, min_serial, assembly)
    np.testing.assert_array_equal(got, want)


def test_screen_paths_shapes_and_bad_input():
    path = np.array([[0.25, 0.12, -0.6], [0.26, 0.13, -0.5]])
    assert kinematics.screen_paths(FIG8, path).shape == ()
    assert kinematics.screen_paths(FIG8, np.zeros((2, 0, 3))).tolist() == [True, True]
    assert kinematics.screen_paths(FIG8, np.zeros((0, 4, 3))).shape == (0,)
    # modes broadcast against paths
    got = kinematics.screen_paths(FIG8, np.broadcast_to(path, (8, 2, 3)), ALL_MODES[:, None, :])
    want = [bool(kinematics.screen_paths(FIG8, path, m)) for m in ALL_MODES]
    assert got.tolist() == want
    with pytest.raises(ValueError, match=r"paths must have shape \(\.\.\., P, 3\)"):
        kinematics.screen_paths(FIG8, [0.2, 0.1, 0.0])
    with pytest.raises(ValueError, match="paths contains NaN"):
        kinematics.screen_paths(FIG8, [[0.2, np.nan, 0.0]])
    with pytest.raises(ValueError, match="mode"):
        kinematics.screen_poses(FIG8, GOOD_POSE, (1, 0, 1))
    with pytest.raises(ValueError, match="do not broadcast"):
        kinematics.screen_poses(FIG8, np.zeros((2, 3)), ALL_MODES[:3])


def rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


@settings(max_examples=200)
@given(
    seed=st.integers(0, 2**32 - 1),
    log_s2=st.floats(-16.0, 0.0),
    log_s3=st.floats(-16.0, 0.0),
    scale=st.sampled_from([1e-3, 1.0, 1e3]),
    rel=st.sampled_from([0.0, 1.0, -1.0, 1e-9, -1e-9, 1e-3, -1e-3, 0.5, -0.5, -0.8, 3.0]),
)
def test_margin_tests_never_contradict_the_svd(seed, log_s2, log_s3, scale, rel):
    """``above`` / ``below`` imply the SVD's ratio is >= / < the threshold, for matrices of
    any conditioning (singular values 1 >= s2 >= s3 down to 1e-16, times a scale), at
    thresholds on, next to and away from the exact ratio; and they decide well-conditioned
    matrices against thresholds outside the bounds' factor of 3."""
    rng = np.random.default_rng(seed)
    s = np.array([1.0, 10.0**log_s2, 10.0 ** min(log_s2, log_s3)])
    m = scale * rotation(rng) @ np.diag(s) @ rotation(rng).T
    sv = np.linalg.svd(m, compute_uv=False)
    pm = sv[-1] / sv[0]
    for thr in {pm * (1.0 + rel), pm + rel * 1e-8, max(pm + rel, 0.0), 0.0}:
        above, below, det = kinematics._bound_test(m, float(thr))
        assert not (above and below)
        if above:
            assert pm >= thr
            assert np.sign(det) == np.sign(np.linalg.det(m))
        if below:
            assert pm < thr
    if s[2] >= 1e-3 and rel in (-0.8, 3.0):
        above, below, _ = kinematics._bound_test(m, float(pm * (1.0 + rel)))
        assert above == (rel < 0) and below == (rel > 0)


@settings(max_examples=60, deadline=None)
@given(
    name=st.sampled_from(["fig8", "generic"]),
    mode=st.sampled_from([tuple(int(v) for v in m) for m in ALL_MODES]),
    seed=st.integers(0, 2**32 - 1),
    points=st.integers(1, 60),
)
def test_min_parallel_margin_is_the_minimum_of_the_margins_bit_for_bit(name, mode, seed, points):
    """The bounds only skip poses that cannot be the minimum: the result is the full SVD's
    minimum to the bit, on straight pose paths between acceptable poses (some pass near a
    parallel singularity)."""
    from planar3p_gym.tasks import sampling

    design = DESIGNS[name]
    rng = np.random.default_rng(seed)
    try:
        poses, _ = sampling.sample_poses(design, mode, rng, sampling.TaskConfig(), max_batches=5)
    except ValueError:  # a working mode of this design with no acceptable pose
        assume(False)
    a, b = poses[rng.integers(len(poses), size=(2, 6))]
    paths = sampling.interpolate(a, b, points)  # (6, points, 3)
    rho = kinematics.inverse(design, paths, mode).rho
    keep = np.isfinite(rho).all(axis=(-2, -1))
    assume(keep.any())
    paths, rho = paths[keep], rho[keep]
    want = kinematics.parallel_margin(design, paths, rho).min(axis=-1)
    np.testing.assert_array_equal(kinematics.min_parallel_margin(design, paths, rho), want)


def test_min_parallel_margin_checks_its_arguments():
    pose = np.array([0.3, 0.12, 0.1])
    rho = np.array([0.1, 0.15, 0.2])
    with pytest.raises(ValueError, match=r"shape \(\.\.\., P, 3\)"):
        kinematics.min_parallel_margin(FIG8, pose, rho)
    with pytest.raises(ValueError, match="at least one pose"):
        kinematics.min_parallel_margin(FIG8, np.zeros((2, 0, 3)), np.zeros((2, 0, 3)))
    empty = kinematics.min_parallel_margin(FIG8, np.zeros((0, 4, 3)), np.zeros((0, 4, 3)))
    assert empty.shape == (0,)


_coordinate = st.floats(-1.0, 1.0, allow_nan=False)
_angle = st.floats(-20.0, 20.0, allow_nan=False)


@given(
    st.tuples(_coordinate, _coordinate, _angle),
    st.tuples(_coordinate, _coordinate, _angle),
    st.floats(0.01, 1.0),
)
def test_the_two_pose_distances_bound_each_other(a, b, length):
    """The Euclidean distance ``|(dp, L dtheta)|`` and the sum ``|dp| + L |dtheta|`` of two
    vectors' norms: ``e <= s <= sqrt(2) e`` (Cauchy-Schwarz); both see the angle wrapped, so a
    turn of ``2 pi`` changes neither beyond the rounding of the wrap (``4 eps`` of the angle)."""
    e = float(kinematics.pose_distance_euclidean(a, b, length))
    s = float(kinematics.pose_distance(a, b, length))
    tol = 1e-12 * (1.0 + s)
    assert e <= s + tol
    assert s <= math.sqrt(2.0) * e + tol
    turned = (b[0], b[1], b[2] + 2.0 * math.pi)
    slack = 4.0 * np.finfo(float).eps * (abs(a[2]) + abs(b[2]) + 2.0 * math.pi) * length
    assert abs(float(kinematics.pose_distance_euclidean(a, turned, length)) - e) <= slack + tol
    dx, dy = b[0] - a[0], b[1] - a[1]
    dth = (b[2] - a[2] + math.pi) % (2.0 * math.pi) - math.pi
    assert e == pytest.approx(math.sqrt(dx * dx + dy * dy + (length * dth) ** 2), rel=1e-12)


def test_pose_distance_euclidean_broadcasts_over_poses():
    poses = np.array([[0.1, 0.2, 0.3], [0.0, 0.0, math.pi - 0.1], [0.3, -0.1, -3.0]])
    ref = np.array([0.0, 0.1, -math.pi + 0.1])
    got = kinematics.pose_distance_euclidean(ref, poses, 0.5)
    assert got.shape == (3,)
    for i, p in enumerate(poses):
        assert got[i] == kinematics.pose_distance_euclidean(ref, p, 0.5)
