"""``planar3p train``: train an SB3 agent (PPO, SAC, TD3, TQC; HER on the goal ids).

The same as :mod:`planar3p_agents.commands.train`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["train", *sys.argv[1:]]))
