"""``planar3p goal-track-baselines``: baselines on the goal and tracking ids.

The same as :mod:`planar3p_agents.commands.goal_track_baselines`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["goal-track-baselines", *sys.argv[1:]]))
