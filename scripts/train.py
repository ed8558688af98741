#!/usr/bin/env python
"""``planar3p train`` (options: ``planar3p train --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["train", *sys.argv[1:]]))
