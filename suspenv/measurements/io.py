"""Saving and loading recordings as one ``.npz`` file (schema in ``docs/recordings.md``).

Layout of the archive:

* ``time``: float64 ``(N,)`` [s];
* ``in.<name>`` / ``out.<name>``: float64 ``(N,)`` per input / output channel;
* ``__meta__``: a 0-d unicode array holding JSON::

      {"format": "suspenv-recording", "version": 1, "name": ..., "test": ...,
       "inputs": [...], "outputs": [...], "units": {...}, "meta": {...}}

Loading first bounds memory (:func:`suspenv.measurements.limits.check_npz`: the
archive's expanded size against the read limit, no object arrays, never unpickles),
then checks the format tag, the version, the header's keys and types, that every
listed channel is present as a 1-D array of real numbers, converts declared non-SI
units to SI (an unknown unit is refused), and then the rules of :class:`Recording`
(lengths, strictly increasing time, SI units, no NaN/inf). ``expect_units`` /
``require_*`` add the caller's expectations.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.atomic import atomic_path
from suspenv.core.jsonable import to_jsonable
from suspenv.measurements.errors import RecordingError
from suspenv.measurements.limits import check_npz, read_limit
from suspenv.measurements.recording import Recording, check_units, real_numbers
from suspenv.measurements.sources._common import require_file
from suspenv.measurements.units import SI_UNITS, to_si

FORMAT = "suspenv-recording"
VERSION = 1


def save_recording(rec: Recording, path: str | Path) -> Path:
    """Write ``rec`` to ``path`` (``.npz`` appended if missing); returns the path."""
    path = Path(path)
    if path.suffix != ".npz":
        path = path.with_suffix(path.suffix + ".npz")
    header = {
        "format": FORMAT,
        "version": VERSION,
        "name": rec.name,
        "test": rec.test,
        "inputs": list(rec.inputs),
        "outputs": list(rec.outputs),
        "units": dict(rec.units),
        # NaN stays NaN in the header: the meta reads back as it was saved
        "meta": to_jsonable(rec.meta, finite=False),
    }
    # name -> array. Any, not np.ndarray: mypy matches **arrays against every keyword of
    # savez_compressed, including ``allow_pickle: bool``, which is never a key here
    arrays: dict[str, Any] = {"time": rec.time}
    arrays.update({f"in.{k}": v for k, v in rec.inputs.items()})
    arrays.update({f"out.{k}": v for k, v in rec.outputs.items()})
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, __meta__=np.array(json.dumps(header)), **arrays)
    return path


def load_recording(
    path: str | Path,
    require_inputs: Iterable[str] = (),
    require_outputs: Iterable[str] = (),
    expect_units: Mapping[str, str] | None = None,
    *,
    max_bytes: int | None = None,
) -> Recording:
    """Read a recording written by :func:`save_recording`; bad files raise ``RecordingError``.

    Args:
        path: the ``.npz`` file.
        require_inputs / require_outputs: channels the caller needs.
        expect_units: channel -> the unit the *file* must declare (checked before the
            conversion to SI, so a caller that needs a file written in N is told when it
            is in lbf).
        max_bytes: read limit [bytes] (default ``$SUSPENV_MAX_READ_BYTES`` or 512 MiB,
            :mod:`suspenv.measurements.limits`): an archive that would expand past it is
            refused before anything is loaded.

    Declared units are converted to SI with :func:`~suspenv.measurements.to_si` (lbf ->
    N, in -> m, mm/s -> m/s, ...; the file's units are kept in
    ``meta["converted_from"]``); an unknown unit is refused, never taken as SI.
    """
    path = Path(path)
    header, chans, time = _read_archive(path, read_limit(max_bytes))
    where = f"{path.name}: recording {header['name']!r} (test {header['test']!r})"
    declared: dict[str, str] = header["units"]
    check_units(where, declared, expect_units or {})  # as the file declares them
    units = dict(declared)
    clock = {"time": time}
    converted = _convert_to_si(where, (chans["in"], chans["out"], clock), units)
    meta = dict(header.get("meta", {}))
    if converted:
        meta["converted_from"] = converted
    try:
        rec = Recording(
            header["name"], header["test"], clock["time"], chans["in"], chans["out"], units, meta
        )
        rec.require(require_inputs, require_outputs)
    except RecordingError as exc:
        raise RecordingError(f"{path.name}: {exc}") from None
    return rec


def _read_archive(
    path: Path, limit: int
) -> tuple[dict[str, Any], dict[str, dict[str, np.ndarray]], np.ndarray]:
    """(checked header, ``{"in": ..., "out": ...}`` channels, time) of the archive
    ``path``, its expanded size bounded by ``limit`` [bytes] before anything is read."""
    require_file(path)
    check_npz(path, limit)
    try:
        npz = np.load(path, allow_pickle=False)
    except Exception as exc:  # noqa: BLE001 - any reader failure means "not our format"
        raise RecordingError(f"{path.name}: not a readable .npz archive ({exc})") from None
    if not isinstance(npz, np.lib.npyio.NpzFile):
        raise RecordingError(f"{path.name}: not an .npz archive (a single array)")
    with npz:
        if "__meta__" not in npz.files:
            raise RecordingError(f"{path.name}: missing the '__meta__' JSON entry; not a recording")
        header = _header(_member(npz, "__meta__", path), path)
        if "time" not in npz.files:
            raise RecordingError(f"{path.name}: missing channel 'time'")
        chans: dict[str, dict[str, np.ndarray]] = {"in": {}, "out": {}}
        for prefix, names in (("in", header["inputs"]), ("out", header["outputs"])):
            for name in names:
                key = f"{prefix}.{name}"
                if key not in npz.files:
                    kind = "input" if prefix == "in" else "output"
                    raise RecordingError(f"{path.name}: missing {kind} channel {name!r}")
                chans[prefix][name] = _numbers(_member(npz, key, path), name, path)
        time = _numbers(_member(npz, "time", path), "time", path)
    return header, chans, time


def _convert_to_si(
    where: str, groups: Iterable[dict[str, np.ndarray]], units: dict[str, str]
) -> dict[str, str]:
    """Convert, in place, every channel of ``groups`` whose unit in ``units`` is not SI
    (``units`` updated to the SI unit); returns channel -> the unit converted from. A
    channel without a unit is left to :class:`Recording`'s own rule; an unknown unit
    is refused."""
    converted: dict[str, str] = {}
    for group in groups:
        for name in list(group):
            stored = units.get(name)
            if stored is None or stored in SI_UNITS:
                continue  # no unit: the Recording's own rule names it; SI: kept as stored
            group[name], units[name] = to_si(group[name], stored, f"{where}: channel {name!r}")
            converted[name] = stored
    return converted


def _member(npz: Any, key: str, path: Path) -> np.ndarray:
    """One array of the archive (its size already checked by :func:`check_npz`)."""
    try:
        arr = npz[key]
    except Exception as exc:  # noqa: BLE001 - corrupt member: truncated, bad CRC, not .npy
        raise RecordingError(f"{path.name}: entry {key!r} cannot be read ({exc})") from None
    if not isinstance(arr, np.ndarray):
        raise RecordingError(f"{path.name}: entry {key!r} is not a .npy array")
    return arr


def _numbers(arr: np.ndarray, name: str, path: Path) -> np.ndarray:
    """A channel: a 1-D array of real numbers (integers, floats or booleans), as floats."""
    arr = real_numbers(path.name, name, arr)
    if arr.ndim != 1:
        raise RecordingError(
            f"{path.name}: channel {name!r} must be 1-D (one value per sample), but has "
            f"shape {arr.shape}"
        )
    return arr


def _header(raw: np.ndarray, path: Path) -> dict[str, Any]:
    """The ``__meta__`` JSON header, its keys and their types checked."""
    if raw.ndim != 0 or raw.dtype.kind != "U":
        raise RecordingError(
            f"{path.name}: '__meta__' must be one text value holding JSON, but got an array "
            f"of type {raw.dtype} and shape {raw.shape}"
        )
    try:
        header = json.loads(str(raw))
    except (ValueError, RecursionError) as exc:
        raise RecordingError(f"{path.name}: '__meta__' is not valid JSON ({exc})") from None
    if not isinstance(header, dict):
        raise RecordingError(
            f"{path.name}: '__meta__' must be a JSON object, but got {type(header).__name__}"
        )
    _check_header_keys(header, path)
    return header


def _check_header_keys(header: dict[str, Any], path: Path) -> None:
    """The header's format tag, version, keys and their types."""
    for key, value in (("format", FORMAT), ("version", VERSION)):
        if header.get(key) != value:
            raise RecordingError(
                f"{path.name}: {key} must be {value!r}, but got {header.get(key)!r}"
            )
    for key in ("name", "test", "inputs", "outputs", "units"):
        if key not in header:
            raise RecordingError(f"{path.name}: '__meta__' lacks the key {key!r}")
    for key in ("name", "test"):
        if not isinstance(header[key], str):
            raise RecordingError(
                f"{path.name}: '__meta__' {key!r} must be text, but got {header[key]!r}"
            )
    for key in ("inputs", "outputs"):
        names = header[key]
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise RecordingError(
                f"{path.name}: '__meta__' {key!r} must be a list of channel names, but got "
                f"{names!r}"
            )
        if len(set(names)) < len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise RecordingError(f"{path.name}: '__meta__' {key!r} repeats {dup}")
    units = header["units"]
    if not isinstance(units, dict) or not all(isinstance(u, str) for u in units.values()):
        raise RecordingError(
            f"{path.name}: '__meta__' 'units' must map channel names to unit text, but got "
            f"{units!r}"
        )
    if not isinstance(header.get("meta", {}), dict):
        raise RecordingError(
            f"{path.name}: '__meta__' 'meta' must be a JSON object, but got "
            f"{type(header['meta']).__name__}"
        )
