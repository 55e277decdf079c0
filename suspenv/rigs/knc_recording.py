"""K&C rig results as recordings, and back (the format: :mod:`suspenv.measurements.knc`).

A rig result (:class:`~suspenv.rigs.knc.KCResult`, one row per design) becomes one
:class:`~suspenv.measurements.Recording` per test and design: inputs ``pad_left``,
``pad_right`` [m], ``stroke`` [m] (travel tests: the left pad's stroke; steering: the
rack travel along +y) or ``force`` (compliance tests: [N], or [N*m] in ``aligning``),
``branch`` and ``grid`` (loop indices); outputs ``<channel>_<side>`` in SI units, ISO
8855, lateral channels outboard positive on each side.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.measurements.knc import (
    CHANNELS,
    LOADED_TESTS,
    SIDES,
    TEST_PREFIX,
    branch_index,
    rig_test,
)
from suspenv.measurements.recording import Recording
from suspenv.rigs.knc import KCResult, loop_path, pad_offsets, stroke_grid


def channels_of(result: KCResult, row: int = 0) -> dict[str, np.ndarray]:
    """Recorded outputs of design ``row`` of a rig result: ``<channel>_<side>`` -> (P,)."""
    out = {}
    for name, (rig_name, _, flip) in CHANNELS.items():
        v = np.asarray(result.channels[rig_name][row], float)  # (P, 2)
        for j, side in enumerate(SIDES):
            out[f"{name}_{side}"] = -v[:, j] if (flip and j == 1) else v[:, j]
    return out


def to_recording(
    result: KCResult,
    row: int = 0,
    name: str | None = None,
    amplitude: float | None = None,
    meta: Mapping[str, Any] | None = None,
) -> Recording:
    """The loop of design ``row`` of ``result`` as a :class:`Recording`."""
    if not bool(np.asarray(result.ok)[row]):
        raise ValidationError(
            f"design row {row} failed the {result.test} test: {result.messages[row]}"
        )
    steps = result.grid.size - 1
    amp = float(amplitude if amplitude is not None else result.grid[-1])
    s = result.grid[result.path]
    force = result.test in LOADED_TESTS
    pads = pad_offsets(result.test, s)  # zero in a compliance test
    drive_key = "force" if force else "stroke"
    inputs = {
        "pad_left": pads[:, 0],
        "pad_right": pads[:, 1],
        drive_key: s,
        "branch": branch_index(steps),
        "grid": result.path.astype(float),
    }
    units = {"pad_left": "m", "pad_right": "m", drive_key: result.unit, "branch": "-", "grid": "-"}
    for c, (_, unit, _) in CHANNELS.items():
        for side in SIDES:
            units[f"{c}_{side}"] = unit
    info = {
        "rig": "knc",
        "knc_test": result.test,
        "amplitude": amp,
        "amplitude_unit": result.unit,
        "steps": int(steps),
        "time_axis": "step index (quasi-static rig; 1 s per step)",
        "frame": "ISO 8855; lateral channels outboard positive on each side",
    }
    info.update(dict(meta or {}))
    return Recording(
        name or f"knc_{result.test}",
        TEST_PREFIX + result.test,
        np.arange(s.size, dtype=float),
        inputs,
        channels_of(result, row),
        units,
        info,
    )


def to_recordings(
    results: Mapping[str, KCResult],
    row: int = 0,
    prefix: str = "",
    meta: Mapping[str, Any] | None = None,
) -> dict[str, Recording]:
    """One recording per test: ``{test: Recording}``."""
    return {
        t: to_recording(r, row, f"{prefix}{t}" if prefix else None, meta=meta)
        for t, r in results.items()
    }


def from_recording(rec: Recording) -> KCResult:
    """The recording as a one-design :class:`KCResult` (only the recorded channels)."""
    test = rig_test(rec)
    steps = int(rec.meta["steps"])
    grid = stroke_grid(float(rec.meta["amplitude"]), steps)
    path = loop_path(steps)
    if rec.n_samples != path.size:
        raise ValidationError(
            f"recording {rec.name!r}: a loop of {steps} steps has {path.size} samples, "
            f"but the recording has {rec.n_samples}"
        )
    chans = {}
    for name, (rig_name, _, flip) in CHANNELS.items():
        key = [f"{name}_{s}" for s in SIDES]
        if not all(k in rec.outputs for k in key):
            continue
        left, right = (np.asarray(rec.outputs[k], float) for k in key)
        chans[rig_name] = np.stack([left, -right if flip else right], axis=-1)[None]
    return KCResult(test, grid, path, chans, np.ones(1, bool), [""])
