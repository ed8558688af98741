#!/usr/bin/env python
"""``planar3p play`` (options: ``planar3p play --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["play", *sys.argv[1:]]))
