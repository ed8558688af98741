#!/usr/bin/env python
"""``planar3p fidelity`` (options: ``planar3p fidelity --help``)."""

import sys

from planar3p_agents.cli import main

raise SystemExit(main(["fidelity", *sys.argv[1:]]))
