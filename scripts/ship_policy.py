"""``planar3p ship``: ship a trained model into the zoo, or verify the zoo's files.

The same as :mod:`planar3p_agents.commands.ship_policy`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["ship", *sys.argv[1:]]))
