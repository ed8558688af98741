"""Helpers shared by the benchmark tests: reading ``episodes.csv`` and replaying a run's
saved suites with ``planar3p benchmark``."""

from __future__ import annotations

import csv
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
