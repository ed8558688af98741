#!/usr/bin/env python
"""``planar3p track-curves`` (options: ``planar3p track-curves --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["track-curves", *sys.argv[1:]]))
