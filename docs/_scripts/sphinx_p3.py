"""The site's Sphinx extension: generate the pages, resolve docstring references, read the
docstrings' Markdown-style section headings.

* ``builder-inited``: run the generators (environment pages from the registry, model cards,
  results pages, API lists); a generator's warning becomes a Sphinx warning, so a missing
  GIF or an observation layout that no longer matches its space fails ``-W`` builds.
* ``missing-reference``: a Python reference that Sphinx cannot find as written (``:class:`Design```
  inside a module that imports ``Design``; a name moved to another module) is looked up by
  importing: the object's defining module gives the documented name
  (:func:`p3docs.canonical_target`); then by its last name component when exactly one
  documented object has it.  References to other projects stay unresolved (the site does not
  use intersphinx: it is built offline).
* ``autodoc-process-docstring``: the environment docstrings follow Gymnasium's template with
  Markdown headings (``## Rewards``) and lists; for autodoc (reStructuredText) a heading
  becomes a rubric and a list gets the blank line it needs.
"""

from __future__ import annotations

import builtins
import inspect
import re
import time
import warnings
from typing import Any

import p3docs as P
from sphinx.util import logging

logger = logging.getLogger(__name__)


def _generate(app: Any) -> None:
    import gen_api
    import gen_envs
    import gen_models
    import gen_results

    t0 = time.perf_counter()
    for gen in (gen_api, gen_envs, gen_models, gen_results):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            gen.generate()
        for w in caught:
            if issubclass(w.category, UserWarning) and "_scripts" in str(w.filename):
                logger.warning("%s: %s", gen.__name__, w.message, type="planar3p", subtype="gen")
    logger.info("planar3p: pages generated in %.1f s", time.perf_counter() - t0)


def _is_external(target: str, module: str | None, cls: str | None) -> bool:
    """Whether ``target`` names, by importing, an object of another project (a builtin, a
    numpy alias, a Gymnasium type variable or attribute)."""
    bare = target.lstrip("~!.")
    if hasattr(builtins, bare):
        return True
    found = P._import_dotted(P.canonical_target(target, module, cls))
    if found is None:
        return False
    obj = found[0]
    owner = obj.__name__ if inspect.ismodule(obj) else getattr(obj, "__module__", None)
    origin = getattr(obj, "__origin__", None)
    if origin is not None:
        owner = getattr(origin, "__module__", owner)
    if not isinstance(owner, str):
        return False
    return owner.split(".")[0] not in P.documented_packages()


def _exists_undocumented(target: str, module: str | None, cls: str | None) -> bool:
    """Whether ``target`` names an object of the documented packages that exists but has no
    entry in the reference: a private name (``_helper``), a constant without a doc comment, an
    instance attribute (assigned in ``__init__``).  Such a reference is shown as text; a name
    that does not exist still fails the build."""
    bare = target.lstrip("~!.")
    if bare.rsplit(".", 1)[-1].startswith("_"):
        return True
    if P._import_dotted(P.canonical_target(target, module, cls)) is not None:
        return True
    if module and cls and "." not in bare:
        klass = P._import_dotted(f"{module}.{cls}")
        if klass is not None and inspect.isclass(klass[0]):
            for k in inspect.getmro(klass[0]):
                init = vars(k).get("__init__")
                code = getattr(init, "__code__", None)
                if code is not None and bare in code.co_names:
                    return True
    return False


