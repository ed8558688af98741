"""Normalized scores, D4RL-style: per suite, 0 = the random policy, 100 = the best baseline.

A policy's per-suite ``success``, ``time`` (``speed_bound / time_to_success``, 0 for a failed
episode) and ``return`` are mapped to ``100 * (value - random) / (best - random)`` with the
reference values of :data:`REFERENCE_FILE`; rliable-style statistics over training seeds
(numpy code of :mod:`planar3p_agents.evaluation.seed_statistics`).  The reference baselines and
the command lines: docs/benchmark.md, "How the suite and score modules work".

* :func:`get_normalized_score`, :func:`load_references`, :func:`make_references`,
  :func:`best_baselines`: the scores and their references;
* :func:`score_matrix`, :func:`write_scores`, :func:`probability_of_improvement`,
  :func:`scores_markdown`, :func:`replace_report_section`: the per-seed matrix, its figures and
  the report's section (``python -m planar3p_agents.evaluation.normalized_scores``).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import shlex
import sys
from collections.abc import Iterable, Mapping, Sequence
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from planar3p_agents.controllers.registry import STRONGEST_REACH_BASELINES
from planar3p_agents.evaluation.seed_statistics import group_label, stratified_bootstrap_iqm
from planar3p_gym import atomic_files

__all__ = [
    "BEST_BASELINES",
    "RANDOM_POLICY",
    "REFERENCE_FILE",
    "SCORE_FILES",
    "SCORE_METRICS",
    "TASK_BEST_BASELINES",
    "best_baselines",
    "get_normalized_score",
    "load_references",
    "make_references",
    "probability_of_improvement",
    "read_rows",
    "replace_report_section",
    "score_matrix",
    "scores_markdown",
    "suite_values",
    "write_scores",
]

#: The per-suite values that can be normalized.
SCORE_METRICS: tuple[str, ...] = ("success", "time", "return")
#: The policy that scores 0.
RANDOM_POLICY = "random"
#: The baselines whose best value scores 100 on the reaching suites (the
#: strongest baselines).
BEST_BASELINES: tuple[str, ...] = STRONGEST_REACH_BASELINES
#: The suites where other baselines are the strongest: the task's own (the certified planner of
#: the working-mode change, the crossing demonstration and the simple motions of the
#: assembly-mode change, the tuned feed-forward tracker, the delay-aware and the bang-bang laws of
#: the on-off motors).
TASK_BEST_BASELINES: dict[str, tuple[str, ...]] = {
    "mode-change": ("planner",),
    "real-mode-change": ("planner",),
    "assembly-change": ("crossing", "analytic-simultaneous"),
    "real-assembly-change": ("crossing", "analytic-simultaneous"),
    "track-segments": ("analytic-feedforward-tuned",),
    "track-figure-eight": ("analytic-feedforward-tuned",),
    "real-on-off": ("analytic-on-off-predictive", "analytic-on-off"),
    # On the built machine the certified planner and the slider line lose half their episodes
    # (they plan on the nominal model) and the paper's controller at its shipped gain is best.
    "real-reach": (*BEST_BASELINES, "analytic-simultaneous"),
}
#: The reference values.
REFERENCE_FILE = Path(__file__).with_name("reference_scores.json")
#: Files :func:`write_scores` writes.
SCORE_FILES = ("scores.csv", "scores_iqm.png", "scores_profiles.png", "scores_improvement.png")


def _float(v: Any) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def _truth(v: Any) -> bool:
    return v is True or str(v).strip().lower() in ("true", "1", "1.0")


def episode_values(row: Mapping[str, Any]) -> dict[str, float]:
    """``success`` (0/1), ``time`` (``speed_bound / time_to_success``, 0 if failed, NaN
    without a speed bound) and ``return`` of one episode row (``episodes.csv`` or
    :meth:`~planar3p_agents.evaluation.episodes.EpisodeResult.row`)."""
    ok = _truth(row.get("success"))
    bound, t = _float(row.get("speed_bound")), _float(row.get("time_to_success"))
    time = (bound / t if ok and t > 0 else 0.0) if math.isfinite(bound) else math.nan
    return {"success": float(ok), "time": time, "return": _float(row.get("episode_return"))}


def read_rows(path: str | Path) -> list[dict[str, str]]:
    """The rows of a benchmark's ``episodes.csv`` (``ValueError`` if missing)."""
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"no such file: {p}")
    with p.open(newline="") as fh:
        return list(csv.DictReader(fh))


