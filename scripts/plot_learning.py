#!/usr/bin/env python
"""Plot learning curves of training runs (``evaluations.npz`` written by ``scripts/train.py``).

Runs are grouped by algorithm (from each run's ``config.json``); for each group the mean over
seeds of the evaluation success rate and return is drawn against environment steps, with the
range over seeds shaded.  Also prints a table of every run (steps, wall time, steps/s, final
success rate) as markdown.

    python scripts/plot_learning.py runs/sac-s1 runs/ppo-s1 --out docs/figures/learning.png
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


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
    successes = curve["successes"].mean(axis=1) if "successes" in curve else None
    return {
        "name": path.name,
        "algo": config["algo"],
        "seed": config["seed"],
        "timesteps": curve["timesteps"],
        "returns": curve["results"].mean(axis=1),
        "successes": successes,
        "metrics": metrics,
    }


def _group_curves(
    runs: list[dict], key: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    n = min(len(r["timesteps"]) for r in runs)
    steps = runs[0]["timesteps"][:n]
    values = np.array([r[key][:n] for r in runs], dtype=float)
    return steps, values.mean(0), values.min(0), values.max(0)


def plot(runs: list[dict], out: Path) -> None:
    """Success rate and return against steps, one line per algorithm (mean, range shaded)."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for algo in sorted({r["algo"] for r in runs}):
        group = [r for r in runs if r["algo"] == algo]
        label = f"{algo.upper()} ({len(group)} seed{'s' if len(group) > 1 else ''})"
        for ax, key in zip(axes, ("successes", "returns"), strict=True):
            if any(r[key] is None for r in group):
                continue
            steps, mean, lo, hi = _group_curves(group, key)
            ax.plot(steps, mean, label=label)
            ax.fill_between(steps, lo, hi, alpha=0.2)
    axes[0].set(xlabel="environment steps", ylabel="evaluation success rate", ylim=(-0.02, 1.02))
    axes[0].set_title("Success rate (deterministic evaluation)")
    axes[1].set(xlabel="environment steps", ylabel="mean evaluation return")
    axes[1].set_title("Return")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend()
    fig.suptitle("Planar3P-v0 learning curves (mean over seeds, range shaded)")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def table(runs: list[dict]) -> str:
    """Markdown table of the runs."""
    lines = [
        "| run | algo | seed | steps | wall time (min) | steps/s | final success | final return |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        m = r["metrics"]
        head = f"| {r['name']} | {r['algo'].upper()} | {r['seed']} "
        if m.get("wall_time_s") is None:
            lines.append(head + f"| {int(r['timesteps'][-1])} | (running) | | | |")
            continue
        fe = m.get("final_evaluation", {})
        lines.append(
            head
            + f"| {m['timesteps']} | {m['wall_time_s'] / 60:.1f} | {m['steps_per_s']:.0f} "
            + f"| {fe.get('success_rate', float('nan')):.2f} "
            + f"| {fe.get('mean_return', float('nan')):.1f} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("runs", nargs="+", type=Path, help="run directories")
    p.add_argument("--out", type=Path, default=Path("docs/figures/learning_curves.png"))
    args = p.parse_args(argv)
    try:
        runs = [load_run(path) for path in args.runs]
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    plot(runs, args.out)
    print(table(runs))
    print(f"\nlearning curves written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
