"""``planar3p demo``: the main job: shipped policies against the analytic controller.

The same as :mod:`planar3p_agents.commands.demo`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["demo", *sys.argv[1:]]))
