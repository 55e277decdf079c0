"""The missing-input check on synthetic cases whose truth is known.

``python -m benchmarks.missing_input`` diagnoses, with the defaults (as ``suspenv
diagnose`` does):

- MR dampers under random motion whose coil current switches between 0 and 1 A
  (:func:`benchmarks.component_truth.mr_field_case`, seeds :data:`FIELD_SEEDS`),
  once without the current channel (the check should flag an unrecorded input) and once
  with it (the field-dependent law should explain the force to its noise: residual RMS
  over the noise drawn, largest relative error of the field law's parameters);
- the concealed-effect cases of :func:`benchmarks.component_truth.make_case` of
  every component family: effect-free controls (white, coloured and drifting noise),
  one library effect, and one effect outside the library (seeds fixed below), where
  the check should stay silent (their residual, if any, is a function of the motion).

Writes ``docs/benchmarks/missing_input.json`` and prints a table.
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

FIELD_SEEDS = range(5)
FAMILIES = ("damper", "mr_damper", "friction_guide", "quarter_car_rig")
#: (effects, outside, seeds) of the concealed-effect cases
CASES = ((0, False, range(6)), (1, False, range(4)), (0, True, range(3)))


def _flag(diag: Any) -> str | None:
    found = diag.findings.get("missing_input")
    return found.numbers.get("cause") if found is not None else None


def field_rows() -> list[dict[str, Any]]:
    from benchmarks.component_truth import mr_field_case
    from suspenv.diagnosis.engine import diagnose
    from suspenv.measurements import Recording

    rows = []
    for seed in FIELD_SEEDS:
        case = mr_field_case(seed)
        rec = case.recording
        drop = Recording(
            rec.name,
            rec.test,
            rec.time,
            {k: v for k, v in rec.inputs.items() if k != "coil_current"},
            rec.outputs,
            {k: u for k, u in rec.units.items() if k != "coil_current"},
            rec.meta,
        )
        c0 = time.process_time()
        without = diagnose(drop, "mr_damper")
        c1 = time.process_time()
        whole = diagnose(rec, "mr_damper")
        c2 = time.process_time()
        fit = whole.final_fit
        res = rec.outputs["force"] - fit.model.simulate(fit.theta, rec)["force"]
        got = {k: v["value"] for k, v in whole.final_params.items()}
        names = ("c", "c_field", "f_y", "f_field", "x_y")
        rows.append(
            {
                "seed": seed,
                "without_channel": {
                    "flag": _flag(without),
                    "headline": without.headline,
                    "share_of_force_rms": float(
                        np.std(
                            drop.outputs["force"]
                            - without.final_fit.model.simulate(without.final_fit.theta, drop)[
                                "force"
                            ]
                        )
                        / np.std(rec.outputs["force"])
                    ),
                    "cpu_s": c1 - c0,
                },
                "with_channel": {
                    "flag": _flag(whole),
                    "headline": whole.headline,
                    "residual_over_noise": float(np.sqrt(np.mean(res**2)) / case.truth.noise_rms),
                    "max_param_rel_err": max(abs(got[k] / case.truth.base[k] - 1.0) for k in names),
                    "cpu_s": c2 - c1,
                },
            }
        )
        print(f"field seed {seed}: {rows[-1]}", flush=True)
    return rows


def case_rows() -> list[dict[str, Any]]:
    from benchmarks.component_truth import make_case
    from suspenv.diagnosis.engine import diagnose

    rows = []
    for n_effects, outside, seeds in CASES:
        for family in FAMILIES:
            for seed in seeds:
                case = make_case(family, seed, n_effects, outside=outside)
                c0 = time.process_time()
                diag = diagnose(case.recording, family)
                rows.append(
                    {
                        "case": case.truth.case_id,
                        "kind": "outside"
                        if outside
                        else ("control" if not n_effects else "effect"),
                        "noise": case.truth.noise_kind,
                        "flag": _flag(diag),
                        "cpu_s": time.process_time() - c0,
                    }
                )
                print(f"{rows[-1]}", flush=True)
    return rows


def _count(rows: list[dict[str, Any]], flag: Any) -> str:
    return f"{sum(bool(flag(r)) for r in rows)}/{len(rows)}"


def summary(field: list[dict[str, Any]], cases: list[dict[str, Any]]) -> dict[str, Any]:
    """Flags per group (``k/n``) and the field law's fit with the channel."""
    out: dict[str, Any] = {
        "field_flagged_without_channel": _count(field, lambda r: r["without_channel"]["flag"]),
        "field_flagged_with_channel": _count(field, lambda r: r["with_channel"]["flag"]),
        "field_max_residual_over_noise": max(
            r["with_channel"]["residual_over_noise"] for r in field
        ),
        "field_max_param_rel_err": max(r["with_channel"]["max_param_rel_err"] for r in field),
    }
    for kind in ("control", "effect", "outside"):
        out[f"{kind}_flagged"] = _count(
            [r for r in cases if r["kind"] == kind], lambda r: r["flag"]
        )
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--no-docs", action="store_true", help="do not write docs/benchmarks")
    args = ap.parse_args(argv)
    field, cases = field_rows(), case_rows()
    found = summary(field, cases)
    result = {
        "summary": found,
        "field": field,
        "cases": cases,
        "command": "python -m benchmarks.missing_input",
        "machine": machine_info(),
    }
    print("| measurement | value |\n|---|---|")
    for k, v in found.items():
        print(f"| {k} | {v if isinstance(v, str) else f'{v:.3g}'} |")
    if not args.no_docs:
        out = Path("docs") / "benchmarks"
        out.mkdir(parents=True, exist_ok=True)
        (out / "missing_input.json").write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
