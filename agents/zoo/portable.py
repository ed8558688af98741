"""Shipped files carry no trace of the machine they were made on: no absolute path, no host name.

:func:`machine_traces` scans files for them (text, the strings of JSON and YAML files, the
``data`` JSON of a Stable-Baselines3 zip with its serialised entries, the strings of every pickle,
the pickles inside PyTorch's ``.pth`` archives) without unpickling anything.
:func:`portable_text` and :func:`portable_model` rewrite a run's absolute paths as ``runs/<run>``
when a run is shipped (:func:`planar3p_agents.zoo.shipping.ship`).
"""

from __future__ import annotations

import base64
import io
import json
import pickletools
import re
import socket
import zipfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from planar3p_agents.policies.sb3_models import load_yaml_data

__all__ = [
    "ABSOLUTE_PATH_MARKS",
    "file_strings",
    "machine_traces",
    "portable_model",
    "portable_record",
    "portable_text",
    "text_traces",
]

#: Substrings that betray an absolute path of a machine (POSIX homes and work places, Windows).
ABSOLUTE_PATH_MARKS = ("/work/", "/home/", "/root/", "/tmp/", "C:\\", "c:\\", "/Users/")

_GENERIC_HOSTS = {"", "localhost", "localhost.localdomain"}


class _Binary(str):
    """Bytes of a pickle read as text: searched for paths, not for the host name (a short name
    occurs by chance in numbers)."""


def _host_pattern(hostname: str | None) -> re.Pattern[str] | None:
    host = socket.gethostname() if hostname is None else hostname
    if host.lower() in _GENERIC_HOSTS:
        return None
    names = {host, host.split(".")[0]}
    alternatives = "|".join(re.escape(n) for n in sorted(names, key=len, reverse=True) if n)
    return re.compile(rf"(?<![A-Za-z0-9_\-])(?:{alternatives})(?![A-Za-z0-9_\-])")


def text_traces(text: str, hostname: str | None = None) -> list[str]:
    """The machine traces in ``text``: absolute-path marks and the host name (``hostname``,
    default this machine's, matched as a whole word)."""
    found = [mark for mark in ABSOLUTE_PATH_MARKS if mark in text]
    pattern = None if isinstance(text, _Binary) else _host_pattern(hostname)
    match = pattern.search(text) if pattern is not None else None
    if match is not None:
        found.append(f"host name {match.group(0)!r}")
    return found


def _strings(value: Any) -> Iterator[str]:
    """Every string (keys included) of parsed JSON/YAML, but SB3's serialised entries (base64,
    decoded by :func:`_sb3_data_strings`)."""
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for k, v in value.items():
            yield from _strings(k)
            if k != ":serialized:":
                yield from _strings(v)
    elif isinstance(value, (list, tuple)):
        for v in value:
            yield from _strings(v)


def _pickle_strings(data: bytes) -> Iterator[str]:
    """The string arguments of a pickle's opcodes (read with :mod:`pickletools`, never run)."""
    try:
        for _, arg, _ in pickletools.genops(io.BytesIO(data)):
            if isinstance(arg, str):
                yield arg
            elif isinstance(arg, (bytes, bytearray)):
                yield _Binary(bytes(arg).decode("latin-1"))
    except Exception as exc:  # a malformed pickle: report it rather than pass it unread
        yield f"<unreadable pickle: {exc}>"


def _yaml_strings(text: str) -> Iterator[str]:
    import yaml

    try:
        yield from _strings(load_yaml_data(text))  # python tags become plain data, never objects
    except yaml.YAMLError as exc:
        yield f"<unreadable YAML: {exc}>"


def _sb3_data_strings(raw: bytes) -> Iterator[str]:
    """Strings of a Stable-Baselines3 ``data`` member, serialised entries decoded."""
    try:
        data = json.loads(raw)
    except ValueError:
        yield raw.decode("utf-8", "replace")
        return
    yield from _strings(data)
    for value in data.values() if isinstance(data, dict) else ():
        if isinstance(value, dict) and isinstance(value.get(":serialized:"), str):
            try:
                blob = base64.b64decode(value[":serialized:"])
            except ValueError:
                continue
            yield from _pickle_strings(blob)


