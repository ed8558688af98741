"""The API reference: one page per package, listed from the package tree.

Walks the documented packages (``planar3p_gym`` and the agents package, whatever its import
name) and writes one page per package or subpackage, ``docs/api/<package>.md`` (an
``automodule`` of each of its modules), plus ``docs/api/index.md`` with the tree.  Modules
that move to new subpackages, and new modules, need no edit anywhere.

Also writes ``docs/_generated/kinematics_api.md``, the reference shown on the kinematics page:
the module whose last name component is ``kinematics`` and the class ``Design``, wherever they
live.
"""

from __future__ import annotations

import importlib
import re

import p3docs as P

OUT = P.DOCS / "api"
#: The package of the command line's subcommands (plain-text docstrings: their ``--help``).
COMMANDS = "planar3p_agents.commands"

INDEX_INTRO = """\
# API reference

Generated from the docstrings, one page per package of the tree (the list below is
read from the packages at build time).  `{env}` is the simulator and its Gymnasium
environments and imports neither torch nor Stable-Baselines3; `{agents}` holds the
controllers, policies, benchmark and training code.
"""


def _anchor(module: str) -> str:
    """The anchor MyST gives the heading of ``module`` (``myst_heading_anchors``)."""
    return re.sub(r"[^a-z0-9_-]", "", module.lower().replace(" ", "-"))


def _title(module: str) -> str:
    mod = importlib.import_module(module)
    doc = (mod.__doc__ or "").strip().split("\n\n")[0]
    first = " ".join(doc.split())
    return first


def _is_package(module: str) -> bool:
    return hasattr(importlib.import_module(module), "__path__")


def package_page(package: str, modules: list[str]) -> str:
    """One page per package: the package's docstring, then each of its modules."""
    out = [f"# `{package}`", "", "```{eval-rst}", f".. automodule:: {package}", "```", ""]
    for m in modules:
        if m.startswith(COMMANDS + "."):
            # A command's docstring is its plain-text ``--help`` description, not reST.
            doc = (importlib.import_module(m).__doc__ or "").strip()
            out += [f"## `{m}`", "", "```text", doc, "```", ""]
            continue
        out += [f"## `{m}`", "", "```{eval-rst}", f".. automodule:: {m}", "```", ""]
    return "\n".join(out)


def generate() -> list:
    written = []
    packages = P.documented_packages()
    pages: dict[str, list[str]] = {}
    index = [INDEX_INTRO.format(env=packages[0], agents=packages[1])]
    for top in packages:
        modules = P.walk_modules(top)
        index += [f"## `{top}`", "", "| module | summary |", "|---|---|"]
        for m in modules:
            if _is_package(m):
                pages.setdefault(m, [])
                page, anchor = m, ""
            else:
                page = m.rsplit(".", 1)[0]
                pages.setdefault(page, []).append(m)
                anchor = "#" + _anchor(m)
            summary = P.md_cell(_title(m))
            if len(summary) > 160:
                summary = summary[:157].rsplit(" ", 1)[0] + " ..."
            index.append(f"| [`{m}`]({page}.md{anchor}) | {summary} |")
        index.append("")
    index += ["```{toctree}", ":hidden:", ":maxdepth: 1", ""] + list(pages) + ["```", ""]
    if P.write_if_changed(OUT / "index.md", "\n".join(index)):
        written.append(OUT / "index.md")
    for page, modules in pages.items():
        path = OUT / f"{page}.md"
        if P.write_if_changed(path, package_page(page, modules)):
            written.append(path)
    keep = {f"{m}.md" for m in pages} | {"index.md"}
    for stale in OUT.glob("*.md"):
        if stale.name not in keep:
            stale.unlink()
    kin = P.find_module("kinematics")
    design = P.qualified_name(P.find_object("Design"))
    fragment = (
        f"The reference of `{kin}` (every function, generated from its docstrings; "
        f"also in the [API reference](api/{kin.rsplit('.', 1)[0]}.md#{_anchor(kin)})):\n\n"
        "```{eval-rst}\n"
        f".. autoclass:: {design}\n   :no-index:\n   :members: fig8, fig7\n\n"
        f".. automodule:: {kin}\n   :no-index:\n"
        "```\n"
    )
    if P.write_if_changed(P.GENERATED / "kinematics_api.md", fragment):
        written.append(P.GENERATED / "kinematics_api.md")
    return written


if __name__ == "__main__":
    for p in generate():
        print(p)
