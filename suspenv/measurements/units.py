"""Unit conversion at the edges: recordings are stored in SI.

Only linear conversions are needed for the supported sources. ``to_si(values, unit)``
returns the SI values and the SI unit string; unknown units raise.

Rules:

* a :class:`~suspenv.measurements.Recording` holds only the SI units of
  :data:`SI_UNITS` (checked on construction); anything else is converted by the reader
  with :func:`to_si` or refused;
* :func:`to_si` knows the units of :data:`FACTORS` (exact definitions: 1 in = 0.0254 m,
  1 ft = 0.3048 m, 1 lbf = 4.4482216152605 N, NIST SP 811; 1 kgf = 9.80665 N); a unit it
  does not know raises :class:`~suspenv.measurements.RecordingError` naming the unit, never
  passes as SI.
"""

from __future__ import annotations

import re

import numpy as np

from suspenv.measurements.errors import RecordingError

#: the SI units a recording may hold: unit -> quantity (words for messages)
SI_UNITS: dict[str, str] = {
    "s": "time",
    "m": "length",
    "m/s": "velocity",
    "m/s^2": "acceleration",
    "N": "force",
    "N*m": "moment",
    "rad": "angle",
    "rad/s": "angular velocity",
    "V": "voltage",
    "A": "electric current",
    "1": "dimensionless",
    "-": "dimensionless",
}

_LBF = 4.4482216152605  # pound-force [N], exact (NIST SP 811)
_KGF = 9.80665  # kilogram-force [N] = standard gravity, exact (CGPM 1901)

#: unit -> (factor to SI, SI unit)
FACTORS: dict[str, tuple[float, str]] = {
    "m": (1.0, "m"),
    "cm": (1e-2, "m"),
    "mm": (1e-3, "m"),
    "in": (0.0254, "m"),
    "m/s": (1.0, "m/s"),
    "mm/s": (1e-3, "m/s"),
    "in/s": (0.0254, "m/s"),
    "km/h": (1.0 / 3.6, "m/s"),
    "m/s^2": (1.0, "m/s^2"),
    "N": (1.0, "N"),
    "kN": (1e3, "N"),
    "lbf": (_LBF, "N"),
    "kgf": (_KGF, "N"),
    "N*m": (1.0, "N*m"),
    "N m": (1.0, "N*m"),
    "Nm": (1.0, "N*m"),
    "N.m": (1.0, "N*m"),
    "kN*m": (1e3, "N*m"),
    "kNm": (1e3, "N*m"),
    "N*mm": (1e-3, "N*m"),
    "Nmm": (1e-3, "N*m"),
    "lbf*ft": (_LBF * 0.3048, "N*m"),
    "ft*lbf": (_LBF * 0.3048, "N*m"),
    "lbf*in": (_LBF * 0.0254, "N*m"),
    "in*lbf": (_LBF * 0.0254, "N*m"),
    "kgf*m": (_KGF, "N*m"),
    "s": (1.0, "s"),
    "sec": (1.0, "s"),
    "ms": (1e-3, "s"),
    "V": (1.0, "V"),
    "mV": (1e-3, "V"),
    "A": (1.0, "A"),
    "mA": (1e-3, "A"),
    "rad": (1.0, "rad"),
    "mrad": (1e-3, "rad"),
    "deg": (np.pi / 180.0, "rad"),
    "rad/s": (1.0, "rad/s"),
    "deg/s": (np.pi / 180.0, "rad/s"),
    "1": (1.0, "1"),
    "-": (1.0, "-"),
}


_PRODUCT = re.compile(r"\s*[*.·]\s*")
_FOLDED = {u.lower(): u for u in FACTORS}  # no two units differ only in case


def unit_key(unit: object) -> str | None:
    """The :data:`FACTORS` key that ``unit`` names, or None: exact after stripping, else
    with each product sign (``*``, ``.``, ``·`` and the spaces around it) read as ``*``,
    else case-folded (``"KN·M"`` -> ``"kN*m"``)."""
    if not isinstance(unit, str):
        return None
    key = unit.strip()
    if key not in FACTORS:
        key = _PRODUCT.sub("*", key)
    return key if key in FACTORS else _FOLDED.get(key.lower())


def si_unit_of(unit: object) -> str | None:
    """The SI unit ``unit`` converts to (``"lbf"`` -> ``"N"``), or None when unknown."""
    key = unit_key(unit)
    return None if key is None else FACTORS[key][1]


def to_si(values: np.ndarray, unit: object, owner: str = "") -> tuple[np.ndarray, str]:
    """Convert ``values`` from ``unit`` to SI; returns ``(values_si, si_unit)``. An
    unknown unit raises, the message naming its ``owner`` (``"f.npz: channel 'x'"``)."""
    key = unit_key(unit)
    if key is None:
        what = f"{owner} has the unknown unit" if owner else "unknown unit"
        raise RecordingError(f"{what} {unit!r}; known units are {sorted(FACTORS)}")
    factor, si = FACTORS[key]
    with np.errstate(over="ignore"):  # an overflow gives inf, which Recording refuses
        return np.asarray(values, dtype=float) * factor, si
