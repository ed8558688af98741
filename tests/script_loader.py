"""What the tests call a script: a command of the ``planar3p`` command line.

``load_script(name)`` gives the command module behind ``scripts/<name>.py`` (its attributes)
with a ``main(argv)`` that runs ``planar3p <command> *argv`` and returns the exit status, as the
scripts' own ``main`` did.
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType
from typing import Any

from planar3p_agents.cli import main as cli_main
from planar3p_agents.commands import COMMANDS, load

#: The repository's root.
ROOT = Path(__file__).resolve().parents[1]
#: Script names that differ from their command module's.
SCRIPT_MODULES = {"ship_policy": "ship"}


class Script:
    """A command module seen as a script: its attributes, and ``main(argv) -> status``."""

    def __init__(self, command: str, module: ModuleType) -> None:
        self._command, self._module = command, module

    def __getattr__(self, name: str) -> Any:
        return getattr(self._module, name)

    def main(self, argv: list[str] | None = None) -> int:
        return cli_main([self._command, *(argv or [])])


def load_script(name: str) -> Script:
    """The command that ``scripts/<name>.py`` runs."""
    module = SCRIPT_MODULES.get(name, name)
    command = next(c for c, m in COMMANDS.items() if m == module)
    return Script(command, load(command))
