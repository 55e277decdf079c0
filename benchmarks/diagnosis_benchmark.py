"""Blind benchmark of the diagnosis engine, plus the real-data rows.

``run_benchmark_pipeline(config, run_dir)`` (pipeline ``"diagnosis_benchmark"``)
generates concealed cases (:mod:`benchmarks.component_truth`) for every family, seed
and number of effects, runs :func:`suspenv.diagnosis.engine.diagnose` on each
without the truth, then scores the findings against the truth:

- top-1 naming accuracy on single-effect cases (signature family and exact kind),
- false alarms on no-effect controls (white, coloured and drifting noise): an element
  named or a residual called unexplained,
- cases with physics outside the library (``outside = true``): reported as an
  unexplained residual,
- two-effect cases: both effects found,
- held-out RMS error before/after where an effect exists (median reduction),
- recovered effect parameters vs truth (median relative error, same kind named),
- time per diagnosis;

and adds one row per real recording (EMPS, MR damper, damper dyno;
:mod:`suspenv.measurements.catalog`) with the published physics to compare against.
Rows are appended to ``rows.jsonl`` as they finish (a killed run resumes where it
stopped); the score table is written to ``table.md`` and ``benchmark.json``. Run from the
command line (:func:`main`), it also rewrites the table in ``docs/diagnosis.md``
(:func:`update_doc`) and ``docs/benchmarks/diagnosis_benchmark.json``.

The development seed set and the reported seed set are both stated in the config
(``seeds_dev``, ``seeds_report``) and must not overlap; ``seed_set`` picks one.

Run the committed configuration with
``python -m benchmarks.diagnosis_benchmark experiments/diagnosis_benchmark.toml``.
"""

from __future__ import annotations

import argparse
import difflib
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import machine_info
from benchmarks.component_truth import (
    CONDITIONS,
    Case,
    condition_families,
    make_case,
    write_case,
)
from suspenv.core.errors import ValidationError
from suspenv.core.jsonable import to_jsonable
from suspenv.diagnosis.engine import Diagnosis, diagnose, make_family
from suspenv.diagnosis.hypothesis import family_of, split_candidate
from suspenv.measurements.catalog import REAL_CASES, real_data_dir
from suspenv.reports.diagnosis import write_diagnosis_report

DEFAULT_FAMILIES = ("damper", "mr_damper", "friction_guide", "quarter_car_rig")


# ------------------------------------------------------------------ scoring
#: an element whose parameters include another family's effect as a special part
#: (a gas spring's preload is a constant force offset)
CONTAINS: dict[str, tuple[str, ...]] = {
    "directional_friction": ("friction", "sensor_offset"),
    "gas_spring": ("spring", "sensor_offset"),
    "asymmetric_digressive_damping": ("digressive", "damper_asymmetry"),
}


def families_covered(kinds: Sequence[str]) -> set[str]:
    """Signature families the named kinds account for, structural equivalents included."""
    out: set[str] = set()
    for k in kinds:
        out.add(family_of(k))
        out.update(CONTAINS.get(k, ()))
    return out


def derived_values(kind: str, params: dict[str, dict[str, float]], name: str) -> dict[str, float]:
    """Values of the equivalent combination (e.g. Coulomb level and offset of a
    direction-dependent friction), for comparison with published figures."""
    if kind == "directional_friction":
        fp = params[f"{name}.f_pos"]["value"]
        fn = params[f"{name}.f_neg"]["value"]
        return {"coulomb_friction.f_c": 0.5 * (fp + fn), "force_offset.offset": 0.5 * (fp - fn)}
    return {}


def param_errors(diag: Diagnosis, case: Case) -> list[float]:
    """Relative errors |fit - truth| / |truth| of the parameters of truly present and
    correctly named (same kind) effects; fixed parameters are not fitted and skipped."""
    fitted = {}
    for h in diag.named:
        for name, p in h.params.items():
            fitted[name] = p["value"]
    errs = []
    for eff in case.truth.effects:
        for pname, true in eff["params"].items():
            key = f"{eff['kind']}.{pname}"
            if key in fitted and abs(true) > 0:
                errs.append(abs(fitted[key] - true) / abs(true))
    return errs


