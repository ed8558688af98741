"""``python -m planar3p_agents``: the ``planar3p`` command line (:mod:`planar3p_agents.cli`)."""

from planar3p_agents.cli import main

if __name__ == "__main__":  # not on a worker's import (SubprocVecEnv, Ray)
    raise SystemExit(main())
