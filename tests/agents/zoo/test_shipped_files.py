"""No shipped file carries a trace of the machine it was made on: no absolute
path (``/work/``, ``/home/``, ``/root/``, ``/tmp/``, ``C:\\``) and not this machine's host name, in
the text files, the strings of the JSON and YAML files, the ``data`` JSON inside each model zip
(its serialised entries decoded) and the strings of every pickle (read, never run)."""

from __future__ import annotations

import base64
import json
import pickle
import re
import shutil
import socket
import zipfile
from pathlib import Path
from typing import Any

import pytest
import yaml

from planar3p_agents.zoo.layout import PRETRAINED_DIR
from planar3p_agents.zoo.portable import machine_traces

MARKS = ("/work/", "/home/", "/root/", "/tmp/", "C:\\")
SHIPPED = sorted(p for p in PRETRAINED_DIR.rglob("*") if p.is_file())
HOST = socket.gethostname()


def _host_in(text: str) -> bool:
    """The host name as a whole word (a short name like ``vm`` is a part of many words)."""
    if HOST.lower() in ("", "localhost"):
        return False
    return re.search(rf"(?<![A-Za-z0-9_\-]){re.escape(HOST)}(?![A-Za-z0-9_\-])", text) is not None


def _strings(value: Any) -> list[str]:
    if isinstance(value, str):
        return [value]
    if isinstance(value, dict):
        return [s for k, v in value.items() for s in (*_strings(k), *_strings(v))]
    if isinstance(value, list):
        return [s for v in value for s in _strings(v)]
    return []


def _yaml(text: str) -> Any:
    """YAML with any Python tag read as plain data (nothing is constructed)."""

    class Loader(yaml.SafeLoader):
        pass

    def plain(loader: Any, suffix: str, node: Any) -> Any:
        if isinstance(node, yaml.MappingNode):
            return loader.construct_mapping(node, deep=True)
        if isinstance(node, yaml.SequenceNode):
            return loader.construct_sequence(node, deep=True)
        return loader.construct_scalar(node)

    Loader.add_multi_constructor("", plain)
    return yaml.load(text, Loader=Loader)  # a SafeLoader subclass


def _texts(path: Path) -> list[str]:
    """What a reader of ``path`` sees as text: a text file and its JSON/YAML strings; for a
    model zip its ``data`` strings (serialised entries apart) and its text members."""
    if path.suffix == ".pkl":
        return []  # binary: covered by test_every_shipped_file_is_free_of_machine_traces
    if path.suffix == ".zip":
        out = []
        with zipfile.ZipFile(path) as zf:
            data = json.loads(zf.read("data"))
            out += [s for k, v in data.items() if not _serialized(v) for s in _strings({k: v})]
            out += [zf.read(n).decode() for n in zf.namelist() if n.endswith(".txt")]
        return out
    text = path.read_text()
    if path.suffix == ".json":
        return [text, *_strings(json.loads(text))]
    if path.suffix in (".yml", ".yaml"):
        return [text, *_strings(_yaml(text))]
    return [text]


def _serialized(value: Any) -> bool:
    return isinstance(value, dict) and ":serialized:" in value


def test_the_pretrained_directory_is_scanned() -> None:
    kinds = {p.suffix or p.name for p in SHIPPED}
    assert {".zip", ".pkl", ".json", ".yml", ".md", "SHA256SUMS"} <= kinds
    assert sum(p.suffix == ".zip" for p in SHIPPED) >= 7


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.relative_to(PRETRAINED_DIR).as_posix())
def test_shipped_text_names_no_machine_path_or_host(path: Path) -> None:
    for text in _texts(path):
        assert not [m for m in MARKS if m in text], f"{path}: {text[:200]!r}"
        assert not _host_in(text), f"{path} names the host {HOST!r}: {text[:200]!r}"


def test_every_shipped_file_is_free_of_machine_traces() -> None:
    """The deep scan (pickles and serialised entries too), as shipping runs it."""
    assert machine_traces(SHIPPED) == []
    assert machine_traces(SHIPPED, hostname=HOST) == []


def test_the_deep_scan_finds_each_kind_of_trace(tmp_path: Path) -> None:
    """The scanner sees a planted trace in each kind of file and never unpickles."""
    host = "build-box-7"
    (tmp_path / "r.json").write_text(json.dumps({"command": "--run-dir C:\\Users\\me\\runs\\x"}))
    (tmp_path / "a.yml").write_text("command: python train.py --out /root/x\n")
    (tmp_path / "README.md").write_text(f"made on {host}.example.org\n")
    (tmp_path / "s.pkl").write_bytes(pickle.dumps({"where": "/home/me/x"}))
    model = next(p for p in SHIPPED if p.suffix == ".zip")
    with zipfile.ZipFile(model) as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    data = json.loads(members["data"])
    blob = base64.b64encode(pickle.dumps({"log": "/tmp/runs/x"})).decode()
    data["policy_kwargs"] = {":type:": "<class 'dict'>", ":serialized:": blob}
    members["data"] = json.dumps(data, indent=4).encode()
    with zipfile.ZipFile(tmp_path / "m.zip", "w") as zf:
        for name, raw in members.items():
            zf.writestr(name, raw)
    shutil.copyfile(model, tmp_path / "clean.zip")
    found = machine_traces(sorted(tmp_path.iterdir()), hostname=host)
    for name, mark in [
        ("r.json", "C:\\"),
        ("a.yml", "/root/"),
        ("README.md", f"host name '{host}'"),
        ("s.pkl", "/home/"),
        ("m.zip", "/tmp/"),
    ]:
        assert any(line.startswith(f"{tmp_path / name}: ") and mark in line for line in found), (
            name,
            found,
        )
    assert not [line for line in found if "clean.zip" in line]
    assert machine_traces([tmp_path / "README.md"], hostname="build") == []  # whole words only
