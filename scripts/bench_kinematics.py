"""``planar3p bench-kinematics``: throughput of the vectorised kinematics.

The same as :mod:`planar3p_agents.commands.bench_kinematics`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["bench-kinematics", *sys.argv[1:]]))
