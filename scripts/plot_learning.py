"""``planar3p plot-learning``: learning curves of training runs.

The same as :mod:`planar3p_agents.commands.plot_learning`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["plot-learning", *sys.argv[1:]]))
