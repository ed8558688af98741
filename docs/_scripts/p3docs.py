"""Shared helpers of the documentation generators (no Sphinx import here).

Nothing in this file names a module of the project except the two top-level import packages
(found at run time), so modules may move between subpackages without edits here:

* :func:`agents_package` -- the import name of the agents package (``planar3p_agents`` once it
  is installed under that name, ``planar3p_agents`` before);
* :func:`walk_modules` -- every module of a package tree;
* :func:`find_module` -- the one module whose last name component is given (``kinematics``);
* :func:`canonical_target` -- where a Sphinx cross-reference target really lives (the object's
  defining module), used to resolve the roles of docstrings shown outside their module;
* :func:`myst_roles` -- RST roles (``:class:`X```) rewritten as MyST roles (``{class}`X```).
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import sys
import warnings
from functools import cache
from pathlib import Path
from types import ModuleType
from typing import Any

DOCS = Path(__file__).resolve().parents[1]
ROOT = DOCS.parent
#: Generated include fragments (excluded from the Sphinx sources, read through ``{include}``).
GENERATED = DOCS / "_generated"
#: Static files of the site (the environment media live in ``_static/envs``).
STATIC = DOCS / "_static"
#: The benchmark's data folders (written by ``scripts/benchmark.py``; read, never written).
BENCHMARK = DOCS / "benchmark"
#: Hand-written notes shown at the top of generated pages (excluded from the sources).
NOTES = DOCS / "_notes"

#: Prefix of the environment ids this project registers.
ID_PREFIX = "Planar3P"
#: Import name of the environment package.
ENV_PACKAGE = "planar3p_gym"

if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


@cache
def agents_package() -> str:
    """Import name of the agents package (the repository's ``agents/`` folder)."""
    return "planar3p_agents"


def documented_packages() -> list[str]:
    """The top-level packages the API reference documents."""
    return [ENV_PACKAGE, agents_package()]


@cache
def _documented_tuple() -> tuple[str, ...]:
    return tuple(documented_packages())


def walk_modules(package: str) -> list[str]:
    """Names of ``package`` and every module and subpackage under it, sorted (no import of
    the modules themselves)."""
    pkg = importlib.import_module(package)
    names = [package]
    for info in pkgutil.walk_packages(pkg.__path__, prefix=package + "."):
        if not info.name.rsplit(".", 1)[-1].startswith("_"):
            names.append(info.name)
    return sorted(names)


def find_module(last: str, packages: list[str] | None = None) -> str:
    """The one module of the documented packages whose last name component is ``last``
    (``"kinematics"`` -> ``planar3p_gym.machine.kinematics`` or wherever it moved); ``LookupError``
    when there is none or more than one."""
    hits = [
        m
        for p in (packages or documented_packages())
        for m in walk_modules(p)
        if m.rsplit(".", 1)[-1] == last
    ]
    if len(hits) != 1:
        raise LookupError(f"expected one module named {last!r}, found {hits or 'none'}")
    return hits[0]


def find_object(name: str, packages: list[str] | None = None) -> Any:
    """The object called ``name`` defined (not imported) at the top of one module of the
    documented packages (``"AnalyticController"``); ``LookupError`` unless exactly one."""
    found = []
    for p in packages or documented_packages():
        for m in walk_modules(p):
            mod = importlib.import_module(m)
            obj = mod.__dict__.get(name)
            if obj is not None and getattr(obj, "__module__", None) == m:
                found.append(obj)
    if len(found) != 1:
        raise LookupError(f"expected one definition of {name!r}, found {len(found)}")
    return found[0]


def qualified_name(obj: Any) -> str:
    """``module.qualname`` of a class or function (where it is defined)."""
    if inspect.ismodule(obj):
        return obj.__name__
    return f"{obj.__module__}.{obj.__qualname__}"


def _import_dotted(name: str) -> tuple[Any, ModuleType | None] | None:
    """Import the longest module prefix of ``name`` and walk the attributes after it;
    ``(object, module it was found in)`` or ``None``."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            # Probing a reference imports the module it names; what that import prints is
            # not the reader's business (gymnasium.utils.play warns "matplotlib is not
            # installed" when pyplot already runs headless, though it is installed).
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                mod = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        except Exception:
            return None
        obj: Any = mod
        for attr in parts[i:]:
            try:
                obj = getattr(obj, attr)
            except AttributeError:
                return None
        return obj, mod
    return None


def canonical_target(target: str, module: str | None = None, cls: str | None = None) -> str:
    """Where the cross-reference ``target`` (role prefixes ``~ ! .`` removed) points, written
    as the defining module's name plus the qualified name, or ``target`` unchanged when it
    cannot be found.  Relative names are looked up on ``cls`` (a class name in ``module``),
    then in ``module`` (imported names included), then as a full dotted name."""
    target = target.lstrip("~!.")
    candidates = []
    if module and cls:
        candidates.append(f"{module}.{cls}.{target}")
    if module:
        candidates.append(f"{module}.{target}")
    candidates.append(target)
    for cand in candidates:
        found = _import_dotted(cand)
        if found is None:
            continue
        obj, _ = found
        if inspect.ismodule(obj):
            return obj.__name__
        if inspect.isclass(obj) or inspect.isfunction(obj):
            qn = qualified_name(obj)
            if "<locals>" not in qn:
                return qn
        # data, properties, methods, attributes: the owner's canonical name + the last part
        owner_name, _, last = cand.rpartition(".")
        owner = _import_dotted(owner_name)
        if owner is not None and (inspect.isclass(owner[0]) or inspect.ismodule(owner[0])):
            where = owner[0]
            if inspect.isclass(where):
                # the class that defines the attribute (it may be inherited)
                for klass in inspect.getmro(where):
                    if last in vars(klass):
                        where = klass
                        break
            return f"{qualified_name(where)}.{last}"
        return cand
    return target


_ROLE = re.compile(r":(?P<role>[a-z]+(?::[a-z]+)?):`(?P<body>[^`]+)`", re.S)


def _normalise_role_body(body: str) -> tuple[str, str | None, str]:
    """``(prefix, title, target)`` of a role body, whitespace removed from the target."""
    title = None
    m = re.match(r"(?s)(.*?)\s*<([^<>]+)>\s*$", body)
    if m:
        title, body = " ".join(m.group(1).split()), m.group(2)
    body = "".join(body.split())
    prefix = ""
    while body[:1] in ("~", "!", "."):
        prefix, body = prefix + body[0], body[1:]
    return prefix, title, body


def myst_roles(text: str, module: str | None = None, cls: str | None = None) -> str:
    """``text`` with every RST role ``:role:`target``` written as MyST's ``{role}`target```,
    each target made canonical (:func:`canonical_target`) so it resolves on a page outside the
    module that wrote it; the displayed text stays what the author wrote."""

    def sub(m: re.Match[str]) -> str:
        role = m.group("role")
        prefix, title, target = _normalise_role_body(m.group("body"))
        resolved = canonical_target(target, module, cls)
        if title is None:
            title = target.rsplit(".", 1)[-1] if "~" in prefix else target
        if title == resolved:
            return f"{{{role}}}`{resolved}`"
        return f"{{{role}}}`{title} <{resolved}>`"

    return _ROLE.sub(sub, text)


def write_if_changed(path: Path, text: str) -> bool:
    """Write ``text`` to ``path`` unless it already holds exactly that (keeps Sphinx's
    incremental builds incremental); returns whether it wrote."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.exists() and path.read_text(encoding="utf-8") == text:
        return False
    path.write_text(text, encoding="utf-8")
    return True


def md_cell(value: Any) -> str:
    """A value as the text of a Markdown table cell (pipes escaped, no line breaks)."""
    return " ".join(str(value).split()).replace("|", "\\|")


def md_table(header: list[str], rows: list[list[Any]]) -> str:
    """A Markdown pipe table."""
    out = ["| " + " | ".join(md_cell(h) for h in header) + " |"]
    out.append("|" + "---|" * len(header))
    out += ["| " + " | ".join(md_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(out) + "\n"


def registered_ids() -> list[str]:
    """The ids ``import planar3p_gym`` registers (the registry's order)."""
    import gymnasium as gym

    importlib.import_module(ENV_PACKAGE)
    return [i for i in gym.registry if i.startswith(ID_PREFIX)]
