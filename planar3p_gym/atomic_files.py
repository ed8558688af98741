"""Atomic file writes: the content goes to a temporary file in the target's directory, which
then replaces the target in one ``os.replace``.  A reader (or an interrupted run) never sees a
half-written file; a failure leaves the old file as it was and no temporary file behind.

The temporary file is created with ``open(..., "x")``, so it gets the ordinary permissions
(``0o666`` less the umask) and its name (``.<name>.<pid>.<random>.tmp``) never collides with
another writer's.  Text is written as UTF-8 without newline translation.
"""

from __future__ import annotations

import os
import secrets
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

__all__ = ["copy_atomic", "write_atomic"]


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
