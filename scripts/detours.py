#!/usr/bin/env python
"""``planar3p detours`` (options: ``planar3p detours --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["detours", *sys.argv[1:]]))
