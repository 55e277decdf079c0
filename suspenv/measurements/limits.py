"""Memory bounds of the file readers: a file is refused before it is expanded past a limit.

The limit, in bytes of memory the data may take once read, is in order: the reader's
``max_bytes`` argument; else the environment variable ``SUSPENV_MAX_READ_BYTES``; else
:data:`DEFAULT_MAX_READ_BYTES` (512 MiB: 64 million float64 samples, thousands of
times the largest shared recording (the damper dyno file, about 80 000 samples x 3
columns) and small enough that a hostile file cannot exhaust a workstation's memory).

Rules, each checked before anything is allocated:

* every file: its size on disk must not exceed the limit;
* ``.npz`` (a zip archive, :func:`check_npz`): the members' declared uncompressed sizes
  together must not exceed the limit (the zip reader never inflates a member past its
  declared size); each array member's ``.npy`` header (shape, dtype) must describe at
  most the bytes the member holds, and no object (pickled) arrays;
* ``.mat`` (MATLAB v5, :func:`check_mat`): the compressed variables are decompressed
  in a streaming pass (64 KiB at a time) and counted; the total must not exceed the limit;
* text (``.csv``, ``.dat``, ``.txt``, :func:`check_text`): a text file of ``B`` bytes
  holds at most ``B / 2`` numbers (one digit and a separator each), ``8 B / 2 = 4 B``
  bytes as float64, so a text file may be at most a quarter of the limit.

Messages name the file, the size found, the limit and how to raise it.
"""

from __future__ import annotations

import math
import os
import struct
import zipfile
import zlib
from pathlib import Path
from typing import IO

import numpy as np

from suspenv.measurements.errors import RecordingError

#: environment variable overriding the read limit [bytes]
MAX_READ_ENV = "SUSPENV_MAX_READ_BYTES"
#: default read limit [bytes] (512 MiB; see the module docstring)
DEFAULT_MAX_READ_BYTES = 512 * 2**20
#: bytes of float64 memory per byte of a text file (at most one number per 2 characters)
TEXT_EXPANSION = 4
_CHUNK = 2**16


def _mib(n: int) -> str:
    return f"{n / 2**20:.3g} MiB"


def read_limit(max_bytes: int | None = None) -> int:
    """The read limit [bytes]: ``max_bytes``, else ``$SUSPENV_MAX_READ_BYTES``, else
    :data:`DEFAULT_MAX_READ_BYTES`; a limit that is not a positive integer is refused."""
    if max_bytes is None:
        text = os.environ.get(MAX_READ_ENV, "").strip()
        if not text:
            return DEFAULT_MAX_READ_BYTES
        try:
            max_bytes = int(text)
        except ValueError:
            raise RecordingError(
                f"{MAX_READ_ENV} must be a positive whole number of bytes, but got {text!r}"
            ) from None
    if isinstance(max_bytes, bool) or not isinstance(max_bytes, int) or max_bytes <= 0:
        raise RecordingError(
            f"the read limit must be a positive whole number of bytes, but got {max_bytes!r}"
        )
    return max_bytes


def _too_big(path: Path, what: str, size: int, limit: int) -> RecordingError:
    """``path``'s ``what`` ``size`` [bytes] is past the read ``limit``: the error, how to
    raise the limit."""
    return RecordingError(
        f"{path.name}: {what} {size} bytes ({_mib(size)}), more than the read limit of "
        f"{limit} bytes ({_mib(limit)}); raise it with max_bytes= or the environment "
        f"variable {MAX_READ_ENV} if the file is trusted"
    )


def check_file_size(path: Path, limit: int) -> int:
    """The size of ``path`` on disk [bytes]; refused above ``limit``."""
    size = path.stat().st_size
    if size > limit:
        raise _too_big(path, "the file holds", size, limit)
    return size


def check_text(path: Path, limit: int) -> None:
    """Refuse a text file whose numbers could take more than ``limit`` bytes as float64
    (:data:`TEXT_EXPANSION` bytes of memory per byte of text)."""
    size = path.stat().st_size
    if size * TEXT_EXPANSION > limit:
        what = (
            f"a text file of {size} bytes ({_mib(size)}) may expand to float64 values of "
            f"{TEXT_EXPANSION} bytes per character,"
        )
        raise _too_big(path, what, TEXT_EXPANSION * size, limit)


