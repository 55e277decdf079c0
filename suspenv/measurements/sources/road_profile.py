"""Measured road profiles: a two-column text file (distance [m], elevation) as a
:class:`~suspenv.measurements.Recording` on a uniform grid.

Frame and units: distance ``x`` along the road [m] (+ in the direction of travel),
elevation ``z`` [m] (+ up). A profile is not a time history: the recording's ``time``
is distance over a nominal 1 m/s (``meta["axis"]`` says so).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.measurements.limits import MAX_READ_ENV, check_text, read_limit
from suspenv.measurements.recording import Recording


def profile_recording(
    distance: np.ndarray,
    elevation: np.ndarray,
    name: str = "road_profile",
    dx: float = 0.25,
    unit: str = "m",
    source: str = "",
    *,
    max_bytes: int | None = None,
) -> Recording:
    """A measured profile as a :class:`Recording` on a uniform ``dx`` grid (m).

    The recording's ``time`` is distance divided by a nominal 1 m/s (a profile is
    not a time history; ``meta["axis"]`` says so). Input channel ``distance`` [m],
    output channel ``elevation`` [m]. Irregular samples are linearly interpolated.
    Distances and elevations must be finite; the resampled grid (three float64 arrays)
    must fit the read limit ``max_bytes`` (:mod:`suspenv.measurements.limits`), so a
    long distance over a fine ``dx`` is refused before it is allocated.
    """
    x = np.asarray(distance, float)
    z = np.asarray(elevation, float)
    if x.ndim != 1 or x.shape != z.shape or x.size < 16:
        raise ValidationError(
            f"distance and elevation must be 1-D of equal length >= 16, but got "
            f"({x.shape}, {z.shape})"
        )
    for what, arr in (("distance", x), ("elevation", z)):
        if not np.all(np.isfinite(arr)):
            i = int(np.argmax(~np.isfinite(arr)))
            raise ValidationError(f"{what} must be finite, but sample {i} is {arr[i]}")
    if not np.all(np.diff(x) > 0):
        i = int(np.argmax(np.diff(x) <= 0))
        raise ValidationError(
            f"distance must be strictly increasing, but got x[{i}]={x[i]} and x[{i + 1}]={x[i + 1]}"
        )
    if not dx > 0 or not np.isfinite(dx):
        raise ValidationError(f"`dx > 0` (finite) must hold, but got dx={dx}")
    factor = {"m": 1.0, "mm": 1e-3}.get(unit)
    if factor is None:
        raise ValidationError(f"elevation unit must be 'm' or 'mm', but got {unit!r}")
    points = float(np.floor((x[-1] - x[0]) / dx + 1e-9)) + 1.0
    limit = read_limit(max_bytes)
    if not points * 3 * 8 <= limit:
        raise ValidationError(
            f"a profile over {x[-1] - x[0]:.6g} m on a {dx} m grid has {points:.6g} points "
            f"({3 * 8 * points:.6g} bytes as three float64 arrays), more than the read limit "
            f"of {limit} bytes; use a coarser dx or raise the limit (max_bytes= or "
            f"{MAX_READ_ENV})"
        )
    grid = x[0] + dx * np.arange(int(points))
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


def load_profile_txt(
    path: str | Path, dx: float = 0.25, unit: str = "m", *, max_bytes: int | None = None
) -> Recording:
    """Read a two-column text profile (distance [m], elevation) into a Recording.

    The shared ``profile_*.txt`` files hold elevations of about 582-583 (an altitude
    in metres; read as millimetres they would be ~1e-6 times class A), so ``unit``
    defaults to ``"m"``. ``max_bytes``: read limit (:mod:`suspenv.measurements.limits`;
    a text file may be a quarter of it).
    """
    path = Path(path)
    if not path.is_file():
        raise ValidationError(f"profile file {str(path)!r} does not exist")
    check_text(path, read_limit(max_bytes))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data"
            data = np.loadtxt(path, encoding="utf-8")
    except (ValueError, UnicodeDecodeError) as exc:
        raise ValidationError(f"{path.name}: not a table of numbers ({exc})") from None
    if data.ndim != 2 or data.shape[1] < 2:
        raise ValidationError(
            f"{path.name}: two columns (distance, elevation) expected, but got {data.shape}"
        )
    return profile_recording(
        data[:, 0], data[:, 1], path.stem, dx, unit, source=str(path.name), max_bytes=max_bytes
    )
