"""The checksum manifest of the shipped pretrained models: ``agents/zoo/pretrained/SHA256SUMS``
(``sha256sum`` format), written when a policy is shipped (:func:`write_manifest`) and checked
before a ``pretrained:<name>`` file is loaded (:func:`verify_pretrained`): model and
statistics files are code.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

from planar3p_agents.policies.spec import PRETRAINED_DIR, PolicyError

__all__ = ["MANIFEST", "MANIFEST_SUFFIXES", "file_sha256", "verify_pretrained", "write_manifest"]

#: SHA-256 sums of the shipped files, in ``sha256sum`` format (``sha256sum -c SHA256SUMS``).
MANIFEST = "SHA256SUMS"


def file_sha256(path: Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _read_manifest(directory: Path) -> dict[str, str]:
    path = directory / MANIFEST
    try:
        lines = path.read_text().splitlines()
    except OSError as exc:
        raise PolicyError(f"cannot read the checksum manifest {path}: {exc}") from exc
    sums = {}
    for line in lines:
        if not line.strip():
            continue
        m = re.fullmatch(r"([0-9a-fA-F]{64}) [ *](.+)", line.rstrip("\r\n"))
        if m is None:
            raise PolicyError(f"malformed line in {path} (want sha256sum format): {line!r}")
        sums[m.group(2)] = m.group(1).lower()
    return sums


#: Shipped files the manifest covers (all are read by a loader; ``.yml`` by rl-zoo3's YAML).
MANIFEST_SUFFIXES = (".zip", ".pkl", ".json", ".yml", ".yaml")


def write_manifest(directory: Path | None = None) -> Path:
    """(Re)write ``SHA256SUMS`` for every model, statistics, record and config file under the
    pretrained directory, subfolders included (rl-zoo3 layout), named by their relative POSIX
    paths as ``sha256sum -c`` expects (``scripts/ship_policy.py`` calls this after copying)."""
    d = directory or PRETRAINED_DIR
    files = sorted(p for p in d.rglob("*") if p.is_file() and p.suffix in MANIFEST_SUFFIXES)
    out = d / MANIFEST
    lines = (f"{file_sha256(p)}  {p.relative_to(d).as_posix()}\n" for p in files)
    out.write_text("".join(lines))
    return out


def verify_pretrained(name: str, directory: Path | None = None) -> list[Path]:
    """Check the shipped files of ``pretrained:<name>`` against ``SHA256SUMS``; return the
    verified files (model first, then its statistics if shipped).  Raises :class:`PolicyError`
    naming the file if one is missing from the manifest or its bytes differ."""
    d = directory or PRETRAINED_DIR
    sums = _read_manifest(d)
    files = [d / f"{name}.zip"]
    stats = d / f"{name}_vecnormalize.pkl"
    if stats.is_file() or stats.name in sums:
        files.append(stats)
    for path in files:
        want = sums.get(path.name)
        if want is None:
            raise PolicyError(
                f"{path} is not listed in {d / MANIFEST}; refusing to load an unverified file "
                "(model and statistics files are code)"
            )
        if not path.is_file():
            raise PolicyError(f"shipped file {path} is missing")
        got = file_sha256(path)
        if got != want:
            raise PolicyError(
                f"checksum mismatch for shipped file {path}: SHA-256 {got}, expected {want} "
                f"({MANIFEST}); the file was altered or corrupted, refusing to load it "
                "(model and statistics files are code)"
            )
    return files