def score_case(diag: Diagnosis, case: Case) -> dict[str, Any]:
    """One blind case scored against its truth. A control is a false alarm when anything
    is named or a residual is called unexplained; under the condition ``input_missing``
    (a force switched by an unrecorded signal) a residual called unexplained is the right
    report, and only an element named is a false alarm."""
    cond = (case.truth.condition or {}).get("kind")
    truth_kinds = case.truth.kinds
    truth_fams = [family_of(k) for k in truth_kinds]
    named = diag.named_kinds
    named_fams = diag.named_families
    c = diag.comparison
    errs = param_errors(diag, case)
    # kinds the first named effect was reported inseparable from ("cannot separate A from
    # B with this data; test T would")
    inseparable = [
        split_candidate(k)[0]
        for a in diag.ambiguities
        if named[:1] == [split_candidate(a.a)[0]]
        for k in str(a.b).split("+")
    ]
    row: dict[str, Any] = {
        "case": case.truth.case_id,
        "family": case.truth.family,
        "n_true": len(truth_kinds),
        "truth": "+".join(truth_kinds) or "none",
        "named": "+".join(named) or "none",
        "top1_family_ok": bool(named_fams[:1] and named_fams[0] in truth_fams),
        "top1_kind_ok": bool(named[:1] and named[0] in truth_kinds),
        "inseparable_from_first": inseparable,
        "top1_family_or_inseparable": bool(
            (named_fams[:1] and named_fams[0] in truth_fams)
            or any(family_of(k) in truth_fams for k in inseparable)
        ),
        "all_found": bool(set(truth_fams) <= set(named_fams)) if truth_kinds else not named,
        "all_found_equivalent": bool(set(truth_fams) <= families_covered(named))
        if truth_kinds
        else not named,
        "outside": bool(case.truth.outside),
        "unexplained": bool(diag.unexplained),
        # the residual check's largest structured / noise RMS ratio over the channels
        "residual_ratio": max((float(q.ratio) for q in (diag.residual or [])), default=None),
        "noise_kind": case.truth.noise_kind,
        # a control is a false alarm when anything is named or a residual is called
        # unexplained; an outside case is never a control
        "false_alarm": bool(not truth_kinds and not case.truth.outside)
        and bool(named or (diag.unexplained and cond != "input_missing")),
        "condition": cond,
        # the missing-input check called the residual driven by an unrecorded input
        "missing_input_said": bool(getattr(diag.findings.get("missing_input"), "remains", False)),
        "assumptions": diag.assumptions,
        "heldout_before": diag.baseline["heldout_rms"][diag.channel],
        "heldout_after": (c.heldout_rms_after[diag.channel] if c else float("nan")),
        "heldout_reduction": (c.heldout_reduction if c else 0.0),
        "param_rel_err_median": float(np.median(errs)) if errs else float("nan"),
        "param_rel_errs": errs,
        "ambiguities": [a.sentence() for a in diag.ambiguities],
        "seconds": diag.seconds,
        "noise_fraction": case.truth.noise_fraction,
    }
    return row


#: keys of the per-case audit rows written into the benchmark JSON
CASE_KEYS = (
    "case",
    "family",
    "outside",
    "unexplained",
    "residual_ratio",
    "noise_kind",
    "truth",
    "named",
    "seconds",
    "cpu_seconds",
    "heldout_before",
    "heldout_after",
    "heldout_reduction",
    "param_rel_errs",
    "ambiguities",
    "inseparable_from_first",
    "condition",
    "missing_input_said",
    "assumptions",
)


def case_record(row: dict[str, Any]) -> dict[str, Any]:
    """One blind case for the audit table: case id, family, truth kinds, named kinds,
    wall and process-CPU seconds, held-out RMS before/after, parameter errors."""
    out = {k: row.get(k) for k in CASE_KEYS}
    out["truth"] = [k for k in str(row["truth"]).split("+") if k != "none"]
    out["named"] = [k for k in str(row["named"]).split("+") if k != "none"]
    return out


