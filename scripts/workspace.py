"""Workspace and singularity study of the 3-PRR manipulator (MECHANISM.md, Section 6).

Runs the paper's relative-workspace study ``S(L)`` on the ``fig8`` preset (21 strokes from
0.10 to 0.30 m, 201 x 201 grid, 360 orientations, 8 working modes) on one core and prints its
time, writes the ``S(L)`` / usable ``S(L)`` table (markdown and CSV), recommends a stroke (the
shortest one without dead zones), and draws the figures:

* ``workspace_fig7.png``: the workspace map of the ``fig7`` preset (the paper's Figure 7);
* ``workspace_stroke.png``: ``S`` and usable ``S`` versus the stroke (the paper's Figure 8);
* ``workspace_dead_zones.png``: the whole-plane workspace of ``fig8`` at a few strokes;
* ``workspace_singularities_ytheta.png``: ``det A = 0`` and ``det B = 0`` over ``(y, theta)``
  with the workspace boundary, per working mode;
* ``workspace_singularities_plane.png``: the same loci in the plane at a fixed orientation.

Usage::

    .venv/bin/python scripts/workspace.py            # full study, figures, tables -> docs/
    .venv/bin/python scripts/workspace.py --quick    # coarse settings, for a smoke test
"""

from __future__ import annotations

import os

# One core, one thread: set before numpy is imported.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import csv  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import BoundaryNorm, ListedColormap  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch, Rectangle  # noqa: E402

from planar3p_gym.design import Design  # noqa: E402
from planar3p_gym.kinematics import ALL_MODES, inverse  # noqa: E402
from planar3p_gym.workspace import (  # noqa: E402
    DEFAULT_MIN_PARALLEL,
    DEFAULT_MIN_SERIAL,
    StrokeStudy,
    dead_zones,
    full_plane,
    margin_levels,
    reachable_exact,
    serial_singularity_points,
    singularity_map,
    singularity_segments,
    stroke_study,
    workspace,
)

ROOT = Path(__file__).resolve().parents[1]


def rel(path: Path) -> str:
    """``path`` relative to the repository if inside it."""
    try:
        return str(path.resolve().relative_to(ROOT))
    except ValueError:
        return str(path)


# ------------------------------------------------------------------------------ helpers
def pin_one_core() -> str:
    """Pin this process to one CPU (Linux); returns a description."""
    if hasattr(os, "sched_setaffinity"):
        cpus = sorted(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpus[-1]})
        return f"pinned to CPU {cpus[-1]} (of {len(cpus)})"
    return "not pinned (no sched_setaffinity)"


def timed(fn, repeats: int):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, times


def mode_label(mode) -> str:
    return "(" + ",".join("+" if s > 0 else "-" for s in mode) + ")"


def draw_rails(ax, design: Design, label: bool = True) -> None:
    for i, a in enumerate(design.rail_origins):
        ax.plot(
            [a, a + design.stroke],
            [0, 0],
            color="k",
            lw=3,
            solid_capstyle="butt",
            label="stroke segments (rails)" if (label and i == 0) else None,
        )


def draw_rectangle(ax, design: Design, full: bool, label: bool = True) -> None:
    x0, x1, _, h = design.search_rectangle
    y0 = -h if full else 0.0
    ax.add_patch(
        Rectangle(
            (x0, y0),
            x1 - x0,
            h - y0,
            fill=False,
            ls="--",
            lw=1,
            ec="0.3",
            label="search rectangle (and its mirror)" if label else None,
        )
    )


