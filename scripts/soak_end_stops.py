#!/usr/bin/env python
"""``planar3p soak-end-stops`` (options: ``planar3p soak-end-stops --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["soak-end-stops", *sys.argv[1:]]))