Run = tuple[str, str, str]  # (policy, training seed or "", suite)


def suite_values(rows: Iterable[Mapping[str, Any]]) -> dict[Run, dict[str, float]]:
    """Per (policy, training seed, suite): the mean of each of :data:`SCORE_METRICS` over the
    suite's episodes (NaN where an episode has no value)."""
    acc: dict[Run, list[dict[str, float]]] = {}
    for row in rows:
        seed = row.get("training_seed", "")
        key = (str(row["policy"]), "" if seed is None else str(seed), str(row["suite"]))
        acc.setdefault(key, []).append(episode_values(row))
    return {
        k: {m: float(np.mean([v[m] for v in vals])) for m in SCORE_METRICS}
        for k, vals in acc.items()
    }


def best_baselines(suite: str) -> tuple[str, ...]:
    """The baselines whose best value scores 100 on ``suite``."""
    return TASK_BEST_BASELINES.get(suite, BEST_BASELINES)


def make_references(
    rows: Iterable[Mapping[str, Any]],
    best_of: Sequence[str] | None = None,
    random: str = RANDOM_POLICY,
) -> dict[str, dict[str, dict[str, Any]]]:
    """``{suite: {metric: {"random", "best", "best_policy"}}}`` from benchmark rows that hold
    the random policy and some of the suite's best baselines (``best_of``, default
    :func:`best_baselines`) on each suite (``ValueError`` if no suite does).  A metric whose
    best value is not above the random policy's, or not finite, gets no entry."""
    values = suite_values(rows)
    suites = list(dict.fromkeys(s for _, _, s in values))
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for suite in suites:
        names = tuple(best_of) if best_of is not None else best_baselines(suite)
        rnd = [v for (p, _, s), v in values.items() if s == suite and p == random]
        best = {p: v for (p, _, s), v in values.items() if s == suite and p in names}
        if not rnd or not best:
            continue
        entry = {}
        for m in SCORE_METRICS:
            ranked = {p: v[m] for p, v in best.items() if math.isfinite(v[m])}
            if not ranked or not math.isfinite(rnd[0][m]):
                continue
            name = max(ranked, key=lambda p: (ranked[p], -names.index(p)))
            if ranked[name] > rnd[0][m]:
                entry[m] = {
                    "random": round(rnd[0][m], 6),
                    "best": round(ranked[name], 6),
                    "best_policy": name,
                }
        if entry:
            out[suite] = entry
    if not out:
        raise ValueError(f"no suite holds both {random!r} and one of its best baselines")
    return out


@cache
def _reference_file(path: str) -> dict[str, Any]:
    return json.loads(Path(path).read_text())


def load_references(references: Mapping[str, Any] | str | Path | None = None) -> Mapping[str, Any]:
    """The per-suite reference values: a mapping as :func:`make_references` returns (or a
    reference file's content), a reference file, or ``None`` (:data:`REFERENCE_FILE`)."""
    if isinstance(references, Mapping):
        return references.get("suites", references)
    p = Path(references) if references is not None else REFERENCE_FILE
    try:
        return _reference_file(str(p))["suites"]
    except (OSError, ValueError, KeyError) as exc:
        raise ValueError(f"cannot read the reference scores {p.name}: {exc}") from exc


def get_normalized_score(
    suite: str,
    value: float,
    metric: str = "success",
    references: Mapping[str, Any] | str | Path | None = None,
) -> float:
    """``value`` of ``metric`` (:data:`SCORE_METRICS`: a success rate in [0, 1], a mean
    ``speed_bound / time_to_success``, or a mean return) on ``suite`` as a normalized score:
    0 = the random policy, 100 = the best of the suite's :func:`best_baselines` (D4RL's
    ``get_normalized_score``).  ``references``: the reference values (a mapping as
    :func:`make_references` returns, a file, or ``None``: :data:`REFERENCE_FILE`).
    ``ValueError`` for an unknown metric or a suite without references."""
    if metric not in SCORE_METRICS:
        raise ValueError(f"unknown metric {metric!r}; known: {', '.join(SCORE_METRICS)}")
    refs = load_references(references)
    if suite not in refs:
        raise ValueError(f"no reference scores for suite {suite!r}; known: {', '.join(refs)}")
    if metric not in refs[suite]:
        raise ValueError(f"suite {suite!r} has no reference for the {metric} score")
    lo, hi = float(refs[suite][metric]["random"]), float(refs[suite][metric]["best"])
    if not hi > lo:
        raise ValueError(f"degenerate references for {suite!r}/{metric}: {lo} >= {hi}")
    return 100.0 * (float(value) - lo) / (hi - lo)


