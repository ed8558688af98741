"""The benchmark's written outputs: the markdown report and its tables, ``episodes.csv`` and
``summary.json``.  The figures are in :mod:`planar3p_agents.evaluation.report_plots`.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planar3p_agents.evaluation.episodes import FAILURE_CAUSES, EpisodeResult
from planar3p_agents.evaluation.reach_suites import Suite
from planar3p_gym.machine.design import Design

__all__ = [
    "DEFINITIONS",
    "TASK_DEFINITIONS",
    "causes_table",
    "metrics_table",
    "path_table",
    "results_table",
    "suite_definitions",
    "suites_section",
    "task_suites_section",
    "task_table",
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
    "orient. err. deg | time to success s | time / speed bound (median / p90) | "
    "min parallel margin (worst / median) | "
    "sing. crossings | breakdowns | time limits | saturated % | energy J |"
)


def results_table(summaries: Sequence[dict[str, Any]]) -> str:
    """The markdown results table (medians unless stated)."""
    lines = [TABLE_HEADER, "|" + "---|" * 15]
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
                    f"{_fmt(s.get('median_time_over_bound', math.nan), 2)} / "
                    f"{_fmt(s.get('p90_time_over_bound', math.nan), 2)}",
                    f"{_fmt(s['worst_min_parallel_margin'], 4)} / "
                    f"{_fmt(s['median_min_parallel_margin'], 4)}",
                    str(s["singularity_crossings"]),
                    str(s["physics_breakdowns"]),
                    str(s["time_limits"]),
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
    causes += [
        c for c in dict.fromkeys(c for s in summaries for c in s["causes"]) if c not in causes
    ]
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
    """Success split by whether the straight path / the sequential path is clear and by
    whether the straight line in slider space solves the pair."""
    lines = [
        "| policy | suite | straight path clear | straight path not clear | "
        "sequential path clear | sequential path not clear | slider line solves | "
        "slider line does not |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for (pol, suite), res in results.items():
        lines.append(
            f"| {pol} | {suite} | {_rate(res, 'path_clear', True)} | "
            f"{_rate(res, 'path_clear', False)} | {_rate(res, 'sequential_path_clear', True)} | "
            f"{_rate(res, 'sequential_path_clear', False)} | "
            f"{_rate(res, 'slider_line_reaches', True)} | "
            f"{_rate(res, 'slider_line_reaches', False)} |"
        )
    return "\n".join(lines)


def suites_section(suites: dict[str, Suite]) -> str:
    """One row per suite: its size, working mode and the kinds of path it holds."""
    lines = [
        "| suite | episodes | working mode | straight path clear | crosses det A = 0 | "
        "min parallel margin on path (median) | pose distance m (median) | "
        "sequential path clear | slider line solves |",
        "|---|---|---|---|---|---|---|---|---|",
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
            f"{sum(bool(p.get('sequential_clear')) for p in paths)} | "
            f"{sum(bool(p.get('slider_line_reaches')) for p in paths)} |"
        )
    return "\n".join(lines)


def _is_task(suite: Suite) -> bool:
    return suite.params.get("task") is not None


def task_suites_section(suites: dict[str, Suite]) -> str:
    """One row per task suite: its environment, size and start working modes."""
    lines = [
        "| suite | environment | episodes | steps per episode (at most) | start working modes | "
        "what |",
        "|---|---|---|---|---|---|",
    ]
    for s in suites.values():
        kwargs = ", ".join(f"{k}={v!r}" for k, v in s.params.get("env_kwargs", {}).items())
        modes = sorted({tuple(e.working_mode) for e in s.episodes})
        fig8 = Design.fig8().to_dict()
        design = s.params.get("design", fig8)
        changed = ", ".join(f"{k} {v}" for k, v in design.items() if fig8.get(k) != v)
        what = s.params.get("description", "")
        what += f" (design fig8 with {changed})" if changed else ""
        lines.append(
            f"| {s.name} | `{s.params['env_id']}`{f' ({kwargs})' if kwargs else ''} | "
            f"{len(s)} | {s.params.get('max_episode_steps', '–')} | {len(modes)} | {what} |"
        )
    return "\n".join(lines)


def _metric_cell(key: str, value: float) -> str:
    if "orientation" in key:
        return _fmt(math.degrees(value), 2)
    if "error" in key:
        return _fmt(1000.0 * value, 2)
    return _fmt(value, 2)


def _metric_summary(key: str, m: dict[str, float]) -> str:
    """An error: median / worst episode; another metric (a flag, a count): mean [min, max]."""
    if "error" in key:
        return f"{_metric_cell(key, m['median'])} / {_metric_cell(key, m['max'])}"
    return f"{_fmt(m['mean'], 2)} [{_fmt(m['min'], 0)}, {_fmt(m['max'], 0)}]"


def metrics_table(summaries: Sequence[dict[str, Any]]) -> str:
    """Task metrics of the summaries that have any (see :func:`_metric_summary`); errors in mm
    (``*_orientation_error`` in deg), other metrics as the task reports them."""
    rows = [s for s in summaries if s.get("task_metrics")]
    if not rows:
        return ""
    keys = list(dict.fromkeys(k for s in rows for k in s["task_metrics"]))
    head = " | ".join(
        k.replace("_", " ") + (" deg" if "orientation" in k else " mm" if "error" in k else "")
        for k in keys
    )
    lines = [
        f"| policy | suite | {head} |",
        "|" + "---|" * (len(keys) + 2),
    ]
    for s in rows:
        cells = []
        for k in keys:
            m = s["task_metrics"].get(k)
            cells.append("–" if m is None else _metric_summary(k, m))
        lines.append(f"| {s['policy']} | {s['suite']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def task_table(summaries: Sequence[dict[str, Any]], suites: dict[str, Suite]) -> str:
    """The compact table of the task suites (one row per policy and suite): success with its
    interval, median time to success, singularity crossings, physics breakdowns, working-mode
    changes and the tracking error (RMS and maximum pose error ``|dp| + L_ref |dtheta|``,
    median / worst episode, mm)."""
    lines = [
        "| suite | environment | policy | n | success % [95% CI] | time to success s | "
        "sing. crossings | breakdowns | working-mode changes | tracking RMS error mm | "
        "tracking max error mm |",
        "|" + "---|" * 11,
    ]
    order = {name: i for i, name in enumerate(suites)}
    rows = [s for s in summaries if s["suite"] in suites and _is_task(suites[s["suite"]])]
    for s in sorted(rows, key=lambda s: order[s["suite"]]):  # stable: policy order kept
        suite = suites[s["suite"]]
        m = s.get("task_metrics", {})

        def pair(key: str, m: dict[str, Any] = m) -> str:
            v = m.get(key)
            return (
                "–"
                if v is None
                else f"{_metric_cell(key, v['median'])} / " + _metric_cell(key, v["max"])
            )

        lines.append(
            f"| {s['suite']} | `{suite.params['env_id']}` | {s['policy']} | {s['episodes']} | "
            f"{_ci(s['success_rate'], s['success_ci'], 0, 100.0)} | "
            f"{_fmt(s['median_time_to_success'], 2)} | {s['singularity_crossings']} | "
            f"{s['physics_breakdowns']} | {s['working_mode_changes']} | "
            f"{pair('tracking_rms_error')} | {pair('tracking_max_error')} |"
        )
    return "\n".join(lines)


def suite_definitions(suites: dict[str, Suite]) -> str:
    """What each suite is, from the parameters that generated it."""
    out = ["Generated from the seed and saved in `suites.json`:", ""]
    for s in suites.values():
        p = s.params
        if _is_task(s):
            out.append(
                f"- `{s.name}`: `{p['env_id']}`, {p.get('description', '')}; episode `i` is the "
                'environment\'s own draw (its `info["episode_spec"]`) after a reset with a '
                "seed derived from the suite seed, name and `i`, replayed with "
                "`reset(options=spec)`."
            )
            continue
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
- **time / speed bound**: time to success divided by the episode's speed bound
  `max_i |rho_i(target) - rho_i(start)| / max_speed` (travels by inverse kinematics in the
  episode's working mode; no slider moves faster than `max_speed`, so no policy can reach the
  target sooner): median and 90th percentile over the successful episodes (reach and goal
  suites; `speed_bound` and `time_over_bound` columns of `episodes.csv`).
- **min parallel margin**: the smallest parallel margin (inverse condition number of
  `A_bar`) met in an episode: worst episode / median episode.
- **sing. crossings / breakdowns**: episodes ended by a change of `sign det A` / by the physics
  breaking down; **time limits**: episodes cut by the 250-step (5 s) limit (end reason
  `time_limit`).
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
- **slider line solves**: moving every slider at a constant rate from the start's travels to
  the target's brings the gripper to the target (`planar3p_gym.machine.slider_line`); where it does
  not (it ends at the target's mirror image about the rail line, or the branch is lost), a
  policy must make a detour in slider space.
"""


