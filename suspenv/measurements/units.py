"""Unit conversion at the edges: recordings are stored in SI.

Only linear conversions are needed for the supported sources. ``to_si(values, unit)``
returns the SI values and the SI unit string; unknown units raise.
"""

from __future__ import annotations

import numpy as np

from suspenv.measurements.errors import RecordingError

#: unit -> (factor to SI, SI unit)
FACTORS: dict[str, tuple[float, str]] = {
    "m": (1.0, "m"),
    "mm": (1e-3, "m"),
    "in": (0.0254, "m"),
    "m/s": (1.0, "m/s"),
    "mm/s": (1e-3, "m/s"),
    "in/s": (0.0254, "m/s"),
    "m/s^2": (1.0, "m/s^2"),
    "N": (1.0, "N"),
    "kN": (1e3, "N"),
    "lbf": (4.4482216152605, "N"),
    "s": (1.0, "s"),
    "sec": (1.0, "s"),
    "ms": (1e-3, "s"),
    "V": (1.0, "V"),
    "rad": (1.0, "rad"),
    "deg": (np.pi / 180.0, "rad"),
    "1": (1.0, "1"),
}


def to_si(values: np.ndarray, unit: str) -> tuple[np.ndarray, str]:
    """Convert ``values`` from ``unit`` to SI; returns ``(values_si, si_unit)``."""
    key = unit.strip()
    if key not in FACTORS and key.lower() in FACTORS:
        key = key.lower()
    if key not in FACTORS:
        raise RecordingError(f"unknown unit {unit!r}; known units are {sorted(FACTORS)}")
    factor, si = FACTORS[key]
    return np.asarray(values, dtype=float) * factor, si