def score_matrix(
    rows: Iterable[Mapping[str, Any]], references: Mapping[str, Any] | str | Path | None = None
) -> list[dict[str, Any]]:
    """The raw per-training-seed x per-suite matrix, one row per (policy, training seed,
    suite) on the suites with references: the raw values and their normalized scores
    (``score_<metric>``).  ``group`` pools policies that differ only by training seed
    (:func:`planar3p_agents.evaluation.seed_statistics.group_label`)."""
    refs = load_references(references)
    out = []
    for (policy, seed, suite), v in suite_values(rows).items():
        if suite not in refs:
            continue
        row: dict[str, Any] = {
            "group": group_label(policy),
            "policy": policy,
            "training_seed": seed,
            "suite": suite,
        }
        for m in SCORE_METRICS:
            row[m] = round(v[m], 6)
        for m in SCORE_METRICS:
            ok = math.isfinite(v[m]) and m in refs[suite]
            s = get_normalized_score(suite, v[m], m, refs) if ok else math.nan
            row[f"score_{m}"] = round(s, 3)
        out.append(row)
    return out


def _runs(matrix: Sequence[Mapping[str, Any]], metric: str) -> dict[str, np.ndarray]:
    """Per group: the ``(runs, suites)`` array of ``score_<metric>`` (runs: training seeds,
    suites in order of appearance; runs missing a suite are dropped)."""
    suites = list(dict.fromkeys(r["suite"] for r in matrix))
    out = {}
    for group in dict.fromkeys(r["group"] for r in matrix):
        cells: dict[str, dict[str, float]] = {}
        for r in matrix:
            if r["group"] == group:
                cells.setdefault(r["policy"] + "|" + str(r["training_seed"]), {})[r["suite"]] = r[
                    f"score_{metric}"
                ]
        runs = [[c[s] for s in suites] for c in cells.values() if all(s in c for s in suites)]
        x = np.asarray(runs, dtype=np.float64)
        if x.size and np.isfinite(x).all():
            out[group] = x
    return out


def probability_of_improvement(
    x: np.ndarray, y: np.ndarray, n_resamples: int = 2000, seed: int = 0
) -> tuple[float, float, float]:
    """rliable's probability of improvement ``P(X > Y)`` of scores ``x`` ``(n, tasks)`` over
    ``y`` ``(m, tasks)``: per task the Mann-Whitney statistic ``P(x > y) + P(x = y) / 2`` over
    all run pairs, averaged over tasks; with its 95 % stratified-bootstrap interval (runs of
    each policy resampled within each task)."""

    def stat(a: np.ndarray, b: np.ndarray) -> float:
        gt = (a[:, None, :] > b[None, :, :]).mean(axis=(0, 1))
        eq = (a[:, None, :] == b[None, :, :]).mean(axis=(0, 1))
        return float(np.mean(gt + 0.5 * eq))

    point = stat(x, y)
    if len(x) == 1 and len(y) == 1:
        return point, point, point
    rng = np.random.default_rng(seed)
    tasks = x.shape[1]
    stats = []
    for _ in range(n_resamples):
        ix = rng.integers(len(x), size=(len(x), tasks))
        iy = rng.integers(len(y), size=(len(y), tasks))
        stats.append(stat(np.take_along_axis(x, ix, 0), np.take_along_axis(y, iy, 0)))
    lo, hi = np.quantile(stats, [0.025, 0.975])
    return point, float(lo), float(hi)


