"""Results across training seeds: rliable's interquartile mean with stratified-bootstrap intervals.

A learned policy's result is a distribution over training seeds, not one number. Following
Agarwal et al. (2021, *Deep RL at the Edge of the Statistical Precipice*, the method of the
``rliable`` library), each training run contributes one score per task (here: its success rate
on a benchmark suite, or for a continuous metric of :data:`METRICS` such as the tracking RMS
error the median over the suite's episodes), the aggregate is the interquartile mean (IQM) of
all run-task scores, and its 95 % interval comes from a *stratified* bootstrap: runs are
resampled with replacement independently within each task, and the percentile interval of the
resampled IQMs is reported.

``rliable`` itself is not a dependency (it pins ``pandas<3`` and ``arch<7.2``); the computation
is a few lines of numpy on top of :func:`planar3p_agents.evaluation.intervals.iqm` (SciPy's
``trim_mean``). SciPy's ``bootstrap`` resamples one sample or paired samples, not independently per
stratum, so the resampling is written here.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from planar3p_agents.evaluation.intervals import iqm

#: Metrics a seed table can aggregate: ``episodes.csv`` column -> (what a seed's score is, the
#: unit shown, the factor from the column's unit to it).  ``success`` is the rate over the
#: suite's episodes; the others are the median over its episodes (rows without a value skipped).
METRICS: dict[str, tuple[str, str, float]] = {
    "success": ("success", "%", 100.0),
    "episode_return": ("median return", "", 1.0),
    "time_to_success": ("median time to success", "s", 1.0),
    "time_over_bound": ("median time to success over the speed bound", "x", 1.0),
    "tracking_rms_error": ("median tracking RMS error", "mm", 1000.0),
    "tracking_max_error": ("median tracking max error", "mm", 1000.0),
    "tracking_rms_position_error": ("median tracking RMS position error", "mm", 1000.0),
    "tracking_rms_orientation_error": (
        "median tracking RMS orientation error",
        "deg",
        math.degrees(1.0),
    ),
}

__all__ = [
    "METRICS",
    "SeedGroup",
    "from_csv",
    "group_label",
    "markdown",
    "read_seed_scores",
    "seed_table",
    "stratified_bootstrap_iqm",
]


def stratified_bootstrap_iqm(
    scores: ArrayLike, n_resamples: int = 2000, confidence: float = 0.95, seed: int = 0
) -> tuple[float, float, float]:
    """IQM of ``scores`` (shape ``(runs, tasks)``) and its stratified-bootstrap interval.

    Each resample draws, for every task (column) independently, ``runs`` runs with replacement
    from that column; the interval is the percentile interval of the resamples' IQMs.  A single
    run gives a point interval.  ``ValueError`` for an empty or non-finite input.
    """
    x = np.asarray(scores, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2 or x.size == 0:
        raise ValueError(f"scores must be a non-empty (runs, tasks) array, got shape {x.shape}")
    if not np.isfinite(x).all():
        raise ValueError("scores must be finite")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    if n_resamples < 1:
        raise ValueError(f"n_resamples must be at least 1, got {n_resamples!r}")
    point = float(iqm(x.reshape(-1)))
    runs, tasks = x.shape
    if runs == 1:
        return point, point, point
    rng = np.random.default_rng(seed)
    picks = rng.integers(runs, size=(n_resamples, runs, tasks))
    resampled = np.take_along_axis(x[None, :, :], picks, axis=1).reshape(n_resamples, -1)
    stats = np.asarray(iqm(resampled, axis=-1))
    alpha = (1.0 - confidence) / 2.0
    lo, hi = np.quantile(stats, [alpha, 1.0 - alpha])
    return point, float(lo), float(hi)


def group_label(policy: str) -> str:
    """Policies that differ only by training seed share a label: the seed token ``-s<n>`` of a
    run name (``runs/ppo-v1-s3/model`` -> ``runs/ppo-v1/model``) is removed."""
    return re.sub(r"-s\d+(?=/|$|:)", "", policy)


#: Per-seed scores of one group: ``{suite: {training_seed: success rate}}``.
SeedGroup = dict[str, dict[int, float]]


def _check_metric(metric: str) -> None:
    if metric not in METRICS:
        raise ValueError(f"unknown metric {metric!r}; known: {', '.join(METRICS)}")


def read_seed_scores(
    rows: Iterable[Mapping[str, Any]], metric: str = "success"
) -> dict[str, SeedGroup]:
    """One score per (group, suite, training seed) from benchmark ``episodes.csv`` rows
    (columns ``policy``, ``training_seed``, ``suite`` and ``metric``): the success rate, or
    the median of a continuous :data:`METRICS` column over the episodes that have a value (not
    empty, not NaN; in the column's own unit).  Rows without a training seed (analytic
    controllers, unknown models) are skipped; ``ValueError`` for an unknown metric or a
    non-numeric value."""
    _check_metric(metric)
    values: dict[tuple[str, str, int], list[float]] = {}
    for row in rows:
        seed = str(row.get("training_seed", "")).strip()
        if not seed:
            continue
        text = str(row.get(metric, "")).strip()
        if metric == "success":
            value = float(text.lower() in ("true", "1", "1.0"))
        elif not text:
            continue
        else:
            try:
                value = float(text)
            except ValueError:
                raise ValueError(f"{metric} value {text!r} is not a number") from None
            if math.isnan(value):  # no value: e.g. the time to success of a failed episode
                continue
        key = (group_label(str(row["policy"])), str(row["suite"]), int(seed))
        values.setdefault(key, []).append(value)
    out: dict[str, SeedGroup] = {}
    for (group, suite, seed), vals in sorted(values.items()):
        score = float(np.mean(vals)) if metric == "success" else float(np.median(vals))
        out.setdefault(group, {}).setdefault(suite, {})[seed] = score
    return out


def seed_table(
    groups: Mapping[str, SeedGroup], n_resamples: int = 2000, seed: int = 0
) -> list[dict[str, Any]]:
    """One row per group and suite: seeds, per-seed success rates, IQM and its interval
    (:func:`stratified_bootstrap_iqm` with one task), and the same over all of the group's
    suites together (stratified by suite, only when every suite has the same seeds)."""
    rows = []
    for group, suites in groups.items():
        for suite, per_seed in suites.items():
            seeds = sorted(per_seed)
            point, lo, hi = stratified_bootstrap_iqm(
                [per_seed[s] for s in seeds], n_resamples=n_resamples, seed=seed
            )
            rows.append(
                {"group": group, "suite": suite, "seeds": seeds,
                 "scores": [per_seed[s] for s in seeds], "iqm": point, "low": lo, "high": hi}
            )  # fmt: skip
        seed_sets = {tuple(sorted(v)) for v in suites.values()}
        if len(suites) > 1 and len(seed_sets) == 1:
            seeds = list(next(iter(seed_sets)))
            matrix = [[suites[name][s] for name in suites] for s in seeds]
            point, lo, hi = stratified_bootstrap_iqm(matrix, n_resamples=n_resamples, seed=seed)
            rows.append(
                {"group": group, "suite": "all (stratified by suite)", "seeds": seeds,
                 "scores": [], "iqm": point, "low": lo, "high": hi}
            )  # fmt: skip
    return rows


def markdown(rows: list[dict[str, Any]], metric: str = "success") -> str:
    """The :func:`seed_table` rows of ``metric`` as a markdown table (success rates in %,
    tracking errors in mm: the unit of :data:`METRICS`)."""
    _check_metric(metric)
    name, unit, factor = METRICS[metric]
    what = f"{name} {unit}".strip()
    digits = {"%": (0, 1), "mm": (3, 3), "deg": (3, 3), "s": (2, 3), "x": (3, 3)}.get(unit, (1, 1))
    lines = [
        f"| policy (seeds pooled) | suite | training seeds | {what} per seed "
        f"| IQM {what} [95 % stratified-bootstrap CI] |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        per_seed = " / ".join(f"{factor * v:.{digits[0]}f}" for v in r["scores"]) or "–"
        lines.append(
            f"| {r['group']} | {r['suite']} | {', '.join(map(str, r['seeds']))} | {per_seed} "
            f"| {factor * r['iqm']:.{digits[1]}f} [{factor * r['low']:.{digits[1]}f}, "
            f"{factor * r['high']:.{digits[1]}f}] |"
        )
    return "\n".join(lines)


def from_csv(path: str | Path, metric: str = "success") -> dict[str, SeedGroup]:
    """:func:`read_seed_scores` of ``metric`` from a benchmark's ``episodes.csv``
    (``ValueError`` if it is missing or lacks the needed columns)."""
    _check_metric(metric)
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"no such file: {p}")
    with p.open(newline="") as fh:
        reader = csv.DictReader(fh)
        need = {"policy", "training_seed", "suite", metric}
        if not need <= set(reader.fieldnames or ()):
            raise ValueError(f"{p} lacks columns {sorted(need - set(reader.fieldnames or ()))}")
        return read_seed_scores(list(reader), metric)
