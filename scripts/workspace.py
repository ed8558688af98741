#!/usr/bin/env python
"""``planar3p workspace`` (options: ``planar3p workspace --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["workspace", *sys.argv[1:]]))