def _npy_header(fp: IO[bytes], name: str, path: Path) -> tuple[tuple[int, ...], np.dtype]:
    """(shape, dtype) from a ``.npy`` member's header, read without reading the data."""
    fmt = np.lib.format
    try:
        version = fmt.read_magic(fp)
        if version == (1, 0):
            shape, _, dtype = fmt.read_array_header_1_0(fp)
        elif version == (2, 0):
            shape, _, dtype = fmt.read_array_header_2_0(fp)
        else:
            raise ValueError(f"unsupported .npy format version {version}")
    except Exception as exc:  # noqa: BLE001 - any header failure means "not a valid array"
        raise RecordingError(
            f"{path.name}: member {name!r} is not a valid .npy array ({exc})"
        ) from None
    return tuple(int(n) for n in shape), np.dtype(dtype)


def check_npz(path: Path, limit: int) -> None:
    """Refuse a ``.npz`` archive that would expand past ``limit`` bytes, holds an object
    array, or has an array header claiming more data than its member holds."""
    check_file_size(path, limit)
    try:
        zf = zipfile.ZipFile(path)
    except Exception as exc:  # noqa: BLE001 - any failure means "not a zip archive"
        raise RecordingError(f"{path.name}: not a readable .npz archive ({exc})") from None
    with zf:
        infos = zf.infolist()
        total = sum(int(i.file_size) for i in infos)
        if total > limit:
            raise _too_big(path, f"the archive's {len(infos)} member(s) expand to", total, limit)
        for info in infos:
            # every member numpy would read as an array (it starts with the .npy magic,
            # whatever its name), not only those named *.npy
            try:
                with zf.open(info) as fp:
                    if fp.read(len(np.lib.format.MAGIC_PREFIX)) != np.lib.format.MAGIC_PREFIX:
                        continue  # raw bytes: numpy returns them as bytes, at most file_size
                with zf.open(info) as fp:
                    shape, dtype = _npy_header(fp, info.filename, path)
            except RecordingError:
                raise
            except Exception as exc:  # noqa: BLE001 - corrupt member, encrypted, bad CRC...
                raise RecordingError(
                    f"{path.name}: member {info.filename!r} cannot be read ({exc})"
                ) from None
            if dtype.hasobject:
                raise RecordingError(
                    f"{path.name}: member {info.filename!r} is an object array (dtype "
                    f"{dtype}); recordings hold numbers and text only, and pickled objects "
                    "are never loaded"
                )
            nbytes = math.prod(shape) * dtype.itemsize
            if nbytes > info.file_size:
                raise RecordingError(
                    f"{path.name}: member {info.filename!r} declares an array of shape "
                    f"{shape} ({dtype}, {nbytes} bytes) but holds only {info.file_size} "
                    "bytes; the archive is corrupt"
                )


def check_mat(path: Path, limit: int) -> None:
    """Refuse a MATLAB file whose data would expand past ``limit`` bytes.

    A v5 file's compressed variables (``miCOMPRESSED``) are decompressed in a streaming
    pass and their sizes added to the uncompressed ones; a v4 file is uncompressed (its
    size on disk bounds it). A malformed file is left for the reader to refuse.
    """
    check_file_size(path, limit)
    with open(path, "rb") as fh:
        head = fh.read(128)
        if len(head) < 128 or head[126:128] not in (b"IM", b"MI"):
            return  # not MATLAB v5 (v4 is never compressed; anything else: the reader says)
        endian = "<" if head[126:128] == b"IM" else ">"
        total = 0
        while True:
            tag = fh.read(8)
            if len(tag) < 8:
                break
            mdtype, nbytes = struct.unpack(endian + "II", tag)
            if mdtype >> 16:  # small data element: its data sit in the tag
                continue
            if mdtype != 15:  # miCOMPRESSED
                total += nbytes
                fh.seek(nbytes, os.SEEK_CUR)
                continue
            total += _inflated_size(fh, nbytes, limit - total, path)
            if total > limit:
                break
    if total > limit:
        raise _too_big(path, "the MATLAB file's variables expand to at least", total, limit)


def _inflated_size(fh: IO[bytes], nbytes: int, room: int, path: Path) -> int:
    """Bytes one zlib stream of ``nbytes`` compressed bytes inflates to (stops counting
    once past ``room``)."""
    d = zlib.decompressobj()
    left, out = nbytes, 0
    try:
        while left > 0 and out <= room:
            chunk = fh.read(min(left, _CHUNK))
            if not chunk:
                break
            left -= len(chunk)
            data = chunk
            while data and out <= room:
                out += len(d.decompress(data, _CHUNK))
                data = d.unconsumed_tail
            if d.eof:
                break
    except zlib.error:
        pass  # a corrupt stream: the reader refuses it
    if left > 0:
        fh.seek(left, os.SEEK_CUR)
    return out
