#!/usr/bin/env python
"""``planar3p bench-kinematics`` (options: ``planar3p bench-kinematics --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["bench-kinematics", *sys.argv[1:]]))
