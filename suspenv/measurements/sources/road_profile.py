"""Measured road profiles: a two-column text file (distance [m], elevation) as a
:class:`~suspenv.measurements.Recording` on a uniform grid.

Frame and units: distance ``x`` along the road [m] (+ in the direction of travel),
elevation ``z`` [m] (+ up). A profile is not a time history: the recording's ``time``
is distance over a nominal 1 m/s (``meta["axis"]`` says so).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.measurements.recording import Recording


def profile_recording(
    distance: np.ndarray,
    elevation: np.ndarray,
    name: str = "road_profile",
    dx: float = 0.25,
    unit: str = "m",
    source: str = "",
) -> Recording:
    """A measured profile as a :class:`Recording` on a uniform ``dx`` grid (m).

    The recording's ``time`` is distance divided by a nominal 1 m/s (a profile is
    not a time history; ``meta["axis"]`` says so). Input channel ``distance`` [m],
    output channel ``elevation`` [m]. Irregular samples are linearly interpolated.
    """
    x = np.asarray(distance, float)
    z = np.asarray(elevation, float)
    if x.ndim != 1 or x.shape != z.shape or x.size < 16:
        raise ValidationError(
            f"distance and elevation must be 1-D of equal length >= 16, but got "
            f"({x.shape}, {z.shape})"
        )
    if not np.all(np.diff(x) > 0):
        i = int(np.argmax(np.diff(x) <= 0))
        raise ValidationError(
            f"distance must be strictly increasing, but got x[{i}]={x[i]} and x[{i + 1}]={x[i + 1]}"
        )
    if not dx > 0:
        raise ValidationError(f"`dx > 0` must hold, but got dx={dx}")
    factor = {"m": 1.0, "mm": 1e-3}.get(unit)
    if factor is None:
        raise ValidationError(f"elevation unit must be 'm' or 'mm', but got {unit!r}")
    grid = x[0] + dx * np.arange(int(np.floor((x[-1] - x[0]) / dx + 1e-9)) + 1)
    zg = np.interp(grid, x, z * factor)
    spacing = np.diff(x)
    return Recording(
        name=name,
        test="road_profile",
        time=grid - grid[0],
        inputs={"distance": grid},
        outputs={"elevation": zg},
        units={"distance": "m", "elevation": "m"},
        meta={
            "axis": "time = distance / (1 m/s); a spatial profile",
            "dx": dx,
            "source": source,
            "resampled": bool(np.ptp(spacing) > 1e-6 * dx or abs(spacing[0] - dx) > 1e-6 * dx),
            "raw_spacing_range_m": [float(spacing.min()), float(spacing.max())],
        },
    )


def load_profile_txt(path: str | Path, dx: float = 0.25, unit: str = "m") -> Recording:
    """Read a two-column text profile (distance [m], elevation) into a Recording.

    The shared ``profile_*.txt`` files hold elevations of about 582-583 (an altitude
    in metres; read as millimetres they would be ~1e-6 times class A), so ``unit``
    defaults to ``"m"``.
    """
    path = Path(path)
    if not path.is_file():
        raise ValidationError(f"profile file {str(path)!r} does not exist")
    data = np.loadtxt(path)
    if data.ndim != 2 or data.shape[1] < 2:
        raise ValidationError(
            f"{path.name}: two columns (distance, elevation) expected, but got {data.shape}"
        )
    return profile_recording(data[:, 0], data[:, 1], path.stem, dx, unit, source=str(path.name))
