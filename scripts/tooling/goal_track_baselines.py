"""Baselines on the goal-conditioned and tracking ids (the logic of
``scripts/goal_track_baselines.py``): the analytic controller (``analytic-simultaneous``,
through :class:`planar3p_agents.controllers.goal_adapter.GoalAdapter`) on ``Planar3PGoal-v0`` /
``Planar3PGoalDense-v0``, and on ``Planar3PTrack-v0`` with and without the reference velocity
fed forward (``analytic-feedforward``, ``analytic-simultaneous``), all built by
:func:`planar3p_agents.policies.factory.load_policy`.  Episodes: the first reset with ``seed``,
the following ones unseeded.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

import planar3p_gym
from planar3p_agents.policies.factory import load_policy

__all__ = [
    "TRACKING_BASELINES",
    "goal_baseline",
    "play_episodes",
    "run_tracking_episodes",
    "summarize_tracking",
    "tracking_baselines",
]

#: Controllers compared on the tracking id: label -> baseline name (registry of
#: :mod:`planar3p_agents.controllers.registry`).
TRACKING_BASELINES = {
    "analytic (feedback)": "analytic-simultaneous",
    "analytic + feed-forward": "analytic-feedforward",
}


def play_episodes(
    env: Any, policy: Any, episodes: int, seed: int
) -> list[tuple[dict[str, Any], int, float, dict[str, Any]]]:
    """Play ``episodes`` episodes of ``env`` with ``policy`` (SB3-style ``predict``, reset
    before each episode if it can be), the first reset with ``seed``, then unseeded; per
    episode the ``info`` at reset, the number of steps, the return and the last ``info``."""
    if not (isinstance(episodes, int) and episodes >= 1):
        raise ValueError(f"episodes must be an integer >= 1, got {episodes!r}")
    out = []
    obs, info = env.reset(seed=seed)
    for _ in range(episodes):
        first = info
        if callable(getattr(policy, "reset", None)):
            policy.reset()
        steps, total = 0, 0.0
        while True:
            action, _ = policy.predict(obs)
            obs, reward, terminated, truncated, last = env.step(action)
            total += reward
            steps += 1
            if terminated or truncated:
                break
        out.append((first, steps, total, last))
        obs, info = env.reset()
    return out


def goal_baseline(env_id: str, episodes: int, seed: int) -> dict[str, float]:
    """Success rate, mean steps of the successful episodes and mean return of the analytic
    controller (``analytic-simultaneous``) on a goal id, over ``episodes`` episodes."""
    env = gym.make(env_id)
    try:
        played = play_episodes(env, load_policy("analytic-simultaneous", env), episodes, seed)
    finally:
        env.close()
    steps = [n for _, n, _, last in played if last["is_success"]]
    return {
        "episodes": episodes,
        "success_rate": len(steps) / episodes,
        "steps_to_success_mean": float(np.mean(steps)) if steps else float("nan"),
        "return_mean": float(np.mean([total for _, _, total, _ in played])),
    }


def run_tracking_episodes(
    env: Any, controller: Any, episodes: int, seed: int
) -> list[dict[str, Any]]:
    """Run ``controller`` for ``episodes`` episodes of a tracking env; the last ``info``
    metrics of each episode plus its length, its end (``termination_reason``, None at the
    time limit) and its spec."""
    out = []
    for first, steps, _, last in play_episodes(env, controller, episodes, seed):
        row = {k: last[k] for k in last if k.startswith("tracking_")}
        row.update(
            steps=steps, termination_reason=last["termination_reason"], spec=first["episode_spec"]
        )
        out.append(row)
    return out


def summarize_tracking(rows: list[dict[str, Any]]) -> dict[str, float]:
    """Mean, median and worst episode RMS / max pose error (m) and failures of ``rows``."""
    rms = np.array([r["tracking_rms_error"] for r in rows])
    mx = np.array([r["tracking_max_error"] for r in rows])
    rms_p = np.array([r["tracking_rms_position_error"] for r in rows])
    rms_o = np.array([r["tracking_rms_orientation_error"] for r in rows])
    return {
        "episodes": len(rows),
        "failures": sum(r["termination_reason"] is not None for r in rows),
        "rms_error_mean": float(rms.mean()),
        "rms_error_median": float(np.median(rms)),
        "rms_error_worst": float(rms.max()),
        "max_error_mean": float(mx.mean()),
        "max_error_worst": float(mx.max()),
        "rms_position_error_mean": float(rms_p.mean()),
        "rms_orientation_error_mean": float(rms_o.mean()),
    }


def tracking_baselines(
    episodes: int, seed: int, kinds: tuple[str, ...] = ("segments", "figure_eight")
) -> dict[str, dict[str, float]]:
    """:func:`summarize_tracking` of each of :data:`TRACKING_BASELINES` on
    ``Planar3PTrack-v0`` per reference kind, keyed ``"<kind>/<label>"``."""
    out = {}
    for kind in kinds:
        for label, name in TRACKING_BASELINES.items():
            env = gym.make(planar3p_gym.TRACK_ENV_ID, reference=kind)
            try:
                rows = run_tracking_episodes(env, load_policy(name, env), episodes, seed)
            finally:
                env.close()
            out[f"{kind}/{label}"] = summarize_tracking(rows)
    return out
