"""``planar3p track-curves``: learning curves of tracking policies in tracking error.

The same as :mod:`planar3p_agents.commands.track_curves`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["track-curves", *sys.argv[1:]]))
