#!/usr/bin/env python
"""Benchmark policies on fixed evaluation suites of ``Planar3P-v0``.

Every policy plays exactly the same episodes (``standard``, ``hard``, ``far``; see
``agents/evaluation.py``), generated from ``--seed``.  Writes into ``--out``:

* ``report.md``: the results table (success rate and IQM return with 95% bootstrap intervals,
  median final errors, time to success, margins, failure counts, saturation, energy), the
  suites, a breakdown of why episodes failed, and the plots;
* ``episodes.csv``: one row per episode and policy;
* ``summary.json``: the aggregates and the run's settings;
* ``suites.json``: the suite definition (replay it with ``--suite-file``);
* ``success_rate.png``, ``errors.png``, ``trajectories.png``.

Examples::

    python scripts/benchmark.py --quick
    python scripts/benchmark.py --policies analytic-simultaneous,runs/sac/model.zip --out res/sac
    python scripts/benchmark.py --policies pretrained:sac_default --suites standard,hard

Exit status: 0 on success; 2 for bad input (unknown policy or suite, missing or corrupt model,
bad option), detected before anything is written; 1 if a policy fails while running (the
results of the policies and suites already finished are written first); 130 if interrupted.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import shlex
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # running from a checkout without installing
    sys.path.insert(0, str(ROOT))

import gymnasium as gym  # noqa: E402

import planar3p_gym  # noqa: E402
from agents import evaluation as ev  # noqa: E402
from agents.policies import PolicyError, load_policy, parse_policy_spec, policy_label  # noqa: E402

DEFAULT_POLICIES = "analytic-simultaneous,analytic-sequential,random,zero"
DEFAULT_EPISODES = 100
QUICK_EPISODES = 20
#: Episodes per suite whose trajectories are recorded for the trajectory plot.
TRAJECTORIES_PER_SUITE = 3


class InputError(Exception):
    """Bad command-line input (exit status 2)."""


# =============================================================================== CLI
def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description="Benchmark policies of Planar3P-v0 on fixed evaluation suites.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    p.add_argument(
        "--policies",
        default=DEFAULT_POLICIES,
        help="comma-separated: analytic-simultaneous, analytic-sequential, random, zero, "
        "pretrained:NAME, or paths to SB3 model .zip files (optionally prefixed ppo:, sac:, "
        "td3:, a2c:, ddpg:)",
    )
    p.add_argument(
        "--suites",
        default=",".join(ev.SUITE_NAMES),
        help=f"comma-separated suites among {', '.join(ev.SUITE_NAMES)}",
    )
    p.add_argument(
        "--episodes",
        type=int,
        default=None,
        help=f"episodes per suite (default {DEFAULT_EPISODES}, {QUICK_EPISODES} with --quick)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the suites and of the policies")
    p.add_argument("--out", default="results/benchmark", help="output directory")
    p.add_argument(
        "--quick",
        action="store_true",
        help=f"{QUICK_EPISODES} episodes per suite and 500 bootstrap resamples (about a minute)",
    )
    p.add_argument("--suite-file", default=None, help="replay the suites of a saved suites.json")
    p.add_argument(
        "--working-mode",
        default=None,
        help="override the working mode of every generated suite, e.g. 1,1,-1 "
        f"(default per suite: {ev.DEFAULT_SUITE_MODES})",
    )
    p.add_argument(
        "--hard-end-margin",
        type=float,
        default=None,
        help="parallel margin of the ends of hard pairs (default: the environment's 0.04)",
    )
    p.add_argument(
        "--hold-force-fraction",
        type=float,
        default=0.25,
        help="hard/far ends need at most this fraction of max_force to be held against gravity",
    )
    p.add_argument("--bootstrap", type=int, default=None, help="bootstrap resamples (2000)")
    p.add_argument("--device", default="cpu", help="torch device of SB3 models")
    p.add_argument("--no-plots", action="store_true", help="skip the plots")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p.parse_args(argv)


def _split(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def _parse_mode(text: str | None) -> tuple[int, int, int] | None:
    if text is None:
        return None
    try:
        mode = tuple(int(v) for v in _split(text))
    except ValueError:
        mode = ()
    if len(mode) != 3 or any(m not in (1, -1) for m in mode):
        raise InputError(f"--working-mode must be three of +1/-1 like 1,1,-1, got {text!r}")
    return mode  # type: ignore[return-value]


# =============================================================================== output
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
    causes = list(ev.FAILURE_CAUSES)
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


def _rate(results: Sequence[ev.EpisodeResult], key: str, value: bool) -> str:
    sel = [r for r in results if getattr(r, key) == value]
    if not sel:
        return "–"
    return f"{sum(r.success for r in sel)}/{len(sel)}"


def path_table(results: dict[tuple[str, str], list[ev.EpisodeResult]]) -> str:
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


def suites_section(suites: dict[str, ev.Suite]) -> str:
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


def suite_definitions(suites: dict[str, ev.Suite]) -> str:
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
  1 deg of the target, every slider slower than 0.01 m/s); 95% percentile-bootstrap interval.
  With every episode a success (or none) the bootstrap interval collapses to a point.
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
    suites: dict[str, ev.Suite],
    summaries: list[dict[str, Any]],
    results: dict[tuple[str, str], list[ev.EpisodeResult]],
    plots: list[str],
    complete: bool,
) -> str:
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


def write_rows(out: Path, results: dict[tuple[str, str], list[ev.EpisodeResult]]) -> None:
    rows = [r.row() for res in results.values() for r in res]
    if not rows:
        return
    with (out / "episodes.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for row in rows:
            w.writerow({k: (round(v, 6) if isinstance(v, float) else v) for k, v in row.items()})


def write_summary(out: Path, settings: dict[str, Any], summaries: list[dict[str, Any]]) -> None:
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


# =============================================================================== plots
def plot_success(out: Path, summaries: list[dict[str, Any]], suites: list[str]) -> str:
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
    ax.set_title("Success rate per suite (95% bootstrap CI)")
    ax.legend(fontsize=7, loc="upper right", ncols=1 if len(policies) < 5 else 2)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "success_rate.png", dpi=110)
    plt.close(fig)
    return "success_rate.png"


def plot_errors(
    out: Path, results: dict[tuple[str, str], list[ev.EpisodeResult]], suites: list[str]
) -> str:
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
    th = (th + math.pi) % (2.0 * math.pi) - math.pi
    jumps = np.flatnonzero(np.abs(np.diff(th)) > math.pi) + 1
    return np.insert(th, jumps, np.nan), np.insert(y, jumps, np.nan)


def plot_trajectories(
    out: Path,
    design: planar3p_gym.Design,
    suites: dict[str, ev.Suite],
    results: dict[tuple[str, str], list[ev.EpisodeResult]],
) -> str | None:
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
        f = ev.ytheta_fields(design, mode, ys, ths)
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


# =============================================================================== main
def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    command = "python scripts/benchmark.py" + (
        " " + shlex.join(list(argv)) if argv is not None else " " + shlex.join(sys.argv[1:])
    )
    try:
        return _run(args, command.strip())
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


def _run(args: argparse.Namespace, command: str) -> int:
    t_start = time.perf_counter()
    # ---- validate everything before writing anything
    episodes = (
        args.episodes
        if args.episodes is not None
        else (QUICK_EPISODES if args.quick else DEFAULT_EPISODES)
    )
    if episodes < 1:
        raise InputError(f"--episodes must be >= 1, got {episodes}")
    n_boot = args.bootstrap if args.bootstrap is not None else (500 if args.quick else 2000)
    if n_boot < 10:
        raise InputError(f"--bootstrap must be >= 10, got {n_boot}")
    suite_names = _split(args.suites)
    if not suite_names:
        raise InputError("--suites is empty")
    unknown = [s for s in suite_names if s not in ev.SUITE_NAMES]
    if unknown and args.suite_file is None:
        raise InputError(
            f"unknown suite(s) {', '.join(map(repr, unknown))}; known: {', '.join(ev.SUITE_NAMES)}"
        )
    mode = _parse_mode(args.working_mode)
    specs = _split(args.policies)
    if not specs:
        raise InputError("--policies is empty")
    env = gym.make(planar3p_gym.ENV_ID)
    design = env.unwrapped.design
    labels: list[str] = []
    policies: dict[str, Any] = {}
    for text in specs:
        try:
            ps = parse_policy_spec(text)
            label = policy_label(text)
            if label in policies:
                raise PolicyError(f"policy {text!r} given twice (as {label!r})")
            policies[label] = load_policy(ps, env=env, seed=args.seed, device=args.device)
        except PolicyError as exc:
            raise InputError(str(exc)) from exc
        labels.append(label)
        trained_with = getattr(policies[label], "env_kwargs", None)
        if trained_with:
            print(
                f"warning: {label} was trained with environment arguments {trained_with}; "
                "the benchmark runs the default Planar3P-v0",
                file=sys.stderr,
            )
    if args.suite_file is not None:
        try:
            loaded, file_design = ev.load_suites(args.suite_file)
        except ValueError as exc:
            raise InputError(str(exc)) from exc
        if file_design != design:
            raise InputError(f"{args.suite_file} was made for another design: {file_design}")
        missing = [s for s in suite_names if s not in loaded]
        if missing:
            raise InputError(
                f"suite(s) {', '.join(missing)} not in {args.suite_file}; it has "
                f"{', '.join(loaded)}"
            )
        suites = {s: loaded[s] for s in suite_names}
        episodes = max(len(s) for s in suites.values())
    else:
        try:
            suites = {
                name: ev.make_suite(
                    name,
                    episodes,
                    args.seed,
                    design,
                    working_mode=mode,
                    end_parallel_margin=args.hard_end_margin,
                    hold_force_fraction=args.hold_force_fraction,
                )
                for name in suite_names
            }
        except ValueError as exc:
            raise InputError(f"cannot generate the suites: {exc}") from exc

    # ---- run
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output directory {out}: {exc}") from exc
    ev.save_suites(out / "suites.json", suites, design)
    settings: dict[str, Any] = {
        "command": command,
        "seed": args.seed,
        "episodes": episodes,
        "suites": suite_names,
        "policies": dict(zip(labels, specs, strict=True)),
        "policy_env_kwargs": {
            k: getattr(p, "env_kwargs", None)
            for k, p in policies.items()
            if getattr(p, "env_kwargs", None)
        },
        "bootstrap": n_boot,
        "design": "fig8" if design == planar3p_gym.Design.fig8() else design.to_dict(),
        "env": env.unwrapped.config(),
        "elapsed_s": 0.0,
    }
    results: dict[tuple[str, str], list[ev.EpisodeResult]] = {}
    summaries: list[dict[str, Any]] = []
    total = sum(len(s) for s in suites.values()) * len(labels)
    bar = _progress(total, disable=args.no_progress)
    status = 0
    try:
        for label in labels:
            for name, suite in suites.items():
                bar.set_description(f"{label} / {name}")
                res = ev.evaluate(
                    env,
                    policies[label],
                    suite,
                    policy_name=label,
                    seed=args.seed,
                    record=lambda spec: spec.index < TRAJECTORIES_PER_SUITE,
                    callback=lambda _r: bar.update(1),
                )
                results[(label, name)] = res
                summaries.append(ev.summarize(res, n_resamples=n_boot, seed=args.seed))
                write_rows(out, results)
                settings["elapsed_s"] = time.perf_counter() - t_start
                write_summary(out, settings, summaries)
    except KeyboardInterrupt:
        print("\ninterrupted: writing the results finished so far", file=sys.stderr)
        status = 130
    except Exception as exc:  # a policy or model failing at run time
        print(
            f"\nerror: evaluation failed ({type(exc).__name__}: {exc}); "
            f"writing the results finished so far to {out}",
            file=sys.stderr,
        )
        status = 1
    finally:
        bar.close()
    settings["elapsed_s"] = time.perf_counter() - t_start
    write_summary(out, settings, summaries)
    plots: list[str] = []
    if summaries and not args.no_plots:
        done = [s for s in suite_names if any(k[1] == s for k in results)]
        plots.append(plot_success(out, summaries, done))
        plots.append(plot_errors(out, results, done))
        traj = plot_trajectories(out, design, {s: suites[s] for s in done}, results)
        if traj:
            plots.append(traj)
    table = write_report(
        out, command, settings, suites, summaries, results, plots, complete=status == 0
    )
    print(table)
    print(f"\nreport: {out / 'report.md'}  ({settings['elapsed_s']:.0f} s)")
    return status


class _NoBar:
    def update(self, n: int = 1) -> None: ...
    def set_description(self, text: str) -> None: ...
    def close(self) -> None: ...


def _progress(total: int, disable: bool) -> Any:
    if disable:
        return _NoBar()
    try:
        from tqdm.auto import tqdm
    except ImportError:  # tqdm comes with the [train] extra
        return _NoBar()
    return tqdm(total=total, unit="ep", dynamic_ncols=True)


if __name__ == "__main__":
    sys.exit(main())
