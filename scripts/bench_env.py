#!/usr/bin/env python
"""``planar3p bench-env`` (options: ``planar3p bench-env --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["bench-env", *sys.argv[1:]]))
