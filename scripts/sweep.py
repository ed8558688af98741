#!/usr/bin/env python
"""``planar3p sweep`` (options: ``planar3p sweep --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["sweep", *sys.argv[1:]]))
