#!/usr/bin/env python
"""``planar3p task-baselines`` (options: ``planar3p task-baselines --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["task-baselines", *sys.argv[1:]]))
