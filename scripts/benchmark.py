#!/usr/bin/env python
"""``planar3p benchmark`` (options: ``planar3p benchmark --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["benchmark", *sys.argv[1:]]))