def _missing_reference(app: Any, env: Any, node: Any, contnode: Any) -> Any:
    if node.get("refdomain") != "py":
        return None
    target = "".join(node.get("reftarget", "").split())  # a target broken across lines
    typ = node.get("reftype")
    domain = env.get_domain("py")
    module, cls = node.get("py:module"), node.get("py:class")
    canonical = P.canonical_target(target, module, cls)
    candidates = [target, canonical]
    bare = target.lstrip("~!.")
    # a name moved to another module, imported from one, or written relative to its class:
    # the documented objects whose name ends with it, when there is exactly one
    for suffix in dict.fromkeys((bare, canonical.rsplit(".", 1)[-1], bare.rsplit(".", 1)[-1])):
        hits = [name for name in domain.objects if name == suffix or name.endswith("." + suffix)]
        if len(hits) == 1:
            candidates.append(hits[0])
            break
    for cand in dict.fromkeys(candidates):
        if cand in domain.objects or cand in domain.modules:
            ref = domain.resolve_xref(env, node["refdoc"], app.builder, typ, cand, node, contnode)
            if ref is None:  # the role does not fit the object's type: resolve as "obj"
                ref = domain.resolve_xref(
                    env, node["refdoc"], app.builder, "obj", cand, node, contnode
                )
            if ref is not None:
                return ref
    if _is_external(target, module, cls) or _exists_undocumented(target, module, cls):
        return contnode  # no link: another project's object, or one without a reference entry
    return None


def _unlink_variable_names(app: Any, doctree: Any) -> None:
    """The names of a ``Variables`` field (napoleon's ``:ivar x:``) describe the class's own
    attributes: they are not references (Sphinx would search for ``x`` everywhere)."""
    from docutils import nodes
    from sphinx import addnodes

    for field in doctree.findall(nodes.field):
        name = field.children[0].astext() if field.children else ""
        if name not in ("Variables", "Variable"):
            continue
        for ref in list(field.findall(addnodes.pending_xref)):
            if ref.get("refdomain") == "py" and ref.get("reftype") == "obj":
                ref.replace_self(ref.children or [nodes.literal(text=ref.astext())])


def _signature_defaults(
    app: Any,
    what: str,
    name: str,
    obj: Any,
    options: Any,
    signature: str | None,
    return_annotation: str | None,
) -> tuple[str | None, str | None] | None:
    """Dataclass fields with a ``default_factory`` show ``<factory>``, which is not Python
    and breaks Sphinx's parsing of the whole signature: show ``...`` instead."""
    if signature and "<factory>" in signature:
        return signature.replace("<factory>", "..."), return_annotation
    return None


_BORDER = re.compile(r"^(\s*)=+( +=+)+\s*$")


def _simple_table_ok(block: list[str]) -> bool:
    from docutils.parsers.rst.tableparser import SimpleTableParser, TableMarkupError
    from docutils.statemachine import StringList

    try:
        SimpleTableParser().parse(StringList(block))
    except TableMarkupError:
        return False
    return True


def _relayout(block: list[str]) -> list[str]:
    """A simple table whose text runs into a column margin, laid out again: each row's cells
    (separated by two or more spaces) go to the column they start in, and every column is as
    wide as its widest cell."""
    indent = len(block[0]) - len(block[0].lstrip())
    border = block[0]
    starts = [m.start() for m in re.finditer(r"=+", border)]
    rows: list[list[str] | None] = []
    for line in block:
        if _BORDER.match(line):
            rows.append(None)
            continue
        cells = [""] * len(starts)
        col, prev_end = 0, -10
        for m in re.finditer(r"\S+", line):
            by_position = max((i for i, st in enumerate(starts) if st <= m.start()), default=0)
            if m.start() - prev_end >= 2 or m.start() in starts:
                col = by_position  # a new cell (or a word at a column's start)
            cells[col] = f"{cells[col]} {m.group(0)}".strip()
            prev_end = m.end()
        rows.append(cells)
    widths = [max([len(r[i]) for r in rows if r is not None] + [1]) for i in range(len(starts))]
    out = []
    for r in rows:
        if r is None:
            out.append(" " * indent + "  ".join("=" * w for w in widths))
        else:
            out.append(
                (
                    " " * indent + "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True))
                ).rstrip()
            )
    return out


def _repair_simple_tables(lines: list[str]) -> None:
    """Simple tables that docutils rejects ("Malformed table": text in a column margin) are
    laid out again; valid tables are left alone."""
    i = 0
    while i < len(lines):
        if not _BORDER.match(lines[i]):
            i += 1
            continue
        end, borders = i + 1, 1
        while end < len(lines) and lines[end].strip():
            if _BORDER.match(lines[end]):
                borders += 1
            end += 1
        block = lines[i:end]
        if borders >= 2 and not _simple_table_ok(block):
            fixed = _relayout(block)
            if _simple_table_ok(fixed):
                lines[i:end] = fixed
        i = end


