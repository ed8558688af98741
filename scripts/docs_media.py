"""``planar3p docs-media``: the frames and GIFs of the environment pages.

The same as :mod:`planar3p_agents.commands.docs_media`'s ``planar3p`` command; see its ``--help``.
"""

import sys

from planar3p_agents.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["docs-media", *sys.argv[1:]]))
