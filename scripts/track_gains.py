"""``planar3p track-gains``: the feed-forward tracking controller at other gains.

The same as :mod:`planar3p_agents.commands.track_gains`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["track-gains", *sys.argv[1:]]))
