"""``python -m planar3p_agents``: the ``planar3p`` command line (:mod:`planar3p_agents.cli`)."""

from planar3p_agents.cli import main

raise SystemExit(main())
