"""``planar3p sweep``: training sweeps as Ray Tune trials.

The same as :mod:`planar3p_agents.commands.sweep`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["sweep", *sys.argv[1:]]))
