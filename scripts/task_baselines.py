"""``planar3p task-baselines``: baselines on the mode- and assembly-change ids.

The same as :mod:`planar3p_agents.commands.task_baselines`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["task-baselines", *sys.argv[1:]]))
