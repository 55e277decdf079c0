"""The component diagnosis on recordings from the independent generator, reported only.

``python -m benchmarks.independent_diagnosis [--seeds 5000-5009] [--out DIR]``
generates the cases with :mod:`benchmarks.independent` (which shares no code with the
diagnosis engine or the component models), diagnoses each one as a user would (the
model family and the rig from the recording's ``meta["rig"]``, every other setting at
its default), scores the verdicts against the truth files, prints the table, and writes
``docs/benchmarks/independent_diagnosis.json`` and the table between the markers of
``docs/diagnosis.md``.

Scores (per family and in total):

* **single**: the first named element is of the truth's signature family (the truth's
  labels are the generator's own vocabulary, mapped in :data:`LABEL_FAMILY`); a constant
  sensor offset on a channel whose standard baseline already holds a zero offset (the
  guide's force offset, the quarter car's sensor zeros) is not missing physics: it is
  right when nothing is named, the residual is not left unexplained, and the verdict says
  that the baseline's offset on that channel is off zero (the row's
  ``baseline_offsets``);
* **control**: a false alarm is any named element or an "unexplained residual" verdict;
* **outside** (physics not in the library): reported as unexplained;
* a recording the diagnosis refuses counts as a miss, with its message kept;
* time per diagnosis, wall and process CPU.

Parameters are scored where the generator's law has an exact counterpart in the element
named first (:func:`parameter_errors`): friction levels (Coulomb ``Fc``; Stribeck and
LuGre also the static level ``Fc fs_ratio``), a Maxwell branch (``km``, ``km tau``), a
cubic spring ``k3``, a linear end stop (stiffness and gap of each side), a sensor lag
``tau``, a gain error and a one-sided extra damping (its size). The other
parameterisations (Bouc-Wen with its own exponents, the valve curves, an MR damper's
field-dependent laws) are not the library's: a comparison there would measure the
translation between them, not the diagnosis.

Every seed set is run once, for reporting, and then retired (``docs/diagnosis.md`` lists
the sets and the code each was run with).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import machine_info
from suspenv.core.jsonable import to_jsonable

#: generator label -> the engine's signature family that names it
LABEL_FAMILY = {
    "friction": "friction",
    "hysteresis": "hysteresis",
    "digressive": "digressive",
    "damper_asymmetry": "damper_asymmetry",
    "viscoelastic": "viscoelastic",
    "progressive": "progressive",
    "end_stop": "end_stop",
    "sensor_offset": "sensor_offset",
    "sensor_gain": "sensor_gain",
    "sensor_lag": "sensor_lag",
}
DOC_BEGIN = "<!-- independent-table:begin -->"
DOC_END = "<!-- independent-table:end -->"
REPORT_SEEDS = "5226-5237"
#: a recovered parameter within this relative error of the truth counts as found
PARAMETER_TOLERANCE = 0.2


def _true_parameters(effect: dict[str, Any], kind: str) -> dict[str, float]:
    """The named element's parameters [SI] that the generator's law fixes exactly, from
    the truth's parameters; empty where the law has no counterpart in ``kind``. Sizes
    only where the library writes the law in another frame (a one-sided extra damping
    in compression is, in the library's rebound term, ``-dc`` beside a base ``c + dc``)."""
    lab, p = effect.get("label"), effect.get("params", {})
    var = p.get("variant")
    if lab == "friction" and var in ("tanh", "stribeck", "lugre"):
        out = {}
        if kind in ("coulomb_friction", "stribeck_friction", "lugre_friction"):
            out["f_c"] = p["Fc"]
        if var != "tanh" and kind in ("stribeck_friction", "lugre_friction"):
            out["f_s"] = p["Fc"] * p["fs_ratio"]
        return out
    if lab == "viscoelastic" and kind == "maxwell_viscoelastic":
        return {"k_m": p["km"], "c_m": p["km"] * p["tau"]}
    if lab == "progressive" and kind == "cubic_stiffness":
        return {"k3": p["k3"]}
    if lab == "end_stop" and var == "linear":
        sides = [s for s in ("bump", "rebound") if p.get(s)]
        if kind == "bump_and_rebound_stops":
            return {q: p[w] for s in sides for q, w in ((f"k_{s}", "ks"), (f"gap_{s}", "gap"))}
        if kind in ("bump_stop", "rebound_stop") and kind.split("_")[0] in sides:
            return {"k_stop": p["ks"], "gap": p["gap"]}
        return {}
    if lab == "sensor_lag" and kind == "sensor_lag":
        return {"tau": p["tau"]}
    if lab == "sensor_gain" and kind == "sensor_gain":
        return {"gain_error": p["gain_error"]}
    if lab == "damper_asymmetry" and kind == "damper_asymmetry":
        return {"|dc_rebound|": p["dc"]}
    return {}


def parameter_errors(effect: dict[str, Any], named_first: Any) -> dict[str, dict[str, float]]:
    """``{parameter: {true, fitted, rel_error}}`` of the element named first against the
    concealed effect's law (:func:`_true_parameters`); ``rel_error = |fitted - true| /
    |true|`` (for a gain error, of the error ``gain - 1``)."""
    kind = named_first.kind
    fitted = {k.rpartition(".")[2]: v["value"] for k, v in named_first.params.items()}
    if "gain" in fitted:
        fitted["gain_error"] = fitted["gain"] - 1.0
    if "dc_rebound" in fitted:
        fitted["|dc_rebound|"] = abs(fitted["dc_rebound"])
    out = {}
    for name, true in _true_parameters(effect, kind).items():
        if name in fitted and true != 0.0:
            got = float(fitted[name])
            out[name] = {"true": float(true), "fitted": got, "rel_error": abs(got / true - 1.0)}
    return out


def score_case(truth: dict[str, Any], diag: Any | None, error: str = "") -> dict[str, Any]:
    """One case's record: what was concealed, what was said, and whether it was right."""
    kind = truth["kind"]
    labels = [e["label"] for e in truth.get("effects", [])]
    row: dict[str, Any] = {
        "case_id": truth["case_id"],
        "family": truth["family"],
        "kind": kind,
        "labels": labels,
        "noise": truth.get("noise", {}).get("kind"),
        "refused": error,
    }
    if diag is None:
        row.update(named=[], unexplained=False, right=False, verdict=error)
        return row
    named = diag.named_families
    row.update(
        named=named,
        unexplained=bool(diag.unexplained),
        verdict=diag.verdict,
        wall_s=diag.seconds,
    )
    # zero errors the recording's standard baseline holds (a guide's force offset, the
    # quarter car's sensor zeros): not missing physics, said in the verdict when off zero
    found = getattr(diag, "findings", {}).get("baseline_offsets", [])
    offsets = [o for o in found if o["significant"]]
    row["baseline_offsets"] = [o["channel"] for o in offsets]
    if kind == "single":
        want = LABEL_FAMILY.get(labels[0], labels[0])
        row["right"] = bool(named) and named[0] == want
        if row["right"] and getattr(diag, "named", None):
            row["parameters"] = parameter_errors(truth["effects"][0], diag.named[0])
        if want == "sensor_offset" and not named and not diag.unexplained:
            # right when the baseline's offset on the offset channel is said to be off zero
            channel = truth["effects"][0].get("params", {}).get("channel")
            row["right"] = channel in row["baseline_offsets"]
    elif kind == "control":
        row["right"] = not named and not diag.unexplained
    else:
        row["right"] = bool(diag.unexplained)
    return row


def diagnose_case(work: Path, cid: str) -> dict[str, Any]:
    """Diagnose one generated case as a user would and score it (module docstring)."""
    from suspenv.diagnosis.engine import diagnose
    from suspenv.measurements import load_recording

    truth = json.loads((work / "truth" / f"{cid}.json").read_text())
    rec = load_recording(work / "cases" / f"{cid}.npz")
    c0 = time.process_time()
    t0 = time.perf_counter()
    try:
        diag = diagnose(rec, str(rec.meta.get("rig", {}).get("device", truth["family"])))
        row = score_case(truth, diag)
    except Exception as exc:  # a refusal or a failure is a miss, kept with its message
        row = score_case(truth, None, f"{type(exc).__name__}: {exc}")
    row["wall_s"] = time.perf_counter() - t0
    row["cpu_s"] = time.process_time() - c0
    return row


def _finished(work: Path, ids: list[str]) -> dict[str, dict[str, Any]]:
    """Rows already scored in ``work/rows.jsonl`` for cases of ``ids`` (a stopped run
    resumes from them); a truncated last line (a kill mid-write) is ignored."""
    path = work / "rows.jsonl"
    done: dict[str, dict[str, Any]] = {}
    if not path.is_file():
        return done
    for line in path.read_text().splitlines():
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
        if row.get("case_id") in ids:
            done[row["case_id"]] = row
    return done


def run(seeds: str, work: Path, jobs: int = 1, resume: bool = False) -> dict[str, Any]:
    """Generate, diagnose and score every case of ``seeds`` in ``work``; ``jobs`` worker
    processes (the times are per case: wall and the worker's process CPU). ``resume``:
    keep the rows ``work/rows.jsonl`` already holds for these cases (the cases are
    generated again, identically, from their seeds); otherwise start a new file."""
    from concurrent.futures import ProcessPoolExecutor

    from benchmarks.independent.generate import main as generate

    generate(["--out", str(work), "--seeds", seeds, "--overwrite", "--jobs", str(jobs)])
    manifest = json.loads((work / "manifest.json").read_text())
    ids = list(manifest.get("cases") or manifest.get("case_ids") or [])
    done = _finished(work, ids) if resume else {}
    if not resume:
        (work / "rows.jsonl").unlink(missing_ok=True)
    todo = [cid for cid in ids if cid not in done]
    with ProcessPoolExecutor(max_workers=max(1, jobs)) as pool:
        futures = [pool.submit(diagnose_case, work, cid) for cid in todo]
        for i, fut in enumerate(futures):
            row = fut.result()
            done[row["case_id"]] = row
            # one line per case as it finishes: a stopped run keeps what it scored
            with (work / "rows.jsonl").open("a") as fh:
                fh.write(json.dumps(to_jsonable(row)) + "\n")
            print(
                f"[{i + 1}/{len(todo)}] {row['case_id']}: {'right' if row['right'] else 'MISS'} "
                f"({row['wall_s']:.1f} s) {str(row['verdict'])[:110]}",
                flush=True,
            )
    rows = [done[cid] for cid in ids]
    return {
        "seeds": seeds,
        "generator": manifest.get("generator"),
        "cases": rows,
        "resumed_rows": len(ids) - len(todo),
    }


def summarise(result: dict[str, Any]) -> dict[str, Any]:
    """Rates per family and in total (see the module docstring)."""
    groups: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in result["cases"]:
        groups[r["family"]].append(r)
        groups["all"].append(r)
    out = {}
    for fam, rows in groups.items():

        def rate(kind: str, rows: list[dict[str, Any]] = rows) -> tuple[int, int]:
            sel = [r for r in rows if r["kind"] == kind]
            return sum(bool(r["right"]) for r in sel), len(sel)

        wall = [r["wall_s"] for r in rows]
        cpu = [r["cpu_s"] for r in rows]
        single, control, outside = rate("single"), rate("control"), rate("outside")
        errors = [e["rel_error"] for r in rows for e in r.get("parameters", {}).values()]
        out[fam] = {
            "single_named_first": single,
            "parameters_within_20_percent": (
                sum(e <= PARAMETER_TOLERANCE for e in errors),
                len(errors),
            ),
            "parameter_error_median": float(np.median(errors)) if errors else float("nan"),
            "control_false_alarms": (control[1] - control[0], control[1]),
            "outside_unexplained": outside,
            "refused": sum(bool(r["refused"]) for r in rows),
            "wall_s_median": float(np.median(wall)),
            "wall_s_max": float(np.max(wall)),
            "cpu_s_median": float(np.median(cpu)),
            "cpu_s_max": float(np.max(cpu)),
        }
    return out


def _frac(pair: tuple[int, int]) -> str:
    k, n = pair
    return f"{k}/{n} ({100 * k / n:.0f} %)" if n else "-"


def _parameters(s: dict[str, Any]) -> str:
    """``k/n (p %), median e %`` of the compared parameters ("-" where none)."""
    k, n = s.get("parameters_within_20_percent", (0, 0))
    if not n:
        return "-"
    return f"{_frac((k, n))}, {100 * s['parameter_error_median']:.2g} %"


def table_markdown(summary: dict[str, Any], seeds: str) -> str:
    families = ("damper", "mr_damper", "friction_guide", "quarter_car_rig")
    order = [f for f in families if f in summary]
    lines = [
        f"Independent generator (`benchmarks.independent`), reported seeds {seeds}; "
        "every case diagnosed with the defaults, the model and rig from the recording's "
        "metadata.",
        "",
        "| family | one effect named first (target >= 90 %) | controls: false alarms "
        "(target <= 10 %) | outside the library: reported unexplained (target >= 90 %) "
        "| parameters within 20 % (median error) | refused | time median / max, wall (CPU) |",
        "|---|---|---|---|---|---|---|",
    ]
    for fam in [*order, "all"]:
        s = summary[fam]
        lines.append(
            f"| {fam} | {_frac(s['single_named_first'])} | {_frac(s['control_false_alarms'])} "
            f"| {_frac(s['outside_unexplained'])} | {_parameters(s)} | {s['refused']} | "
            f"{s['wall_s_median']:.1f} s ({s['cpu_s_median']:.1f} s) / "
            f"{s['wall_s_max']:.1f} s ({s['cpu_s_max']:.1f} s) |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", default=REPORT_SEEDS)
    ap.add_argument("--out", default=None, help="folder for the generated cases (default: temp)")
    ap.add_argument("--no-docs", action="store_true", help="do not rewrite docs/")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    ap.add_argument(
        "--resume", action="store_true", help="keep the rows of --out's rows.jsonl (a stopped run)"
    )
    args = ap.parse_args(argv)
    if args.resume and not args.out:
        ap.error("--resume needs --out (the folder of the stopped run)")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(args.out) if args.out else Path(tmp)
        t0 = time.perf_counter()
        result = run(args.seeds, work, args.jobs, args.resume)
    result["summary"] = summarise(result)
    result["command"] = "python -m benchmarks.independent_diagnosis"
    result["machine"] = machine_info()
    result["wall_s"] = time.perf_counter() - t0
    table = table_markdown(result["summary"], args.seeds)
    print(table)
    if not args.no_docs:
        out = Path("docs") / "benchmarks"
        out.mkdir(parents=True, exist_ok=True)
        (out / "independent_diagnosis.json").write_text(json.dumps(result, indent=2) + "\n")
        from benchmarks.diagnosis_benchmark import update_doc

        update_doc(Path("docs") / "diagnosis.md", table, DOC_BEGIN, DOC_END)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