def _member_strings(name: str, raw: bytes) -> Iterator[str]:
    """Strings of one member of a zip archive (members of nested archives too)."""
    base = name.rsplit("/", 1)[-1]
    if base == "data" and raw[:1] == b"{":
        yield from _sb3_data_strings(raw)
    elif base.endswith(".pkl"):
        yield from _pickle_strings(raw)
    elif raw[:4] == b"PK\x03\x04":
        yield from _zip_strings(raw)
    elif base.endswith((".txt", ".json", ".yml", ".yaml")) or base in ("version", "byteorder"):
        yield raw.decode("utf-8", "replace")
    elif "_version" in base:
        yield raw.decode("utf-8", "replace")
    # other members (tensor storages) are numbers, not text


def _zip_strings(raw: bytes) -> Iterator[str]:
    try:
        with zipfile.ZipFile(io.BytesIO(raw)) as zf:
            for info in zf.infolist():
                yield info.filename
                yield from _member_strings(info.filename, zf.read(info))
    except zipfile.BadZipFile as exc:
        yield f"<unreadable zip: {exc}>"


def file_strings(path: Path) -> Iterator[str]:
    """The text a shipped file carries, by its kind (see the module docstring)."""
    raw = path.read_bytes()
    if path.suffix == ".zip":
        yield from _zip_strings(raw)
    elif path.suffix in (".pkl", ".pickle"):
        yield from _pickle_strings(raw)
    else:
        text = raw.decode("utf-8", "replace")
        yield text
        if path.suffix == ".json":
            try:
                yield from _strings(json.loads(text))
            except ValueError:
                pass
        elif path.suffix in (".yml", ".yaml"):
            yield from _yaml_strings(text)


def machine_traces(paths: Iterable[Path], hostname: str | None = None) -> list[str]:
    """``"<file>: <trace>"`` for every machine trace (:func:`text_traces`) in the files
    ``paths`` (see :func:`file_strings`); empty if there is none."""
    out = []
    for path in paths:
        seen: set[str] = set()
        for text in file_strings(path):
            for trace in text_traces(text, hostname):
                if trace not in seen:
                    seen.add(trace)
                    snippet = text if len(text) <= 120 else text[:117] + "..."
                    out.append(f"{path}: {trace!r} in {snippet!r}")
    return out


def portable_text(text: str, run: Path, repo: Path | None = None) -> str:
    """``text`` with the run directory ``run`` (absolute or as given) written ``runs/<run>``,
    paths inside the repository ``repo`` relative to it, and any other ``.../runs/<x>`` as
    ``runs/<x>``."""
    run = Path(run)
    for prefix in sorted({str(run.resolve()), str(run.absolute())}, key=len, reverse=True):
        text = text.replace(prefix, f"runs/{run.name}")
    if repo is not None:
        text = text.replace(f"{Path(repo).resolve()}/", "")
    return re.sub(r"(?<![\w.\-])(?:/[\w.\-]+)+/(runs/)", r"\1", text)


def _portable_value(value: Any, run: Path, repo: Path | None) -> Any:
    if isinstance(value, str):
        return portable_text(value, run, repo)
    if isinstance(value, dict):
        return {k: _portable_value(v, run, repo) for k, v in value.items()}
    if isinstance(value, list):
        return [_portable_value(v, run, repo) for v in value]
    return value


def portable_record(record: Any, run: Path, repo: Path | None = None) -> Any:
    """A JSON record with :func:`portable_text` applied to every string value."""
    return _portable_value(record, run, repo)


def portable_model(src: Path, dst: Path, run: Path, repo: Path | None = None) -> bool:
    """Write the SB3 model ``src`` to ``dst`` with the plain string entries of its ``data``
    (``tensorboard_log``) made portable (:func:`portable_text`); every other member is copied
    byte for byte and nothing is unpickled.  Returns whether anything changed (if not, ``dst``
    is a byte copy)."""
    with zipfile.ZipFile(src) as zf:
        infos = zf.infolist()
        members = {info.filename: zf.read(info) for info in infos}
    data = json.loads(members["data"]) if "data" in members else {}
    changed = False
    for key, value in data.items():
        if isinstance(value, str):
            new = portable_text(value, run, repo)
            if new != value:
                data[key], changed = new, True
    dst.parent.mkdir(parents=True, exist_ok=True)
    if not changed:
        dst.write_bytes(src.read_bytes())
        return False
    # SB3 writes ``data`` with json.dumps(..., indent=4); keep its form
    members["data"] = json.dumps(data, indent=4).encode()
    with zipfile.ZipFile(dst, "w") as out:
        for info in infos:
            out.writestr(info, members[info.filename])
    return True
