"""The subcommands of the ``planar3p`` command line (:mod:`planar3p_agents.cli`), one module
each, and their table :data:`COMMANDS`.

Every command module has a docstring (its first paragraph, one sentence, is the summary in
``planar3p --help``, the whole is its ``--help`` description) and three functions:

* ``add_arguments(parser)``: the options, on a
  :class:`~planar3p_agents.commands.parser.CliParser`;
* ``check(args)``: every argument and output location checked, before any work
  (:mod:`planar3p_agents.commands.checks`; a bad one raises
  :class:`~planar3p_agents.commands.parser.UsageError`: exit status 2, one line);
* ``run(args) -> int``: the work, through library calls; the exit status.

Command modules import the library inside these functions, so that ``planar3p --help`` and
each ``--help`` stay quick and no command pays for another's imports.
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["COMMANDS", "load", "summary"]

#: Command name -> module of this package, in the order ``planar3p --help`` lists them.
COMMANDS: dict[str, str] = {
    "train": "train",
    "play": "play",
    "sweep": "sweep",
    "benchmark": "benchmark",
    "demo": "demo",
    "seed-report": "seed_report",
    "plot-learning": "plot_learning",
    "ship": "ship",
    "workspace": "workspace",
    "list": "listing",
}


def load(name: str) -> ModuleType:
    """The module of command ``name`` (``KeyError`` for an unknown name)."""
    return importlib.import_module(f"{__name__}.{COMMANDS[name]}")


def summary(module: ModuleType) -> str:
    """The first paragraph of a command module's docstring, on one line, without the
    reStructuredText literal marks (``x`` shows as x in a terminal)."""
    first = (module.__doc__ or "").strip().split("\n\n")[0]
    return " ".join(first.replace("``", "").split())
