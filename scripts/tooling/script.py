"""Run a script of ``scripts/`` as a command: its module's ``add_arguments``, ``check`` and
``run``, with the exit statuses and one-line errors of the ``planar3p`` command line
(:func:`planar3p_agents.cli.run_command`): 0 done, 2 bad input naming the flag, 130
interrupted."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from planar3p_agents.cli import run_command

__all__ = ["main", "prog"]


def prog(file: str) -> str:
    """The program name of the script at ``file``: ``python scripts/<name>.py``."""
    return f"python scripts/{Path(file).name}"


def main(module_name: str, argv: Sequence[str] | None = None) -> int:
    """Run the script module ``module_name`` (its ``__name__``) with ``argv`` (default: the
    process's arguments); the exit status."""
    module = sys.modules[module_name]
    argv = list(sys.argv[1:] if argv is None else argv)
    return run_command(module, prog(module.__file__), argv)
