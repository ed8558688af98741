"""Tests of planar3p_gym.analysis.workspace: exactness against brute-force IK and the exact
swept-circle description, convergence, monotonicity, dead zones, symmetry and singularity loci."""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import pytest

from planar3p_gym.analysis.workspace import (
    constant_orientation_area,
    dead_zones,
    exact_workspace,
    full_plane,
    in_constant_orientation_workspace,
    label_components,
    margin_levels,
    orientations,
    parallel_singularity_points,
    reachable_exact,
    row_margins,
    search_grid,
    serial_singularity_points,
    singularity_map,
    singularity_segments,
    stroke_study,
    workspace,
)
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.kinematics import (
    ALL_MODES,
    classify_singularity,
    inverse,
    parallel_margin,
    serial_margin,
)


def brute_force(design, n, thetas, modes=ALL_MODES, half="upper"):
    """The paper's procedure, literally: IK at every grid point, orientation and mode."""
    x, y = search_grid(design, n, half)
    X, Y, T = np.meshgrid(x, y, thetas, indexing="ij")
    P = np.stack([X, Y, T], -1)[..., None, :]
    return inverse(design, P, np.atleast_2d(modes)).reachable.any(axis=(2, 3)).T


# ----------------------------------------------------------------------------- grid test
@pytest.mark.parametrize(
    "design",
    [
        Design.fig8(stroke=0.10),
        Design.fig8(stroke=0.22),
        Design.fig7(),
        Design.fig8(stroke=0.15, rail_origins=(0.0, 0.05, -0.03)),
    ],
    ids=["fig8-0.10", "fig8-0.22", "fig7", "offset-rails"],
)
def test_fast_grid_equals_brute_force_ik(design):
    thetas = orientations(30)
    ws = workspace(design, 37, 30)
    np.testing.assert_array_equal(ws.reachable, brute_force(design, 37, thetas))
    assert 0.0 < ws.S < 1.0


def test_options_fixed_mode_fixed_orientation_range_and_full_plane():
    d = Design.fig8(stroke=0.2)
    mode = (1, -1, 1)
    ws = workspace(d, 31, 24, mode=mode)
    np.testing.assert_array_equal(ws.reachable, brute_force(d, 31, orientations(24), mode))
    ws = workspace(d, 31, theta=math.radians(195))
    np.testing.assert_array_equal(ws.reachable, brute_force(d, 31, np.array([math.radians(195)])))
    ws = workspace(d, 31, 11, theta_range=(0.5, 2.0), half="full")
    np.testing.assert_array_equal(
        ws.reachable, brute_force(d, 31, np.linspace(0.5, 2.0, 11), half="full")
    )
    assert ws.y.size == 61 and ws.y[0] == -ws.y[-1]
    # per-mode masks are the single-mode workspaces
    ws = workspace(d, 31, 24, per_mode=True)
    for m in (0, 5):
        np.testing.assert_array_equal(
            ws.per_mode[m], workspace(d, 31, 24, mode=ALL_MODES[m]).reachable
        )
    np.testing.assert_array_equal(ws.per_mode.any(axis=0), ws.reachable)


# ----------------------------------------------------------------------------- exact tests
def test_exact_constant_orientation_test_matches_ik():
    rng = np.random.default_rng(3)
    for d in (Design.fig8(stroke=0.12), Design.fig7()):
        x0, x1, _, h = d.search_rectangle
        x = rng.uniform(x0, x1, 4000)
        y = rng.uniform(-h, h, 4000)
        th = rng.uniform(-math.pi, math.pi, 4000)
        pose = np.stack([x, y, th], -1)[:, None, :]
        ik = inverse(d, pose, ALL_MODES).reachable
        np.testing.assert_array_equal(in_constant_orientation_workspace(d, x, y, th), ik.any(-1))
        for m in (0, 3, 6):
            np.testing.assert_array_equal(
                in_constant_orientation_workspace(d, x, y, th, mode=ALL_MODES[m]), ik[:, m]
            )


