"""Every real component recording in the shared data through the diagnosis, held out.

``python -m benchmarks.real_recordings [--data-dir DIR]`` runs the component diagnosis
(defaults, as ``suspenv diagnose`` does) on the real recordings of
:data:`suspenv.measurements.catalog.REAL_CASES` (EMPS friction guide, MR damper on a
shaking table, racing damper on a dyno), then evaluates the baseline and the final model
on **every** further recording of the same rig that was not fitted: all MR-damper runs
(``ensaio*.mat``: the validation runs ``ensaio.vali.*`` and every other run) and both
EMPS runs. For each it reports the RMS error of the baseline and of the final model
(parameters as fitted, nothing refitted), so a named element is judged on data it never
saw. Writes ``docs/benchmarks/real_recordings.json`` and prints a table; the README's
table is generated from that file (``python -m benchmarks.readme``).

Each recording, fitted or further, is also put to the missing-input check
(:mod:`suspenv.diagnosis.checks.missing_input`) with the final model: a flag would say an
input the recording does not carry drives the residual. For the MR damper the variables
of every ``.mat`` file are listed (``mat_variables``): none is a coil voltage or current
(``coil_channel``), so the field-dependent MR law cannot be fitted to these runs.

Sources and licences: ``../shared/data/README.md`` (EMPS: Janot, Gautier, Brunot; MR
damper: A. N. Vargas, 2021, Zenodo, MIT; racing damper: a Formula Student team's public
repository). The data are read in place, never copied.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import machine_info


def _conditioned(diag: Any, rec: Any) -> Any:
    """``rec`` with its motion channels in the version the diagnosis chose for its own
    recordings (:mod:`suspenv.diagnosis.component.motion_inputs`)."""
    from suspenv.diagnosis.component.motion_inputs import conditioned

    version = str(diag.baseline.get("motion_version", "channel"))
    (out,), _ = conditioned([rec], diag.base_fit.model.input_channels, version)
    return out


def _rms_errors(diag: Any, rec: Any) -> tuple[float, float]:
    """RMS error [channel unit] of the baseline and the final model on ``rec``
    (:func:`_conditioned`)."""

    ch = diag.channel
    rec = _conditioned(diag, rec)
    meas = np.asarray(rec.outputs[ch], float)
    out = []
    for fit in (diag.base_fit, diag.final_fit):
        pred = np.asarray(fit.model.simulate(fit.theta, rec)[ch], float)
        out.append(float(np.sqrt(np.mean((meas - pred) ** 2))))
    return out[0], out[1]


def _extra_recordings(name: str, root: Path, used: set[str]) -> list[Any]:
    """The rig's other recordings (not fitted, not the held-out one already scored)."""
    from suspenv.measurements.sources import load_emps, load_mr_damper

    if name == "mr_damper":
        d = root / "mr_damper_shaking_table"
        paths = sorted(d.glob("ensaio*.mat"))
        return [load_mr_damper(p) for p in paths if p.name not in used]
    if name == "emps":
        d = root / "emps"
        return [load_emps(p) for p in sorted(d.glob("DATA_EMPS*.mat")) if p.name not in used]
    return []


def _missing_input(diag: Any, rec: Any) -> str | None:
    """The missing-input check's cause on ``rec`` with the final model (None: no flag)."""
    from suspenv.diagnosis.checks.missing_input import cause, judge_recording

    judged = judge_recording(diag.final_fit, rec)
    causes = [cause(n, diag.rule.alpha / len(judged)) for n in judged.values()]
    return next((c for c in causes if c), None)


def _mat_variables(root: Path) -> list[str]:
    """Every variable name in the MR damper's ``.mat`` files (read from their headers)."""
    from scipy.io import whosmat

    names = set()
    for p in sorted((root / "mr_damper_shaking_table").glob("ensaio*.mat")):
        names |= {n for n, _, _ in whosmat(p)}
    return sorted(names)


def run(root: Path) -> dict[str, Any]:
    from suspenv.diagnosis.engine import diagnose
    from suspenv.measurements.catalog import REAL_CASES

    rows = []
    for name, loader in REAL_CASES.items():
        fit, hold, family, _ = loader(root)
        t0, c0 = time.perf_counter(), time.process_time()
        diag = diagnose(fit, family, holdout=hold)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        fitted = [str(r.meta.get("file", r.name)) for r in diag.fit_recordings]
        held = [str(r.meta.get("file", r.name)) for r in diag.heldout_recordings]
        c = diag.comparison
        ch = diag.channel
        entry: dict[str, Any] = {
            "case": name,
            "family": family,
            "headline": diag.headline,
            "named": diag.named_kinds,
            "unexplained": diag.unexplained,
            "holdout": diag.holdout,
            "fitted": fitted,
            "channel": ch,
            "heldout_before": diag.baseline["heldout_rms"][ch],
            "heldout_after": c.heldout_rms_after[ch] if c else diag.baseline["heldout_rms"][ch],
            "wall_s": wall,
            "cpu_s": cpu,
            "other_recordings": [],
        }
        found = diag.findings.get("missing_input")
        entry["missing_input"] = found.numbers.get("cause") if found is not None else None
        used = {Path(f).name for f in fitted + held}
        for rec in _extra_recordings(name, root, used):
            before, after = _rms_errors(diag, rec)
            entry["other_recordings"].append(
                {
                    "file": str(rec.meta.get("file", rec.name)),
                    "before": before,
                    "after": after,
                    "missing_input": _missing_input(diag, _conditioned(diag, rec)),
                }
            )
        if name == "mr_damper":
            entry["mat_variables"] = _mat_variables(root)
            words = ("volt", "current", "coil", "corrente", "tensao")
            entry["coil_channel"] = any(
                w in v.lower() for v in entry["mat_variables"] for w in words
            )
        rows.append(entry)
        flagged = sum(bool(o["missing_input"]) for o in entry["other_recordings"])
        print(
            f"{name}: {diag.headline}; held out {entry['heldout_before']:.4g} -> "
            f"{entry['heldout_after']:.4g} ({len(entry['other_recordings'])} further "
            f"recordings) in {wall:.1f} s; missing input flagged: "
            f"{entry['missing_input'] or 'no'} (fitted), {flagged} further",
            flush=True,
        )
    return {"rows": rows}


def table_markdown(result: dict[str, Any]) -> str:
    """The table the README shows (:func:`benchmarks.readme.real_recordings_table`)."""
    from benchmarks.readme import real_recordings_table

    return real_recordings_table(result)


def main(argv: list[str] | None = None) -> int:
    from suspenv.measurements.catalog import real_data_dir

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data-dir", default=None, help="folder of the real recordings")
    ap.add_argument("--no-docs", action="store_true", help="do not write docs/benchmarks")
    args = ap.parse_args(argv)
    root = Path(args.data_dir) if args.data_dir else Path(real_data_dir())
    if not root.is_dir():
        print(f"real recordings folder {str(root)!r} does not exist; nothing to run")
        return 1
    result = run(root)
    result["command"] = "python -m benchmarks.real_recordings"
    result["machine"] = machine_info()
    print(table_markdown(result))
    if not args.no_docs:
        out = Path("docs") / "benchmarks"
        out.mkdir(parents=True, exist_ok=True)
        (out / "real_recordings.json").write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
