"""planar3p_gym.atomic_files: writes, replaces, and a failure leaves the old file and no
temporary file behind."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from planar3p_gym import atomic_files
from planar3p_gym.atomic_files import copy_atomic, write_atomic


def _names(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir())


def test_write_text_and_bytes(tmp_path: Path) -> None:
    text = tmp_path / "a.md"
    assert write_atomic(text, "x,y\r\nü\n") == text
    # UTF-8, no newline translation
    assert text.read_bytes() == "x,y\r\nü\n".encode()
    blob = tmp_path / "b.png"
    write_atomic(str(blob), b"\x89PNG\x00\xff")
    assert blob.read_bytes() == b"\x89PNG\x00\xff"
    assert _names(tmp_path) == ["a.md", "b.png"]


def test_replaces_and_uses_ordinary_permissions(tmp_path: Path) -> None:
    target = tmp_path / "t.txt"
    target.write_text("old old old")
    write_atomic(target, "new")
    assert target.read_text() == "new"
    umask = os.umask(0)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask
    assert _names(tmp_path) == ["t.txt"]


def test_copy(tmp_path: Path) -> None:
    src = tmp_path / "src.bin"
    src.write_bytes(bytes(range(256)) * 100)
    dst = tmp_path / "dst.bin"
    dst.write_bytes(b"old")
    assert copy_atomic(src, dst) == dst
    assert dst.read_bytes() == src.read_bytes()
    assert _names(tmp_path) == ["dst.bin", "src.bin"]


def test_failure_mid_write_keeps_old_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    src = tmp_path / "src.bin"
    src.write_bytes(b"0123456789")
    dst = tmp_path / "dst.bin"
    dst.write_bytes(b"old")

    def half_then_fail(source, fh) -> None:  # a full disk halfway through
        fh.write(source.read(5))
        fh.flush()
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(atomic_files.shutil, "copyfileobj", half_then_fail)
    with pytest.raises(OSError, match="No space"):
        copy_atomic(src, dst)
    assert dst.read_bytes() == b"old"
    assert _names(tmp_path) == ["dst.bin", "src.bin"]


def test_failure_at_replace_keeps_old_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "t.txt"
    target.write_text("old")

    def refuse(src, dst) -> None:
        raise PermissionError("replace refused")

    monkeypatch.setattr(atomic_files.os, "replace", refuse)
    with pytest.raises(PermissionError):
        write_atomic(target, "new")
    assert target.read_text() == "old"
    assert _names(tmp_path) == ["t.txt"]


def test_bad_input(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="str or bytes"):
        write_atomic(tmp_path / "x", 3)  # type: ignore[arg-type]
    with pytest.raises(FileNotFoundError):
        write_atomic(tmp_path / "missing" / "x", "text")
    assert _names(tmp_path) == []