def test_grid_converges_to_exact_constant_orientation_area():
    cases = [
        (Design.fig8(stroke=0.30), 4.0),
        (Design.fig8(stroke=0.10), 5.5),
        (Design.fig7(), 1.0),
        (Design.fig8(stroke=0.20), 0.3),
    ]
    for d, th in cases:
        exact = constant_orientation_area(d, th)
        assert exact > 0
        ns = (51, 201, 801, 3201)
        errs = [abs(workspace(d, n, theta=th).area - exact) / exact for n in ns]
        # O(1/n) convergence of the grid estimate of an indicator's integral
        assert all(e <= 4.0 / n for e, n in zip(errs, ns, strict=True)), errs
        assert errs[-1] < 1e-3, errs
        # S is the same quantity relative to the rectangle
        ws = workspace(d, 801, theta=th)
        assert ws.S * ws.rectangle_area == pytest.approx(exact, rel=4.0 / 801 + 2.0 / 801)
    # the whole plane and a custom rectangle work too
    d = Design.fig8(stroke=0.2)
    x0, x1, _, h = d.search_rectangle
    full = constant_orientation_area(d, 3.0, (x0, x1, -h, h))
    grid = workspace(d, 1601, theta=3.0, half="full").area
    assert abs(grid - full) / full < 4.0 / 1601


def test_exact_area_of_one_swept_circle():
    # One leg's region: the stadium (2 r L + pi r^2) minus the lens of the two discs of
    # radius r about the stroke ends (2 r^2 acos(L / 2r) - (L/2) sqrt(4 r^2 - L^2)).
    from planar3p_gym.analysis.workspace import _leg_boundary

    for r, L in ((0.17, 0.1), (0.19, 0.3), (2.5, 1.0), (0.1, 0.25)):
        prims = _leg_boundary(0, 0.3, -0.2, L, r)
        area = sum(p.green(0.0, 1.0) for p in prims)
        lens = 0.0
        if L < 2 * r:
            lens = 2 * r * r * math.acos(L / (2 * r)) - (L / 2) * math.sqrt(4 * r * r - L * L)
        assert area == pytest.approx(2 * r * L + math.pi * r * r - lens, rel=1e-12)


def test_reachable_exact_contains_sampled_and_matches_dense_sampling():
    rng = np.random.default_rng(7)
    d = Design.fig8(stroke=0.18)
    x0, x1, _, h = d.search_rectangle
    x = rng.uniform(x0, x1, 500)
    y = rng.uniform(-h, h, 500)
    exact = reachable_exact(d, x, y)
    dense = np.zeros(x.size, dtype=bool)
    th = np.linspace(0, 2 * math.pi, 20000, endpoint=False)
    for c in range(0, th.size, 2000):
        dense |= in_constant_orientation_workspace(d, x[:, None], y[:, None], th[c : c + 2000]).any(
            -1
        )
    assert not (dense & ~exact).any()  # never misses an orientation the sampling finds
    assert (exact & ~dense).sum() <= 3  # only points reachable in windows < 0.018 deg
    # per mode and within a range
    mode = (1, 1, 1)
    assert not (
        in_constant_orientation_workspace(d, x[:, None], y[:, None], th[::10], mode).any(-1)
        & ~reachable_exact(d, x, y, mode=mode)
    ).any()
    inside = reachable_exact(d, x, y, theta_range=(0.2, 1.0))
    thr = np.linspace(0.2, 1.0, 2001)
    sampled = in_constant_orientation_workspace(d, x[:, None], y[:, None], thr).any(-1)
    assert not (sampled & ~inside).any()
    assert (inside & ~sampled).sum() <= 3
    # grid version
    ew = exact_workspace(d, 41)
    sw = workspace(d, 41, 90)
    assert not (sw.reachable & ~ew.reachable).any()


# ----------------------------------------------------------------------------- stroke study
def test_relative_workspace_never_decreases_with_stroke():
    strokes = np.linspace(0.10, 0.30, 21)
    st = stroke_study(Design.fig8(), strokes, n=101, n_theta=120)
    assert np.all(np.diff(st.S) >= 0), st.S
    assert np.all(np.diff(st.S_usable) >= 0), st.S_usable
    assert np.all(st.S_usable <= st.S)
    # the reachable set itself grows (as sets, on a common grid)
    d = Design.fig8(stroke=0.30)
    prev = None
    for L in (0.10, 0.16, 0.22, 0.30):
        x, y = search_grid(d, 81)
        reach = reachable_exact(d.with_(stroke=L), x[None, :], y[:, None])
        if prev is not None:
            assert not (prev & ~reach).any()
        prev = reach


