#!/usr/bin/env python
"""``planar3p bench-resets`` (options: ``planar3p bench-resets --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["bench-resets", *sys.argv[1:]]))
