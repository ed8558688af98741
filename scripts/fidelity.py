"""``planar3p fidelity``: closure error and DK gap of the physics models.

The same as :mod:`planar3p_agents.commands.fidelity`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["fidelity", *sys.argv[1:]]))