def test_study_matches_single_workspaces():
    d = Design.fig8()
    strokes = [0.12, 0.27]
    st = stroke_study(d, strokes, n=51, n_theta=48, keep_masks=True)
    for i, L in enumerate(strokes):
        ws = workspace(d.with_(stroke=L), 51, 48, usable=True)
        np.testing.assert_array_equal(st.masks[i], ws.reachable)
        np.testing.assert_array_equal(st.usable_masks[i], ws.usable)
        assert st.S[i] == ws.S and st.S_usable[i] == ws.S_usable
        assert st.dead_zones[i] == dead_zones(ws).count


# ----------------------------------------------------------------------------- dead zones
def _bfs_count(mask):
    ny, nx = mask.shape
    seen = np.zeros_like(mask)
    count = 0
    for j in range(ny):
        for i in range(nx):
            if mask[j, i] and not seen[j, i]:
                count += 1
                q = deque([(j, i)])
                seen[j, i] = True
                while q:
                    a, b = q.popleft()
                    for da, db in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                        c, e = a + da, b + db
                        if 0 <= c < ny and 0 <= e < nx and mask[c, e] and not seen[c, e]:
                            seen[c, e] = True
                            q.append((c, e))
    return count


def test_label_components_matches_breadth_first_search():
    rng = np.random.default_rng(0)
    for p in (0.3, 0.55, 0.7):
        mask = rng.random((40, 55)) < p
        labels, count = label_components(mask)
        assert count == _bfs_count(mask)
        assert (labels[~mask] == -1).all()
        # neighbours on the mask share a label
        both = mask[:, 1:] & mask[:, :-1]
        assert (labels[:, 1:][both] == labels[:, :-1][both]).all()
        both = mask[1:] & mask[:-1]
        assert (labels[1:][both] == labels[:-1][both]).all()


def _rail_gaps(design, n_x=4001):
    """Exactly unreachable stretches of the rail line between reachable points."""
    x0, x1, _, _ = design.search_rectangle
    x = np.linspace(x0, x1, n_x)
    r = reachable_exact(design, x, np.zeros_like(x))
    idx = np.flatnonzero(r)
    return x[idx[0] : idx[-1] + 1][~r[idx[0] : idx[-1] + 1]]


def test_short_stroke_has_a_dead_zone_long_stroke_has_none():
    d = Design.fig8()
    # The exact description picks the strokes.  With G on the rail line at x = L/2, leg 3
    # (L_3G = 0.1, L_3 = 0.19) stays closer than L_3 to both stroke ends whenever
    # 0.1^2 + L^2/4 + 0.1 L < 0.19^2, i.e. L < 0.18: the centre is unreachable for every
    # orientation, while the envelope surrounds it.
    short, long_ = 0.15, 0.40
    assert 0.1**2 + short**2 / 4 + 0.1 * short < 0.19**2
    gaps = _rail_gaps(d.with_(stroke=short))
    assert gaps.size and gaps.min() < short / 2 < gaps.max()
    assert _rail_gaps(d.with_(stroke=long_)).size == 0
    ws_short = workspace(d.with_(stroke=short), 101, 180)
    ws_long = workspace(d.with_(stroke=long_), 101, 180)
    dz_short, dz_long = dead_zones(ws_short), dead_zones(ws_long)
    assert dz_short.count >= 1 and dz_long.count == 0
    # the hole contains the centre of the stroke segment on the rail line
    j = np.argmin(np.abs(dz_short.y))
    i = np.argmin(np.abs(dz_short.x - short / 2))
    assert dz_short.labels[j, i] >= 0
    assert dz_short.exact
    # ...and every point of the hole is unreachable by the exact test
    hy, hx = np.nonzero(dz_short.labels >= 0)
    assert not reachable_exact(d.with_(stroke=short), dz_short.x[hx], dz_short.y[hy]).any()
    # without the refinement, sampling artefacts add spurious one-point holes, never fewer
    assert dead_zones(ws_short, refine=False).count >= dz_short.count


