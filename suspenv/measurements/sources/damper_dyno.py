"""Damper dyno export (MTS 793 text, inch/lbf) -> :class:`Recording` in SI.

File layout (tab separated, CRLF): blocks of about 1 s, each starting with a
system line or blank line, a ``Data Acquisition ... Time: ...`` line, the column
names ``Stroke Load Time`` and their units ``in lbf Sec``, then samples. Every
block's names and units are checked; a block in other units is rejected.

Output channels (SI): input ``displacement`` [m] (stroke), input ``velocity`` [m/s]
from the Savitzky-Golay differentiator of :mod:`suspenv.measurements.differentiate`
(window ``window_s``, cubic), output ``force`` [N]. Sign convention: displacement
keeps the dyno's stroke sign; the force sign is chosen so that the damper absorbs
power on average (``mean(F v) > 0``, i.e. force positive when it resists positive
velocity); the applied flip is recorded in ``meta["force_sign"]``.
"""

from __future__ import annotations

from array import array
from pathlib import Path

import numpy as np

from suspenv.core.sampling import increasing_steps
from suspenv.measurements.differentiate import smooth_derivative
from suspenv.measurements.errors import RecordingError
from suspenv.measurements.limits import check_text, read_limit
from suspenv.measurements.recording import Recording
from suspenv.measurements.sources._common import dissipative_sign, named_errors, require_file
from suspenv.measurements.units import to_si

EXPECTED_COLUMNS = ("Stroke", "Load", "Time")
SOURCE = "Formula Student team's public damper-analysis repository (MTS 793 export)"


def _parse(path: Path) -> tuple[np.ndarray, tuple[str, str, str]]:
    # float64 values straight into one buffer: 8 bytes per number, so the memory is
    # bounded by the text check of load_damper_dyno (no Python object per value)
    rows = array("d")
    units: tuple[str, str, str] | None = None
    expect_units_next = False
    with open(path, encoding="latin-1") as fh:
        for lineno, raw in enumerate(fh, start=1):
            fields = [f.strip() for f in raw.rstrip("\r\n").split("\t")]
            if fields[:3] == list(EXPECTED_COLUMNS):
                expect_units_next = True
                continue
            if expect_units_next:
                block_units = tuple(fields[:3])
                if len(block_units) < 3:
                    raise RecordingError(
                        f"{path.name}: line {lineno} must give the units of {EXPECTED_COLUMNS}, "
                        f"but holds {raw.strip()!r}"
                    )
                if units is None:
                    units = block_units  # type: ignore[assignment]
                elif block_units != units:
                    raise RecordingError(
                        f"{path.name}: unit mismatch at line {lineno}: units {block_units} "
                        f"differ from the first block's {units}"
                    )
                expect_units_next = False
                continue
            if len(fields) == 3:
                try:
                    rows.extend((float(fields[0]), float(fields[1]), float(fields[2])))
                except ValueError:
                    raise RecordingError(
                        f"{path.name}: line {lineno} is not three numbers: {raw.strip()!r}"
                    ) from None
    if units is None:
        raise RecordingError(
            f"{path.name}: no column header {EXPECTED_COLUMNS} with a units line was found"
        )
    if len(rows) < 30:
        raise RecordingError(f"{path.name}: only {len(rows) // 3} data rows")
    return np.array(rows, dtype=float).reshape(-1, 3), units


def load_damper_dyno(
    path: str | Path,
    window_s: float = 0.01,
    name: str | None = None,
    *,
    max_bytes: int | None = None,
) -> Recording:
    """Load an MTS 793 damper dyno export; see the module docstring for channels and signs.

    Each column's declared unit is converted to SI (``in`` -> m, ``lbf`` -> N, ``Sec`` ->
    s, also mm, kN, ...); an unknown unit or one of another quantity is refused.
    ``max_bytes``: read limit (:mod:`suspenv.measurements.limits`; a text file may be a
    quarter of it)."""
    path = require_file(path)
    check_text(path, read_limit(max_bytes))
    table, units = _parse(path)
    converted = [
        to_si(table[:, j], units[j], f"{path.name}: column {col!r}")
        for j, col in enumerate(EXPECTED_COLUMNS)
    ]
    (x, x_unit), (f, f_unit), (t, t_unit) = converted
    for got, want, col in ((x_unit, "m", "Stroke"), (f_unit, "N", "Load"), (t_unit, "s", "Time")):
        if got != want:
            raise RecordingError(
                f"{path.name}: column {col!r} must convert to {want!r}, but its unit "
                f"{dict(zip(EXPECTED_COLUMNS, units, strict=True))[col]!r} converts to {got!r}"
            )
    dt = increasing_steps(t, f"{path.name}: ", error=RecordingError)
    with named_errors(path):
        v = smooth_derivative(x, t, window_s, order=3)
    sign = dissipative_sign(f, v)
    meta = {
        "source": SOURCE,
        "file": path.name,
        "sampling": {"dt_s": float(np.median(dt)), "rate_hz": 1.0 / float(np.median(dt))},
        "original_units": dict(zip(EXPECTED_COLUMNS, units, strict=True)),
        "differentiator": f"Savitzky-Golay, cubic, window {window_s} s",
        "force_sign": sign,
        "notes": "stroke in the dyno's sign; force oriented to absorb power on average",
    }
    return Recording(
        name or path.stem,
        "damper_dyno",
        t,
        {"displacement": x, "velocity": v},
        {"force": sign * f},
        {"displacement": "m", "velocity": "m/s", "force": "N"},
        meta,
    )