_HEADING = re.compile(r"^(\s*)#{2,4}\s+(\S.*)$")
_ITEM = re.compile(r"^(\s*)[-*]\s+\S")


def _markdown_sections(
    app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]
) -> None:
    """Gymnasium-style docstrings (Markdown headings and lists) made valid RST, and simple
    tables with text in a column margin laid out again."""
    _repair_simple_tables(lines)
    out: list[str] = []
    literal_open = False  # inside a ``double-backtick`` literal that spans lines
    for line in lines:
        if not line.strip():
            literal_open = False
            out.append(line)
            continue
        m = _HEADING.match(line)
        if m and not literal_open:
            if out and out[-1].strip():
                out.append("")
            out += [f"{m.group(1)}.. rubric:: {m.group(2)}", ""]
            continue
        item = _ITEM.match(line)
        if item and not literal_open and out and out[-1].strip():
            prev = out[-1]
            prev_indent = len(prev) - len(prev.lstrip())
            if (
                not _ITEM.match(prev)
                and prev_indent <= len(item.group(1))
                and not _continues_item(out)
            ):
                out.append("")  # a list straight after a paragraph needs a blank line
        if line.count("``") % 2:
            literal_open = not literal_open
        out.append(line)
    lines[:] = out


def _continues_item(out: list[str]) -> bool:
    """Whether the last line of ``out`` belongs to a list item (its continuation)."""
    for prev in reversed(out):
        if not prev.strip():
            return False
        if _ITEM.match(prev):
            return True
        if len(prev) - len(prev.lstrip()) == 0:
            return False
    return False


_SAVED: dict[str, list[str]] = {}


def _save_attribute_docstring(
    app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]
) -> None:
    """Napoleon reads ``"text: more"`` on the first line of an attribute's docstring as
    ``type: description``; this project writes types in annotations and its attribute
    docstrings are prose, so they are kept from napoleon: saved before it runs..."""
    if what in ("attribute", "data", "property"):
        _SAVED[name] = list(lines)


def _restore_attribute_docstring(
    app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]
) -> None:
    """... and put back after it.  Also: napoleon's ``:vartype x: T`` (from ``x (T): ...`` in
    an ``Attributes:`` section) is folded into the text of ``:ivar x:`` as ``(T)``: in this
    project that parenthesis is a unit or a note (``rho (m)``), not a type to link."""
    saved = _SAVED.pop(name, None)
    if saved is not None:
        lines[:] = saved
        return
    lines[:] = [_IVAR_NAMES.sub(lambda m: m.group(0).replace(", ", ","), ln) for ln in lines]
    types = {}
    for line in lines:
        m = _VARTYPE.match(line)
        if m:
            types[m.group(2)] = m.group(3)
    if not types:
        return
    out = []
    for line in lines:
        if _VARTYPE.match(line):
            continue
        m = _IVAR.match(line)
        if m and m.group(2) in types:
            line = f"{m.group(1)}:ivar {m.group(2)}: ({types[m.group(2)]}) {m.group(3)}"
        out.append(line)
    lines[:] = out


_VARTYPE = re.compile(r"^(\s*):vartype (\S+): (.*)$")
_IVAR_NAMES = re.compile(r"^\s*:(?:ivar|vartype) [^:]*, [^:]*:")
_IVAR = re.compile(r"^(\s*):ivar (\S+): ?(.*)$")


def setup(app: Any) -> dict[str, Any]:
    app.connect("builder-inited", _generate)
    app.connect("missing-reference", _missing_reference)
    app.connect("doctree-read", _unlink_variable_names)
    app.connect("autodoc-process-signature", _signature_defaults)
    app.connect("autodoc-process-docstring", _save_attribute_docstring, priority=400)
    app.connect("autodoc-process-docstring", _restore_attribute_docstring, priority=600)
    app.connect("autodoc-process-docstring", _markdown_sections, priority=450)
    return {"parallel_read_safe": True, "parallel_write_safe": True, "version": "1"}
