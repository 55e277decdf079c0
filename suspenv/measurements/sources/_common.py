"""Helpers shared by the converters: files, bounded MATLAB reads, checked variables."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.measurements.errors import RecordingError
from suspenv.measurements.limits import check_mat, read_limit


@contextmanager
def named_errors(path: Path) -> Iterator[None]:
    """A :class:`RecordingError` raised in the block, prefixed with the file's name."""
    try:
        yield
    except RecordingError as exc:
        raise RecordingError(f"{path.name}: {exc}") from None


def require_file(path: str | Path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"recording file {str(path)!r} does not exist")
    return path


def load_mat(path: Path, names: Iterable[str], max_bytes: int | None = None) -> dict[str, Any]:
    """The variables ``names`` (those present) of a MATLAB file, after the memory bound
    of :func:`suspenv.measurements.limits.check_mat`; an unreadable file raises
    :class:`RecordingError` naming it."""
    import scipy.io

    check_mat(path, read_limit(max_bytes))
    try:
        present = {name for name, _, _ in scipy.io.whosmat(path)}
        wanted = [n for n in names if n in present]
        data: dict[str, Any] = scipy.io.loadmat(path, variable_names=wanted) if wanted else {}
    except Exception as exc:  # noqa: BLE001 - any reader failure means "not a .mat file"
        raise RecordingError(f"{path.name}: not a readable MATLAB file ({exc})") from None
    data["__present__"] = sorted(present)
    return data


def mat_field(data: dict, key: str, path: Path) -> np.ndarray:
    """A variable of a file read by :func:`load_mat` as a float array; missing or not
    numeric -> clear error."""
    if key not in data:
        names = data["__present__"]
        raise RecordingError(f"{path.name}: missing variable {key!r}; the file holds {names}")
    arr = np.asarray(data[key])
    if arr.dtype.kind not in "biuf":
        raise RecordingError(
            f"{path.name}: variable {key!r} must be a numeric array, but is of type {arr.dtype}"
        )
    return np.asarray(arr, dtype=float)


def mat_scalar(data: dict, key: str, path: Path) -> float:
    """A scalar variable of a loaded .mat file (its first element); empty -> clear error."""
    arr = mat_field(data, key, path).ravel()
    if arr.size == 0:
        raise RecordingError(f"{path.name}: variable {key!r} must hold a number, but is empty")
    return float(arr[0])


def dissipative_sign(force: np.ndarray, velocity: np.ndarray) -> float:
    """+1 or -1 so that ``sign * force`` absorbs power on average (``mean(F v) > 0``)."""
    return 1.0 if float(np.mean(force * velocity)) >= 0.0 else -1.0
