"""The argument parser every ``planar3p`` subcommand uses.

* :class:`CliParser` reports a bad argument in one line, ``planar3p <command>: error: <message>``,
  and never exits the interpreter: it raises :class:`UsageError` (exit status 2) or
  :class:`ParserExit` (``--help``: status 0), which :func:`planar3p_agents.cli.main` turns into
  its return value.
* :class:`HelpFormatter` keeps the descriptions' line breaks and shows each option's default,
  except where there is nothing to show (``None``, a flag that is off, an empty string or list)
  or the help text already says what the default is (it contains ``default``).
"""

from __future__ import annotations

import argparse
import textwrap
from typing import Any, NoReturn

__all__ = ["CliParser", "HelpFormatter", "ParserExit", "UsageError"]


class UsageError(ValueError):
    """Bad command-line input, found before any work: exit status 2 with this one line."""


class ParserExit(Exception):
    """The parser is done without an error (``--help``): exit with ``status``."""

    def __init__(self, status: int = 0) -> None:
        super().__init__(status)
        self.status = status


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Raw descriptions (their examples keep their lines) and ``(default: X)`` after each
    option's help, where the default says something."""

    def _split_lines(self, text: str, width: int) -> list[str]:
        # as argparse does, but names such as analytic-simultaneous stay on one line
        return textwrap.wrap(" ".join(text.split()), width, break_on_hyphens=False)

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        if (
            "default" in text
            or default is None
            or default is False
            or default in ([], "")
            or default is argparse.SUPPRESS
            or not action.option_strings
        ):
            return text
        return f"{text} (default: %(default)s)"


class CliParser(argparse.ArgumentParser):
    """:class:`argparse.ArgumentParser` that raises instead of exiting (see the module)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        kwargs.setdefault("allow_abbrev", False)  # a typo must not pick another flag
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        raise UsageError(message)

    def note(self, text: str) -> None:
        """Set the epilog to ``text``, wrapped (the formatter keeps descriptions as written)."""
        self.epilog = textwrap.fill(" ".join(text.split()), width=88, break_on_hyphens=False)

    def exit(self, status: int = 0, message: str | None = None) -> NoReturn:
        if message:
            self._print_message(message)
        raise ParserExit(status)
