#!/usr/bin/env python
"""``planar3p ship`` (options: ``planar3p ship --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["ship", *sys.argv[1:]]))
