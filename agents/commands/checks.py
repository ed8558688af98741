"""Checks of command-line values, made before any work: each raises
:class:`~planar3p_agents.commands.parser.UsageError` with one line that names the flag, e.g.
``--seed must be >= 0, got -1``.

Numbers: :func:`at_least`, :func:`in_range`.  Lists: :func:`split_list`, :func:`known`.
Optional packages: :func:`extra_installed`.  Files: :func:`output_dir`, :func:`output_file`
(where the command will write: not a file of the other kind, not under a file, writable;
:mod:`planar3p_gym.atomic_files` does the checking),
:func:`input_file`, :func:`input_dir` and :func:`json_file` (what it will read).
"""

from __future__ import annotations

import importlib.util
import json
import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from planar3p_agents.commands.parser import UsageError
from planar3p_gym import atomic_files

__all__ = [
    "at_least",
    "extra_installed",
    "in_range",
    "input_dir",
    "input_file",
    "json_file",
    "known",
    "output_dir",
    "output_file",
    "split_list",
]


def _num(value: float) -> str:
    """``value`` as written on a command line: integers in full, other numbers with ``:g``."""
    if isinstance(value, int) or (isinstance(value, float) and value.is_integer()):
        return str(int(value)) if abs(value) < 1e15 else f"{value:g}"
    return f"{value:g}"


def at_least(flag: str, value: float, minimum: float) -> None:
    """``value`` must be a number ``>= minimum`` (NaN is refused)."""
    if not value >= minimum:
        raise UsageError(f"{flag} must be >= {_num(minimum)}, got {_num(value)}")


def in_range(
    flag: str,
    value: float,
    low: float,
    high: float,
    *,
    low_open: bool = False,
    high_open: bool = False,
    unit: str = "",
) -> None:
    """``value`` must be finite and between ``low`` and ``high`` (each end included unless
    ``*_open``)."""
    above = value > low if low_open else value >= low
    below = value < high if high_open else value <= high
    if not (math.isfinite(value) and above and below):
        if low_open or high_open:
            bounds = (
                f"{'>' if low_open else '>='} {_num(low)} and {'<' if high_open else '<='} "
                f"{_num(high)}"
            )
        else:
            bounds = f"between {_num(low)} and {_num(high)}"
        suffix = f" {unit}" if unit else ""
        raise UsageError(f"{flag} must be {bounds}{suffix}, got {_num(value)}")


def extra_installed(flag: str, module: str, extra: str, what: str) -> None:
    """``module`` must be importable for ``what``: otherwise the line names ``flag`` and the
    extra of planar3p-gym that installs it (a lookup that fails counts as not installed)."""
    try:
        found = importlib.util.find_spec(module) is not None
    except ImportError:
        found = False
    if not found:
        raise UsageError(
            f"{flag}: {what} needs {module}, which is not installed "
            f"(pip install 'planar3p-gym[{extra}]')"
        )


def split_list(flag: str, text: str) -> list[str]:
    """The non-empty items of a comma-separated list; at least one."""
    items = [t.strip() for t in str(text).split(",") if t.strip()]
    if not items:
        raise UsageError(f"{flag} is empty")
    return items


def known(flag: str, items: Iterable[str], choices: Iterable[str], what: str = "value") -> None:
    """Every item must be one of ``choices`` (``what``: what an item is, for the message)."""
    choices = list(choices)
    unknown = [i for i in items if i not in choices]
    if unknown:
        plural = "s" if len(unknown) > 1 else ""
        raise UsageError(
            f"{flag}: unknown {what}{plural} {', '.join(map(repr, unknown))}; choose from "
            f"{', '.join(choices)}"
        )


def output_dir(flag: str, path: str | Path) -> Path:
    """A directory the command creates or writes into (nothing is created here)."""
    try:
        return atomic_files.check_output_dir(path)
    except ValueError as exc:
        raise UsageError(f"{flag} {path}: {exc}") from None


def output_file(flag: str, path: str | Path, *, parents: bool = False) -> Path:
    """A file the command writes: its directory must exist, unless ``parents`` (the command
    makes it).  Nothing is created here."""
    try:
        return atomic_files.check_output_file(path, parents=parents)
    except ValueError as exc:
        raise UsageError(f"{flag} {path}: {exc}") from None


def input_file(flag: str, path: str | Path) -> Path:
    """A file the command reads."""
    p = Path(path)
    if not p.is_file():
        what = "is not a file" if p.exists() else "does not exist"
        raise UsageError(f"{flag} {path} {what}")
    return p


def input_dir(flag: str, path: str | Path) -> Path:
    """A directory the command reads."""
    p = Path(path)
    if not p.is_dir():
        what = "is not a directory" if p.exists() else "does not exist"
        raise UsageError(f"{flag} {path} {what}")
    return p


def json_file(flag: str, path: str | Path) -> Any:
    """The content of a JSON file the command reads; the error names the file and says it is
    not JSON (with the parser's position) rather than only the parser's message."""
    p = input_file(flag, path)
    try:
        return json.loads(p.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise UsageError(f"{flag}: {p} is not JSON (not UTF-8 text)") from None
    except json.JSONDecodeError as exc:
        raise UsageError(f"{flag}: {p} is not JSON ({exc})") from None
    except OSError as exc:
        raise UsageError(f"{flag}: cannot read {p} ({exc.strerror or exc})") from None
