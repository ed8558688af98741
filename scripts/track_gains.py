#!/usr/bin/env python
"""``planar3p track-gains`` (options: ``planar3p track-gains --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["track-gains", *sys.argv[1:]]))
