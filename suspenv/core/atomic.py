"""Atomic file writes: a file holds its old or its new content whole, never a part,
whatever kills the process; a failed write is a named error saying nothing was
half-written."""

from __future__ import annotations

import contextlib
import errno
import os
from collections.abc import Iterator
from pathlib import Path

from suspenv.core.errors import InfrastructureError

#: what an operating system error of a write means for the user
_WRITE_FAULTS = {
    errno.ENOSPC: "no space left on the device",
    errno.EDQUOT: "disk quota exceeded",
    errno.EROFS: "the file system is read-only",
    errno.EACCES: "permission denied",
    errno.EPERM: "permission denied",
}


def write_fault(path: Path | str, exc: OSError | str) -> InfrastructureError:
    """The named error of a failed write of ``path``: what happened, that nothing was
    half-written, and what to do."""
    if isinstance(exc, OSError):
        why = _WRITE_FAULTS.get(exc.errno or 0, exc.strerror or str(exc))
        why = f"{why} ({errno.errorcode.get(exc.errno or 0, 'OSError')})"
    else:
        why = exc
    return InfrastructureError(
        f"cannot write {str(path)!r}: {why}; nothing was half-written (the file keeps "
        "its previous content, if any). Free space or make the folder writable, then run "
        "the same command again to resume"
    )


@contextlib.contextmanager
def atomic_path(path: Path | str) -> Iterator[Path]:
    """A temporary name beside ``path`` for the block to write; then flushed to disk
    (``fsync``) and renamed over ``path``, so that ``path`` holds the old or the new
    content whole, never a part, whatever kills the process. The temporary name keeps
    the suffix (writers that choose a format by it, as matplotlib, work). A failed write
    is :func:`write_fault`'s named error, and the temporary file is removed."""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.tmp-{os.getpid()}{path.suffix}")
    try:
        yield tmp
        _fsync(tmp)
        os.replace(tmp, path)
        with contextlib.suppress(OSError):  # folders cannot be opened where not POSIX
            _fsync(path.parent)  # the rename
    except OSError as exc:
        raise write_fault(path, exc) from None
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)


def _fsync(path: Path) -> None:
    """Flush a file's content, or a folder's entries, to disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_file(path: Path | str, data: str | bytes) -> Path:
    """Write ``data`` (text as UTF-8) to ``path`` atomically (:func:`atomic_path`)."""
    view = memoryview(data.encode() if isinstance(data, str) else data)
    with atomic_path(path) as tmp:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        try:
            while view:
                view = view[os.write(fd, view) :]
        finally:
            os.close(fd)
    return Path(path)