def scores_markdown(
    matrix: Sequence[Mapping[str, Any]], n_resamples: int = 2000, seed: int = 0
) -> str:
    """The normalized-score table: per policy group and suite the score of each metric (runs
    pooled: the IQM over training seeds where there are several), and the IQM over all
    runs and suites with its 95 % stratified-bootstrap interval."""
    suites = list(dict.fromkeys(r["suite"] for r in matrix))
    head = " | ".join(f"{s} success / time / return" for s in suites)
    lines = [
        f"| policy | runs | {head} | IQM success score [95% CI] | IQM time score [95% CI] |",
        "|" + "---|" * (len(suites) + 4),
    ]
    per_metric = {m: _runs(matrix, m) for m in ("success", "time")}
    for group in dict.fromkeys(r["group"] for r in matrix):
        cells = []
        for s in suites:
            sel = [r for r in matrix if r["group"] == group and r["suite"] == s]
            if not sel:
                cells.append("–")
                continue
            cells.append(
                " / ".join(
                    _fmt(float(np.median([r[f"score_{m}"] for r in sel]))) for m in SCORE_METRICS
                )
            )
        agg = []
        for m in ("success", "time"):
            x = per_metric[m].get(group)
            if x is None:
                agg.append("–")
                continue
            p, lo, hi = stratified_bootstrap_iqm(x, n_resamples=n_resamples, seed=seed)
            agg.append(f"{p:.1f} [{lo:.1f}, {hi:.1f}]")
        runs = len({(r["policy"], r["training_seed"]) for r in matrix if r["group"] == group})
        lines.append(f"| {group} | {runs} | " + " | ".join(cells + agg) + " |")
    return "\n".join(lines)


def _fmt(x: float) -> str:
    return "–" if not math.isfinite(x) else f"{x:.0f}"


