#!/usr/bin/env python
"""``planar3p bench-resets`` (options: ``planar3p bench-resets --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["bench-resets", *sys.argv[1:]]))
