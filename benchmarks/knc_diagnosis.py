"""Blind benchmark of the K&C diagnosis (``python -m benchmarks.knc_diagnosis``).

Each case is a truth vehicle with none, one or two concealed effects
(:func:`suspenv.rigs.knc_truth.blind_case`): the case type comes from a fixed
cycle of 36 (:data:`~suspenv.rigs.knc_truth.BLIND_PLAN`: every single effect
kind and hysteresis location 3 times, 6 two-effect pairs, 6 no-effect controls),
magnitude, location and noise level are drawn from the seed. The diagnosis sees only
the recordings (fit: parallel and opposite travel, lateral and longitudinal compliance;
held out: single-wheel travel).
Scores against the truth kept apart:

* detectability of every concealed effect from the truth:
  :func:`~benchmarks.knc_truth.truth_snr` (the plain model fitted to
  the noise-free loops; signal-to-noise of what it cannot absorb); cases whose
  effect stays below ``DETECTABLE_SNR`` are scored separately, not dropped;
* top-1 naming on one-effect cases; all effects found on two-effect cases;
* false alarms: anything named on a no-effect case, and named kinds that are not in
  the truth on the others;
* held-out RMS (scaled, channel-averaged) of the final model over the baseline's
  (the plain symmetric model fitted to the same data in the same run), against the
  *measured* held-out data (noise included: its floor is the sensor noise, so the
  ratio cannot fall far below 1 however good the model) and, separately, the *model
  error*: the same RMS against the noise-free held-out loops of the truth;
* parameter recovery of correctly named effects: loop width of the wheel load in
  parallel travel (hysteresis, friction) against the truth's noise-free loop,
  right-minus-left static toe (asymmetry), cubic ratio (progressive), gain error
  (sensor gain);
* hysteresis location: the named candidate (lower-arm bushes, top mount, or both)
  against the truth's bushings, strictly and counting a location the diagnosis states
  it cannot separate from the named one;
* wall and process CPU time (``time.process_time``) per diagnosis.

Development seeds (``--dev``, 100-135) differ from the reported seeds (1000-1035); only the
reported run writes ``docs/benchmarks/knc_diagnosis.json`` (``--out`` elsewhere). Rows
are appended to ``--rows`` (a JSON-lines file) as they finish, so a killed run loses
nothing and ``--resume`` skips the finished seeds. ``--outside`` runs the cases outside
the library (seeds 2000-2017, ``knc_outside.json``: a strut bump stop, a progressive or
a preloaded bushing, subframe compliance, load-cell cross-talk, the toe channels'
sign reversed; 3 of each): right is a verdict that names nothing with confidence and
reports the residual left.
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

from benchmarks.common import write_result
from suspenv.diagnosis.evidence import scaled_rms

DEV_SEEDS = tuple(range(100, 136))
REPORT_SEEDS = tuple(range(1000, 1036))
#: cases with physics outside the library (``--outside``, the kind cycling with the seed:
#: strut stop, progressive and preloaded bushings, subframe compliance, load-cell
#: cross-talk, toe sign reversed; :func:`~benchmarks.knc_truth.outside_case`),
#: fixed before their one run: 3 cases of each kind
OUTSIDE_SEEDS = tuple(range(2000, 2018))
STEPS = 6


def _loop_gap_error(diag: Any, truth: dict) -> float:
    from benchmarks.knc_truth import loop_gap_at_static
    from suspenv.rigs.knc_truth import measure_truth

    exact = measure_truth(
        truth["effects"], truth["seed"], steps=STEPS, noise_scale=0.0, tests=("parallel",)
    )["parallel"]
    pred = diag.final_fit.model.simulate(diag.final_fit.theta, exact)
    sides = ("left", "right")
    true_w = np.mean([loop_gap_at_static(exact, exact.outputs[f"tyre_fz_{s}"]) for s in sides])
    fit_w = np.mean([loop_gap_at_static(exact, pred[f"tyre_fz_{s}"]) for s in sides])
    return float(abs(fit_w / true_w - 1.0)) if true_w else float("nan")


def parameter_error(diag: Any, truth: dict, kind: str) -> float:
    """Relative error of the recovered effect (see the module docstring)."""
    from suspenv.models.mcpherson.params import PARAMETER_NAMES
    from suspenv.models.mcpherson.truth import truth_vehicle

    eff = diag.effect(kind)
    if eff is None:
        return float("nan")
    if kind in ("dahl_hysteresis", "coulomb_friction"):
        return _loop_gap_error(diag, truth)
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
    if kind == "sensor_offset":
        o = truth["effects"]["sensor_offset"]["offset"]
        return float(abs(eff.params["offset"] - o) / abs(o))
    return float("nan")


def hysteresis_location(diag: Any) -> str | None:
    """The hysteresis candidate (location variant) the diagnosis named, if any."""
    for h in diag.named:
        if h.kind == "dahl_hysteresis":
            return str(h.candidate)
    return None


def detectability(truth: dict) -> dict[str, dict]:
    """Signal-to-noise of each concealed effect alone (the four fitted tests, noise-free
    truth)."""
    from benchmarks.knc_truth import truth_snr
    from suspenv.rigs.knc_truth import TRUTH_KIND

    return {
        TRUTH_KIND[name]: truth_snr(
            {name: values}, truth["seed"], truth["noise_scale"], steps=STEPS
        )
        for name, values in truth["effects"].items()
    }


def model_error(diag: Any, truth: dict) -> dict[str, float]:
    """Held-out RMS (scaled as the diagnosis' held-out score) of the baseline and the
    final model against the measured data, the noise-free truth, and the noise floor."""
    from benchmarks.knc_truth import noise_levels
    from suspenv.diagnosis.evidence import heldout_rms
    from suspenv.measurements.knc import rig_test
    from suspenv.rigs.knc_truth import measure_truth

    scales = diag.base_fit.scales
    held = diag.heldout_recordings
    exact = measure_truth(
        truth["effects"],
        truth["seed"],
        steps=STEPS,
        noise_scale=0.0,
        tests=tuple(rig_test(r) for r in held),
    )
    clean = [exact[rig_test(r)] for r in held]
    sigma = noise_levels(truth["noise_scale"])
    floor = scaled_rms({c: sigma[c] for c in scales}, scales)
    out = {"noise_floor": floor}
    for label, f in (("base", diag.base_fit), ("final", diag.final_fit)):
        out[f"measured_{label}"] = scaled_rms(heldout_rms(f, held), scales)
        out[f"model_{label}"] = scaled_rms(heldout_rms(f, clean), scales)
    return out


def _ratio(a: float, b: float) -> float:
    return float(a / b) if b > 0 else float("nan")


def run_case(seed: int) -> dict[str, Any]:
    from suspenv.diagnosis.engine import diagnose
    from suspenv.diagnosis.knc.detectability import DETECTABLE_SNR
    from suspenv.rigs.knc_truth import blind_case, truth_effects

    case, truth = blind_case(seed, steps=STEPS)
    t0, c0 = time.perf_counter(), time.process_time()
    diag = diagnose(case["recordings"], "knc", holdout="single")
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    expected = truth["expected_kinds"]
    named = diag.named_kinds
    snr = detectability(truth)
    err = model_error(diag, truth)
    excess = [
        np.sqrt(max(err[f"measured_{k}"] ** 2 - err["noise_floor"] ** 2, 0.0))
        for k in ("base", "final")
    ]
    errs = {k: parameter_error(diag, truth, k) for k in named if k in expected}
    where = hysteresis_location(diag)
    # the truth's hysteresis is the candidate effect that puts it where it is
    concealed, _ = truth_effects(truth["effects"])
    true_where = next((e.name for e in concealed if e.kind == "dahl_hysteresis"), None)
    return {
        "seed": seed,
        "case_type": truth["case_type"],
        "truth": ",".join(expected) or "none",
        "named": ",".join(named) or "none",
        "n_true": len(expected),
        "snr": ",".join(f"{snr[k]['snr']:.1f}" for k in expected),
        "detectable": all(snr[k]["snr"] >= DETECTABLE_SNR for k in expected) if expected else None,
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
        "heldout_ratio": _ratio(err["measured_final"], err["measured_base"]),
        "model_error_ratio": _ratio(err["model_final"], err["model_base"]),
        "excess_ratio": _ratio(excess[1], excess[0]),
        "model_error_base": err["model_base"],
        "noise_floor": err["noise_floor"],
        "param_rel_err": float(np.nanmedian(list(errs.values()))) if errs else float("nan"),
        "noise_scale": truth["noise_scale"],
        "seconds": seconds,
        "cpu_seconds": cpu,
        "verdict": diag.verdict,
    }


def run_outside_case(seed: int) -> dict[str, Any]:
    """One case outside the library: right when the verdict names nothing with
    confidence and reports the residual left."""
    from benchmarks.knc_truth import outside_case
    from suspenv.diagnosis.engine import diagnose

    case, truth = outside_case(seed, steps=STEPS)
    c0 = time.process_time()
    diag = diagnose(case["recordings"], "knc", holdout="single")
    left = diag.findings.get("residual_left")
    return {
        "seed": seed,
        "kind": truth["case_type"],
        "params": json.dumps(truth["outside"]),
        "noise_scale": truth["noise_scale"],
        "named": ",".join(diag.named_kinds) or "none",
        "confident": diag.confident,
        "unexplained": diag.unexplained,
        "residual_x_noise": left.numbers["worst_rms"] if left is not None else float("nan"),
        "cpu_seconds": time.process_time() - c0,
        "verdict": diag.verdict,
    }


def summarise_outside(rows: list[dict]) -> dict[str, Any]:
    kinds = sorted({r["kind"] for r in rows})
    return {
        "cases": len(rows),
        "reported_unexplained": sum(r["unexplained"] for r in rows) / max(len(rows), 1),
        "confident_wrong_names": sum(bool(r["confident"] and r["named"] != "none") for r in rows),
        "confident_verdicts": sum(r["confident"] for r in rows),
        "unexplained_by_kind": {
            k: f"{sum(r['unexplained'] for r in rows if r['kind'] == k)}/"
            f"{sum(r['kind'] == k for r in rows)}"
            for k in kinds
        },
        "named_any": sum(r["named"] != "none" for r in rows),
        "median_cpu_s": _median(rows, "cpu_seconds"),
    }


def _mean(rows: list[dict], key: str) -> float:
    vals = [r[key] for r in rows if r[key] is not None]
    return float(np.mean(vals)) if vals else float("nan")


def _median(rows: list[dict], key: str) -> float:
    vals = [r[key] for r in rows if r[key] is not None and np.isfinite(r[key])]
    return float(np.median(vals)) if vals else float("nan")


def summarise(rows: list[dict]) -> dict[str, Any]:
    one = [r for r in rows if r["n_true"] == 1]
    two = [r for r in rows if r["n_true"] == 2]
    none = [r for r in rows if r["n_true"] == 0]
    eff = [r for r in rows if r["n_true"] > 0]
    located = [r for r in rows if r.get("where_ok") is not None]
    seen = [r for r in one if r["detectable"]]
    unseen = [r for r in one if not r["detectable"]]
    by_type = {}
    for t in sorted({r["case_type"] for r in one}):
        sel = [r for r in one if r["case_type"] == t]
        by_type[t] = f"{sum(r['top1_ok'] for r in sel)}/{len(sel)}"
    return {
        "cases": len(rows),
        "one_effect_cases": len(one),
        "top1_accuracy_one_effect": _mean(one, "top1_ok"),
        "one_effect_detectable_cases": len(seen),
        "top1_accuracy_one_effect_detectable": _mean(seen, "top1_ok"),
        "one_effect_undetectable_cases": len(unseen),
        "top1_accuracy_one_effect_undetectable": _mean(unseen, "top1_ok"),
        "top1_by_case_type": by_type,
        "two_effect_cases": len(two),
        "both_found_two_effects": _mean(two, "all_found"),
        "both_found_two_effects_detectable": _mean(
            [r for r in two if r["detectable"]], "all_found"
        ),
        "no_effect_cases": len(none),
        "false_alarm_rate_no_effect": (
            float(np.mean([r["false_alarms"] > 0 for r in none])) if none else float("nan")
        ),
        "extra_kinds_named_per_effect_case": _mean(eff, "false_alarms"),
        "hysteresis_located_cases": len(located),
        "hysteresis_location_correct": _mean(located, "where_ok"),
        "hysteresis_location_correct_or_stated_ambiguous": _mean(located, "where_ok_or_ambiguous"),
        "median_heldout_ratio_effect_cases": _median(eff, "heldout_ratio"),
        "median_model_error_ratio_effect_cases": _median(eff, "model_error_ratio"),
        "median_model_error_ratio_detectable_effect_cases": _median(
            [r for r in eff if r["detectable"]], "model_error_ratio"
        ),
        "median_excess_ratio_effect_cases": _median(eff, "excess_ratio"),
        "median_param_rel_err": _median(rows, "param_rel_err"),
        "median_seconds_per_diagnosis": _median(rows, "seconds"),
        "max_seconds_per_diagnosis": float(np.max([r["seconds"] for r in rows])),
        "median_cpu_seconds_per_diagnosis": _median(rows, "cpu_seconds"),
        "max_cpu_seconds_per_diagnosis": float(np.max([r["cpu_seconds"] for r in rows])),
        "steps": STEPS,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dev", action="store_true", help="development seeds (not reported)")
    ap.add_argument("--cases", type=int, default=None, help="only the first N seeds")
    ap.add_argument("--resume", action="store_true", help="skip seeds already in the rows file")
    ap.add_argument("--out", default=None, help="result folder (default docs/benchmarks)")
    ap.add_argument("--rows", default=None, help="JSON-lines file of finished cases")
    ap.add_argument("--outside", action="store_true", help="cases outside the library")
    args = ap.parse_args(argv)
    seeds = OUTSIDE_SEEDS if args.outside else DEV_SEEDS if args.dev else REPORT_SEEDS
    seeds = seeds[: args.cases] if args.cases else seeds
    name = "knc_outside" if args.outside else "knc_diagnosis_dev" if args.dev else "knc_diagnosis"
    run, summary = (run_outside_case, summarise_outside) if args.outside else (run_case, summarise)
    out = Path(args.out) if args.out else (Path(tempfile.gettempdir()) if args.dev else None)
    rows_path = Path(args.rows or Path(tempfile.gettempdir()) / f"suspenv_{name}.rows.jsonl")
    rows_path.parent.mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []
    if args.resume and rows_path.exists():
        rows = [json.loads(line) for line in rows_path.read_text().splitlines() if line]
    elif rows_path.exists():
        rows_path.unlink()
    done = {r["seed"] for r in rows}
    for seed in tqdm([s for s in seeds if s not in done], desc="K&C blind cases", mininterval=0):
        row = run(seed)
        rows.append(row)
        with rows_path.open("a") as f:
            f.write(json.dumps(row) + "\n")
    rows.sort(key=lambda r: r["seed"])
    flag = " --outside" if args.outside else " --dev" if args.dev else ""
    command = "python -m benchmarks.knc_diagnosis" + flag
    write_result(name, rows, summary(rows), command, output_dir=out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
