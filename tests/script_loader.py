"""What the tests call a script: a file of ``scripts/`` or a command of the ``planar3p`` command
line.

``load_script(name)`` gives ``scripts/<name>.py``: a standalone script (a study or a
measurement of the repository, not installed) is imported from its file and its module
returned; a file that only calls ``planar3p <command>`` gives that command (:class:`Command`).
Either has a ``main(argv)`` that runs in-process and returns the exit status (bad input 2,
``--help`` 0).  ``command(name)`` gives a command by its name.
"""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

from planar3p_agents import cli
from planar3p_agents.commands import COMMANDS, load

#: The repository's root.
ROOT = Path(__file__).resolve().parents[1]
#: The folder of the scripts.
SCRIPTS_DIR = ROOT / "scripts"
#: The subcommand each shim of ``scripts/`` runs (``ship_policy.py``: ``ship``).
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


def standalone(name: str) -> ModuleType:
    """The standalone script ``scripts/<name>.py``, imported once as module ``<name>_script``."""
    module_name = f"{name}_script"
    if module_name in sys.modules:
        return sys.modules[module_name]
    spec = importlib.util.spec_from_file_location(module_name, SCRIPTS_DIR / f"{name}.py")
    assert spec is not None and spec.loader is not None, name
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module  # dataclasses and pickling look the module up
    spec.loader.exec_module(module)
    return module


def load_script(name: str) -> Command | ModuleType:
    """What ``scripts/<name>.py`` runs: the command of a shim, else the script's module."""
    return Command(SCRIPTS[name]) if name in SCRIPTS else standalone(name)
