"""Atomic file writes: the content goes to a temporary file in the target's directory, which
then replaces the target in one ``os.replace``.  A reader (or an interrupted run) never sees a
half-written file; a failure leaves the old file as it was and no temporary file behind.

The temporary file is created with ``open(..., "x")``, so it gets the ordinary permissions
(``0o666`` less the umask) and its name (``.<name>.<pid>.<random>.tmp``) never collides with
another writer's.  Text is written as UTF-8 without newline translation.

:func:`check_output_dir` and :func:`check_output_file` check, before any work and creating
nothing that stays, that an output can be written where it is asked for: not onto an existing
file of the other kind, not under a file, and into a directory this process can write (tried
with a temporary file, so read-only mounts and ``/proc`` are caught as well as permissions).
"""

from __future__ import annotations

import os
import secrets
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

__all__ = ["check_output_dir", "check_output_file", "copy_atomic", "write_atomic"]


def _replace_with(path: str | os.PathLike[str], fill: Callable[[BinaryIO], object]) -> Path:
    """Create a temporary file next to ``path``, let ``fill`` write it, then move it onto
    ``path``; on any failure remove the temporary file and re-raise."""
    target = Path(path)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    try:
        with open(tmp, "xb") as fh:
            fill(fh)
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return target


def write_atomic(path: str | os.PathLike[str], data: str | bytes) -> Path:
    """Write ``data`` (text as UTF-8, or bytes) to ``path`` atomically; returns ``path``.
    The directory must exist."""
    if not isinstance(data, (str, bytes)):
        raise ValueError(f"data must be str or bytes, got {type(data).__name__}")
    raw = data.encode("utf-8") if isinstance(data, str) else data
    return _replace_with(path, lambda fh: fh.write(raw))


def copy_atomic(src: str | os.PathLike[str], dst: str | os.PathLike[str]) -> Path:
    """Copy the file ``src`` to ``dst`` atomically (contents only, like ``shutil.copyfile``);
    returns ``dst``.  The directory of ``dst`` must exist."""
    with open(src, "rb") as source:
        return _replace_with(dst, lambda fh: shutil.copyfileobj(source, fh))


def _check_writable(directory: Path) -> None:
    """``ValueError`` unless a file can be created in the existing ``directory`` (a temporary
    file is created and removed at once)."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".write-check-", dir=directory)
    except OSError as exc:
        raise ValueError(f"cannot create a file in {directory} ({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(probe)


def _nearest_existing(path: Path) -> Path:
    """``path`` or its nearest existing ancestor; ``ValueError`` if that is not a directory
    (``path`` would be under a file)."""
    for candidate in (path, *path.parents):
        try:
            found = candidate.exists()
        except OSError as exc:  # e.g. a directory that cannot be searched
            raise ValueError(f"cannot look at {candidate} ({exc.strerror or exc})") from None
        if found:
            if candidate != path and not candidate.is_dir():
                raise ValueError(f"{path} is under {candidate}, which is not a directory")
            return candidate
        if candidate.is_symlink():  # a dangling link: creating through it fails
            raise ValueError(f"{candidate} is a broken symbolic link")
    return Path.cwd()  # not reached for an absolute path


def check_output_dir(path: str | os.PathLike[str]) -> Path:
    """``path`` if a directory can be made or written there; ``ValueError`` saying why not
    (an existing file, under a file, or not writable).  Creates nothing."""
    target = Path(path)
    if str(path) == "":
        raise ValueError("the path is empty")
    found = _nearest_existing(target.absolute())
    if found == target.absolute() and not found.is_dir():
        raise ValueError(f"{target} exists and is not a directory")
    _check_writable(found)
    return target


def check_output_file(path: str | os.PathLike[str], *, parents: bool = False) -> Path:
    """``path`` if a file can be written there atomically (:func:`write_atomic`: a temporary
    file in its directory, then a rename); ``ValueError`` saying why not (a directory, under
    a file, not writable, or, unless ``parents`` (the writer makes the missing directories), a
    directory that does not exist).  Creates nothing."""
    target = Path(path)
    if str(path) == "" or target.name in ("", ".", ".."):
        raise ValueError(f"{str(path)!r} does not name a file")
    full = target.absolute()
    if full.is_dir():
        raise ValueError(f"{target} is a directory")
    found = _nearest_existing(full)
    if found == full:  # an existing file (or device): its directory must take the new one
        found = full.parent
    if found != full.parent and not parents:
        raise ValueError(f"directory {target.parent} does not exist")
    _check_writable(found)
    return target
