"""The feed-forward tracking controller with other feedback gains, on the benchmark's fixed
tracking suites (the logic of ``scripts/track_gains.py``).

The benchmark's ``analytic-feedforward`` uses the analytic controller's gains (6 1/s).  Higher
gains shrink the lag behind an accelerating reference; this measures by how much, on exactly
the episodes the benchmark plays (:func:`planar3p_agents.evaluation.task_suites.make_task_suite`),
so a learned tracking policy can be compared with a retuned controller as well as with the default
one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from planar3p_agents.controllers.tracking import TrackingController
from planar3p_agents.evaluation.episodes import evaluate
from planar3p_agents.evaluation.task_suites import TASK_SUITES, make_task_env, make_task_suite
from planar3p_gym import TRACK_ENV_ID

__all__ = ["TRACK_SUITES", "gain_sweep"]

#: The benchmark's tracking suites: the task suites played on the tracking id.
TRACK_SUITES = tuple(name for name, d in TASK_SUITES.items() if d.env_id == TRACK_ENV_ID)


def gain_sweep(
    gains: Sequence[float], episodes: int, seed: int, suites: Sequence[str] = TRACK_SUITES
) -> list[dict[str, Any]]:
    """Per suite and gain ``k`` (1/s, used for position and orientation alike): the
    feed-forward controller's median and worst episode RMS pose error (m) and failures over the
    suite's first ``episodes`` episodes of ``seed``.  ``ValueError`` for a gain that is not
    finite and > 0, an unknown suite or ``episodes < 1``."""
    for k in gains:
        if not (isinstance(k, (int, float)) and math.isfinite(k) and k > 0):
            raise ValueError(f"gains must be finite and > 0 (1/s), got {k!r}")
    unknown = [s for s in suites if s not in TRACK_SUITES]
    if unknown:
        raise ValueError(f"unknown tracking suite(s) {unknown}; known: {', '.join(TRACK_SUITES)}")
    rows = []
    for name in suites:
        env = make_task_env(name)
        suite = make_task_suite(name, episodes, seed, env=env)
        for k in gains:
            ctrl = TrackingController.from_env(env, position_gain=k, orientation_gain=k)
            res = evaluate(env, ctrl, suite)
            rms = np.array([r.task_metrics["tracking_rms_error"] for r in res])
            rows.append(
                {
                    "suite": name,
                    "gain": float(k),
                    "episodes": len(res),
                    "failures": sum(r.termination_reason != "time_limit" for r in res),
                    "rms_median": float(np.median(rms)),
                    "rms_worst": float(rms.max()),
                }
            )
        env.close()
    return rows
