"""The package's version is defined once and is 1.0.0; the changelog's latest release is it;
every registered id's env class carries a Version History (Gymnasium's docstring template)
whose newest entry names the id's version and the release.  The ids' behaviour is held by
their episode hashes (``tests/envs/test_episode_hashes.py``)."""

from __future__ import annotations

import importlib
import inspect
import re
from pathlib import Path

import pytest
import tomllib

import planar3p_gym

ROOT = Path(__file__).resolve().parents[2]


def test_the_version_is_defined_once():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "version" not in project["project"] and "version" in project["project"]["dynamic"]
    dynamic = project["tool"]["setuptools"]["dynamic"]["version"]
    assert dynamic == {"attr": "planar3p_gym.__version__"}
    assert planar3p_gym.__version__ == "1.0.0"


def test_the_changelog_s_latest_release_is_the_version():
    text = (ROOT / "CHANGELOG.md").read_text()
    releases = re.findall(r"^## (\d+\.\d+\.\d+)(?: \((\d{4}-\d{2}-\d{2})\))?$", text, re.M)
    assert releases[0] == (planar3p_gym.__version__, "2026-12-01"), releases[:2]
    assert "Every registered id is frozen from here" in text


def _entry_class(entry_point: str) -> type:
    module, _, name = entry_point.partition(":")
    return getattr(importlib.import_module(module), name)


@pytest.mark.parametrize("row", planar3p_gym.ENV_SPECS, ids=lambda row: row.id)
def test_every_id_s_class_has_a_version_history(row):
    doc = inspect.cleandoc(_entry_class(row.entry_point).__doc__ or "")
    _, found, history = doc.partition("## Version History\n")
    assert found, f"{row.entry_point} has no '## Version History' section"
    entries = re.findall(r"^- (v\d+) \(([\d.]+)\)", history, re.M)
    version = row.id.rpartition("-")[2]
    assert entries and entries[0] == (version, planar3p_gym.__version__), entries
