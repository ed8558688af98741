"""``planar3p soak-end-stops``: random and bang-bang soak of the end stops.

The same as :mod:`planar3p_agents.commands.soak_end_stops`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["soak-end-stops", *sys.argv[1:]]))
