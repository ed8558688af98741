#!/usr/bin/env python
"""``planar3p fidelity`` (options: ``planar3p fidelity --help``)."""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main(["fidelity", *sys.argv[1:]]))
