"""Reading the benchmark's data folders (``docs/benchmark`` and its subfolders).

Each folder is one study, written by ``scripts/benchmark.py``: ``summary.json`` (settings and
one summary per policy and suite), ``suites.json`` (the episodes), ``report.md``,
``episodes.csv``, figures, and the seed tables of ``scripts/seed_report.py`` (``seeds*.md``).
The documentation reads these files and never writes them.
"""

from __future__ import annotations

import json
import math
import re
import shlex
from functools import cache
from pathlib import Path
from typing import Any

import p3docs as P

#: Page name of the study in ``docs/benchmark`` itself (the analytic controller and the floor
#: references on the reach suites).
ROOT_STUDY = "baselines"
#: Reach suites are played in this id unless the command names ``--reach-env``.
DEFAULT_REACH_ENV = "Planar3P-v0"
#: How the results name the reach env of studies made on the unprojected model (``Planar3P-v0``
#: before 0.2.0, ``projection=False`` now).
UNPROJECTED_REACH_ENV = "Planar3P-v0, unprojected (before 0.2.0)"


def study_page_name(name: str) -> str:
    """File name (no suffix) of a study's results page."""
    return name


@cache
def studies() -> tuple[dict[str, Any], ...]:
    """Every study, the top folder first, then the subfolders in alphabetical order."""
    folders = [P.BENCHMARK] + sorted(p.parent for p in P.BENCHMARK.glob("*/summary.json"))
    out = []
    for folder in folders:
        path = folder / "summary.json"
        if not path.exists():
            continue
        name = ROOT_STUDY if folder == P.BENCHMARK else folder.name
        summary = json.loads(path.read_text())
        suites_path = folder / "suites.json"
        suites = json.loads(suites_path.read_text()) if suites_path.exists() else {}
        out.append({"name": name, "folder": folder, "summary": summary, "suites": suites})
    return tuple(out)


def command_option(command: str, flag: str) -> str | None:
    """The value of ``flag`` in a shell command line, or ``None``."""
    try:
        words = shlex.split(command)
    except ValueError:
        words = command.split()
    for i, w in enumerate(words):
        if w == flag and i + 1 < len(words):
            return words[i + 1]
        if w.startswith(flag + "="):
            return w.split("=", 1)[1]
    return None


def suite_env(study: dict[str, Any], suite: str) -> str:
    """The environment id a study's suite was played in."""
    for s in study["suites"].get("suites", []):
        if s.get("name") == suite and s.get("params", {}).get("env_id"):
            return s["params"]["env_id"]
    # The reach suites: ``Planar3P-v0`` is the projected physics since 0.2.0 (before, the
    # projected physics was ``Planar3P-v1`` and ``Planar3P-v0`` the unprojected model).
    env = study["summary"]["settings"].get("env", {})
    return DEFAULT_REACH_ENV if env.get("projection") else UNPROJECTED_REACH_ENV


def is_builtin(spec: str) -> bool:
    """Whether a policy spec names a built-in policy (no model file)."""
    return not (
        spec.startswith("pretrained:") or ".zip" in spec or "/" in spec or ":stats=" in spec
    )


def _num(x: Any) -> float | None:
    if x is None:
        return None
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(v) else v


def row_of(study: dict[str, Any], s: dict[str, Any]) -> dict[str, Any]:
    """A flat record of one summary entry."""
    tm = s.get("task_metrics") or {}
    rms = tm.get("tracking_rms_error") or {}
    return {
        "study": study["name"],
        "policy": s["policy"],
        "suite": s["suite"],
        "episodes": s.get("episodes"),
        "success_rate": _num(s.get("success_rate")),
        "success_ci": [_num(v) for v in s.get("success_ci") or []],
        "time_to_success": _num(s.get("median_time_to_success")),
        "tracking_rms_mm": None if _num(rms.get("median")) is None else 1000 * rms["median"],
        "tracking_rms_worst_mm": None if _num(rms.get("max")) is None else 1000 * rms["max"],
        "crossings": s.get("singularity_crossings"),
        "timeouts": s.get("timeouts"),
    }


def format_success(r: dict[str, Any]) -> str:
    """``"100 [96, 100]"``: success % with its 95 % interval."""
    if r["success_rate"] is None:
        return "–"
    ci = r["success_ci"]
    if len(ci) == 2 and None not in ci:
        return f"{100 * r['success_rate']:.0f} [{100 * ci[0]:.0f}, {100 * ci[1]:.0f}]"
    return f"{100 * r['success_rate']:.0f}"


def baseline_summaries(env_id: str) -> list[dict[str, Any]]:
    """The built-in policies' summaries measured in ``env_id`` on seed-0 suites: for each
    (suite, policy) the first study that has it, studies of built-in policies only first."""
    seen: dict[tuple[str, str], dict[str, Any]] = {}

    def learned(study: dict[str, Any]) -> bool:
        specs = study["summary"]["settings"].get("policies", {})
        return not all(is_builtin(spec) for spec in specs.values())

    for study in sorted(studies(), key=learned):
        settings = study["summary"]["settings"]
        if settings.get("seed") != 0:
            continue
        specs = settings.get("policies", {})
        for s in study["summary"]["summaries"]:
            if not is_builtin(specs.get(s["policy"], s["policy"])):
                continue
            if suite_env(study, s["suite"]) != env_id:
                continue
            seen.setdefault((s["suite"], s["policy"]), row_of(study, s))
    return sorted(seen.values(), key=lambda r: (_suite_order(r["suite"]), r["policy"]))


def _suite_order(suite: str) -> tuple[int, str]:
    order = ["standard", "hard", "far"]
    return (order.index(suite), suite) if suite in order else (len(order), suite)


def seed_tables(folder: Path) -> list[Path]:
    """The seed tables of a study (``seeds*.md``)."""
    return sorted(folder.glob("seeds*.md"))


def report_title(folder: Path) -> str:
    """The first heading of a study's ``report.md``."""
    path = folder / "report.md"
    if path.exists():
        for line in path.read_text().splitlines():
            if line.startswith("# "):
                return line[2:].strip()
    return "Policy benchmark"


def report_sections(folder: Path) -> list[tuple[str, str]]:
    """``(heading, body)`` of every second-level section of a study's ``report.md``."""
    path = folder / "report.md"
    if not path.exists():
        return []
    text = path.read_text()
    parts = re.split(r"(?m)^## (.+)$", text)
    return [(parts[i].strip(), parts[i + 1].strip()) for i in range(1, len(parts), 2)]