def _figures(
    out: Path, matrix: Sequence[Mapping[str, Any]], n_resamples: int, seed: int
) -> list[str]:
    """The three rliable figures (file names written into ``out``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    runs = {m: _runs(matrix, m) for m in ("success", "time")}
    # (suites without a speed bound, such as the mode change, have no time score)
    metrics = [m for m in ("success", "time") if runs[m]]
    groups = [g for g in dict.fromkeys(r["group"] for r in matrix) if g in runs["success"]]
    if not groups:
        return written
    # 1. IQM with stratified-bootstrap intervals
    fig, axes = plt.subplots(
        1, len(metrics), figsize=(5 * len(metrics), 0.45 * len(groups) + 1.5), sharey=True,
        squeeze=False,
    )  # fmt: skip
    for ax, m in zip(axes[0], metrics, strict=True):
        for i, g in enumerate(groups):
            x = runs[m].get(g)
            if x is None:
                continue
            p, lo, hi = stratified_bootstrap_iqm(x, n_resamples=n_resamples, seed=seed)
            ax.plot([lo, hi], [i, i], lw=6, alpha=0.5, color=f"C{i % 10}")
            ax.plot([p], [i], "|", ms=14, color="k")
        ax.set_yticks(range(len(groups)), groups)
        ax.set_xlabel(f"IQM normalized {m} score (0 random, 100 best baseline)")
        ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "scores_iqm.png", dpi=120)
    plt.close(fig)
    written.append("scores_iqm.png")
    # 2. performance profiles: fraction of run-suite scores above tau
    fig, axes = plt.subplots(
        1, len(metrics), figsize=(5 * len(metrics), 4), sharey=True, squeeze=False
    )
    for ax, m in zip(axes[0], metrics, strict=True):
        every = np.concatenate([v.ravel() for v in runs[m].values()])
        taus = np.linspace(min(0.0, every.min()), max(110.0, every.max()), 200)
        for i, g in enumerate(groups):
            x = runs[m].get(g)
            if x is None:
                continue
            ax.plot(
                taus, (x.ravel()[None, :] > taus[:, None]).mean(axis=1), label=g, color=f"C{i % 10}"
            )
        ax.set_xlabel(f"normalized {m} score tau")
        ax.set_ylabel("fraction of runs x suites with score > tau")
        ax.grid(alpha=0.3)
    axes[0, -1].legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(out / "scores_profiles.png", dpi=120)
    plt.close(fig)
    written.append("scores_profiles.png")
    # 3. probability of improvement over the best baseline (by the IQM time score; by the
    # success score on suites without one)
    m = metrics[-1]
    every_best = {b for s in dict.fromkeys(r["suite"] for r in matrix) for b in best_baselines(s)}
    base = [g for g in groups if g in every_best and g in runs[m]]
    if base:
        ref = max(
            base,
            key=lambda g: stratified_bootstrap_iqm(runs[m][g], n_resamples=10, seed=seed)[0],
        )
        others = [g for g in groups if g != ref and g in runs[m]]
        fig, ax = plt.subplots(figsize=(6, 0.45 * len(others) + 1.5))
        for i, g in enumerate(others):
            p, lo, hi = probability_of_improvement(runs[m][g], runs[m][ref], n_resamples, seed)
            ax.plot([lo, hi], [i, i], lw=6, alpha=0.5, color=f"C{i % 10}")
            ax.plot([p], [i], "|", ms=14, color="k")
        ax.axvline(0.5, ls="--", color="grey")
        ax.set_xlim(-0.03, 1.03)
        ax.set_yticks(range(len(others)), others)
        ax.set_xlabel(f"P(policy > {ref}) on the normalized {m} score")
        fig.tight_layout()
        fig.savefig(out / "scores_improvement.png", dpi=120)
        plt.close(fig)
        written.append("scores_improvement.png")
    return written


def write_scores(
    out: str | Path,
    rows: Iterable[Mapping[str, Any]],
    *,
    references: Mapping[str, Any] | str | Path | None = None,
    n_resamples: int = 2000,
    seed: int = 0,
    plots: bool = True,
) -> str:
    """Write ``scores.csv`` (:func:`score_matrix`) and the figures into ``out`` and return the
    markdown section of the report (empty if no suite has references)."""
    out = Path(out)
    matrix = score_matrix(rows, references)
    if not matrix:
        return ""
    out.mkdir(parents=True, exist_ok=True)
    with (out / "scores.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(matrix[0]))
        w.writeheader()
        w.writerows(matrix)
    figures = _figures(out, matrix, n_resamples, seed) if plots else []
    parts = [
        "## Normalized scores",
        "",
        "Per suite 0 = `random`, 100 = the best of the suite's strongest baselines ("
        + "; ".join(
            f"{s}: " + ", ".join(f"`{b}`" for b in best_baselines(s))
            for s in dict.fromkeys(r["suite"] for r in matrix)
        )
        + "; `agents/evaluation/reference_scores.json`); `success`: success rate, "
        "`time`: mean of speed bound / time to success (0 for a failure), `return`: mean "
        "episode return.  Raw matrix (per training seed x suite): `scores.csv`.",
        "",
        scores_markdown(matrix, n_resamples, seed),
        "",
    ]
    parts += [f"![{Path(f).stem}]({f})" for f in figures]
    return "\n".join(parts) + "\n"


def replace_report_section(report: Path, section: str) -> bool:
    """Replace the ``## Normalized scores`` section of a benchmark's ``report.md`` (up to the
    next ``## `` heading) by ``section``, so that a report follows the reference file after it
    changes without playing its episodes again; False (nothing written) if the report or the
    section is missing."""
    if not report.is_file():
        return False
    lines = report.read_text().splitlines(keepends=True)
    heading = section.splitlines()[0]
    starts = [i for i, line in enumerate(lines) if line.rstrip("\n") == heading]
    if not starts:
        return False
    start = starts[0]
    end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("## ")), len(lines))
    text = "".join(lines[:start]) + section + "\n" + "".join(lines[end:])
    atomic_files.write_atomic(report, text)
    return True


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Normalized scores of a benchmark run.")
    sub = parser.add_subparsers(dest="command", required=True)
    ref = sub.add_parser("references", help="regenerate the reference scores file")
    ref.add_argument("episodes_csv", nargs="+", help="benchmark episodes.csv files, pooled")
    ref.add_argument("--out", default=str(REFERENCE_FILE))
    mat = sub.add_parser("matrix", help="write scores.csv, the figures and scores.md")
    mat.add_argument("episodes_csv")
    mat.add_argument("--out", required=True, help="output directory")
    mat.add_argument("--resamples", type=int, default=2000)
    args = parser.parse_args(argv)
    given = list(argv) if argv is not None else sys.argv[1:]
    try:
        if args.command == "references":
            rows = [r for path in args.episodes_csv for r in read_rows(path)]
            suites = make_references(rows)
            data = {
                "command": "python -m planar3p_agents.evaluation.normalized_scores "
                + shlex.join(given),
                "random": RANDOM_POLICY,
                "best_of": {s: list(best_baselines(s)) for s in suites},
                "suites": suites,
            }
            Path(args.out).write_text(json.dumps(data, indent=1) + "\n")
            print(json.dumps(data["suites"], indent=1))
        else:
            rows = read_rows(args.episodes_csv)
            text = write_scores(args.out, rows, n_resamples=args.resamples)
            if not text:
                raise ValueError("no suite of this run has reference scores")
            (Path(args.out) / "scores.md").write_text(text)
            if replace_report_section(Path(args.out) / "report.md", text):
                print(f"updated the normalized scores of {Path(args.out) / 'report.md'}")
            print(text)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
