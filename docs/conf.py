"""Sphinx configuration of the planar3p-gym site (MyST Markdown, furo theme).

Build: ``make docs`` (``sphinx-build -W --keep-going -n -b html docs docs/_build/html``).
The environment pages, model cards, results pages and API pages are generated at the start of
every build from the registry, the provenance files and the benchmark data
(``docs/_scripts``); they are not kept in git.  The site is built offline: no intersphinx.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(DOCS / "_scripts"))
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("MPLBACKEND", "Agg")

import planar3p_gym  # noqa: E402

project = "planar3p-gym"
author = "the planar3p-gym authors"
copyright = "the planar3p-gym authors"
version = release = planar3p_gym.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx_p3",
]

source_suffix = {".md": "markdown"}
root_doc = "index"
exclude_patterns = [
    "_build",
    "_generated",  # fragments read through {include}
    "_notes",  # hand-written notes read through the generators
    "_scripts",
    "benchmark",  # the benchmark's data folders (their report.md files are data)
    "workspace_table.md",  # written by scripts/workspace.py, shown on the workspace page
    "**/.ipynb_checkpoints",
]
templates_path: list[str] = []

# MyST
myst_enable_extensions = ["colon_fence", "deflist", "fieldlist", "attrs_inline"]
myst_heading_anchors = 3
# objects are not entries of the navigation tree (it stays small, and the build fast)
toc_object_entries = False

# autodoc: document every object where it is defined (imports are not repeated), in source
# order; members without docstrings are left out.
autodoc_default_options = {
    "members": True,
    "show-inheritance": True,
    "ignore-module-all": True,
    "member-order": "bysource",
}
autodoc_typehints = "signature"
autodoc_typehints_format = "short"
autodoc_preserve_defaults = True
autoclass_content = "class"
autodoc_inherit_docstrings = False  # Gymnasium's own docstrings are not ours to build
autodoc_warningiserror = True
napoleon_google_docstring = True
napoleon_numpy_docstring = False
# Google-style sections; their parenthesised "types" are often units here ("max_speed (m/s)"),
# so they are shown as text, not cross-referenced (sphinx_p3 folds ``:vartype:`` into the text).
napoleon_use_ivar = True
napoleon_use_param = False
napoleon_use_rtype = False
napoleon_use_keyword = False

# Nitpicky: every Python reference must resolve.  References to other projects cannot (the
# site is built offline, without intersphinx): only those are ignored, by package prefix.
nitpicky = True
_EXTERNAL = (
    r"(np|numpy|npt|numpy\.typing|gym|gymnasium|spaces|torch|th|nn|pymunk|pygame|scipy|"
    r"matplotlib|plt|stable_baselines3|sb3_contrib|ray|optuna|yaml|imageio|rl_zoo3|"
    r"collections|concurrent|pathlib|typing|typing_extensions|types|dataclasses|argparse|"
    r"multiprocessing|enum|abc|io|os|json|re|math|random|functools|itertools|csv|"
    r"contextlib|logging|subprocess|threading|tempfile|shutil|warnings)"
)
nitpick_ignore_regex = [
    ("py:.*", _EXTERNAL + r"(\..*)?"),
    # standard-library and typing names written without their module in annotations
    (
        "py:.*",
        r"(Any|Callable|Iterable|Iterator|Sequence|Mapping|MutableMapping|Generator|"
        r"Hashable|Path|PathLike|ArrayLike|NDArray|Literal|Self|ClassVar|TypeVar|"
        r"Protocol|Counter|OrderedDict|ModuleType|Namespace|ArgumentParser|Future|"
        r"Executor|Enum|IntEnum|Pool|Process|Queue|Event|Lock|TextIO|BinaryIO|"
        r"SimpleNamespace|deque|defaultdict|partial|cached_property|Fraction|"
        r"Generic|Final|TypeAlias|Annotated|Union|Optional|NamedTuple|Space|Env|"
        r"Wrapper|VectorEnv|Box|Dict|Discrete|MultiDiscrete|VecEnv|VecNormalize|"
        r"BaseAlgorithm|BaseCallback|ActorCriticPolicy|BaseFeaturesExtractor|"
        r"Distribution|Tensor|Module|Figure|Axes|Space\[.*\])",
    ),
]

# HTML
html_theme = "furo"
html_title = f"planar3p-gym {release}"
html_static_path = ["_static"]
html_logo = None
html_show_sourcelink = False
pygments_style = "sphinx"
pygments_dark_style = "monokai"
