"""The paper's workspace study as data: ``S(L)`` on the ``fig8`` preset, the stroke
recommendation, the check of the fast grid against brute-force IK, and the tables.

``scripts/workspace.py`` is its command line; the figures are in
:mod:`planar3p_gym.analysis.workspace_figures`.  Lengths in metres, areas in m^2 (cm^2 in the
table), angles in radians, times in seconds.
"""

from __future__ import annotations

import csv
import io
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from planar3p_gym.analysis.workspace import (
    DEFAULT_MIN_PARALLEL,
    DEFAULT_MIN_SERIAL,
    StrokeStudy,
    reachable_exact,
    stroke_study,
    workspace,
)
from planar3p_gym.atomic_files import write_atomic
from planar3p_gym.machine.design import Design
from planar3p_gym.machine.kinematics import ALL_MODES, inverse

__all__ = [
    "STROKES",
    "StudySettings",
    "rail_gaps",
    "rail_gaps_near",
    "recommend",
    "recommendation_text",
    "run_study",
    "table_rows",
    "tables",
    "time_study",
    "timed",
    "verify",
    "write_tables",
]

#: The paper's strokes: 0.10 to 0.30 m in steps of 0.01 m.
STROKES = np.round(np.linspace(0.10, 0.30, 21), 10)


@dataclass(frozen=True)
class StudySettings:
    """Resolution of the study: ``grid`` x ``grid`` points, ``orientations`` per point,
    strokes beyond the paper's range up to ``ext_max`` (m); ``quick`` = coarse verification,
    bisection and figures; ``repeats`` = timing repeats (median)."""

    grid: int = 201
    orientations: int = 360
    repeats: int = 3
    ext_max: float = 0.40
    quick: bool = False

    @classmethod
    def preset(cls, quick: bool, repeats: int | None = None) -> StudySettings:
        """The full study (201 x 201, 360 orientations, 3 repeats) or the quick one
        (61 x 61, 72 orientations, 1 repeat)."""
        if quick:
            return cls(61, 72, 1 if repeats is None else repeats, quick=True)
        return cls(repeats=3 if repeats is None else repeats)

    def __post_init__(self) -> None:
        for name in ("grid", "orientations", "repeats"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if self.grid < 2:
            raise ValueError(f"grid must be at least 2, got {self.grid}")
        if not (math.isfinite(self.ext_max) and 0.30 <= self.ext_max <= 1.0):
            raise ValueError(f"ext_max must be from 0.30 to 1.0 m, got {self.ext_max}")


def timed(fn: Callable[[], Any], repeats: int) -> tuple[Any, list[float]]:
    """``fn()``'s last result and the wall time (s) of each of ``repeats`` calls."""
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, times


def time_study(settings: StudySettings) -> dict[str, Any]:
    """Time the ``S(L)`` study: reachable only (``t_core``) and with usable ``S`` and dead
    zones (``t_full``, s per repeat); ``study`` is the full result, ``evals`` the number of
    pose-and-mode tests it stands for."""
    d8 = Design.fig8()
    n, nt = settings.grid, settings.orientations

    def core() -> StrokeStudy:
        return stroke_study(d8, STROKES, n=n, n_theta=nt, usable=False, count_dead_zones=False)

    def full() -> StrokeStudy:
        return stroke_study(d8, STROKES, n=n, n_theta=nt, usable=True, count_dead_zones=True)

    _, t_core = timed(core, settings.repeats)
    study, t_full = timed(full, settings.repeats)
    evals = STROKES.size * n * n * nt * len(ALL_MODES)
    return dict(study=study, t_core=t_core, t_full=t_full, evals=evals)


def run_study(settings: StudySettings) -> dict[str, Any]:
    """The timed ``S(L)`` study (:func:`time_study`), the strokes beyond 0.30 m (``ext``) and
    the stroke recommendation (``rec``, :func:`recommend`)."""
    res = time_study(settings)
    d8 = Design.fig8()
    ext = np.round(np.arange(0.31, settings.ext_max + 1e-9, 0.01), 10)
    ext_study = stroke_study(
        d8,
        ext,
        n=settings.grid,
        n_theta=settings.orientations,
        usable=True,
        count_dead_zones=True,
    )
    res["ext"] = ext_study
    res["rec"] = recommend(d8, res["study"], ext_study, quick=settings.quick)
    return res


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


def recommend(design: Design, study: StrokeStudy, ext: StrokeStudy, quick: bool) -> dict[str, Any]:
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


def verify(quick: bool) -> dict[str, Any]:
    """Fast grid versus brute-force :func:`planar3p_gym.machine.kinematics.inverse` on a reduced
    setting (3 strokes), and the brute-force rate (tests/s), to extrapolate its time for the
    full study."""
    n, nt = (41, 24) if quick else (61, 72)
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
    return dict(mismatches=mism, tested=tested, rate=rate, n=n, nt=nt)


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


def table_rows(res: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per stroke (formatted as in ``docs/workspace_table.csv``)."""
    rows = []
    for st, in_range in ((res["study"], True), (res["ext"], False)):
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
    return rows


def recommendation_text(rec: dict[str, Any]) -> str:
    """The stroke recommendation as a markdown sentence."""
    if rec["in_study"] is not None:
        return (
            f"**Recommended stroke: L = {rec['final']:.2f} m**, the shortest without dead zones "
            f"(grid: {rec['grid']:.2f} m)."
        )
    if rec["final"] is None:
        return "No stroke studied is free of dead zones."
    text = (
        "**No stroke from 0.10 to 0.30 m is free of dead zones on this design.** "
        f"On the grid, the shortest stroke without dead zones (for it and every longer one "
        f"studied) is {rec['grid']:.2f} m."
    )
    if rec["rail"] is not None:
        text += (
            " The last holes sit across the rail line; there the exact test (continuous "
            "orientations, bisection on the stroke with sampling windows shrinking with the "
            f"gaps) finds them closing at L = {rec['rail']['hi']:.5f} m."
        )
    return text + f" **Recommended stroke: L = {rec['final']:.2f} m.**"


def tables(res: dict[str, Any]) -> tuple[str, str]:
    """``(csv, markdown)`` texts of ``docs/workspace_table.*``."""
    rows = table_rows(res)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
    study: StrokeStudy = res["study"]
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
        recommendation_text(res["rec"]),
        "",
    ]
    return buf.getvalue(), "\n".join(lines)


def write_tables(out: Path, res: dict[str, Any]) -> tuple[Path, Path]:
    """Write ``workspace_table.csv`` and ``workspace_table.md`` into ``out`` (atomically)."""
    csv_text, md_text = tables(res)
    paths = (out / "workspace_table.csv", out / "workspace_table.md")
    write_atomic(paths[0], csv_text)
    write_atomic(paths[1], md_text)
    return paths
