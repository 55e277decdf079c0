"""Blind benchmark of the K&C diagnosis (``python -m suspenv.bench.knc_diagnosis``).

Each case is a truth vehicle with none, one or two concealed effects of random kind,
magnitude, location and noise level (:func:`suspenv.diagnosis.knc.recording.blind_case`,
seeded); the diagnosis sees only the recordings (fit: parallel + opposite travel;
held out: single-wheel travel). Scores against the truth kept apart:

* top-1 naming on one-effect cases; all effects found on two-effect cases;
* false alarms: anything named on a no-effect case, and named kinds that are not in
  the truth on the others;
* held-out RMS (scaled, channel-averaged) of the final model over the baseline's
  (the plain symmetric model fitted to the same data in the same run);
* parameter recovery of correctly named effects: loop width of the wheel load in
  parallel travel (hysteresis, friction) against the truth's noise-free loop,
  right-minus-left static toe (asymmetry), cubic ratio (progressive), gain error
  (sensor gain);
* hysteresis location: the named candidate (lower-arm bushes, top mount, or both)
  against the truth's bushings, strictly and counting a location the diagnosis states
  it cannot separate from the named one;
* time per diagnosis.

Development seeds (``--dev``, 100...) differ from the reported seeds (1000...); only the
reported run writes ``docs/benchmarks/knc_diagnosis.json`` (``--out`` elsewhere). Rows
are appended to ``--rows`` (a JSON-lines file) as they finish, so a killed run loses
nothing and ``--resume`` skips the finished seeds.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from suspenv.bench.common import write_result
from suspenv.diagnosis.evidence import scaled_rms

DEV_SEEDS = tuple(range(100, 112))
REPORT_SEEDS = tuple(range(1000, 1012))
STEPS = 6


def _loop_width_error(diag: Any, truth: dict) -> float:
    from suspenv.diagnosis.knc.recording import measure_truth
    from suspenv.diagnosis.knc.report import loop_width

    exact = measure_truth(
        truth["effects"], truth["seed"], steps=STEPS, noise_scale=0.0, tests=("parallel",)
    )["parallel"]
    pred = diag.final_fit.model.simulate(diag.final_fit.theta, exact)
    true_w = np.mean([loop_width(exact, exact.outputs[f"tyre_fz_{s}"]) for s in ("left", "right")])
    fit_w = np.mean([loop_width(exact, pred[f"tyre_fz_{s}"]) for s in ("left", "right")])
    return float(abs(fit_w / true_w - 1.0)) if true_w else float("nan")


def parameter_error(diag: Any, truth: dict, kind: str) -> float:
    """Relative error of the recovered effect (see the module docstring)."""
    from suspenv.models.mcpherson.params import PARAMETER_NAMES
    from suspenv.models.mcpherson.truth import truth_vehicle

    eff = diag.effect(kind)
    if eff is None:
        return float("nan")
    if kind in ("dahl_hysteresis", "coulomb_friction"):
        return _loop_width_error(diag, truth)
    if kind == "lr_asymmetry":
        tol = truth["effects"]["asymmetry"]
        tv = truth_vehicle(
            truth["seed"],
            hysteresis=False,
            noise=False,
            hard_point_tol_mm=tol["hard_point_tol_mm"],
            stiffness_tol=tol["stiffness_tol"],
            alignment_tol_deg=tol["alignment_tol_deg"],
        )
        j = PARAMETER_NAMES.index("static_toe")
        d = tv.right[j] - tv.left[j]
        return float(abs(eff.params["d_static_toe"] - d) / abs(d))
    if kind == "cubic_stiffness":
        r = truth["effects"]["progressive"]["ratio"]
        return float(abs(eff.params["ratio"] - r) / r)
    if kind == "sensor_gain":
        g = truth["effects"]["sensor_gain"]["gain"]
        return float(abs(eff.params["gain"] - g) / abs(g - 1.0))
    return float("nan")


#: truth bushings with hysteresis -> the candidate that puts it there
VARIANT_OF_BUSHINGS = {
    ("lca_front", "lca_rear", "top_mount"): "dahl_hysteresis",
    ("lca_front", "lca_rear"): "dahl_hysteresis:lower_arm",
    ("top_mount",): "dahl_hysteresis:top_mount",
}


def hysteresis_location(diag: Any) -> str | None:
    """The hysteresis candidate (location variant) the diagnosis named, if any."""
    for h in diag.named:
        if h.kind == "dahl_hysteresis" and h.params:
            return next(iter(h.params)).split(".")[0]
    return None


def run_case(seed: int) -> dict[str, Any]:
    from suspenv.diagnosis.evidence import heldout_rms
    from suspenv.diagnosis.knc.diagnose import diagnose_knc
    from suspenv.diagnosis.knc.recording import blind_case

    case, truth = blind_case(seed, steps=STEPS)
    t0 = time.perf_counter()
    diag = diagnose_knc(case["recordings"], holdout="single")
    seconds = time.perf_counter() - t0
    expected = truth["expected_kinds"]
    named = diag.named_kinds
    before = scaled_rms(heldout_rms(diag.base_fit, diag.heldout_recordings), diag.base_fit.scales)
    after = scaled_rms(heldout_rms(diag.final_fit, diag.heldout_recordings), diag.base_fit.scales)
    errs = {k: parameter_error(diag, truth, k) for k in named if k in expected}
    where = hysteresis_location(diag)
    true_where = None
    if "hysteresis" in truth["effects"]:
        true_where = VARIANT_OF_BUSHINGS[tuple(truth["effects"]["hysteresis"]["bushings"])]
    return {
        "seed": seed,
        "truth": ",".join(expected) or "none",
        "named": ",".join(named) or "none",
        "n_true": len(expected),
        "top1_ok": bool(named[:1] == expected[:1]) if len(expected) == 1 else None,
        "all_found": bool(set(expected) <= set(named)),
        "false_alarms": len([k for k in named if k not in expected]),
        "hysteresis_where": where or "",
        "where_ok": (where == true_where) if (where and true_where) else None,
        "where_ok_or_ambiguous": (
            (where == true_where or true_where in {a.b for a in diag.ambiguities})
            if (where and true_where)
            else None
        ),
        "heldout_ratio": float(after / before) if before > 0 else float("nan"),
        "param_rel_err": float(np.nanmedian(list(errs.values()))) if errs else float("nan"),
        "noise_scale": truth["noise_scale"],
        "seconds": seconds,
    }


def summarise(rows: list[dict]) -> dict[str, Any]:
    one = [r for r in rows if r["n_true"] == 1]
    two = [r for r in rows if r["n_true"] == 2]
    none = [r for r in rows if r["n_true"] == 0]
    eff = [r for r in rows if r["n_true"] > 0]
    errs = [r["param_rel_err"] for r in rows if np.isfinite(r["param_rel_err"])]
    located = [r for r in rows if r.get("where_ok") is not None]
    return {
        "cases": len(rows),
        "top1_accuracy_one_effect": (
            float(np.mean([r["top1_ok"] for r in one])) if one else float("nan")
        ),
        "one_effect_cases": len(one),
        "both_found_two_effects": (
            float(np.mean([r["all_found"] for r in two])) if two else float("nan")
        ),
        "two_effect_cases": len(two),
        "false_alarm_rate_no_effect": (
            float(np.mean([r["false_alarms"] > 0 for r in none])) if none else float("nan")
        ),
        "no_effect_cases": len(none),
        "extra_kinds_named_per_effect_case": (
            float(np.mean([r["false_alarms"] for r in eff])) if eff else float("nan")
        ),
        "hysteresis_location_correct": (
            float(np.mean([r["where_ok"] for r in located])) if located else float("nan")
        ),
        "hysteresis_location_correct_or_stated_ambiguous": (
            float(np.mean([r["where_ok_or_ambiguous"] for r in located]))
            if located
            else float("nan")
        ),
        "hysteresis_located_cases": len(located),
        "median_heldout_ratio_effect_cases": (
            float(np.median([r["heldout_ratio"] for r in eff])) if eff else float("nan")
        ),
        "median_param_rel_err": float(np.median(errs)) if errs else float("nan"),
        "median_seconds_per_diagnosis": float(np.median([r["seconds"] for r in rows])),
        "max_seconds_per_diagnosis": float(np.max([r["seconds"] for r in rows])),
        "steps": STEPS,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dev", action="store_true", help="development seeds (not reported)")
    ap.add_argument("--cases", type=int, default=None, help="only the first N seeds")
    ap.add_argument("--resume", action="store_true", help="skip seeds already in the rows file")
    ap.add_argument("--out", default=None, help="result folder (default docs/benchmarks)")
    ap.add_argument("--rows", default=None, help="JSON-lines file of finished cases")
    args = ap.parse_args(argv)
    seeds = DEV_SEEDS if args.dev else REPORT_SEEDS
    seeds = seeds[: args.cases] if args.cases else seeds
    name = "knc_diagnosis_dev" if args.dev else "knc_diagnosis"
    out = Path(args.out) if args.out else (Path(tempfile.gettempdir()) if args.dev else None)
    rows_path = Path(args.rows or Path(tempfile.gettempdir()) / f"suspenv_{name}.rows.jsonl")
    rows_path.parent.mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []
    if args.resume and rows_path.exists():
        rows = [json.loads(line) for line in rows_path.read_text().splitlines() if line]
    elif rows_path.exists():
        rows_path.unlink()
    done = {r["seed"] for r in rows}
    for seed in tqdm([s for s in seeds if s not in done], desc="K&C blind cases"):
        row = run_case(seed)
        rows.append(row)
        with rows_path.open("a") as f:
            f.write(json.dumps(row) + "\n")
    rows.sort(key=lambda r: r["seed"])
    cmd = "python -m suspenv.bench.knc_diagnosis" + (" --dev" if args.dev else "")
    write_result(name, rows, summarise(rows), cmd, output_dir=out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