# ------------------------------------------------------------------------------ study
def run_study(args) -> dict:
    d8 = Design.fig8()
    strokes = np.round(np.linspace(0.10, 0.30, 21), 10)
    n, nt = args.grid, args.orientations
    print(
        f"S(L) study: fig8, {strokes.size} strokes {strokes[0]:.2f}..{strokes[-1]:.2f} m, "
        f"{n} x {n} grid, {nt} orientations, {len(ALL_MODES)} working modes"
    )

    def core():
        return stroke_study(d8, strokes, n=n, n_theta=nt, usable=False, count_dead_zones=False)

    def full():
        return stroke_study(d8, strokes, n=n, n_theta=nt, usable=True, count_dead_zones=True)

    _, t_core = timed(core, args.repeats)
    study, t_full = timed(full, args.repeats)
    evals = strokes.size * n * n * nt * len(ALL_MODES)
    print(
        f"  reachable S(L) only            : median {statistics.median(t_core):.3f} s "
        f"(runs: {', '.join(f'{t:.3f}' for t in t_core)})"
    )
    print(
        f"  S(L) + usable S(L) + dead zones: median {statistics.median(t_full):.3f} s "
        f"(runs: {', '.join(f'{t:.3f}' for t in t_full)})"
    )
    print(f"  ({evals:.3g} pose/mode tests, equivalent to brute-force IK on every one)")

    # Beyond the paper's range: where do the dead zones end?
    ext = np.round(np.arange(0.31, args.ext_max + 1e-9, 0.01), 10)
    ext_study = stroke_study(d8, ext, n=n, n_theta=nt, usable=True, count_dead_zones=True)
    rec = recommend(d8, study, ext_study, quick=args.quick)
    return dict(study=study, ext=ext_study, t_core=t_core, t_full=t_full, evals=evals, rec=rec)