def test_dead_zone_straddles_the_rail_line():
    # judged on the whole plane: the upper half alone sees the hole touch its boundary y = 0
    d = Design.fig8(stroke=0.2)
    ws = workspace(d, 81, 120)
    dz = dead_zones(ws)
    assert dz.count >= 1
    rows = np.flatnonzero((dz.labels >= 0).any(axis=1))
    assert dz.y[rows].min() < 0 < dz.y[rows].max()
    upper_only = dead_zones(ws.reachable, refine=False)
    assert upper_only.count < dz.count or upper_only.total_area < dz.total_area


# ----------------------------------------------------------------------------- symmetry
def test_mirror_symmetry_about_the_rails():
    for d in (Design.fig8(stroke=0.2), Design.fig7()):
        ws = workspace(d, 61, 90, half="full")
        np.testing.assert_array_equal(ws.reachable, ws.reachable[::-1])
        y_full, mirrored = full_plane(workspace(d, 61, 90))
        np.testing.assert_array_equal(y_full, ws.y)
        np.testing.assert_array_equal(mirrored, ws.reachable)
    d = Design.fig8(stroke=0.25)
    rng = np.random.default_rng(5)
    x = rng.uniform(-0.3, 0.5, 3000)
    y = rng.uniform(-0.3, 0.3, 3000)
    np.testing.assert_array_equal(reachable_exact(d, x, y), reachable_exact(d, x, -y))
    # constant orientation: (x, y, theta) mirrors to (x, -y, -theta)
    np.testing.assert_array_equal(
        in_constant_orientation_workspace(d, x, y, 0.7),
        in_constant_orientation_workspace(d, x, -y, -0.7),
    )
    h = d.search_height
    x0, x1, _, _ = d.search_rectangle
    assert constant_orientation_area(d, 0.7, (x0, x1, 0, h)) == pytest.approx(
        constant_orientation_area(d, -0.7, (x0, x1, -h, 0)), rel=1e-12
    )
    # singularity functions: det A(-y, -theta) = det A(y, theta), det B likewise
    sm = singularity_map(d, n_y=41, n_theta=37)
    np.testing.assert_allclose(sm.det_A, sm.det_A[:, ::-1, ::-1], atol=1e-12)
    np.testing.assert_allclose(sm.det_B, sm.det_B[:, ::-1, ::-1], atol=1e-12)
    np.testing.assert_array_equal(sm.feasible, sm.feasible[:, ::-1, ::-1])


# ----------------------------------------------------------------------------- margins
def test_row_margins_match_kinematics_at_any_x():
    d = Design.fig8()
    rng = np.random.default_rng(2)
    y = rng.uniform(-0.29, 0.29, 12)
    th = rng.uniform(-math.pi, math.pi, 10)
    mg = row_margins(d, y, th)
    for x in (-0.1, 0.2, 0.45):
        P = np.broadcast_to(
            np.stack(np.broadcast_arrays(x, y[:, None, None], th[None, :, None]), -1),
            (12, 10, 8, 3),
        )
        rho = inverse(d, P, ALL_MODES).rho
        ok = np.isfinite(rho).all(-1)
        assert ok.sum() > 50
        np.testing.assert_allclose(parallel_margin(d, P[ok], rho[ok]), mg.parallel[ok], atol=1e-9)
        np.testing.assert_allclose(serial_margin(d, P[ok], rho[ok]), mg.serial[ok], atol=1e-12)