def _found_equivalent(row: dict[str, Any]) -> bool:
    """Both truths accounted for, counting an element that contains another (e.g. a
    direction-dependent friction = friction + offset); recomputed from the row."""
    truth = [k for k in row["truth"].split("+") if k != "none"]
    named = [k for k in row["named"].split("+") if k != "none"]
    return {family_of(k) for k in truth} <= families_covered(named)


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Aggregate scores of the blind rows (targets in brackets in the table)."""
    single = [r for r in rows if r["n_true"] == 1]
    double = [r for r in rows if r["n_true"] == 2]
    none = [r for r in rows if r["n_true"] == 0 and not r.get("outside")]
    outside = [r for r in rows if r.get("outside")]
    with_eff = [r for r in rows if r["n_true"] > 0]
    errs = [e for r in with_eff for e in r["param_rel_errs"]]

    def mean(key: str, rs: list[dict[str, Any]]) -> float:
        # rows of an earlier version of the benchmark lack the newer keys (False)
        return float(np.mean([bool(r.get(key, False)) for r in rs])) if rs else float("nan")

    secs = [r["seconds"] for r in rows]
    cpus = [r["cpu_seconds"] for r in rows if r.get("cpu_seconds") is not None]
    return {
        "n_cases": len(rows),
        "single_top1_family": mean("top1_family_ok", single),
        "single_top1_kind": mean("top1_kind_ok", single),
        "single_top1_family_or_inseparable": float(
            np.mean([r.get("top1_family_or_inseparable", r["top1_family_ok"]) for r in single])
        )
        if single
        else float("nan"),
        "double_top1_family": mean("top1_family_ok", double),
        "double_both_found": mean("all_found", double),
        "double_both_found_equivalent": float(
            np.mean([_found_equivalent(r) for r in double]) if double else np.nan
        ),
        "control_false_alarm": mean("false_alarm", none),
        "outside_unexplained": mean("unexplained", outside),
        # the missing-input check called a residual driven by an unrecorded input
        "missing_input_said": mean("missing_input_said", rows),
        "single_unexplained": mean("unexplained", single),
        "median_heldout_reduction": float(np.median([r["heldout_reduction"] for r in with_eff]))
        if with_eff
        else float("nan"),
        "median_param_rel_err": float(np.median(errs)) if errs else float("nan"),
        "n_param_compared": len(errs),
        "median_seconds": float(np.median(secs)) if secs else float("nan"),
        "max_seconds": float(np.max(secs)) if secs else float("nan"),
        "median_cpu_seconds": float(np.median(cpus)) if cpus else float("nan"),
        "max_cpu_seconds": float(np.max(cpus)) if cpus else float("nan"),
    }


def per_family(rows: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    fams = sorted({r["family"] for r in rows})
    return {f: summarise([r for r in rows if r["family"] == f]) for f in fams}


def per_condition(rows: list[dict[str, Any]], seeds: list[int]) -> dict[str, Any]:
    """Scores of the cases under each blind user's condition, over all its families and
    per family: named first (single effect, signature family) and false alarms on the
    controls (:func:`score_case`), with the seed set fixed in the config before the run."""
    out: dict[str, Any] = {}
    for cond in sorted({str(r["condition"]) for r in rows}):
        rs = [r for r in rows if r["condition"] == cond]
        out[cond] = {
            "seeds": seeds,
            "seeds_fixed": "in the committed config before the run",
            "all": summarise(rs),
            "per_family": per_family(rs),
        }
    return out


# ------------------------------------------------------------------ real data
def _checks(params: dict[str, Any], expect: dict[str, Any]) -> dict[str, dict[str, float]]:
    """Fitted values against the published ones (``expect["check"]``), with the relative
    error."""
    out = {}
    for key, ref in expect.get("check", {}).items():
        if key in params:
            out[key] = {
                "value": params[key]["value"],
                "published": ref,
                "rel_err": abs(params[key]["value"] - ref) / abs(ref),
            }
    return out


def real_row(name: str, diag: Diagnosis, expect: dict[str, Any]) -> dict[str, Any]:
    c = diag.comparison
    params = dict(diag.final_params)
    for h in diag.named:
        for k, v in derived_values(h.kind, h.params, h.kind).items():
            params.setdefault(k, {"value": v})
    checks = _checks(params, expect)
    # the first named element on the baseline: the structure a published model often has
    # (e.g. EMPS: Coulomb + viscous + offset), compared whatever the engine names after it
    first = diag.named[0].comparison if diag.named else None
    first_checks = _checks(dict(first.params_after), expect) if first is not None else {}
    found = {f: f in diag.named_families for f in expect.get("families", [])}
    return {
        "case": f"real:{name}",
        "family": diag.model,
        "verdict": diag.verdict,
        "named": "+".join(diag.named_kinds) or "none",
        "expected": expect["named"],
        "expected_found": found,
        "published": expect["published"],
        "heldout_before": diag.baseline["heldout_rms"][diag.channel],
        "heldout_after": c.heldout_rms_after[diag.channel] if c else float("nan"),
        "heldout_reduction": c.heldout_reduction if c else 0.0,
        "checks": checks,
        "checks_first_element": first_checks,
        "ambiguities": [a.sentence() for a in diag.ambiguities],
        "asymmetry": diag.asymmetry.to_dict() if diag.asymmetry else None,
        "seconds": diag.seconds,
    }


# ------------------------------------------------------------------ pipeline
def _seeds(b: dict[str, Any]) -> tuple[list[int], str]:
    dev = [int(s) for s in b.get("seeds_dev", range(0, 10))]
    rep = [int(s) for s in b.get("seeds_report", range(100, 110))]
    overlap = sorted(set(dev) & set(rep))
    if overlap:
        raise ValidationError(
            f"`seeds_dev` and `seeds_report` must not overlap, but both contain {overlap}"
        )
    which = str(b.get("seed_set", "report"))
    if which not in ("dev", "report"):
        raise ValidationError(f"`seed_set in ('dev', 'report')` must hold, but got {which!r}")
    return (dev if which == "dev" else rep), which


#: keys of the ``[benchmark]`` table
BENCHMARK_KEYS = (
    "families",
    "separate_families",
    "n_effects",
    "seeds_dev",
    "seeds_report",
    "seed_set",
    "real_data",
    "real_data_dir",
    "real_cases",
    "outside",
    "conditions",
    "condition_effects",
)


def check_benchmark_config(config: dict[str, Any]) -> dict[str, Any]:
    """Check a "diagnosis_benchmark" config before any work: table keys, seed sets,
    families and each family's diagnosis options (by building the family)."""
    b = dict(config.get("benchmark", {}) or {})
    for key in sorted(set(b) - set(BENCHMARK_KEYS)):
        near = difflib.get_close_matches(key, BENCHMARK_KEYS, n=1)
        hint = f"; did you mean {near[0]!r}?" if near else ""
        raise ValidationError(f"config: unknown key benchmark.{key!r}{hint}")
    _seeds(b)
    diagnosis = dict(config.get("diagnosis", {}) or {})
    opts = {k: v for k, v in diagnosis.items() if k not in ("family", "holdout")}
    fam_opts = dict(diagnosis.get("family", {}) or {})
    families = list(b.get("families", DEFAULT_FAMILIES))
    for fam in sorted(set(fam_opts) - set(families)):
        raise ValidationError(
            f"config: `diagnosis.family.{fam}` names a family the benchmark does not run "
            f"(benchmark.families = {families})"
        )
    for fam in families:
        own = {k: v for k, v in dict(fam_opts.get(fam, {})).items() if k != "holdout"}
        make_family(fam, **(opts | own))
    for n in b.get("n_effects", (0, 1, 2)):
        if not isinstance(n, int) or isinstance(n, bool) or not 0 <= n <= 3:
            raise ValidationError(
                f"config: `benchmark.n_effects` must hold integers in [0, 3], but got {n!r}"
            )
    for cond in b.get("conditions", []):
        if cond not in CONDITIONS:
            raise ValidationError(
                f"config: `benchmark.conditions` must hold names in {CONDITIONS}, but got {cond!r}"
            )
    for name in b.get("real_cases", []):
        if name not in REAL_CASES:
            raise ValidationError(
                f"config: unknown real case {name!r} in benchmark.real_cases "
                f"(known: {', '.join(sorted(REAL_CASES))})"
            )
    return config


