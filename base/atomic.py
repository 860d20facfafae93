"""Atomic file writing: a result file is either the old one or the complete new one, never half-written.

Write to a temporary file in the same directory, flush and fsync it, then os.replace it over the target
(atomic on POSIX and Windows within one file system).
"""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _final_mode(target: Path, executable: bool) -> int:
    """The permissions the file gets: those of the file it replaces, else what the user's umask allows (a
    temporary file is created 0600, which os.replace would otherwise pass on)."""
    try:
        return os.stat(target).st_mode & 0o7777
    except OSError:
        return (0o777 if executable else 0o666) & ~_umask()


@contextmanager
def atomic_path(target: str | os.PathLike, executable: bool = False):
    """Yield a temporary path next to ``target``; on success it replaces ``target``, on error it vanishes.

    A symbolic link stays a link: the file it points to is replaced. The result keeps the permissions of the
    file it replaces, or gets the user's umask (``executable``: a shared library)."""
    target = Path(os.path.realpath(target)) if os.path.islink(target) else Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.chmod(tmp, _final_mode(target, executable))
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def write_text_atomic(target: str | os.PathLike, text: str) -> None:
    with atomic_path(target) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_bytes_atomic(target: str | os.PathLike, data: bytes, executable: bool = False) -> None:
    with atomic_path(target, executable) as tmp:
        tmp.write_bytes(data)


def writable_problem(target: str | os.PathLike) -> str | None:
    """Why `target` could not be written (checked before a long run, not after it), or None. Creates nothing
    but a probe file that is removed at once."""
    target = Path(os.path.realpath(target)) if os.path.islink(target) else Path(target)
    if target.is_dir():
        return "it is a folder"
    folder = target.parent
    while not folder.exists():
        folder = folder.parent
    if not folder.is_dir():
        return f"{folder} is a file, not a folder"
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".probe", dir=folder)
    except OSError as exc:
        return f"{folder} is not writable ({exc.strerror})"
    os.close(fd)
    os.unlink(probe)
    return None
