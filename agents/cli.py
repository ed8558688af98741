"""The ``planar3p`` command line: one entry point with a subcommand per job, in the style of
rl-zoo3's ``cli.py``.

    planar3p train --algo ppo --timesteps 1e6 --seed 1
    planar3p benchmark --quick
    planar3p demo
    planar3p <command> --help

Installed as the console script ``planar3p`` (``[project.scripts]``); also
``python -m planar3p_agents``.  The repository's studies and measurements are not commands:
they are the files of ``scripts/`` (not installed), which run through :func:`run_command`.
The commands live in :mod:`planar3p_agents.commands` (table
:data:`~planar3p_agents.commands.COMMANDS`).

:func:`main` returns the exit status and never exits the interpreter itself: 0 done; 2 bad
input, reported in one line ``planar3p <command>: error: <message>`` that names the flag, before
any work is done and before anything is written; 130 interrupted; other codes as each command
documents (1: the work failed).
"""

from __future__ import annotations

import argparse
import shlex
import sys
import textwrap
from collections.abc import Callable, Sequence
from types import ModuleType

from planar3p_agents.commands import COMMANDS, load, summary
from planar3p_agents.commands.parser import CliParser, HelpFormatter, ParserExit, UsageError

__all__ = ["DESCRIPTION", "PROG", "main", "parse", "parse_command", "run_command"]

PROG = "planar3p"


DESCRIPTION = (
    "The command line of planar3p-gym: train, sweep, benchmark and ship agents of the 3-PRR "
    "planar parallel manipulator, and map its workspace."
)


def _top_parser() -> argparse.ArgumentParser:
    """The parser of ``planar3p --help`` (the commands are dispatched by :func:`parse`)."""
    width = max(map(len, COMMANDS)) + 4
    lines = [
        textwrap.fill(
            summary(load(name)),
            width=100,
            initial_indent=f"  {name:<{width - 2}}",
            subsequent_indent=" " * width,
        )
        for name in COMMANDS
    ]
    return CliParser(
        prog=PROG,
        usage=f"{PROG} <command> [options]",
        description=textwrap.fill(DESCRIPTION, 100),
        epilog="commands:\n" + "\n".join(lines) + f"\n\n'{PROG} <command> --help' for its options",
        formatter_class=HelpFormatter,
    )


def parse(argv: Sequence[str]) -> tuple[ModuleType, argparse.Namespace]:
    """The command module and its checked arguments for ``argv`` (``[command, *options]``).

    :class:`~planar3p_agents.commands.parser.UsageError` for bad input,
    :class:`~planar3p_agents.commands.parser.ParserExit` after ``--help``.  The namespace also
    holds ``command_line``, the command as a shell line (recorded by the commands that write
    their settings).
    """
    argv = list(argv)
    if not argv or argv[0] in ("-h", "--help"):
        _top_parser().print_help(None if argv else sys.stderr)
        raise ParserExit(0 if argv else 2)
    name = argv[0]
    if name not in COMMANDS:
        raise UsageError(f"unknown command {name!r}; choose from {', '.join(COMMANDS)}")
    module = load(name)
    return module, parse_command(module, f"{PROG} {name}", argv[1:])


def parse_command(module: ModuleType, prog: str, argv: Sequence[str]) -> argparse.Namespace:
    """The checked arguments ``argv`` of a command module (its ``add_arguments`` and ``check``)
    run as ``prog``; raises as :func:`parse`."""
    parser = CliParser(prog=prog, description=module.__doc__)
    module.add_arguments(parser)
    args = parser.parse_args(list(argv))
    module.check(args)
    args.command_line = shlex.join([*prog.split(), *argv])
    return args


def _prog(argv: Sequence[str]) -> str:
    return f"{PROG} {argv[0]}" if argv and argv[0] in COMMANDS else PROG


def _error(prog: str, message: object) -> None:
    """One line on stderr: ``<prog>: error: <message>``."""
    text = " ".join(str(message).split())  # a message never spans lines
    print(f"{prog}: error: {text}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``planar3p`` with ``argv`` (default: the process's arguments); the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    return _guarded(_prog(argv), lambda: parse(argv))


def run_command(module: ModuleType, prog: str, argv: Sequence[str]) -> int:
    """Run a command module (``add_arguments``, ``check``, ``run``) with ``argv`` as ``prog``,
    with the exit statuses and error lines of :func:`main`; the repository's scripts run
    through this."""
    return _guarded(prog, lambda: (module, parse_command(module, prog, argv)))


def _guarded(prog: str, parsed: Callable[[], tuple[ModuleType, argparse.Namespace]]) -> int:
    """Parse, then run, turning bad input, ``--help`` and an interrupt into exit statuses."""
    try:
        module, args = parsed()
        return int(module.run(args))
    except ParserExit as done:
        return done.status
    except UsageError as exc:
        _error(prog, exc)
        return 2
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
