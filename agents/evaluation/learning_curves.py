"""Learning curves of training runs (``evaluations.npz`` written by
:mod:`planar3p_agents.training.run`).

Runs are grouped by name (the run directory without ``-s<seed>``); for each group the mean over
seeds of the evaluation success rate and return is drawn against environment steps, with the
range over seeds shaded (:func:`plot`), and :func:`table` lists every run (steps, wall time,
steps/s, final success rate) as markdown.  ``scripts/plot_learning.py`` is the command line.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

__all__ = [
    "group_name",
    "load_run",
    "plot",
    "read_sessions",
    "table",
    "time_to_success",
    "training_time",
]

#: Success rate a run must reach in its evaluations for :func:`time_to_success`.
SUCCESS_LEVEL = 0.9


def load_run(path: Path) -> dict:
    """Learning curve and metadata of one run directory (``ValueError`` if incomplete)."""
    try:
        curve = np.load(path / "evaluations.npz")
        config = json.loads((path / "config.json").read_text())["config"]
    except (OSError, ValueError, KeyError) as exc:
        raise ValueError(f"{path} is not a complete run directory: {exc}") from exc
    metrics = {}
    if (path / "metrics.json").exists():
        metrics = json.loads((path / "metrics.json").read_text())
    timesteps = curve["timesteps"]
    returns = curve["results"].mean(axis=1)
    successes = curve["successes"].mean(axis=1) if "successes" in curve else None
    kick = json.loads((path / "config.json").read_text()).get("kickstart")
    sessions = read_sessions(path)  # the TensorBoard logs, read once
    if kick and kick.get("evaluation"):  # the cloned policy before RL, at step 0
        timesteps = np.concatenate([[0], timesteps])
        returns = np.concatenate([[kick["evaluation"]["mean_return"]], returns])
        if successes is not None:
            successes = np.concatenate([[kick["evaluation"]["success_rate"]], successes])
    return {
        "name": path.name,
        "train_time": training_time(path, sessions),
        "time_to_level": time_to_success(path, sessions=sessions),
        "kickstart": kick,
        "algo": config["algo"],
        "seed": config["seed"],
        "timesteps": timesteps,
        "returns": returns,
        "successes": successes,
        "metrics": metrics,
    }


#: One TensorBoard log (training session) of a run: the wall times of all its scalars (s), and
#: its ``eval/success_rate`` events as ``(step, value, wall time)``.
Session = tuple[list[float], list[tuple[int, float, float]]]


def read_sessions(path: Path) -> list[Session] | None:
    """The TensorBoard logs of the run at ``path``, one per training session (a resumed run
    has several), read once; ``None`` without tensorboard (the train extra)."""
    try:
        from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
    except ImportError:  # pragma: no cover - tensorboard is in the train extra
        return None
    sessions: list[Session] = []
    for log in sorted((path / "tb").glob("*")):
        acc = EventAccumulator(str(log), size_guidance={"scalars": 0})
        acc.Reload()
        tags = acc.Tags()["scalars"]
        stamps = [e.wall_time for tag in tags for e in acc.Scalars(tag)]
        evals = []
        if "eval/success_rate" in tags:
            evals = [(int(e.step), e.value, e.wall_time) for e in acc.Scalars("eval/success_rate")]
        sessions.append((stamps, evals))
    return sessions


def training_time(path: Path, sessions: list[Session] | None = None) -> float | None:
    """Wall time spent training (s): the span of each TensorBoard log of the run, summed over
    sessions (``sessions``: :func:`read_sessions` of ``path``, read if not given)."""
    sessions = read_sessions(path) if sessions is None else sessions
    spans = [max(stamps) - min(stamps) for stamps, _ in sessions or [] if len(stamps) > 1]
    return sum(spans) if spans else None


def time_to_success(
    path: Path, level: float = SUCCESS_LEVEL, sessions: list[Session] | None = None
) -> tuple[int, float] | None:
    """The first evaluation of the run at ``path`` with success rate ``>= level``: its
    environment step and the wall time from the run's first logged scalar to it (s), from the
    TensorBoard logs (``eval/success_rate``, compared with a float32 round-off allowance;
    ``sessions`` as for :func:`training_time`); ``None`` if no evaluation got there.  A resumed
    run's pause between sessions is not counted."""
    sessions = read_sessions(path) if sessions is None else sessions
    elapsed = 0.0
    for stamps, evals in sessions or []:
        if not stamps:
            continue
        start = min(stamps)
        for step, value, wall in evals:
            if value >= level - 1e-6:  # TensorBoard stores float32: 0.9 -> 0.89999998
                return step, elapsed + wall - start
        elapsed += max(stamps) - start
    return None


