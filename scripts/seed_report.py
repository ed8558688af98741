#!/usr/bin/env python
"""``planar3p seed-report`` (options: ``planar3p seed-report --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["seed-report", *sys.argv[1:]]))
