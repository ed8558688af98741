"""``planar3p workspace``: the paper's workspace-versus-stroke study, tables and figures.

The same as :mod:`planar3p_agents.commands.workspace`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["workspace", *sys.argv[1:]]))
