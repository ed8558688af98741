#!/usr/bin/env python
"""``planar3p docs-media`` (options: ``planar3p docs-media --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["docs-media", *sys.argv[1:]]))
