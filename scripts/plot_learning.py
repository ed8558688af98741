#!/usr/bin/env python
"""``planar3p plot-learning`` (options: ``planar3p plot-learning --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["plot-learning", *sys.argv[1:]]))
