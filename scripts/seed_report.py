"""``planar3p seed-report``: success or a metric across training seeds (IQM, CIs).

The same as :mod:`planar3p_agents.commands.seed_report`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["seed-report", *sys.argv[1:]]))
