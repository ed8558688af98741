"""The benchmark's figures: success rates, final errors, and trajectories over the singularity map.

Each function writes one PNG into ``out`` with matplotlib (imported when called) and returns its
file name.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from planar3p_agents.evaluation.episodes import EpisodeResult
from planar3p_agents.evaluation.reach_suites import Suite
from planar3p_agents.evaluation.region_maps import ytheta_fields
from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.machine.design import Design

__all__ = ["plot_errors", "plot_success", "plot_trajectories"]


def plot_success(out: Path, summaries: list[dict[str, Any]], suites: list[str]) -> str:
    """``success_rate.png``: success rate per suite and policy with its interval."""
    import matplotlib.pyplot as plt

    policies = list(dict.fromkeys(s["policy"] for s in summaries))
    fig, ax = plt.subplots(figsize=(1.6 + 1.9 * len(suites), 3.6))
    width = 0.8 / max(len(policies), 1)
    for k, pol in enumerate(policies):
        xs, ys, lo, hi = [], [], [], []
        for j, suite in enumerate(suites):
            s = next((s for s in summaries if s["policy"] == pol and s["suite"] == suite), None)
            if s is None:
                continue
            xs.append(j + (k - (len(policies) - 1) / 2) * width)
            ys.append(100 * s["success_rate"])
            lo.append(100 * (s["success_rate"] - s["success_ci"][0]))
            hi.append(100 * (s["success_ci"][1] - s["success_rate"]))
        ax.bar(xs, ys, width * 0.95, yerr=[lo, hi], capsize=3, label=pol)
    ax.set_xticks(range(len(suites)), suites)
    ax.set_ylabel("success rate (%)")
    ax.set_ylim(0, 105)
    ax.set_title("Success rate per suite (95% Wilson interval)")
    ax.legend(fontsize=7, loc="upper right", ncols=1 if len(policies) < 5 else 2)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "success_rate.png", dpi=110)
    plt.close(fig)
    return "success_rate.png"


def plot_errors(
    out: Path, results: dict[tuple[str, str], list[EpisodeResult]], suites: list[str]
) -> str:
    """``errors.png``: final position and orientation errors of every episode (log scale)."""
    import matplotlib.pyplot as plt

    policies = list(dict.fromkeys(p for p, _ in results))
    fig, axes = plt.subplots(
        2, len(suites), figsize=(1.4 + 3.0 * len(suites), 6.0), squeeze=False, sharey="row"
    )
    rng = np.random.default_rng(0)
    for j, suite in enumerate(suites):
        for row, (key, scale, label, floor) in enumerate(
            (
                ("final_position_error", 1000.0, "final position error (mm)", 1e-3),
                ("final_orientation_error", 180.0 / math.pi, "final orientation error (deg)", 1e-4),
            )
        ):
            ax = axes[row, j]
            for k, pol in enumerate(policies):
                res = results.get((pol, suite), [])
                if not res:
                    continue
                v = np.maximum(np.array([getattr(r, key) for r in res]) * scale, floor)
                ok = np.array([r.success for r in res])
                x = k + rng.uniform(-0.18, 0.18, v.size)
                ax.scatter(x[ok], v[ok], s=7, alpha=0.6, color="tab:green", lw=0)
                ax.scatter(x[~ok], v[~ok], s=7, alpha=0.6, color="tab:red", lw=0)
                ax.hlines(np.median(v), k - 0.3, k + 0.3, color="k", lw=1.5)
            tol = 2.0 if row == 0 else 1.0
            ax.axhline(tol, color="gray", ls="--", lw=0.8)
            ax.set_yscale("log")
            ax.set_xticks(range(len(policies)), policies, rotation=30, ha="right", fontsize=7)
            if j == 0:
                ax.set_ylabel(label)
            if row == 0:
                ax.set_title(suite)
            ax.grid(axis="y", alpha=0.3)
    fig.suptitle("Final errors (green: success, red: failure; bar: median; dashed: tolerance)")
    fig.tight_layout()
    fig.savefig(out / "errors.png", dpi=100)
    plt.close(fig)
    return "errors.png"


def _break_wraps(th: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    th = wrap_angle(th)
    jumps = np.flatnonzero(np.abs(np.diff(th)) > math.pi) + 1
    return np.insert(th, jumps, np.nan), np.insert(y, jumps, np.nan)


def plot_trajectories(
    out: Path,
    design: Design,
    suites: dict[str, Suite],
    results: dict[tuple[str, str], list[EpisodeResult]],
) -> str | None:
    """``trajectories.png``: the recorded gripper paths of up to three policies (not random or
    zero) over the singularity map in ``(theta, y)`` of each suite's working mode; ``None`` if
    there is no such policy."""
    import matplotlib.pyplot as plt

    policies = list(dict.fromkeys(p for p, _ in results))
    shown = [p for p in policies if p not in ("random", "zero")][:3]
    if not shown:
        return None
    styles = ["-", "--", ":"]
    names = list(suites)
    fig, axes = plt.subplots(
        1, len(names), figsize=(max(8.0, 5.2 * len(names)), 4.8), squeeze=False
    )
    h = design.search_height
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for j, name in enumerate(names):
        ax = axes[0, j]
        suite = suites[name]
        mode = suite.episodes[0].working_mode
        ys = np.linspace(-0.1 * h, 1.05 * h, 181)
        ths = np.linspace(-math.pi, math.pi, 361)
        f = ytheta_fields(design, mode, ys, ths)
        feasible = f["closable"] & (f["x_lo"] <= f["x_hi"])
        signed = np.where(feasible, np.sign(f["det"]) * f["parallel_margin"], np.nan)
        im = ax.pcolormesh(ths, ys, signed, cmap="RdBu", vmin=-0.1, vmax=0.1, shading="auto")
        det = np.where(f["closable"], f["det"], np.nan)
        ax.contour(ths, ys, det, levels=[0.0], colors="k", linewidths=1.2)
        ax.contour(
            ths,
            ys,
            np.where(f["closable"], f["serial_margin"], 0.0),
            levels=[0.05],
            colors="0.4",
            linewidths=0.8,
            linestyles="--",
        )
        for k, pol in enumerate(shown):
            for r in results.get((pol, name), []):
                if r.trajectory is None:
                    continue
                c = colours[r.index % len(colours)]
                th, y = _break_wraps(r.trajectory[:, 2], r.trajectory[:, 1])
                ax.plot(th, y, styles[k], color=c, lw=1.3)
                end = r.trajectory[-1]
                if not r.success:
                    ax.plot(end[2], end[1], "x", color=c, ms=8, mew=2)
                if k == 0:
                    spec = suite.episodes[r.index]
                    ax.plot(spec.start[2], spec.start[1], "o", color=c, ms=5)
                    ax.plot(spec.target[2], spec.target[1], "*", color=c, ms=11, mec="k")
        ax.set_xlim(-math.pi, math.pi)
        ax.set_ylim(ys[0], ys[-1])
        ax.set_xlabel("theta (rad)")
        ax.set_ylabel("y of G (m)")
        ax.set_title(f"{name}: working mode {tuple(mode)}", fontsize=10)
        fig.colorbar(im, ax=ax, label="sign(det A) x parallel margin", shrink=0.85)
    legend = ", ".join(f"'{styles[k]}' {p}" for k, p in enumerate(shown))
    fig.text(
        0.5,
        0.01,
        "Trajectories of the gripper over the singularity map in (theta, y), which does not "
        "depend on x. Colour: sign(det A) x parallel margin; black: parallel singularity "
        "det A = 0; dashed: serial margin 0.05; white: unreachable for every x. "
        f"o start, * target, x end of a failed episode. Lines: {legend}.",
        ha="center",
        va="bottom",
        fontsize=8,
        wrap=True,
    )
    fig.tight_layout(rect=(0, 0.09, 1, 1))
    fig.savefig(out / "trajectories.png", dpi=100)
    plt.close(fig)
    return "trajectories.png"
