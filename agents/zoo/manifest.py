"""The checksum manifest of the shipped pretrained models: ``agents/zoo/pretrained/SHA256SUMS``
(``sha256sum`` format), written when a policy is shipped (:func:`write_manifest`) and checked
before a ``pretrained:<name>`` file is loaded (:func:`verify_pretrained`): model and statistics
files are code, and so are rl-zoo3's YAML files (it reads them with PyYAML's unsafe loader).

The manifest lists every file of every model folder (:mod:`planar3p_agents.zoo.layout`).
:func:`verify_zoo_folder` checks one folder against it: each listed file present with its
checksum, and no file in the folder that it does not list.  ``pretrained:<name>`` runs that
check before loading anything; rl-zoo3 (``python -m rl_zoo3.enjoy -f
agents/zoo/pretrained/<name>``) does not, so run ``python scripts/ship_policy.py --verify <name>``
(or ``sha256sum -c SHA256SUMS`` in the pretrained directory) first.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

from planar3p_agents.policies.spec import PRETRAINED_DIR, PolicyError
from planar3p_agents.zoo.layout import ShippedModel, check_name, shipped_model

__all__ = [
    "MANIFEST",
    "file_sha256",
    "manifest_names",
    "verify_pretrained",
    "verify_zoo_folder",
    "write_manifest",
]

#: SHA-256 sums of the shipped files, in ``sha256sum`` format (``sha256sum -c SHA256SUMS``).
MANIFEST = "SHA256SUMS"

_CODE_NOTE = "model, statistics and rl-zoo3 YAML files are code"


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


def _folder_files(folder: Path) -> list[Path]:
    """Every file under ``folder``, sorted."""
    return sorted(p for p in folder.rglob("*") if p.is_file())


def write_manifest(directory: Path | None = None) -> Path:
    """(Re)write ``SHA256SUMS`` for every file of every model folder of the pretrained
    directory (its subfolders; folders whose name starts with ``.`` are skipped), named by their
    relative POSIX paths as ``sha256sum -c`` expects (shipping calls this after copying)."""
    d = Path(directory) if directory is not None else PRETRAINED_DIR
    folders = sorted(p for p in d.iterdir() if p.is_dir() and not p.name.startswith("."))
    files = [f for folder in folders for f in _folder_files(folder)]
    out = d / MANIFEST
    lines = (f"{file_sha256(p)}  {p.relative_to(d).as_posix()}\n" for p in files)
    out.write_text("".join(lines))
    return out


def manifest_names(directory: Path | None = None) -> list[str]:
    """Names of the model folders the manifest lists or the directory holds, sorted."""
    d = Path(directory) if directory is not None else PRETRAINED_DIR
    listed = {rel.split("/", 1)[0] for rel in _read_manifest(d) if "/" in rel}
    present = {p.name for p in d.iterdir() if p.is_dir() and not p.name.startswith(".")}
    return sorted(listed | present)


def verify_zoo_folder(name: str, directory: Path | None = None) -> ShippedModel:
    """Check the folder of ``pretrained:<name>`` against ``SHA256SUMS``: every file the manifest
    lists under ``<name>/`` is there with its checksum, and the folder holds no other file.
    Returns the model's files (:class:`~planar3p_agents.zoo.layout.ShippedModel`).  Raises
    :class:`PolicyError` naming the file that is missing, altered or not listed; nothing in the
    folder is unpickled or parsed before every file has passed."""
    d = Path(directory) if directory is not None else PRETRAINED_DIR
    try:
        check_name(name)
    except ValueError as exc:
        raise PolicyError(str(exc)) from exc
    folder = d / name
    sums = _read_manifest(d)
    listed = {rel: digest for rel, digest in sums.items() if rel.startswith(f"{name}/")}
    if not listed:
        raise PolicyError(
            f"no file of {folder} is listed in {d / MANIFEST}; refusing to load unverified "
            f"files ({_CODE_NOTE})"
        )
    for path in _folder_files(folder) if folder.is_dir() else []:
        if path.relative_to(d).as_posix() not in listed:
            raise PolicyError(
                f"{path} is not listed in {d / MANIFEST}; refusing to load an unverified file "
                f"({_CODE_NOTE})"
            )
    for rel, want in sorted(listed.items()):
        path = d / rel
        if not path.is_file():
            raise PolicyError(f"shipped file {path} is missing (listed in {d / MANIFEST})")
        got = file_sha256(path)
        if got != want:
            raise PolicyError(
                f"checksum mismatch for shipped file {path}: SHA-256 {got}, expected {want} "
                f"({MANIFEST}); the file was altered or corrupted, refusing to load it "
                f"({_CODE_NOTE})"
            )
    try:
        return shipped_model(name, d)
    except ValueError as exc:
        raise PolicyError(str(exc)) from exc


def verify_pretrained(name: str, directory: Path | None = None) -> list[Path]:
    """Check the shipped files of ``pretrained:<name>`` against ``SHA256SUMS``
    (:func:`verify_zoo_folder`); return the model file, then its statistics if shipped."""
    model = verify_zoo_folder(name, directory)
    if not model.model.is_file():
        raise PolicyError(f"shipped model {name!r} has no model file {model.model}")
    return [model.model, *([model.stats] if model.stats.is_file() else [])]
