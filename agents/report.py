"""The benchmark's written outputs: the markdown report and its tables, ``episodes.csv`` and
``summary.json``.  The figures are in :mod:`agents.report_plots`.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .episodes import FAILURE_CAUSES, EpisodeResult
from .suites import Suite

__all__ = [
    "DEFINITIONS",
    "causes_table",
    "path_table",
    "results_table",
    "suite_definitions",
    "suites_section",
    "write_report",
    "write_rows",
    "write_summary",
]


def _fmt(x: float, digits: int = 2) -> str:
    return "–" if x is None or not math.isfinite(x) else f"{x:.{digits}f}"


def _ci(v: float, ci: Sequence[float], digits: int, scale: float = 1.0) -> str:
    if not math.isfinite(v):
        return "–"
    return f"{v * scale:.{digits}f} [{ci[0] * scale:.{digits}f}, {ci[1] * scale:.{digits}f}]"


TABLE_HEADER = (
    "| policy | suite | n | success % [95% CI] | IQM return [95% CI] | pos. err. mm | "
    "orient. err. deg | time to success s | min parallel margin (worst / median) | "
    "sing. crossings | breakdowns | timeouts | saturated % | energy J |"
)


def results_table(summaries: Sequence[dict[str, Any]]) -> str:
    """The markdown results table (medians unless stated)."""
    lines = [TABLE_HEADER, "|" + "---|" * 14]
    for s in summaries:
        lines.append(
            "| "
            + " | ".join(
                [
                    s["policy"],
                    s["suite"],
                    str(s["episodes"]),
                    _ci(s["success_rate"], s["success_ci"], 0, 100.0),
                    _ci(s["return_iqm"], s["return_ci"], 1),
                    _fmt(s["median_position_error_mm"], 1),
                    _fmt(s["median_orientation_error_deg"], 2),
                    _fmt(s["median_time_to_success"], 2),
                    f"{_fmt(s['worst_min_parallel_margin'], 4)} / "
                    f"{_fmt(s['median_min_parallel_margin'], 4)}",
                    str(s["singularity_crossings"]),
                    str(s["physics_breakdowns"]),
                    str(s["timeouts"]),
                    _fmt(100.0 * s["saturation_fraction"], 1),
                    _fmt(s["median_energy"], 3),
                ]
            )
            + " |"
        )
    return "\n".join(lines)


def causes_table(summaries: Sequence[dict[str, Any]]) -> str:
    """How episodes ended, per policy and suite (counts of each cause)."""
    causes = list(FAILURE_CAUSES)
    head = "| policy | suite | " + " | ".join(c.replace("_", " ") for c in causes)
    lines = [head + " | working-mode changes |", "|" + "---|" * (len(causes) + 3)]
    for s in summaries:
        cells = [str(s["causes"].get(c, 0)) for c in causes]
        lines.append(
            f"| {s['policy']} | {s['suite']} | "
            + " | ".join(cells)
            + f" | {s['working_mode_changes']} |"
        )
    return "\n".join(lines)


def _rate(results: Sequence[EpisodeResult], key: str, value: bool) -> str:
    sel = [r for r in results if getattr(r, key) == value]
    if not sel:
        return "–"
    return f"{sum(r.success for r in sel)}/{len(sel)}"


def path_table(results: dict[tuple[str, str], list[EpisodeResult]]) -> str:
    """Success split by whether the straight path / the sequential path is clear."""
    lines = [
        "| policy | suite | straight path clear | straight path not clear | "
        "sequential path clear | sequential path not clear |",
        "|---|---|---|---|---|---|",
    ]
    for (pol, suite), res in results.items():
        lines.append(
            f"| {pol} | {suite} | {_rate(res, 'path_clear', True)} | "
            f"{_rate(res, 'path_clear', False)} | {_rate(res, 'sequential_path_clear', True)} | "
            f"{_rate(res, 'sequential_path_clear', False)} |"
        )
    return "\n".join(lines)


def suites_section(suites: dict[str, Suite]) -> str:
    """One row per suite: its size, working mode and the kinds of path it holds."""
    lines = [
        "| suite | episodes | working mode | straight path clear | crosses det A = 0 | "
        "min parallel margin on path (median) | pose distance m (median) | "
        "sequential path clear |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for s in suites.values():
        paths = [e.path for e in s.episodes]
        n = len(paths)
        lines.append(
            f"| {s.name} | {n} | {tuple(s.episodes[0].working_mode)} | "
            f"{sum(bool(p.get('clear')) for p in paths)} | "
            f"{sum(bool(p.get('crosses')) for p in paths)} | "
            f"{_fmt(float(np.nanmedian([p.get('min_parallel_margin', np.nan) for p in paths])), 4)}"
            f" | {_fmt(float(np.median([p.get('distance', np.nan) for p in paths])), 3)} | "
            f"{sum(bool(p.get('sequential_clear')) for p in paths)} |"
        )
    return "\n".join(lines)


def suite_definitions(suites: dict[str, Suite]) -> str:
    """What each suite is, from the parameters that generated it."""
    out = ["Generated from the seed and saved in `suites.json`:", ""]
    for s in suites.values():
        p = s.params
        if s.name == "standard":
            text = "start/target pairs drawn exactly as the environment draws them."
        elif s.name == "hard":
            text = (
                f"both ends with parallel margin >= {p.get('end_parallel_margin')} and at most "
                f"{p.get('hold_force_fraction')} of the actuator force needed to hold them; the "
                "straight path in pose space stays within the stroke with serial margin >= 0.1 "
                f"but comes within parallel margin {p.get('hard_margin')} of a singularity (or "
                "crosses one); both ends lie in one connected singularity-free region, so a "
                "detour exists."
            )
        elif s.name == "far":
            text = (
                f"pose distance >= {p.get('far_distance')} m (the top "
                f"{100 * (1 - p.get('far_quantile', 0.9)):.0f}% of same-assembly pairs); the "
                "straight path need not be clear; both ends in one connected region."
            )
        else:
            text = ""
        gen = p.get("generation")
        extra = (
            f" ({gen['candidates']} candidate pairs examined, {gen['rejected_unsolvable']} "
            "rejected as not connected)"
            if gen
            else ""
        )
        out.append(f"- `{s.name}`, working mode {tuple(p.get('working_mode', ()))}: {text}{extra}")
    return "\n".join(out)


DEFINITIONS = """\
- **success %**: episodes ended by the environment's success test (gripper within 2 mm and
  1 deg of the target, every slider slower than 0.01 m/s); 95% Wilson score interval (a
  binomial interval: it does not collapse to a point at 0 % or 100 %).
