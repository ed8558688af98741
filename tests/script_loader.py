"""Run a subcommand of the ``planar3p`` command line in-process, as the files of ``scripts/``
do: ``command("benchmark").main(argv)`` is ``planar3p_agents.cli.main(["benchmark", *argv])``
(the exit status; bad input returns 2, ``--help`` 0)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from planar3p_agents import cli

ROOT = Path(__file__).resolve().parents[1]

#: The subcommand each file of ``scripts/`` runs.
SCRIPTS = {
    "bench_env": "bench-env",
    "bench_kinematics": "bench-kinematics",
    "benchmark": "benchmark",
    "demo": "demo",
    "fidelity": "fidelity",
    "goal_track_baselines": "goal-track-baselines",
    "plot_learning": "plot-learning",
    "seed_report": "seed-report",
    "ship_policy": "ship",
    "sweep": "sweep",
    "task_baselines": "task-baselines",
    "track_curves": "track-curves",
    "track_gains": "track-gains",
    "train": "train",
    "workspace": "workspace",
}


@dataclass(frozen=True)
class Command:
    """One subcommand of ``planar3p``."""

    name: str

    def main(self, argv: Sequence[str] = ()) -> int:
        return cli.main([self.name, *argv])


def command(name: str) -> Command:
    """The subcommand ``name`` (``train``, ``benchmark``, ``seed-report``, ...)."""
    return Command(name)


def load_script(name: str) -> Command:
    """The subcommand ``scripts/<name>.py`` runs (for tests written against the scripts)."""
    return Command(SCRIPTS[name])
