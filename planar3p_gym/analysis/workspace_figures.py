"""Figures of the workspace study (``docs/figures/workspace_*.png``).

Each function draws one figure into ``<out>/figures/`` (written atomically) and returns its
path (:func:`fig_fig7` also the numbers it shows).  ``scripts/workspace.py`` calls them; the
numbers come from :mod:`planar3p_gym.analysis.workspace` and
:mod:`planar3p_gym.analysis.workspace_report`. Lengths in metres, orientations in degrees on the
axes.
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any

import numpy as np

try:  # matplotlib is the core package's ``plots`` extra: only these figures need it
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Rectangle
except ModuleNotFoundError as exc:
    raise ModuleNotFoundError(
        f"the workspace figures need matplotlib ({exc.name} is missing): "
        "pip install 'planar3p-gym[plots]'",
        name=exc.name,
    ) from exc

from planar3p_gym.analysis.workspace import (
    DEFAULT_MIN_PARALLEL,
    DEFAULT_MIN_SERIAL,
    StrokeStudy,
    dead_zones,
    full_plane,
    margin_levels,
    serial_singularity_points,
    singularity_map,
    singularity_segments,
    workspace,
)
from planar3p_gym.analysis.workspace_report import StudySettings
from planar3p_gym.atomic_files import write_atomic
from planar3p_gym.machine.design import Design

__all__ = [
    "FIGURES",
    "fig_dead_zones",
    "fig_fig7",
    "fig_sing_plane",
    "fig_sing_ytheta",
    "fig_stroke",
]

#: File names of the figures, in the order ``scripts/workspace.py`` draws them.
FIGURES = (
    "workspace_fig7.png",
    "workspace_stroke.png",
    "workspace_dead_zones.png",
    "workspace_singularities_ytheta.png",
    "workspace_singularities_plane.png",
)


def _save(fig: Any, path: Path, **savefig: Any) -> Path:
    """Save ``fig`` as PNG at ``path`` atomically and close it."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", **savefig)
    plt.close(fig)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, buf.getvalue())
    return path


def mode_label(mode: Any) -> str:
    """A working mode as ``(+,-,+)``."""
    return "(" + ",".join("+" if s > 0 else "-" for s in mode) + ")"


def draw_rails(ax: Any, design: Design, label: bool = True) -> None:
    """The stroke segments (rails) as thick black lines."""
    for i, a in enumerate(design.rail_origins):
        ax.plot(
            [a, a + design.stroke],
            [0, 0],
            color="k",
            lw=3,
            solid_capstyle="butt",
            label="stroke segments (rails)" if (label and i == 0) else None,
        )


def draw_rectangle(ax: Any, design: Design, full: bool, label: bool = True) -> None:
    """The search rectangle (and its mirror image if ``full``), dashed."""
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


def fig_fig7(out: Path, settings: StudySettings) -> dict[str, Any]:
    """The ``fig7`` preset's workspace map (the paper's Figure 7): working modes per point,
    dead zones, and the best parallel margin reachable."""
    d = Design.fig7()
    n, nt = settings.grid, settings.orientations
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
    path = _save(fig, out / "figures" / "workspace_fig7.png", dpi=110)
    return dict(S=ws.S, S_usable=ws.S_usable, dead_zones=dz.count, dz_area=dz.total_area, path=path)


def fig_stroke(out: Path, res: dict[str, Any]) -> Path:
    """``S`` and usable ``S`` versus the stroke (the paper's Figure 8) and the dead zones."""
    rec_info = res["rec"]
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
    return _save(fig, out / "figures" / "workspace_stroke.png", dpi=110)


def fig_dead_zones(out: Path, settings: StudySettings) -> Path:
    """The whole-plane workspace of ``fig8`` and its dead zones at four strokes."""
    strokes = (0.10, 0.20, 0.30, 0.36)
    fig, axs = plt.subplots(1, 4, figsize=(17, 4.4), constrained_layout=True)
    for ax, L in zip(axs, strokes, strict=True):
        d = Design.fig8(stroke=L)
        ws = workspace(d, settings.grid, settings.orientations, usable=True)
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
    return _save(fig, path, dpi=100, bbox_inches="tight")


def fig_sing_ytheta(out: Path, settings: StudySettings) -> Path:
    """``det A = 0`` and ``det B = 0`` over ``(theta, y)`` with the workspace boundary, per
    working mode."""
    d = Design.fig8()
    ny, nt = (201, 241) if settings.quick else (401, 541)
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
    return _save(fig, path, dpi=95, bbox_inches="tight")


def fig_sing_plane(out: Path, settings: StudySettings, theta_deg: float) -> Path:
    """The constant-orientation workspace per working mode at ``theta_deg`` (degrees) and its
    singularity loci."""
    d = Design.fig8()
    th = math.radians(theta_deg)
    n = 201 if settings.quick else 401
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
    return _save(fig, path, dpi=95, bbox_inches="tight")
