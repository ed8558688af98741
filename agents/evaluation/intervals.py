"""Statistics of the benchmark: interval estimates and the per-suite summary of a policy.

The estimators come from SciPy: :func:`iqm` is ``scipy.stats.trim_mean(x, 0.25)`` (the
interquartile mean rliable reports), :func:`bootstrap_ci` is ``scipy.stats.bootstrap`` with the
percentile method, and :func:`success_interval` is the Wilson score interval of
``scipy.stats.binomtest``.  What is kept here is specific to the benchmark: fixed seeds (every
interval is reproducible), defined results for the inputs SciPy rejects or warns about (an
empty sample gives NaN, a single value gives a point), and :func:`summarize`, which aggregates
:class:`~planar3p_agents.evaluation.episodes.EpisodeResult` rows.

A success rate is a binomial proportion, so its interval is the Wilson score interval rather
than a bootstrap: the bootstrap interval collapses to a point at 0 % and 100 % (every resample
is all failures or all successes), the Wilson interval does not (100/100 gives
[0.963, 1] at 95 %).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

from planar3p_agents.evaluation.episodes import FAILURE_CAUSES, EpisodeResult

__all__ = ["bootstrap_ci", "iqm", "success_interval", "summarize"]


def iqm(values: ArrayLike, axis: int = -1) -> np.ndarray | float:
    """Interquartile mean along ``axis``: ``scipy.stats.trim_mean(values, 0.25)``, the mean
    after trimming ``floor(n / 4)`` values at each end.  NaN for an empty input."""
    x = np.asarray(values, dtype=np.float64)
    if x.size == 0:
        return math.nan
    out = stats.trim_mean(x, 0.25, axis=axis)
    return float(out) if np.ndim(out) == 0 else out


def _mean(x: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.mean(x, axis=axis)


def bootstrap_ci(
    values: ArrayLike,
    statistic: Callable[..., Any] = _mean,
    n_resamples: int = 2000,
    confidence: float = 0.95,
    seed: int = 0,
) -> tuple[float, float]:
    """Percentile-bootstrap confidence interval of ``statistic`` of ``values``
    (``scipy.stats.bootstrap``, ``method="percentile"``).

    ``statistic(samples, axis=-1)`` must reduce the last axis (as ``np.mean``, :func:`iqm`).
    Resampling uses a generator seeded with ``seed``, so the interval is reproducible.
    ``(nan, nan)`` for an empty input; a single value ``v`` gives ``(v, v)`` (every resample is
    that value; SciPy refuses samples of one).
    """
    x = np.asarray(values, dtype=np.float64).reshape(-1)
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    if x.size == 0:
        return (math.nan, math.nan)
    if x.size == 1:
        v = float(np.asarray(statistic(x[None, :], axis=-1)).reshape(-1)[0])
        return (v, v)
    res = stats.bootstrap(
        (x,),
        statistic,
        n_resamples=int(n_resamples),
        confidence_level=confidence,
        method="percentile",
        vectorized=True,
        axis=-1,
        rng=np.random.default_rng(seed),
    )
    ci = res.confidence_interval
    return (float(ci.low), float(ci.high))


def success_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a success rate of ``successes`` in ``n`` episodes
    (``scipy.stats.binomtest(...).proportion_ci(method="wilson")``); ``(nan, nan)`` if
    ``n == 0``."""
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    if n < 0 or not 0 <= successes <= max(n, 0):
        raise ValueError(f"need 0 <= successes <= n, got {successes} of {n}")
    if n == 0:
        return (math.nan, math.nan)
    ci = stats.binomtest(int(successes), int(n)).proportion_ci(confidence, method="wilson")
    return (float(ci.low), float(ci.high))


def _median(values: Sequence[float]) -> float:
    x = np.asarray(values, dtype=np.float64)
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else math.nan


