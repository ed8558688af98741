"""``planar3p bench-env``: environment throughput against Gymnasium's references.

The same as :mod:`planar3p_agents.commands.bench_env`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["bench-env", *sys.argv[1:]]))
