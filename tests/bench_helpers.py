"""Helpers shared by the benchmark tests: reading ``episodes.csv``, replaying a run's saved
suites with ``planar3p benchmark`` and playing a trained model there."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any


def read_csv(path: Path) -> list[dict[str, str]]:
    """The rows of a CSV file as dicts (all values strings)."""
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def replay(bench: Any, run: Path, suite: str, policy: str, out: Path) -> list[dict[str, str]]:
    """Play ``policy`` on ``suite`` of the suites a benchmark run saved in ``run/suites.json``
    (``bench``: ``planar3p benchmark``), writing to ``out``; the episodes' CSV rows."""
    args = ["--suite-file", str(run / "suites.json"), "--suites", suite, "--policies", policy]
    assert bench.main([*args, "--out", str(out), "--no-progress", "--no-plots"]) == 0
    return read_csv(out / "episodes.csv")


def assert_plays_one_episode(bench: Any, run: Path, out: Path, algo: str = "") -> None:
    """``planar3p benchmark`` (``bench``) plays the model of training run ``run`` (with its
    statistics; ``algo``: a ``"dqn:"``-style prefix) on one ``real-on-off`` episode into
    ``out``, and its summary has that one episode."""
    spec = f"{algo}{run / 'model.zip'}:stats={run / 'vecnormalize.pkl'}"
    args = "--suites real-on-off --episodes 1 --no-progress --no-plots".split()
    assert bench.main([*args, "--policies", spec, "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    (row,) = [r for r in summary["summaries"] if r["suite"] == "real-on-off"]
    assert row["episodes"] == 1