def test_usable_workspace_definition():
    d = Design.fig8(stroke=0.25)
    tp, ts = 0.08, 0.2
    ws = workspace(d, 25, 36, usable=True, min_parallel=tp, min_serial=ts)
    assert not (ws.usable & ~ws.reachable).any()
    assert 0 < ws.S_usable < ws.S
    X, Y, T = np.meshgrid(ws.x, ws.y, ws.thetas, indexing="ij")
    P = np.broadcast_to(np.stack([X, Y, T], -1)[..., None, :], X.shape + (8, 3))
    ik = inverse(d, P, ALL_MODES)
    ok = ik.reachable
    pm = np.zeros(ok.shape)
    sm = np.zeros(ok.shape)
    pm[ok] = parallel_margin(d, P[ok], ik.rho[ok])
    sm[ok] = serial_margin(d, P[ok], ik.rho[ok])
    brute = (ok & (pm >= tp) & (sm >= ts)).any(axis=(2, 3)).T
    # thresholds compared with margins from two formulas (closed form vs SVD): allow a
    # point whose best margin sits within 1e-9 of the threshold
    near = (ok & (np.abs(pm - tp) < 1e-9)).any(axis=(2, 3)).T
    assert not ((brute != ws.usable) & ~near).any()
    # margin levels: usable at a level iff best >= level
    _, _, best = margin_levels(d, (0.0, tp), 25, 36, min_serial=ts)
    np.testing.assert_array_equal(best >= tp, ws.usable)


# ----------------------------------------------------------------------------- singularities
def test_parallel_singularity_curves_are_classified_parallel():
    d = Design.fig8()
    thetas = np.linspace(-math.pi, math.pi, 9)
    seen = 0
    for mode in ALL_MODES:
        ys, ts = parallel_singularity_points(d, thetas, mode)
        for yv, tv in zip(ys, ts, strict=True):
            pose = np.array([0.07, yv, tv])
            rho = inverse(d, pose, mode).rho
            rep = classify_singularity(d, pose, rho)
            assert rep.kind == "parallel" and rep.at_singularity, (mode, yv, tv, rep)
            seen += 1
    assert seen > 40
    # and the map's det A changes sign across them
    sm = singularity_map(d, n_y=201, n_theta=9)
    assert np.nanmin(sm.det_A) < 0 < np.nanmax(sm.det_A)


def test_serial_singularity_curves_are_classified_serial():
    d = Design.fig8()
    ys, ts, legs = serial_singularity_points(d, np.linspace(-3, 3, 13))
    k = np.array(d.joint_offsets)
    L = np.array(d.leg_lengths)
    checked = 0
    for yv, tv, leg in zip(ys, ts, legs, strict=True):
        cy = yv + k * math.sin(tv)
        if np.any(np.abs(cy) > L * (1 + 1e-12)):
            continue  # another leg cannot close there
        pose = np.array([0.1, yv, tv])
        rho = inverse(d, pose, (1, 1, 1)).rho
        if not np.isfinite(rho).all():  # rounding pushed C_iy a hair beyond L_i
            continue
        rep = classify_singularity(d, pose, rho, tol=1e-6)
        assert rep.kind == "serial" and rep.leg == leg and rep.at_singularity, rep
        checked += 1
    assert checked >= 20


def test_plane_singularity_segments_lie_in_the_workspace():
    d = Design.fig8()
    th = math.radians(195)
    segs = singularity_segments(d, th)
    kinds = {s.kind for s in segs}
    assert kinds == {"parallel", "serial"}
    for s in segs:
        mode = np.array(s.mode)
        for x in (s.x0, 0.5 * (s.x0 + s.x1), s.x1):
            pose = np.array([x, s.y, th])
            rho = inverse(d, pose, mode).rho
            if s.kind == "serial":  # C_iy = +-L_i to rounding: use the branch-free travel
                rho = np.where(
                    np.isfinite(rho),
                    rho,
                    x + np.array(d.joint_offsets) * math.cos(th) - np.array(d.rail_origins),
                )
            assert np.all(rho >= -1e-9) and np.all(rho <= d.stroke + 1e-9)
            rep = classify_singularity(d, pose, rho, tol=1e-6)
            assert rep.at_singularity and rep.kind == s.kind, (s, rep)


# ----------------------------------------------------------------------------- validation
def test_bad_arguments():
    d = Design.fig8()
    with pytest.raises(ValueError):
        workspace(d, 1)
    with pytest.raises(ValueError):
        workspace(d, 11, mode=(1, 0, 1))
    with pytest.raises(ValueError):
        orientations(0)
    with pytest.raises(ValueError):
        orientations(5, theta_range=(1.0, 0.0))
    with pytest.raises(ValueError):
        stroke_study(d, [0.1, -0.2])
    with pytest.raises(ValueError):
        workspace("fig8", 11)  # type: ignore[arg-type]
