#!/usr/bin/env python
"""``planar3p plot-learning`` (options: ``planar3p plot-learning --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["plot-learning", *sys.argv[1:]]))
