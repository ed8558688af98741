"""Learning curves of tracking policies in the task's own metric: the median episode RMS pose
error on the benchmark's fixed tracking suites at each saved checkpoint of each training seed,
and its interquartile mean across seeds with a stratified-bootstrap interval (the logic of
``scripts/track_curves.py``).

The training runs' own evaluations (``evaluations.npz``) record returns only, and a tracking
return mixes the pose error with the action effort; this plays every checkpoint
(``checkpoints/rl_model_<n>_steps.zip`` of ``scripts/train.py``) deterministically on the first
``episodes`` episodes of each suite (:func:`planar3p_agents.evaluation.task_suites.make_task_suite`,
the same episodes the benchmark plays), all episodes of a suite side by side so that the policy is
called on one batch per step.  Step 0 is the untrained residual policy, i.e. the feed-forward
controller (``Design.fig8()``, the tracking id's design).  Model files are code: only the
runs named are loaded, each checkpoint with no statistics (the tracking recipe normalises
rewards only; a run that normalises observations is refused).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from planar3p_agents.evaluation.episodes import reset_episode
from planar3p_agents.evaluation.seed_statistics import stratified_bootstrap_iqm
from planar3p_agents.evaluation.task_suites import make_task_env, make_task_suite
from planar3p_agents.training.checkpoints import run_checkpoints

__all__ = ["CACHE", "SuitePlayer", "checkpoints", "plot_curves", "run_curve", "seed_curves"]


def checkpoints(run: Path) -> list[tuple[int, Path]]:
    """``(steps, path)`` of a run directory's checkpoints and final ``model.zip``, by steps
    (the final model's steps from ``metrics.json``); ``ValueError`` if there are none or the
    run normalised observations (its checkpoints would need their statistics)."""
    run = Path(run)
    config = run / "config.json"
    if not config.is_file():
        raise ValueError(f"{run} is not a run directory (no config.json)")
    normalize = json.loads(config.read_text())["config"].get("normalize")
    if normalize is not None and normalize.get("norm_obs", True):
        raise ValueError(f"{run} normalised observations; its checkpoints need their statistics")
    out = run_checkpoints(run)
    metrics = run / "metrics.json"
    if (run / "model.zip").is_file() and metrics.is_file():
        out[int(json.loads(metrics.read_text())["timesteps"])] = run / "model.zip"
    if not out:
        raise ValueError(f"{run} has no checkpoints")
    return sorted(out.items())


class SuitePlayer:
    """The first ``episodes`` episodes of tracking suite ``name`` from ``seed`` (the
    benchmark's), each in its own environment (made once), played side by side.

    Args:
        name: a tracking suite (``track-segments``, ``track-figure-eight``).
        episodes: how many of its episodes.
        seed: the suite's seed.
    """

    def __init__(self, name: str, episodes: int, seed: int) -> None:
        self.name, self.seed = name, int(seed)
        self.envs = [make_task_env(name) for _ in range(episodes)]
        self.suite = make_task_suite(name, episodes, seed, env=self.envs[0])

    def play(self, policy: Any) -> np.ndarray:
        """Episode RMS pose errors (m) of ``policy`` (SB3-style ``predict`` on a batch,
        deterministic; ``inf`` for an episode ended by failure); each episode reset like the
        benchmark's runner (:func:`planar3p_agents.evaluation.episodes.reset_episode`)."""
        obs = np.stack(
            [
                reset_episode(env, spec, self.seed)[0]
                for env, spec in zip(self.envs, self.suite.episodes, strict=True)
            ]
        )
        rms = np.full(len(self.envs), np.nan)
        live = np.ones(len(self.envs), dtype=bool)
        while live.any():
            actions = np.asarray(policy.predict(obs, deterministic=True)[0], dtype=np.float64)
            for i in np.flatnonzero(live):
                o, _, terminated, truncated, info = self.envs[i].step(actions[i])
                obs[i] = o
                if terminated or truncated:
                    live[i] = False
                    rms[i] = np.inf if terminated else info["tracking_rms_error"]
        return rms

    def close(self) -> None:
        for env in self.envs:
            env.close()


#: File in a run directory where :func:`run_curve` keeps its result (``runs/`` is not shipped).
CACHE = "track_curve.json"


def run_curve(run: Path, players: list[SuitePlayer]) -> dict[str, dict[int, float]]:
    """``{suite: {steps: median episode RMS error (m)}}`` over the run's checkpoints; step 0 is
    the untrained residual policy, which is the feed-forward controller exactly.  The result is
    kept in ``<run>/track_curve.json`` and reused while the suites, their seed and episode
    count, and the checkpoint files (names and sizes) are the same."""
    from stable_baselines3 import PPO

    from planar3p_agents.controllers.tracking import TrackingController

    points = checkpoints(run)
    key = {
        "suites": [[p.name, len(p.envs), p.seed] for p in players],
        "checkpoints": [[steps, str(path.relative_to(run)), path.stat().st_size]
                        for steps, path in points],
    }  # fmt: skip
    cache = Path(run) / CACHE
    if cache.is_file():
        try:
            data = json.loads(cache.read_text())
            if data.get("key") == key:
                return {
                    n: {int(k): float(v) for k, v in c.items()} for n, c in data["curve"].items()
                }
        except (ValueError, AttributeError, TypeError):
            pass  # recomputed below
    out: dict[str, dict[int, float]] = {p.name: {} for p in players}
    for steps, path in [(0, None), *points]:
        model = TrackingController() if path is None else PPO.load(path, device="cpu")
        for player in players:
            out[player.name][steps] = float(np.median(player.play(model)))
    cache.write_text(json.dumps({"key": key, "curve": out}, indent=2))
    return out


def seed_curves(
    curves: dict[int, dict[str, dict[int, float]]], n_resamples: int = 2000, seed: int = 0
) -> dict[str, list[tuple[int, float, float, float]]]:
    """Per suite, at every step all seeds share: ``(steps, IQM, low, high)`` of the seeds'
    median RMS errors (m), 95 % stratified-bootstrap interval (one task)."""
    out: dict[str, list[tuple[int, float, float, float]]] = {}
    suites = sorted({s for c in curves.values() for s in c})
    for name in suites:
        common = sorted(set.intersection(*(set(c[name]) for c in curves.values())))
        out[name] = [
            (step, *stratified_bootstrap_iqm(
                [c[name][step] for c in curves.values()], n_resamples=n_resamples, seed=seed
            ))
            for step in common
        ]  # fmt: skip
    return out


def plot_curves(
    curves: dict[int, dict[str, dict[int, float]]],
    baselines: dict[str, float],
    out: Path,
    n_resamples: int = 2000,
) -> Path:
    """One panel per suite: each seed's median RMS error (mm) against steps (thin lines), the
    IQM across seeds with its 95 % interval (band), and the baselines' medians (dashed)."""
    import matplotlib.pyplot as plt

    agg = seed_curves(curves, n_resamples=n_resamples)
    fig, axes = plt.subplots(1, len(agg), figsize=(5.5 * len(agg), 4), squeeze=False)
    for ax, (name, rows) in zip(axes[0], agg.items(), strict=True):
        for s, c in sorted(curves.items()):
            steps = sorted(c[name])
            ax.plot(steps, [1e3 * c[name][k] for k in steps], lw=0.8, alpha=0.5, label=f"seed {s}")
        x = [r[0] for r in rows]
        ax.plot(x, [1e3 * r[1] for r in rows], color="k", lw=2, label="IQM over seeds")
        ax.fill_between(x, [1e3 * r[2] for r in rows], [1e3 * r[3] for r in rows],
                        color="k", alpha=0.15, label="95 % CI")  # fmt: skip
        for label, value in baselines.items():
            if label.startswith(name + "/"):
                ax.axhline(1e3 * value, ls="--", lw=1, color="tab:red",
                           label=label.split("/", 1)[1])  # fmt: skip
        ax.set(title=name, xlabel="environment steps", ylabel="median episode RMS error (mm)",
               ylim=(0, None))  # fmt: skip
        ax.legend(fontsize=7)
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
