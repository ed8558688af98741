#!/usr/bin/env python
"""``planar3p track-curves`` (options: ``planar3p track-curves --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["track-curves", *sys.argv[1:]]))
