#!/usr/bin/env python
"""``planar3p seed-report`` (options: ``planar3p seed-report --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["seed-report", *sys.argv[1:]]))
