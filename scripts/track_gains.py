#!/usr/bin/env python
"""``planar3p track-gains`` (options: ``planar3p track-gains --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["track-gains", *sys.argv[1:]]))
