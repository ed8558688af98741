#!/usr/bin/env python
"""``planar3p detours`` (options: ``planar3p detours --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["detours", *sys.argv[1:]]))
