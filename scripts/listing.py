#!/usr/bin/env python
"""``planar3p list`` (options: ``planar3p list --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["list", *sys.argv[1:]]))