def _runs(x: np.ndarray, gap: np.ndarray) -> list[tuple[float, float, float]]:
    """Runs of True in ``gap`` as ``(first x, last x, sampling step)``."""
    d = np.diff(np.concatenate([[0], gap.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1
    step = float(x[1] - x[0]) if x.size > 1 else 0.0
    return [(float(x[i]), float(x[j]), step) for i, j in zip(starts, ends, strict=True)]


def rail_gaps(design: Design, n_x: int = 40001) -> list[tuple[float, float, float]]:
    """Exactly unreachable stretches of the rail line ``y = 0`` lying between reachable points
    (holes crossing the rail line), with continuous orientations, sampled at ``n_x`` points."""
    x0, x1, _, _ = design.search_rectangle
    x = np.linspace(x0, x1, n_x)
    r = reachable_exact(design, x, np.zeros_like(x))
    idx = np.flatnonzero(r)
    if idx.size == 0:
        return []
    sl = slice(idx[0], idx[-1] + 1)
    return _runs(x[sl], ~r[sl])


def rail_gaps_near(
    design: Design, runs: list[tuple[float, float, float]], n_w: int = 4001
) -> list[tuple[float, float, float]]:
    """The gaps of the rail line inside windows around earlier ``runs`` (a longer stroke only
    adds reachable points, so its gaps lie inside those of a shorter one); each window is
    sampled with ``n_w`` points, so the resolution grows as the gaps shrink."""
    out = []
    for a, b, step in runs:
        x = np.linspace(a - step, b + step, n_w)
        r = reachable_exact(design, x, np.zeros_like(x))
        out += _runs(x, ~r)
    return out


def recommend(design: Design, study: StrokeStudy, ext: StrokeStudy, quick: bool) -> dict:
    """The stroke recommendation (the paper's: the shortest stroke without dead zones).

    1. On the grid study (0.01 m steps): the shortest stroke without dead zones, for it and
       for every longer stroke studied.
    2. On the rail line, where this design's dead zones sit, the exact test (continuous
       orientations) locates the stroke at which the holes close, by bisection with sampling
       windows that shrink with the gaps; the grid may miss a hole narrower than its spacing,
       so this refines (1).
    3. Recommended: the first 0.01 m step at or above both.
    """
    all_L = np.concatenate([study.strokes, ext.strokes])
    all_dz = np.concatenate([study.dead_zones, ext.dead_zones])
    clear = np.logical_and.accumulate(all_dz[::-1] == 0)[::-1]
    out: dict = dict(grid=None, rail=None, final=None, in_study=study.recommended_stroke())
    if not clear.any():
        return out
    j = int(np.flatnonzero(clear)[0])
    out["grid"] = float(all_L[j])
    out["final"] = out["grid"]
    if j == 0:
        return out
    lo, hi = float(all_L[j - 1]), float(all_L[j])
    runs = rail_gaps(design.with_(stroke=lo), 8001 if quick else 40001)
    if not runs:
        return out  # the last holes found by the grid do not cross the rail line
    while True:
        found = rail_gaps_near(design.with_(stroke=hi), runs)
        if not found:
            break
        lo, hi, runs = hi, round(hi + 0.01, 10), found
        if hi > 1.0:
            return out
    for _ in range(16 if quick else 30):
        mid = 0.5 * (lo + hi)
        found = rail_gaps_near(design.with_(stroke=mid), runs)
        if found:
            lo, runs = mid, found
        else:
            hi = mid
    out["rail"] = dict(lo=lo, hi=hi, last_gaps=[(round(a, 7), round(b, 7)) for a, b, _ in runs])
    out["final"] = max(out["grid"], math.ceil(round(hi * 100, 6)) / 100)
    return out


# ------------------------------------------------------------------------------ verification
def verify(args) -> dict:
    """Fast grid versus brute-force :func:`planar3p_gym.kinematics.inverse` on a reduced
    setting, and the brute-force rate, to extrapolate its time for the full study."""
    n, nt = (41, 24) if args.quick else (61, 72)
    mism, tested, t_brute = 0, 0, 0.0
    for L in (0.10, 0.20, 0.30):
        d = Design.fig8(stroke=L)
        ws = workspace(d, n, nt)
        t0 = time.perf_counter()
        X, Y, T = np.meshgrid(ws.x, ws.y, ws.thetas, indexing="ij")
        P = np.stack([X, Y, T], -1)[..., None, :]
        brute = inverse(d, P, ALL_MODES).reachable.any(axis=(2, 3)).T
        t_brute += time.perf_counter() - t0
        mism += int((brute != ws.reachable).sum())
        tested += brute.size
    rate = 3 * n * n * nt * len(ALL_MODES) / t_brute
    print(
        f"verification: {tested} grid points ({n} x {n}, {nt} orientations, 3 strokes) -- "
        f"fast grid vs brute-force kinematics.inverse: {mism} mismatches; brute force "
        f"{rate:.3g} pose/mode tests per s"
    )
    return dict(mismatches=mism, tested=tested, rate=rate, n=n, nt=nt)


# ------------------------------------------------------------------------------ tables
def _stroke_table(rows: list[dict], paper_range: str) -> list[str]:
    """Markdown table lines of the study rows whose ``paper_range`` is ``"yes"`` or ``"no"``."""
    lines = [
        "| stroke L (m) | S | usable S | dead zones | dead-zone area (cm^2) |",
        "|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        if r["paper_range"] == paper_range:
            lines.append(
                f"| {r['stroke_m']} | {r['S']} | {r['S_usable']} | {r['dead_zones']} | "
                f"{r['dead_zone_area_cm2']} |"
            )
    return lines


def write_tables(out: Path, res: dict, args) -> str | None:
    study: StrokeStudy = res["study"]
    ext: StrokeStudy = res["ext"]
    rec = res["rec"]
    rows = []
    for st, in_range in ((study, True), (ext, False)):
        for i, L in enumerate(st.strokes):
            rows.append(
                dict(
                    stroke_m=f"{L:.2f}",
                    S=f"{st.S[i]:.4f}",
                    S_usable=f"{st.S_usable[i]:.4f}",
                    dead_zones=int(st.dead_zones[i]),
                    dead_zone_area_cm2=f"{st.dead_zone_area[i] * 1e4:.1f}",
                    paper_range="yes" if in_range else "no",
                )
            )
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "workspace_table.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    n, nt = study.n[0], study.n_theta
    lines = [
        "# Relative workspace versus stroke (`fig8` preset)",
        "",
        f"Grid {n} x {n} over the search rectangle, {nt} orientations, all 8 working modes. "
        "`S` = reachable grid points / all grid points (upper half, as in the paper). "
        f"Usable: reachable with parallel margin >= {DEFAULT_MIN_PARALLEL:.2f} and serial "
        f"margin >= {DEFAULT_MIN_SERIAL:.2f} for the same orientation and working mode. "
        "Dead zones: holes of the whole-plane workspace (the upper half and its mirror "
        "image), unreachable grid points re-tested over the continuum of orientations; "
        "area is a grid estimate.",
        "",
        *_stroke_table(rows, paper_range="yes"),
        "",
        "Beyond the paper's range (same settings):",
        "",
        *_stroke_table(rows, paper_range="no"),
        "",
    ]
    if rec["in_study"] is not None:
        rec_text = (
            f"**Recommended stroke: L = {rec['final']:.2f} m**, the shortest without dead zones "
            f"(grid: {rec['grid']:.2f} m)."
        )
    elif rec["final"] is not None:
        rec_text = (
            "**No stroke from 0.10 to 0.30 m is free of dead zones on this design.** "
            f"On the grid, the shortest stroke without dead zones (for it and every longer one "
            f"studied) is {rec['grid']:.2f} m."
        )
        if rec["rail"] is not None:
            rec_text += (
                " The last holes sit across the rail line; there the exact test (continuous "
                "orientations, bisection on the stroke with sampling windows shrinking with the "
                f"gaps) finds them closing at L = {rec['rail']['hi']:.5f} m."
            )
        rec_text += f" **Recommended stroke: L = {rec['final']:.2f} m.**"
    else:
        rec_text = "No stroke studied is free of dead zones."
    lines.append(rec_text)
    lines.append("")
    (out / "workspace_table.md").write_text("\n".join(lines))
    print(rec_text.replace("**", ""))
    return rec_text


# ------------------------------------------------------------------------------ figures
def fig_fig7(out: Path, args) -> dict:
    d = Design.fig7()
    n, nt = args.grid, args.orientations
    ws = workspace(d, n, nt, usable=True, per_mode=True)
    y_full, _ = full_plane(ws)
    count = ws.per_mode.sum(axis=0)
    count = np.concatenate([count[:0:-1], count])
    dz = dead_zones(ws)
    _, _, best = margin_levels(d, (0.0, 0.01, 0.02, 0.03, 0.05), n, nt)
    best = np.concatenate([best[:0:-1], best])
    extent = [ws.x[0], ws.x[-1], y_full[0], y_full[-1]]

    fig, axs = plt.subplots(1, 2, figsize=(13, 5.2), constrained_layout=True)
    ax = axs[0]
    cmap = ListedColormap(plt.get_cmap("viridis")(np.linspace(0.05, 0.95, 8)))
    img = np.where(count > 0, count, np.nan)
    im = ax.imshow(
        img, origin="lower", extent=extent, cmap=cmap, norm=BoundaryNorm(np.arange(0.5, 9), 8)
    )
    holes = np.where(dz.labels >= 0, 1.0, np.nan)
    ax.imshow(holes, origin="lower", extent=extent, cmap=ListedColormap(["red"]), alpha=0.8)
    fig.colorbar(im, ax=ax, ticks=range(1, 9), label="working modes reaching the point")
    draw_rails(ax, d)
    draw_rectangle(ax, d, full=True)
    handles, _ = ax.get_legend_handles_labels()
    handles.append(Patch(color="red", alpha=0.8, label=f"dead zone ({dz.count})"))
    ax.legend(handles=handles, loc="upper right", fontsize=8)
    ax.set_title(
        f"reachable workspace: S = {ws.S:.3f}\n({n}x{n} grid per half, {nt} orientations, "
        "8 working modes)"
    )
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")

    ax = axs[1]
    levels = [0.0, 0.01, 0.02, 0.03, 0.05]
    cmap2 = ListedColormap(plt.get_cmap("magma")(np.linspace(0.15, 0.95, len(levels))))
    im2 = ax.imshow(
        best,
        origin="lower",
        extent=extent,
        cmap=cmap2,
        norm=BoundaryNorm(levels + [1.0], len(levels)),
    )
    cb = fig.colorbar(im2, ax=ax, label="best parallel margin reachable (at least)")
    cb.set_ticks([0.005, 0.015, 0.025, 0.04, 0.5])
    cb.set_ticklabels([">= 0", ">= 0.01", ">= 0.02", ">= 0.03", ">= 0.05"])
    draw_rails(ax, d)
    draw_rectangle(ax, d, full=True)
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(
        f"usable (parallel margin >= {DEFAULT_MIN_PARALLEL:.2f}, serial >= "
        f"{DEFAULT_MIN_SERIAL:.2f}): "
        f"S = {ws.S_usable:.3f}\ncolour: best parallel margin over orientations and modes"
    )
    fig.suptitle(
        f"fig7 preset (legs {d.leg_lengths[0]} m, spacings {d.spacings[0]} m, stroke "
        f"{d.stroke} m): workspace map, whole plane (the paper's Figure 7 setting)"
    )
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    path = out / "figures" / "workspace_fig7.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(
        f"fig7: S = {ws.S:.4f}, usable S = {ws.S_usable:.4f}, dead zones = {dz.count} "
        f"({dz.total_area:.3f} m^2) -> {rel(path)}"
    )
    return dict(S=ws.S, S_usable=ws.S_usable, dead_zones=dz.count, dz_area=dz.total_area)


def fig_stroke(out: Path, res: dict, rec_info: dict) -> None:
    rec = rec_info["final"]
    study: StrokeStudy = res["study"]
    ext: StrokeStudy = res["ext"]
    L = np.concatenate([study.strokes, ext.strokes])
    S = np.concatenate([study.S, ext.S])
    Su = np.concatenate([study.S_usable, ext.S_usable])
    dza = np.concatenate([study.dead_zone_area, ext.dead_zone_area]) * 1e4
    fig, axs = plt.subplots(1, 2, figsize=(12, 4.6), constrained_layout=True)
    ax = axs[0]
    ns = study.strokes.size
    ax.plot(L[:ns], S[:ns], "o-", color="C0", label="S (reachable)")
    ax.plot(L[:ns], Su[:ns], "s-", color="C1", label="usable S")
    ax.plot(L[ns - 1 :], S[ns - 1 :], "o:", color="C0", alpha=0.6, label="beyond 0.30 m")
    ax.plot(L[ns - 1 :], Su[ns - 1 :], "s:", color="C1", alpha=0.6)
    ax.axvspan(0.30, L[-1] + 0.005, color="0.92", zorder=0)
    ax.set_xlabel("stroke L (m)")
    ax.set_ylabel("relative workspace S")
    ax.set_ylim(0, 1)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    ax.set_title(
        f"fig8 preset: S versus stroke (paper's Figure 8)\n{study.n[0]}x{study.n[1]} grid, "
        f"{study.n_theta} orientations, 8 modes; usable: margins >= "
        f"{DEFAULT_MIN_PARALLEL:.2f} / {DEFAULT_MIN_SERIAL:.2f}"
    )
    ax = axs[1]
    ax.plot(L, dza, "o-", color="C3", label="dead-zone area (whole plane)")
    dz = np.concatenate([study.dead_zones, ext.dead_zones])
    for x, a, c in zip(L, dza, dz, strict=True):
        ax.annotate(
            str(c), (x, a), textcoords="offset points", xytext=(0, 5), fontsize=7, ha="center"
        )
    if rec is not None:
        ax.axvline(rec, color="k", ls="--", label=f"recommended stroke: {rec:.2f} m")
    if rec_info.get("rail"):
        lstar = rec_info["rail"]["hi"]
        ax.axvline(
            lstar, color="0.4", ls=":", label=f"holes close (exact, rail line): {lstar:.4f} m"
        )
    ax.axvspan(0.30, L[-1] + 0.005, color="0.92", zorder=0)
    ax.set_xlabel("stroke L (m)")
    ax.set_ylabel("dead-zone area (cm$^2$)")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    ax.set_title("dead zones (holes inside the envelope); labels: number of holes")
    path = out / "figures" / "workspace_stroke.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"-> {rel(path)}")


def fig_dead_zones(out: Path, args) -> None:
    strokes = (0.10, 0.20, 0.30, 0.36)
    fig, axs = plt.subplots(1, 4, figsize=(17, 4.4), constrained_layout=True)
    for ax, L in zip(axs, strokes, strict=True):
        d = Design.fig8(stroke=L)
        ws = workspace(d, args.grid, args.orientations, usable=True)
        y_full, reach = full_plane(ws)
        use = np.concatenate([ws.usable[:0:-1], ws.usable])
        dz = dead_zones(ws)
        img = np.zeros(reach.shape)
        img[reach] = 1
        img[use] = 2
        img[dz.labels >= 0] = 3
        cmap = ListedColormap(["white", "#f4a259", "#5b8e7d", "#bc4b51"])
        ax.imshow(
            img,
            origin="lower",
            extent=[ws.x[0], ws.x[-1], y_full[0], y_full[-1]],
            cmap=cmap,
            vmin=-0.5,
            vmax=3.5,
            interpolation="nearest",
        )
        draw_rails(ax, d)
        draw_rectangle(ax, d, full=True)
        ax.set_title(f"L = {L:.2f} m: S = {ws.S:.3f}, {dz.count} dead zone(s)")
        ax.set_xlabel("x (m)")
        ax.set_aspect("equal")
    axs[0].set_ylabel("y (m)")
    handles = [
        Patch(color="#5b8e7d", label="usable"),
        Patch(color="#f4a259", label="reachable, not usable"),
        Patch(color="#bc4b51", label="dead zone"),
        Line2D([], [], color="k", lw=3, label="stroke segment"),
        Line2D([], [], color="0.3", ls="--", label="search rectangle + mirror"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=5, bbox_to_anchor=(0.5, -0.08))
    fig.suptitle("fig8 preset: whole-plane workspace and its dead zones as the stroke grows")
    path = out / "figures" / "workspace_dead_zones.png"
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)
    print(f"-> {rel(path)}")


def fig_sing_ytheta(out: Path, args) -> None:
    d = Design.fig8()
    ny, nt = (201, 241) if args.quick else (401, 541)
    sm = singularity_map(d, n_y=ny, n_theta=nt)
    deg = np.degrees(sm.thetas)
    fig, axs = plt.subplots(
        2, 4, figsize=(17, 8), sharex=True, sharey=True, constrained_layout=True
    )
    ser_y, ser_t, ser_leg = serial_singularity_points(d, sm.thetas)
    for m, ax in enumerate(axs.ravel()):
        closable = np.isfinite(sm.det_A[m])
        feas = sm.feasible[m]
        shade = np.where(feas, 2.0, np.where(closable, 1.0, np.nan))
        ax.pcolormesh(
            deg,
            sm.y,
            shade,
            cmap=ListedColormap(["#e8e8e8", "#bcd4e6"]),
            vmin=0.5,
            vmax=2.5,
            shading="auto",
            rasterized=True,
        )
        detA = np.ma.masked_invalid(sm.det_A[m])
        ax.contour(deg, sm.y, detA, levels=[0.0], colors="red", linewidths=1.4)
        ax.contour(deg, sm.y, feas.astype(float), levels=[0.5], colors="k", linewidths=1.0)
        for leg, color in zip(range(3), ("C0", "C2", "C4"), strict=True):
            sel = ser_leg == leg
            for sgn in (0, 1):
                yy = ser_y[sel][sgn::2]
                ax.plot(np.degrees(ser_t[sel][sgn::2]), yy, ls="--", color=color, lw=1)
        ax.set_title(f"working mode {mode_label(sm.modes[m])}")
        ax.set_xlim(-180, 180)
        ax.set_ylim(sm.y[0], sm.y[-1])
        ax.set_xticks(range(-180, 181, 90))
    for ax in axs[1]:
        ax.set_xlabel("orientation theta (deg)")
    for ax in axs[:, 0]:
        ax.set_ylabel("y (m)")
    handles = [
        Line2D([], [], color="red", lw=1.4, label="det A = 0 (parallel singularity)"),
        Line2D([], [], color="C0", ls="--", label="det B = 0, leg 1 (serial)"),
        Line2D([], [], color="C2", ls="--", label="det B = 0, leg 2"),
        Line2D([], [], color="C4", ls="--", label="det B = 0, leg 3"),
        Line2D([], [], color="k", lw=1, label="workspace boundary (some x within the stroke)"),
        Patch(color="#bcd4e6", label="in the workspace (some x)"),
        Patch(color="#e8e8e8", label="legs close, travels outside the stroke"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=4, bbox_to_anchor=(0.5, -0.07))
    fig.suptitle(
        f"fig8 preset (L = {d.stroke:.2f} m): singularity loci over (theta, y) -- the kinematics "
        "do not depend on x; the stroke only limits which x are reachable"
    )
    path = out / "figures" / "workspace_singularities_ytheta.png"
    fig.savefig(path, dpi=95, bbox_inches="tight")
    plt.close(fig)
    print(f"-> {rel(path)}")


def fig_sing_plane(out: Path, args, theta_deg: float) -> None:
    d = Design.fig8()
    th = math.radians(theta_deg)
    n = 201 if args.quick else 401
    ws = workspace(d, n, theta=th, per_mode=True, half="full")
    segs = singularity_segments(d, th)
    extent = [ws.x[0], ws.x[-1], ws.y[0], ws.y[-1]]
    fig, axs = plt.subplots(
        2, 4, figsize=(17, 7.2), sharex=True, sharey=True, constrained_layout=True
    )
    for m, ax in enumerate(axs.ravel()):
        mode = tuple(int(v) for v in ws.modes[m])
        ax.imshow(
            np.where(ws.per_mode[m], 1.0, np.nan),
            origin="lower",
            extent=extent,
            cmap=ListedColormap(["#bcd4e6"]),
            interpolation="nearest",
        )
        ax.imshow(
            np.where(ws.reachable & ~ws.per_mode[m], 1.0, np.nan),
            origin="lower",
            extent=extent,
            cmap=ListedColormap(["#ececec"]),
            interpolation="nearest",
        )
        for s in segs:
            if s.mode != mode:
                continue
            if s.kind == "parallel":
                ax.plot([s.x0, s.x1], [s.y, s.y], color="red", lw=2)
            else:
                ax.plot([s.x0, s.x1], [s.y, s.y], color=("C0", "C2", "C4")[s.leg], lw=2, ls="--")
        draw_rails(ax, d, label=False)
        draw_rectangle(ax, d, full=True, label=False)
        ax.set_title(f"mode {mode_label(mode)}: {ws.per_mode[m].mean() * 100:.1f}% of grid")
        ax.set_aspect("equal")
    for ax in axs[1]:
        ax.set_xlabel("x (m)")
    for ax in axs[:, 0]:
        ax.set_ylabel("y (m)")
    handles = [
        Patch(color="#bcd4e6", label="reachable in this mode"),
        Patch(color="#ececec", label="reachable in another mode only"),
        Line2D([], [], color="red", lw=2, label="det A = 0 (parallel)"),
        Line2D([], [], color="C0", ls="--", lw=2, label="det B = 0, leg 1"),
        Line2D([], [], color="C2", ls="--", lw=2, label="det B = 0, leg 2"),
        Line2D([], [], color="C4", ls="--", lw=2, label="det B = 0, leg 3"),
        Line2D([], [], color="k", lw=3, label="stroke segment"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=7, bbox_to_anchor=(0.5, -0.06))
    fig.suptitle(
        f"fig8 preset (L = {d.stroke:.2f} m), fixed orientation theta = {theta_deg:.0f} deg: "
        "constant-orientation workspace per working mode and its singularity loci "
        "(horizontal: nothing depends on x)"
    )
    path = out / "figures" / "workspace_singularities_plane.png"
    fig.savefig(path, dpi=95, bbox_inches="tight")
    plt.close(fig)
    print(f"-> {rel(path)}")


def bench_only(args) -> None:
    d8 = Design.fig8()
    strokes = np.round(np.linspace(0.10, 0.30, 21), 10)
    n, nt = args.grid, args.orientations
    print(f"load average before: {os.getloadavg()}")
    for label, kw in (
        ("reachable S(L) only", dict(usable=False, count_dead_zones=False)),
        ("S(L) + usable S(L) + dead zones", dict(usable=True, count_dead_zones=True)),
    ):
        _, t = timed(lambda kw=kw: stroke_study(d8, strokes, n=n, n_theta=nt, **kw), args.repeats)
        print(
            f"  {label:32s}: median {statistics.median(t):.3f} s "
            f"(runs: {', '.join(f'{v:.3f}' for v in t)})"
        )
    print(f"load average after: {os.getloadavg()}")


# ------------------------------------------------------------------------------ main
def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=ROOT / "docs", help="output directory (docs/)")
    p.add_argument("--quick", action="store_true", help="coarse settings (smoke test)")
    p.add_argument("--repeats", type=int, default=None, help="benchmark repeats (median)")
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    p.add_argument(
        "--bench-only", action="store_true", help="only time the S(L) study (no tables, no figures)"
    )
    p.add_argument("--no-pin", action="store_true", help="do not pin the process to one CPU")
    p.add_argument(
        "--theta-plane",
        type=float,
        default=195.0,
        help="orientation (deg) of the fixed-orientation singularity figure",
    )
    args = p.parse_args(argv)
    args.grid = 61 if args.quick else 201
    args.orientations = 72 if args.quick else 360
    args.repeats = args.repeats or (1 if args.quick else 3)
    args.ext_max = 0.40
    out: Path = args.out
    (out / "figures").mkdir(parents=True, exist_ok=True)
    print(
        f"numpy {np.__version__}, python {sys.version.split()[0]}; "
        f"{'not pinned' if args.no_pin else pin_one_core()}; "
        f"load average {tuple(round(v, 2) for v in os.getloadavg())}"
    )

    if args.bench_only:
        bench_only(args)
        return 0
    res = run_study(args)
    ver = verify(args)
    est = res["evals"] / ver["rate"]
    print(f"brute-force IK for the same study (extrapolated from that rate): ~{est:.0f} s")
    write_tables(out, res, args)
    study, ext = res["study"], res["ext"]
    rec = res["rec"]
    print("\nS(L) table:")
    print(f"{'L (m)':>7} {'S':>7} {'usable':>7} {'holes':>5} {'area cm2':>9}")
    for st in (study, ext):
        for i, L in enumerate(st.strokes):
            print(
                f"{L:7.2f} {st.S[i]:7.4f} {st.S_usable[i]:7.4f} {st.dead_zones[i]:5d} "
                f"{st.dead_zone_area[i] * 1e4:9.1f}"
            )
    print(f"recommendation details: {rec}")
    print(f"tables -> {rel(out / 'workspace_table.md')}, {rel(out / 'workspace_table.csv')}")
    if not args.no_figures:
        fig_fig7(out, args)
        fig_stroke(out, res, rec)
        fig_dead_zones(out, args)
        fig_sing_ytheta(out, args)
        fig_sing_plane(out, args, args.theta_plane)
    t = statistics.median(res["t_full"])
    print(
        f"\nBENCHMARK: S(L) study (21 strokes, {args.grid}x{args.grid}, {args.orientations} "
        f"orientations, 8 modes, with usable S and dead zones) median {t:.2f} s on one core; "
        f"reachable S(L) alone {statistics.median(res['t_core']):.2f} s"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