def _load_rows(path: Path) -> dict[str, dict[str, Any]]:
    rows: dict[str, dict[str, Any]] = {}
    if path.is_file():
        for line in path.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                rows[r["case"]] = r
    return rows


def _append(path: Path, row: dict[str, Any]) -> None:
    with path.open("a") as fh:
        fh.write(json.dumps(to_jsonable(row)) + "\n")


def run_benchmark_pipeline(config: dict[str, Any], run_dir: Path) -> dict[str, Any]:
    """Run the blind benchmark described by ``config``; write results into ``run_dir``."""
    from tqdm import tqdm

    b = dict(config.get("benchmark", {}))
    opts = {k: v for k, v in dict(config.get("diagnosis", {})).items() if k != "family"}
    # per-family overrides, e.g. [diagnosis.family.quarter_car_rig] max_nfev = 30
    fam_opts = dict(dict(config.get("diagnosis", {})).get("family", {}))
    families = list(b.get("families", DEFAULT_FAMILIES))
    n_effects = [int(n) for n in b.get("n_effects", (0, 1, 2))]
    seeds, which = _seeds(b)
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    rows_path = run_dir / "rows.jsonl"
    done = _load_rows(rows_path)
    kinds: list[int | str] = [*n_effects, *(["out"] if b.get("outside", False) else [])]
    jobs = [(f, n, s, "") for f in families for n in kinds for s in seeds]
    # the blind user's conditions, on the same seed set, fixed before the run
    conds = list(b.get("conditions", []))
    jobs += [
        (f, int(n), s, c)
        for c in conds
        for f in families
        if f in condition_families(c)
        for n in b.get("condition_effects", (0, 1))
        for s in seeds
    ]
    for fam, n, seed, cond in tqdm(jobs, desc="blind cases", unit="case"):
        case_id = f"{fam}-{n}-{seed}" + (f"-{cond}" if cond else "")
        if case_id in done:
            continue
        case = (
            make_case(fam, seed, 0, outside=True)
            if n == "out"
            else make_case(fam, seed, int(n), condition=cond or None)
        )
        write_case(case, run_dir / "cases", run_dir / "truth")
        cpu0 = time.process_time()
        family_opts = opts | dict(fam_opts.get(fam, {}))
        hold = family_opts.pop("holdout", None)
        diag = diagnose(case.recording, make_family(fam, **family_opts), holdout=hold)
        row = score_case(diag, case)
        # process CPU time next to the wall time: load from other jobs shows as the gap
        row["cpu_seconds"] = time.process_time() - cpu0
        _append(rows_path, row)
        done[case_id] = to_jsonable(row)

    real_rows = []
    root = Path(b.get("real_data_dir") or real_data_dir())
    if b.get("real_data", True) and root.is_dir():
        for name in b.get("real_cases", list(REAL_CASES)):
            key = f"real:{name}"
            if key in done:
                real_rows.append(done[key])
                continue
            fit, hold, fam, expect = REAL_CASES[name](root)
            real_opts = {k: v for k, v in opts.items() if k != "holdout"}
            cpu0 = time.process_time()
            diag = diagnose(fit, make_family(fam, **real_opts), holdout=hold)
            cpu = time.process_time() - cpu0
            write_diagnosis_report(diag, run_dir / "real" / name)
            row = real_row(name, diag, expect)
            row["cpu_seconds"] = cpu
            _append(rows_path, row)
            done[key] = to_jsonable(row)
            real_rows.append(done[key])

    every = [done[f"{f}-{n}-{s}" + (f"-{c}" if c else "")] for f, n, s, c in jobs]
    blind_rows = [r for r in every if not r.get("condition")]
    # families scored on their own (not in the headline totals), e.g. the quarter car
    separate = set(b.get("separate_families", []))
    summary = summarise([r for r in blind_rows if r["family"] not in separate])
    summary["seed_set"] = which
    summary["seeds"] = seeds
    summary["separate_families"] = sorted(separate & set(families))
    result = {
        "summary": summary,
        "per_family": per_family(blind_rows),
        "conditions": per_condition([r for r in every if r.get("condition")], seeds),
        "real": real_rows,
        "cases": [case_record(r) for r in every],
        "config": config,
    }
    (run_dir / "benchmark.json").write_text(json.dumps(to_jsonable(result), indent=2) + "\n")
    (run_dir / "table.md").write_text(table_markdown(result) + "\n")
    return summary


