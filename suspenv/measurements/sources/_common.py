"""Helpers shared by the converters."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from suspenv.measurements.errors import RecordingError


def require_file(path: str | Path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"recording file {str(path)!r} does not exist")
    return path


def mat_field(data: dict, key: str, path: Path) -> np.ndarray:
    """A variable of a loaded .mat file as a float array; missing -> clear error."""
    if key not in data:
        names = sorted(k for k in data if not k.startswith("__"))
        raise RecordingError(f"{path.name}: missing variable {key!r}; the file holds {names}")
    return np.asarray(data[key], dtype=float)


def dissipative_sign(force: np.ndarray, velocity: np.ndarray) -> float:
    """+1 or -1 so that ``sign * force`` absorbs power on average (``mean(F v) > 0``)."""
    return 1.0 if float(np.mean(force * velocity)) >= 0.0 else -1.0
