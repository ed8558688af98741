"""What the tests call a script: a command of the ``planar3p`` command line.

``load_script(name)`` gives the command module behind ``scripts/<name>.py`` (its attributes)
with a ``main(argv)`` that runs ``planar3p <command> *argv`` in-process and returns the exit
status (bad input 2, ``--help`` 0), as the scripts' own ``main`` did; ``command(name)`` the same
by the command's name.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

from planar3p_agents import cli
from planar3p_agents.commands import COMMANDS, load

#: The repository's root.
ROOT = Path(__file__).resolve().parents[1]
#: The subcommand each file of ``scripts/`` runs (``ship_policy.py``: ``ship``).
SCRIPTS = {("ship_policy" if m == "ship" else m): c for c, m in COMMANDS.items()}


class Command:
    """One subcommand of ``planar3p``: its module's attributes and ``main(argv) -> status``."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._module: ModuleType = load(name)

    def __getattr__(self, attribute: str) -> Any:
        return getattr(self._module, attribute)

    def main(self, argv: Sequence[str] | None = None) -> int:
        return cli.main([self.name, *(argv or ())])


def command(name: str) -> Command:
    """The subcommand ``name`` (``train``, ``benchmark``, ``seed-report``, ...)."""
    return Command(name)


def load_script(name: str) -> Command:
    """The subcommand ``scripts/<name>.py`` runs."""
    return Command(SCRIPTS[name])
