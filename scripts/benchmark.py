#!/usr/bin/env python
"""``planar3p benchmark`` (options: ``planar3p benchmark --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["benchmark", *sys.argv[1:]]))
