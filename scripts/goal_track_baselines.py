#!/usr/bin/env python
"""``planar3p goal-track-baselines`` (options: ``planar3p goal-track-baselines --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["goal-track-baselines", *sys.argv[1:]]))
