#!/usr/bin/env python
"""``planar3p docs-media`` (options: ``planar3p docs-media --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["docs-media", *sys.argv[1:]]))
