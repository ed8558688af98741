#!/usr/bin/env python
"""``planar3p train`` (options: ``planar3p train --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["train", *sys.argv[1:]]))