TASK_DEFINITIONS = """\
- **Task suites**: success, return and errors as above, against each task's own target (the
  goal; the target pose in the other working or assembly mode).  Tracking has no success test:
  its episodes run their full length unless they cross a singularity or the physics breaks
  down, an episode that runs to the end is counted as `completed`, and the final errors are
  against the reference's last pose.
- **Task metrics** (the task's own, from the episode's last `info`): `tracking error` is the
  pose error `|dp| + L_ref |dtheta|` to the moving reference at the last step, `tracking rms
  error` / `tracking max error` its RMS and maximum over the episode (also split into position
  and orientation); `in target mode` / `in target assembly` (1 if the episode ended in the
  target's working / assembly mode), `legs to flip` (legs not yet in their target mode),
  `crossings` (changes of `sign det A`, i.e. parallel singularities crossed).
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
    extra: str = "",
) -> str:
    """Write ``report.md`` into ``out`` (``plots``: file names of figures already written
    there; ``complete=False`` marks an interrupted run; ``extra``: a markdown section put
    before the definitions, e.g. the normalized scores) and return the results table."""
    table = results_table(summaries)
    reach = {k: v for k, v in suites.items() if not _is_task(v)}
    tasks = {k: v for k, v in suites.items() if _is_task(v)}
    parts = [
        "# Policy benchmark: Planar3P-v0" if not tasks else "# Policy benchmark",
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
    ]
    if tasks:
        parts += ["Task suites at a glance:", "", task_table(summaries, suites), ""]
    metrics = metrics_table(summaries)
    if metrics:
        parts += [
            "Task metrics (errors: median / worst episode; flags and counts: mean [min, max],",
            "the mean of a 0/1 flag being the share of episodes):",
            "",
            metrics,
            "",
        ]
    parts += ["## Suites", ""]
    if reach:
        parts += [suites_section(reach), ""]
    if tasks:
        parts += [task_suites_section(tasks), ""]
    parts += [
        suite_definitions(suites),
        "",
        "## Why episodes end",
        "",
        causes_table(summaries),
        "",
    ]
    reach_results = {k: v for k, v in results.items() if k[1] in reach}
    if reach_results:
        parts += ["Success by kind of path (successes / episodes):", "", path_table(reach_results)]
        parts += [""]
    if plots:
        parts += ["## Plots", ""]
        parts += [f"![{Path(p).stem}]({p})" for p in plots]
        parts += [""]
    if extra:
        parts += [extra]
    parts += ["## Definitions", "", DEFINITIONS]
    if tasks:
        parts += [TASK_DEFINITIONS]
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
