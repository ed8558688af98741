"""The command modules behind ``scripts/<name>.py`` and ``planar3p <command>``."""

from __future__ import annotations

import importlib
from pathlib import Path
from types import ModuleType

#: The repository's root.
ROOT = Path(__file__).resolve().parents[1]


def load_script(name: str) -> ModuleType:
    """:mod:`planar3p_agents.commands.<name>` (what ``scripts/<name>.py`` runs)."""
    return importlib.import_module(f"planar3p_agents.commands.{name}")
