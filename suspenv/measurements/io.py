"""Saving and loading recordings as one ``.npz`` file (schema in ``docs/recordings.md``).

Layout of the archive:

* ``time``: float64 ``(N,)`` [s];
* ``in.<name>`` / ``out.<name>``: float64 ``(N,)`` per input / output channel;
* ``__meta__``: a 0-d unicode array holding JSON::

      {"format": "suspenv-recording", "version": 1, "name": ..., "test": ...,
       "inputs": [...], "outputs": [...], "units": {...}, "meta": {...}}

Loading checks the format tag, the version, that every listed channel is present,
and then the rules of :class:`Recording` (lengths, strictly increasing time, units,
no NaN/inf). ``expect_units`` / ``require_*`` add the caller's expectations.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.measurements.errors import RecordingError
from suspenv.measurements.recording import Recording

FORMAT = "suspenv-recording"
VERSION = 1


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


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
        "meta": _jsonable(rec.meta),
    }
    # name -> array. Any, not np.ndarray: mypy matches **arrays against every keyword of
    # savez_compressed, including ``allow_pickle: bool``, which is never a key here
    arrays: dict[str, Any] = {"time": rec.time}
    arrays.update({f"in.{k}": v for k, v in rec.inputs.items()})
    arrays.update({f"out.{k}": v for k, v in rec.outputs.items()})
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")
    with open(tmp, "wb") as fh:
        np.savez_compressed(fh, __meta__=np.array(json.dumps(header)), **arrays)
    tmp.replace(path)
    return path


def load_recording(
    path: str | Path,
    require_inputs: Iterable[str] = (),
    require_outputs: Iterable[str] = (),
    expect_units: Mapping[str, str] | None = None,
) -> Recording:
    """Read a recording written by :func:`save_recording`; bad files raise ``RecordingError``."""
    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"recording file {str(path)!r} does not exist")
    try:
        npz = np.load(path, allow_pickle=False)
    except Exception as exc:  # noqa: BLE001 - any reader failure means "not our format"
        raise RecordingError(f"{path.name}: not a readable .npz archive ({exc})") from None
    with npz:
        if "__meta__" not in npz.files:
            raise RecordingError(f"{path.name}: missing the '__meta__' JSON entry; not a recording")
        try:
            header = json.loads(str(npz["__meta__"]))
        except json.JSONDecodeError as exc:
            raise RecordingError(f"{path.name}: '__meta__' is not valid JSON ({exc})") from None
        if header.get("format") != FORMAT:
            raise RecordingError(
                f"{path.name}: format must be {FORMAT!r}, but got {header.get('format')!r}"
            )
        if header.get("version") != VERSION:
            raise RecordingError(
                f"{path.name}: version must be {VERSION}, but got {header.get('version')!r}"
            )
        for key in ("name", "test", "inputs", "outputs", "units"):
            if key not in header:
                raise RecordingError(f"{path.name}: '__meta__' lacks the key {key!r}")
        if "time" not in npz.files:
            raise RecordingError(f"{path.name}: missing channel 'time'")
        chans: dict[str, dict[str, np.ndarray]] = {"in": {}, "out": {}}
        for prefix, names in (("in", header["inputs"]), ("out", header["outputs"])):
            for name in names:
                key = f"{prefix}.{name}"
                if key not in npz.files:
                    kind = "input" if prefix == "in" else "output"
                    raise RecordingError(f"{path.name}: missing {kind} channel {name!r}")
                chans[prefix][name] = npz[key]
        time = npz["time"]
    try:
        rec = Recording(
            header["name"],
            header["test"],
            time,
            chans["in"],
            chans["out"],
            header["units"],
            header.get("meta", {}),
        )
    except RecordingError as exc:
        raise RecordingError(f"{path.name}: {exc}") from None
    try:
        rec.require(require_inputs, require_outputs, expect_units)
    except RecordingError as exc:
        raise RecordingError(f"{path.name}: {exc}") from None
    return rec
