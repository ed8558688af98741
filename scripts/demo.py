#!/usr/bin/env python
"""``planar3p demo`` (options: ``planar3p demo --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["demo", *sys.argv[1:]]))
