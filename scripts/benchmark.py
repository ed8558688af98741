"""``planar3p benchmark``: play policies on the fixed suites and write the report.

The same as :mod:`planar3p_agents.commands.benchmark`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["benchmark", *sys.argv[1:]]))