def _group_curves(
    runs: list[dict], key: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """IQM over the seeds that reached each evaluation step and its 95 % bootstrap interval
    over seeds (:func:`planar3p_agents.evaluation.seed_statistics.stratified_bootstrap_iqm`, one
    task)."""
    from planar3p_agents.evaluation.seed_statistics import stratified_bootstrap_iqm

    steps = np.unique(np.concatenate([r["timesteps"] for r in runs]))
    values = np.full((len(runs), len(steps)), np.nan)
    for i, r in enumerate(runs):
        values[i, np.searchsorted(steps, r["timesteps"])] = r[key]
    out = np.full((3, len(steps)), np.nan)
    for j in range(len(steps)):
        column = values[:, j][np.isfinite(values[:, j])]
        if column.size:
            out[:, j] = stratified_bootstrap_iqm(column, n_resamples=1000)
    return steps, out[0], out[1], out[2]


def group_name(run: dict) -> str:
    """Runs that differ only by seed form a group: the directory name without ``-s<seed>``."""
    return re.sub(r"-s\d+$", "", run["name"])


def plot(runs: list[dict], out: Path) -> None:
    """Success rate and return against steps, one line per group of seeds (IQM over seeds,
    95 % bootstrap interval shaded)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for group in sorted({group_name(r) for r in runs}):
        members = [r for r in runs if group_name(r) == group]
        label = f"{group} ({len(members)} seed{'s' if len(members) > 1 else ''})"
        for ax, key in zip(axes, ("successes", "returns"), strict=True):
            if any(r[key] is None for r in members):
                continue
            steps, centre, lo, hi = _group_curves(members, key)
            ax.plot(steps, centre, label=label)
            ax.fill_between(steps, lo, hi, alpha=0.2)
    axes[0].set(xlabel="environment steps", ylabel="evaluation success rate", ylim=(-0.02, 1.02))
    axes[0].set_title("Success rate (deterministic evaluation)")
    axes[1].set(xlabel="environment steps", ylabel="mean evaluation return")
    axes[1].set_title("Return")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend()
    fig.suptitle("Learning curves (IQM over seeds, 95 % stratified-bootstrap CI shaded)")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def table(runs: list[dict]) -> str:
    """Markdown table of the runs (training wall time from the TensorBoard logs)."""
    lines = [
        "| run | algo | seed | kick-started | env steps | training wall time (min) | steps/s "
        f"| first evaluation >= {SUCCESS_LEVEL:.0%} (steps, min) "
        "| final success (100 episodes) | final return |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        m = r["metrics"]
        fe = m.get("final_evaluation", {})
        steps = m.get("timesteps", int(r["timesteps"][-1]))
        wall = r["train_time"]
        kick = "yes" if r["kickstart"] else "no"
        rate = f"{steps / wall:.0f}" if wall else "?"
        minutes = f"{wall / 60:.1f}" if wall else "?"
        reached = r.get("time_to_level")
        first = f"{reached[0]}, {reached[1] / 60:.1f}" if reached else "never"
        lines.append(
            f"| {r['name']} | {r['algo'].upper()} | {r['seed']} | {kick} | {steps} | {minutes} "
            f"| {rate} | {first} | {fe.get('success_rate', float('nan')):.2f} "
            f"| {fe.get('mean_return', float('nan')):.1f} |"
        )
    return "\n".join(lines)