def summarize(
    results: Sequence[EpisodeResult], n_resamples: int = 2000, seed: int = 0
) -> dict[str, Any]:
    """Aggregate statistics of one policy on one suite.

    Success rate with its Wilson interval (NaN for a task without a success test); IQM of the
    return with a percentile-bootstrap interval; median final errors (mm, deg), time to success
    (s, successful episodes only) and mechanical energy (J); the worst and median smallest
    parallel margin; counts of each ending
    (:data:`~planar3p_agents.evaluation.episodes.FAILURE_CAUSES`); the share of steps with a
    saturated actuator; the median speed bound (s) and the median and 90th percentile of time to
    success over the speed bound (successful episodes); and, for tasks that report them, the median,
    mean, smallest and largest value of each task metric (``task_metrics`` of the results, e.g.
    tracking errors, or 0/1 flags whose mean is the share of episodes).
    """
    if not results:
        raise ValueError("no episodes to summarize")
    succ = np.array([r.success for r in results], dtype=np.float64)
    ret = np.array([r.episode_return for r in results])
    causes = {c: 0 for c in FAILURE_CAUSES}
    for r in results:
        causes[r.cause] = causes.get(r.cause, 0) + 1
    total_steps = sum(r.steps for r in results)
    defined = all(r.success_defined for r in results)  # tracking has no success test
    out: dict[str, Any] = {
        "policy": results[0].policy,
        "suite": results[0].suite,
        "episodes": len(results),
        "successes": int(succ.sum()),
        "success_rate": float(succ.mean()) if defined else math.nan,
        "success_ci": success_interval(int(succ.sum()), len(results))
        if defined
        else (math.nan, math.nan),
        "return_iqm": iqm(ret),
        "return_ci": bootstrap_ci(ret, iqm, n_resamples=n_resamples, seed=seed),
        "median_position_error_mm": 1000.0 * _median([r.final_position_error for r in results]),
        "median_orientation_error_deg": math.degrees(
            _median([r.final_orientation_error for r in results])
        ),
        "median_time_to_success": _median([r.time_to_success for r in results]),
        "worst_min_parallel_margin": float(min(r.min_parallel_margin for r in results)),
        "median_min_parallel_margin": _median([r.min_parallel_margin for r in results]),
        "singularity_crossings": causes["singularity_crossing"],
        "physics_breakdowns": causes["physics_breakdown"],
        "time_limits": sum(r.termination_reason == "time_limit" for r in results),
        "saturation_fraction": float(
            sum(r.saturation_fraction * r.steps for r in results) / total_steps
        ),
        "median_energy": _median([r.energy for r in results]),
        "median_speed_bound": _median([r.speed_bound for r in results]),
        "median_time_over_bound": _median([r.time_over_bound for r in results]),
        "p90_time_over_bound": _quantile([r.time_over_bound for r in results], 0.9),
        "causes": causes,
        "path_crossing_episodes": int(sum(r.path_crosses for r in results)),
        "working_mode_changes": int(sum(r.working_mode_changed for r in results)),
    }
    keys = list(dict.fromkeys(k for r in results for k in r.task_metrics))
    if keys:
        out["task_metrics"] = {
            k: _describe([r.task_metrics.get(k, math.nan) for r in results]) for k in keys
        }
    return out


def _quantile(values: Sequence[float], q: float) -> float:
    """Quantile ``q`` of the finite values (NaN if none)."""
    x = np.asarray(values, dtype=np.float64)
    x = x[np.isfinite(x)]
    return float(np.quantile(x, q)) if x.size else math.nan


def _describe(values: Sequence[float]) -> dict[str, float]:
    """Median, mean, smallest and largest of the finite values (NaN if none)."""
    x = np.asarray(values, dtype=np.float64)
    x = x[np.isfinite(x)]
    if not x.size:
        return dict.fromkeys(("median", "mean", "min", "max"), math.nan)
    return {
        "median": float(np.median(x)),
        "mean": float(np.mean(x)),
        "min": float(np.min(x)),
        "max": float(np.max(x)),
    }