# ------------------------------------------------------------------ table
def _pct(v: Any) -> str:
    return f"{100 * v:.0f} %" if isinstance(v, float) and np.isfinite(v) else "n/a"


def _secs(f: dict[str, Any], which: str) -> str:
    """``"12.3 s (11.9 s)"``: wall seconds and, where recorded, process CPU seconds
    (``which``: "median", "max", or "" for a single row's own times)."""
    key = f"{which}_" if which else ""
    wall = f"{f[f'{key}seconds']:.1f} s"
    cpu = f.get(f"{key}cpu_seconds", float("nan"))
    return f"{wall} ({cpu:.1f} s)" if isinstance(cpu, float) and np.isfinite(cpu) else wall


def _condition_table(conds: dict[str, Any]) -> list[str]:
    """Rows of the blind user's conditions (target: named first >= 95 %, false alarms
    <= 5 %), over all families and per family."""
    if not conds:
        return []
    L = [
        "",
        "| condition (not declared by the recording) | family | cases | single effect: named "
        "first [>= 95 %] | controls: false alarm [<= 5 %] | residual called unexplained | "
        "residual called driven by an unrecorded input | time median: wall (CPU) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for cond, c in conds.items():
        for fam, f in [("all", c["all"]), *c["per_family"].items()]:
            L.append(
                f"| {cond} | {fam} | {f['n_cases']} | {_pct(f['single_top1_family'])} | "
                f"{_pct(f['control_false_alarm'])} | {_pct(f['single_unexplained'])} (single) | "
                f"{_pct(f.get('missing_input_said', float('nan')))} (all) | {_secs(f, 'median')} |"
            )
    return L


def table_markdown(result: dict[str, Any]) -> str:
    """The score table (blind summary, per family, real data) as Markdown."""
    s = result["summary"]
    sep = s.get("separate_families", [])
    note = f" Totals leave out {', '.join(sep)}, scored on its own row below." if sep else ""
    L = [
        f"Blind cases: {s['n_cases']} ({s['seed_set']} seed set {s['seeds']}).{note}",
        "",
        "| score | value | target |",
        "|---|---|---|",
        f"| single effect: right effect named first (signature family) | "
        f"{_pct(s['single_top1_family'])} | >= 90 % |",
        f"| single effect: right effect named first (exact kind) | {_pct(s['single_top1_kind'])} "
        "| |",
        f"| single effect: right effect named first, or reported as inseparable from the "
        f'first ("cannot separate A from B with this data; test T would") | '
        f"{_pct(s.get('single_top1_family_or_inseparable', float('nan')))} | |",
        f"| two effects: both found | {_pct(s['double_both_found'])} | |",
        f"| two effects: both found, counting an element that contains the other "
        f"(direction-dependent friction = friction + offset; gas spring = spring + preload) | "
        f"{_pct(s.get('double_both_found_equivalent', float('nan')))} | |",
        f"| no-effect controls (white, coloured, drifting noise): effect claimed or residual "
        f"called unexplained | {_pct(s['control_false_alarm'])} | <= 10 % |",
        f"| physics outside the library: reported as unexplained residual | "
        f"{_pct(s.get('outside_unexplained', float('nan')))} | >= 90 % |",
        f"| single effect: residual left called unexplained after naming | "
        f"{_pct(s.get('single_unexplained', float('nan')))} | |",
        f"| median held-out RMS reduction where an effect exists | "
        f"{_pct(s['median_heldout_reduction'])} | >= 50 % |",
        f"| median relative error of recovered effect parameters ({s['n_param_compared']}) | "
        f"{_pct(s['median_param_rel_err'])} | <= 20 % |",
        f"| time per diagnosis: median / max, wall (process CPU) | {_secs(s, 'median')} / "
        f"{_secs(s, 'max')} | < 30 s |",
        "",
        "| family | cases | top-1 (single) | false alarm | outside: unexplained | both found "
        "(two) | held-out reduction | param error | time median / max: wall (CPU) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for fam, f in result["per_family"].items():
        L.append(
            f"| {fam} | {f['n_cases']} | {_pct(f['single_top1_family'])} | "
            f"{_pct(f['control_false_alarm'])} | "
            f"{_pct(f.get('outside_unexplained', float('nan')))} | "
            f"{_pct(f['double_both_found'])} | "
            f"{_pct(f['median_heldout_reduction'])} | {_pct(f['median_param_rel_err'])} | "
            f"{_secs(f, 'median')} / {_secs(f, 'max')} |"
        )
    L += _condition_table(result.get("conditions", {}))
    if result["real"]:
        L += [
            "",
            "| real recording | named (in order) | expected (published physics) | expected "
            "found | held-out RMS before -> after | checks | time: wall (CPU) |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in result["real"]:
            checks = "; ".join(
                f"{k} = {c['value']:.4g} (published {c['published']:.4g}, "
                f"{100 * c['rel_err']:.0f} % off)"
                for k, c in r["checks"].items()
            )
            first = r.get("checks_first_element") or {}
            if first and first != r["checks"]:
                checks += "; with the first named element only: " + "; ".join(
                    f"{k} = {c['value']:.4g} ({100 * c['rel_err']:.0f} % off)"
                    for k, c in first.items()
                )
            amb = " ".join(r["ambiguities"])
            if r.get("asymmetry"):
                amb = f"{amb} Asymmetry check: {r['asymmetry']['sentence']}".strip()
            found = ", ".join(
                f"{k}: {'yes' if v else 'no'}" for k, v in r.get("expected_found", {}).items()
            )
            L.append(
                f"| {r['case']} | {r['named']} | {r['expected']} | {found} | "
                f"{r['heldout_before']:.4g} -> {r['heldout_after']:.4g} N "
                f"({-100 * r['heldout_reduction']:+.0f} %) | {checks}{(' ' + amb) if amb else ''} "
                f"| {_secs(r, '')} |"
            )
    return "\n".join(L)


DOC_BEGIN = "<!-- benchmark-table:begin -->"
DOC_END = "<!-- benchmark-table:end -->"


def update_doc(doc: Path, table: str, begin: str = DOC_BEGIN, end: str = DOC_END) -> bool:
    """Replace the table between the markers ``begin`` and ``end`` in ``doc``; False when
    the markers are absent."""
    if not doc.is_file():
        return False
    text = doc.read_text()
    if begin not in text or end not in text:
        return False
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    doc.write_text(f"{head}{begin}\n{table}\n{end}{tail}")
    return True


def main(argv: list[str] | None = None) -> int:
    """``python -m benchmarks.diagnosis_benchmark [CONFIG.toml]``: run the benchmark into
    its run directory (as ``suspenv run`` would), then write the table into
    ``docs/diagnosis.md`` (between its markers) and ``docs/benchmarks/``."""
    from suspenv.runs.config import load_config
    from suspenv.runs.runner import run_experiment

    ap = argparse.ArgumentParser(description="Run the diagnosis benchmark; write its table.")
    ap.add_argument(
        "config",
        nargs="?",
        default="experiments/diagnosis_benchmark.toml",
        help="benchmark config (TOML)",
    )
    config = load_config(ap.parse_args(argv).config)
    t0 = time.perf_counter()
    # as `suspenv run` does: resume only the same experiment of the same code
    run_dir, summary = run_experiment(config)
    result = json.loads((run_dir / "benchmark.json").read_text())
    table = table_markdown(result)
    out = Path("docs") / "benchmarks"
    out.mkdir(parents=True, exist_ok=True)
    result["command"] = (
        "python -m benchmarks.diagnosis_benchmark experiments/diagnosis_benchmark.toml"
    )
    result["machine"] = machine_info()
    (out / "diagnosis_benchmark.json").write_text(json.dumps(result, indent=2) + "\n")
    update_doc(Path("docs") / "diagnosis.md", table)
    print(table)
    print(f"run directory {run_dir}; wall time {time.perf_counter() - t0:.0f} s")
    print(f"summary: {summary}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
