#!/usr/bin/env python
"""``planar3p bench-kinematics`` (options: ``planar3p bench-kinematics --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["bench-kinematics", *sys.argv[1:]]))
