"""No reference points at a file the repository lacks: every path of the repository cited in a
docstring, a comment or a Markdown page exists, and no page cites the internal notes a user of
the repository does not have (the mechanism's spec is ``docs/mechanism.md``)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: A path under one of the repository's top folders, with a file suffix.
CITED = re.compile(
    r"(?<![\w./-])((?:planar3p_gym|agents|scripts|tests|docs)/[\w./-]*?\.(?:py|md|yml|yaml|json|csv|png|gif|txt))(?![\w])"
)
#: Files that no checkout has: the old internal spec names.
FORBIDDEN = re.compile(r"(?<![\w/.])(MECHANISM\.md|ARCHITECTURE\.md)")


def _tracked() -> list[Path]:
    out = subprocess.run(
        ["git", "ls-files", "*.py", "*.md", "*.yml"], cwd=ROOT, capture_output=True, text=True
    )
    if out.returncode != 0:  # not a git checkout (an sdist): every text file
        return [p for p in ROOT.rglob("*") if p.suffix in (".py", ".md", ".yml")]
    return [ROOT / f for f in out.stdout.split()]


def _sources() -> list[Path]:
    skip = ("docs/benchmark/", "docs/_build/", ".venv/")
    return [p for p in _tracked() if not any(s in p.relative_to(ROOT).as_posix() for s in skip)]


def _cited(path: Path) -> set[str]:
    text = path.read_text(encoding="utf-8")
    found = set(CITED.findall(text))
    # Generated output locations (written by the commands, not in the repository).
    return {f for f in found if "*" not in f and not f.startswith("docs/_build")}


@pytest.mark.parametrize("path", _sources(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_cited_paths_exist(path: Path) -> None:
    missing = sorted(f for f in _cited(path) if not (ROOT / f).exists())
    assert not missing, f"{path.relative_to(ROOT)} cites files the repository lacks: {missing}"


@pytest.mark.parametrize("path", _sources(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_internal_spec_is_cited(path: Path) -> None:
    if path.name == "CHANGELOG.md":
        return
    hits = FORBIDDEN.findall(path.read_text(encoding="utf-8"))
    assert not hits, f"{path.relative_to(ROOT)} cites {sorted(set(hits))}: cite docs/mechanism.md"
