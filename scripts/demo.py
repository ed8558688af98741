#!/usr/bin/env python
"""``planar3p demo`` (options: ``planar3p demo --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["demo", *sys.argv[1:]]))
