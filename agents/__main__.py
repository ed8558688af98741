"""``python -m planar3p_agents``: the ``planar3p`` command line."""

from planar3p_agents.cli import main

raise SystemExit(main())
