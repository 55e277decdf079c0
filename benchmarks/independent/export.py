"""Writing a case: the recording in its declared units, the truth, the manifest.

The channels are first assembled as a :class:`suspenv.measurements.Recording` in SI units
(which validates shapes, time and finiteness); a copy then carries the numbers in the
declared units (SI value / the unit's factor, as a user's export holds them) and is
written with :func:`suspenv.measurements.save_recording`. ``load_recording`` converts
them back to SI.
"""

from __future__ import annotations

import copy
import json
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.independent.cases import TEST_NAME, Case
from suspenv.measurements import Recording, save_recording
from suspenv.measurements.units import FACTORS

GENERATOR = "benchmarks.independent"
VERSION = "1.0"


def to_recording(case: Case) -> Recording:
    """The case as an SI recording (validated); its name does not reveal the case kind."""
    si_units = {name: FACTORS[unit][1] for name, unit in case.units.items()}
    # a neutral run name, as a user's export would carry (the kind stays in the truth)
    name = f"{TEST_NAME[case.spec.family]}_{zlib.crc32(case.spec.case_id.encode()):08x}"
    return Recording(
        name,
        TEST_NAME[case.spec.family],
        case.time,
        case.inputs,
        case.outputs,
        si_units,
        case.meta,
    )


def declared_copy(rec: Recording, units: dict[str, str]) -> Recording:
    """A copy of ``rec`` whose channels hold the numbers in ``units`` (for writing only:
    it bypasses the SI rule of :class:`Recording`, which ``load_recording`` restores)."""
    out = copy.copy(rec)

    def conv(chans: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {k: v / FACTORS[units[k]][0] for k, v in chans.items()}

    out.inputs = conv(rec.inputs)
    out.outputs = conv(rec.outputs)
    out.units = {"time": "s", **units}
    return out


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def write_case(case: Case, out: Path) -> tuple[Path, Path]:
    """Write ``cases/<id>.npz`` and ``truth/<id>.json`` under ``out``; return both paths."""
    rec = to_recording(case)
    npz = save_recording(declared_copy(rec, case.units), out / "cases" / f"{case.spec.case_id}.npz")
    truth = out / "truth" / f"{case.spec.case_id}.json"
    truth.parent.mkdir(parents=True, exist_ok=True)
    truth.write_text(json.dumps(case.truth, indent=1, default=_json_default) + "\n")
    return npz, truth


def write_manifest(out: Path, case_ids: list[str], seeds: list[int], families: list[str]) -> Path:
    """``manifest.json``: case ids, generator name and version, seeds, families."""
    path = out / "manifest.json"
    path.write_text(
        json.dumps(
            {
                "generator": GENERATOR,
                "version": VERSION,
                "seeds": seeds,
                "families": families,
                "cases": case_ids,
            },
            indent=1,
        )
        + "\n"
    )
    return path