- **IQM return**: interquartile mean of the undiscounted episode return (mean of the middle
  50%, as rliable), with its 95% bootstrap interval.
- **pos. err. / orient. err.**: median over episodes of the final errors.
- **time to success**: median over successful episodes (s).
- **min parallel margin**: the smallest parallel margin (inverse condition number of
  `A_bar`) met in an episode: worst episode / median episode.
- **sing. crossings / breakdowns**: episodes ended by a change of `sign det A` / by the physics
  breaking down; **timeouts**: episodes cut by the 250-step (5 s) limit.
- **saturated %**: share of control steps in which some actuator hit its force limit.
- **energy**: median over episodes of `sum_t sum_i |F_i rho_dot_i| dt` (J).
- **Why** (failure causes): a timeout is diagnosed from the final state, in this order:
  parallel margin < 0.01 (`stalled at parallel singularity`), a slider within 5 mm of an end
  of its stroke (`stroke limit`), serial margin < 0.05 (`serial singularity`), within the
  tolerances but still moving (`not at rest`), else `not converged`.  A *working-mode change* is
  an episode in which some leg turned past the perpendicular to its rail (a serial
  singularity crossed, `sign cos alpha_i` changed).
- **straight path / sequential path clear**: the straight line in pose space from start to
  target (or the rotation-vertical-horizontal path of the sequential simple motions) stays
  reachable within the stroke, in the start's assembly mode, with parallel margin >= 0.02 and
  serial margin >= 0.1 (checked at 64 points per segment).
"""


def write_report(
    out: Path,
    command: str,
    settings: dict[str, Any],
    suites: dict[str, Suite],
    summaries: list[dict[str, Any]],
    results: dict[tuple[str, str], list[EpisodeResult]],
    plots: list[str],
    complete: bool,
) -> str:
    """Write ``report.md`` into ``out`` (``plots``: file names of figures already written
    there; ``complete=False`` marks an interrupted run) and return the results table."""
    table = results_table(summaries)
    parts = [
        "# Policy benchmark: Planar3P-v0",
        "",
        f"Command: `{command}`" + ("" if complete else "  \n**Incomplete run** (see stderr)."),
        "",
        f"Seed {settings['seed']}; {settings['episodes']} episodes per suite; design "
        f"`{settings['design']}`; {settings['bootstrap']} bootstrap resamples; "
        f"{settings['elapsed_s']:.0f} s.",
        "",
        "## Results",
        "",
        table,
        "",
        "## Suites",
        "",
        suites_section(suites),
        "",
        suite_definitions(suites),
        "",
        "## Why episodes end",
        "",
        causes_table(summaries),
        "",
        "Success by kind of path (successes / episodes):",
        "",
        path_table(results),
        "",
    ]
    if plots:
        parts += ["## Plots", ""]
        parts += [f"![{Path(p).stem}]({p})" for p in plots]
        parts += [""]
    parts += ["## Definitions", "", DEFINITIONS]
    text = "\n".join(parts)
    (out / "report.md").write_text(text)
    return table


def write_rows(
    out: Path,
    results: dict[tuple[str, str], list[EpisodeResult]],
    training_seeds: dict[str, int | None] | None = None,
) -> None:
    """``episodes.csv``: one row per episode and policy.  The column ``training_seed`` (after
    ``policy``) is the seed the policy was trained with, where known (empty otherwise), so
    that rliable-style aggregates can group runs by seed.  Floats are rounded to 1e-6."""
    seeds = training_seeds or {}
    rows = []
    for res in results.values():
        for r in res:
            row = r.row()
            seed = seeds.get(r.policy)
            rows.append(
                {"policy": row.pop("policy"), "training_seed": "" if seed is None else seed, **row}
            )
    if not rows:
        return
    fields = list(dict.fromkeys(k for row in rows for k in row))
    with (out / "episodes.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, restval="")
        w.writeheader()
        for row in rows:
            w.writerow({k: (round(v, 6) if isinstance(v, float) else v) for k, v in row.items()})


def write_summary(out: Path, settings: dict[str, Any], summaries: list[dict[str, Any]]) -> None:
    """``summary.json``: the run's settings and the aggregates."""
    data = {"settings": settings, "summaries": summaries}
    (out / "summary.json").write_text(json.dumps(data, indent=1, default=_jsonable) + "\n")


def _jsonable(x: Any) -> Any:
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, Path):
        return str(x)
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")
