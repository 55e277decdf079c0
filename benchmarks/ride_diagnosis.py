"""Blind benchmark of the ride and road diagnosis.

Ride: for each concealed kind (bump stop, leaf interleaf friction, damper friction,
seat mount) and no-effect controls, a seeded truth minibus generates pulse runs at
20 and 50 km/h (x2) and a class-C random-road run; the diagnosis sees the first
pulse runs, holds out the rest and is scored on: named kind and location (top-1),
false alarms on the controls, held-out RMS error before/after, recovered effect
parameters vs truth. Baseline in the same run: the plain fitted model (no effect),
whose held-out error is the "before" number.

Out-of-library ride cases (scored on their own rows): truths whose extra physics is
not a candidate (damper curve of another shape, other tyres, a seat accelerometer
with a gain error, a lag or upside down, an undeclared payload, tyre run-out the
recordings do not carry; :mod:`benchmarks.ride_mismatch`). Scored on the
wrong-name rate (a candidate named with confidence although the truth is outside
the library), held-out error before/after against the noise floor, and whether the
verdict says a residual remains (:mod:`suspenv.diagnosis.ride.residual`).

Road (:func:`~suspenv.diagnosis.road.diagnose_road`, the one loop): synthetic Gaussian
profiles of ISO 8608 class B with w = 2 (controls), w = 2.5 and 1.6 (planted), scored on
false/true detections and the recovered w; spectra outside ISO 8608's form (two
slopes, a corrugation band, periodic joint bumps: :data:`ROAD_TRUTH`), scored on
whether the verdict says a residual remains and on confident wrong names; and the
real ``profile_1/2.txt`` (when the shared data is present,
:func:`suspenv.measurements.data_dir`).

Speed baseline in the same run: the in-library cases of the first seed diagnosed
again with the ride model's numpy loop (``ride_model.COMPILED`` off), CPU time
(``time.process_time``, the machine is shared) and whether the outcome is the same.

Seeds: ``--dev`` runs the tuning seeds; the default runs the reported seeds (a
different set). Rows are appended to ``<tmp>/suspenv_bench/ride_diagnosis.rows.jsonl`` as they
finish (nothing is lost if killed; ``--resume`` reuses them); the table and summary
go to ``docs/benchmarks/ride_diagnosis.json``.

Run: ``python -m benchmarks.ride_diagnosis [--dev] [--quick] [--resume]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from benchmarks.common import DEFAULT_OUTPUT_DIR, write_result
from benchmarks.ride_mismatch import OUT_OF_LIBRARY_KINDS, mismatch_words
from benchmarks.ride_truth import make_ride_case
from suspenv.diagnosis.engine import Diagnosis, diagnose
from suspenv.diagnosis.ride.family import RideFamily
from suspenv.diagnosis.road import diagnose_road, load_profile_txt
from suspenv.measurements import Recording, data_dir
from suspenv.measurements.sources.road_profile import profile_recording
from suspenv.models.road import N0, ROAD_CLASS_GD0

KINDS: tuple[str | None, ...] = (
    "bump_stop",
    "leaf_friction",
    "damper_friction",
    "seat_mount",
    None,
)
DEV_SEEDS = (11, 12)
#: the reported seeds, fixed before the run (501, 502 before the blind user's conditions
#: were added; 503-505 added with them)
REPORT_SEEDS = (501, 502, 503, 504, 505)
#: cases run again with the numpy loop (the speed baseline, same run): the in-library
#: kinds and a control of the first reported seed
BASELINE_KINDS: tuple[str | None, ...] = KINDS


def ride_row(kind: str | None, seed: int) -> dict[str, Any]:
    case = make_ride_case(seed, kind)
    wall, cpu = time.perf_counter(), time.process_time()
    diag = diagnose(case.fit, RideFamily(screen_count=3, max_effects=1), holdout=case.heldout)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    truth = case.truth.effects
    expected = f"{truth[0].kind}@{truth[0].location}" if truth else ""
    res = diag.residual
    common = {
        "confident": diag.confident,
        "residual_remains": bool(res.residual_remains),
        "noise_floor_scaled": res.noise_floor,
        "excess_ratio_after": res.excess_ratio,
        "explained_share": res.explained_share,
        "ljung_box_p_after": res.ljung_box_p,
        "params_on_bound": ";".join(
            diag.findings["at_bounds"].numbers["at_bounds"] if "at_bounds" in diag.findings else []
        ),
        "wall_seconds": wall,
        "cpu_seconds": cpu,
    }
    if not case.truth.in_library:
        mismatch = case.truth.mismatch
        assert mismatch is not None  # invariant: in_library is defined as `mismatch is None`
        named = diag.named_candidates
        return {
            "part": "ride (out of library)",
            "case": f"{kind}/{seed}",
            "truth": mismatch_words(mismatch),
            "named": ";".join(named) or "none",
            "wrong_name_confident": bool(named and diag.confident),
            "named_any": bool(named),
            "heldout_scaled_rms_before": res.heldout_before,
            "heldout_scaled_rms_after": res.heldout_after,
            **common,
            "verdict": diag.verdict,
        }
    named = diag.named_candidates
    before = diag.baseline["heldout_rms"]
    scales = diag.base_fit.scales
    b = float(np.sqrt(np.mean([(before[c] / scales[c]) ** 2 for c in before])))
    after = b
    if diag.comparison is not None:
        h = diag.comparison.heldout_rms_after
        after = float(np.sqrt(np.mean([(h[c] / scales[c]) ** 2 for c in h])))
    rel_err = []
    if truth and named and named[0] == expected:
        for p, v in truth[0].params.items():
            key = f"{truth[0].name}.{p}"
            if key in diag.final_params and v:
                rel_err.append(abs(diag.final_params[key]["value"] / float(v) - 1.0))
    return {
        "part": "ride",
        "case": f"{kind or 'none'}/{seed}",
        "truth": expected or "none",
        "named": ";".join(named) or "none",
        "correct_top1": bool(named[0] == expected) if truth else not named,
        "false_alarm": bool(not truth and named),
        "heldout_scaled_rms_before": b,
        "heldout_scaled_rms_after": after,
        "param_rel_error_max": max(rel_err) if rel_err else float("nan"),
        **common,
    }


def baseline_row(kind: str | None, seed: int, compiled: dict[str, Any]) -> dict[str, Any]:
    """The case ``kind/seed`` diagnosed again with the ride model's numpy loop
    (:data:`suspenv.models.minibus.ride_model.COMPILED` off): its CPU time against the
    compiled run's row ``compiled``, and whether the outcome is the same (named
    candidates; the largest relative difference of the final parameters)."""
    from suspenv.models.minibus import ride_model

    case = make_ride_case(seed, kind)
    family = RideFamily(screen_count=3, max_effects=1)
    runs = []
    for flag in (False, True):
        ride_model.COMPILED = flag
        try:
            cpu = time.process_time()
            diag = diagnose(case.fit, family, holdout=case.heldout)
            runs.append((diag, time.process_time() - cpu))
        finally:
            ride_model.COMPILED = True
    (slow, cpu_numpy), (fast, _) = runs
    a, b = slow.final_params, fast.final_params
    diff = max(
        (abs(b[k]["value"] - a[k]["value"]) / max(abs(a[k]["value"]), 1e-300) for k in a if k in b),
        default=0.0,
    )
    return {
        "part": "speed baseline",
        "case": f"{kind or 'none'}/{seed}",
        "cpu_seconds_numpy_loop": cpu_numpy,
        "cpu_seconds_compiled": compiled["cpu_seconds"],
        "same_named": slow.named_candidates == fast.named_candidates
        and ";".join(fast.named_candidates or ["none"]) == compiled["named"],
        "final_param_rel_diff_max": float(diff),
    }


#: road truths outside the library (the spectrum leaves ISO 8608's form), each a
#: function of the seed's generator -> a profile of 544 m at 0.25 m, class B
def synthetic_profile(
    length: float,
    dx: float = 0.25,
    gd0: float = ROAD_CLASS_GD0["B"],
    waviness: float = 2.0,
    seed: int = 0,
    name: str | None = None,
    shape: Callable[[np.ndarray], np.ndarray] | None = None,
) -> Recording:
    """A Gaussian random profile with Gd(n) = gd0 (n/n0)^-waviness (test/benchmark input),
    times ``shape(n)`` where given (a spectrum outside ISO 8608's form).

    Complex Gaussian line amplitudes (a true Gaussian process, so periodograms
    scatter as Exp(1)) on a grid four times longer than ``length``; a window of
    ``length`` is cut out, so the profile is not periodic (as a measured one).
    """
    n_long = int(round(4 * length / dx))
    n = np.fft.rfftfreq(n_long, dx)
    dn = 1.0 / (n_long * dx)
    rng = np.random.default_rng(seed)
    psd = np.zeros_like(n)
    psd[1:] = gd0 * (n[1:] / N0) ** (-waviness) * (shape(n[1:]) if shape else 1.0)
    coef = np.sqrt(psd * dn / 4.0) * (
        rng.standard_normal(n.size) + 1j * rng.standard_normal(n.size)
    )
    coef[-1] = coef[-1].real if n_long % 2 == 0 else coef[-1]
    z = np.fft.irfft(coef * n_long, n=n_long)
    m = int(round(length / dx))
    start = int(rng.integers(0, n_long - m))
    x = dx * np.arange(m)
    return profile_recording(
        x, z[start : start + m], name or f"synthetic_w{waviness:g}_s{seed}", dx, source="synthetic"
    )


def _knee(n: np.ndarray) -> np.ndarray:
    """Two slopes: w = 2 below 0.2 cycle/m, w = 3 above."""
    return np.where(n > 0.2, (n / 0.2) ** -1.0, 1.0)


def _hump(n: np.ndarray) -> np.ndarray:
    """A band of corrugation: the PSD 7 times ISO's at 0.3 cycle/m, +-15 % in log n."""
    return 1.0 + 6.0 * np.exp(-0.5 * (np.log(n / 0.3) / 0.15) ** 2)


def road_case(kind: str, seed: int) -> Any:
    """A synthetic class-B profile (544 m, 0.25 m) of ``kind``: ``w2`` (control),
    ``w2.5`` / ``w1.6`` (in the library), ``knee``, ``hump``, ``joints`` (outside it:
    a triangular joint bump 8-12 mm high, 0.6 m long, every 4.5-6 m)."""
    gd0, length = ROAD_CLASS_GD0["B"], 544.0
    if kind in ("w2", "w2.5", "w1.6"):
        return synthetic_profile(length, 0.25, gd0, float(kind[1:]), seed=seed)
    if kind in ("knee", "hump"):
        return synthetic_profile(
            length, 0.25, gd0, 2.0, seed, shape=_knee if kind == "knee" else _hump
        )
    rec = synthetic_profile(length, 0.25, gd0, 2.0, seed=seed)
    rng = np.random.default_rng(seed)
    period, height = rng.uniform(4.5, 6.0), rng.uniform(0.008, 0.012)
    phase = rec.inputs["distance"] % period
    bump = height * np.clip(1.0 - np.abs(phase - 0.3) / 0.3, 0.0, None)
    return rec.with_outputs({"elevation": rec.outputs["elevation"] + bump})


ROAD_TRUTH = {
    "w2": "w=2 (none)",
    "w2.5": "steeper w=2.5",
    "w1.6": "shallower w=1.6",
    "knee": "two slopes: w = 2 below 0.2 cycle/m, 3 above",
    "hump": "corrugation band at 0.3 cycle/m (PSD x7)",
    "joints": "periodic joint bumps 8-12 mm every 4.5-6 m",
}


def road_named(d: Diagnosis) -> str:
    """A road verdict's name in the rows: ``waviness_steeper`` / ``waviness_shallower``
    (the way of the named free waviness) or ``none``."""
    if not d.named:
        return "none"
    free = d.findings["spectrum"].numbers["free_fit"]
    return f"waviness_{'steeper' if free['waviness'] > 2.0 else 'shallower'}"


def road_rows(seeds: tuple[int, ...]) -> list[dict[str, Any]]:
    rows = []
    for kind, truth in ROAD_TRUTH.items():
        for s in seeds:
            cpu = time.process_time()
            d = diagnose_road(road_case(kind, s), ride=False)
            cpu = time.process_time() - cpu
            named = road_named(d)
            free, std = (d.findings["spectrum"].numbers[k] for k in ("free_fit", "standard_fit"))
            common = {
                "case": f"road {kind}/{s}",
                "truth": truth,
                "named": named,
                "confident": d.confident,
                "unexplained": d.unexplained,
                "w_fit": free["waviness"],
                "w_se": free["waviness_se"],
                "cpu_seconds": cpu,
            }
            if kind in ("knee", "hump", "joints"):
                rows.append(
                    {
                        "part": "road (out of library)",
                        **common,
                        "wrong_name_confident": bool(d.named and d.confident),
                    }
                )
                continue
            expected = {"w2": "none", "w2.5": "waviness_steeper", "w1.6": "waviness_shallower"}
            rows.append(
                {
                    "part": "road",
                    **common,
                    "correct_top1": named == expected[kind],
                    "false_alarm": bool(kind == "w2" and d.named),
                    "class": (free if d.named else std)["road_class"],
                }
            )
    return rows


def real_road_rows() -> list[dict[str, Any]]:
    shared_road = data_dir() / "real" / "road_profiles"
    if not shared_road.is_dir():
        print(f"real road profiles not found at {shared_road}; skipped", file=sys.stderr)
        return []
    p1, p2 = shared_road / "profile_1.txt", shared_road / "profile_2.txt"
    rows = []
    for a, b in ((p1, p2), (p2, p1)):
        d = diagnose_road(load_profile_txt(a), heldout=load_profile_txt(b))
        free, h = (d.findings["spectrum"].numbers[k] for k in ("free_fit", "heldout"))
        ride = d.findings["ride"].numbers
        rows.append(
            {
                "part": "road (real)",
                "case": f"{a.stem} -> held out {b.stem}",
                "truth": "published: class B, steeper than w = 2",
                "named": road_named(d),
                "correct_top1": road_named(d) == "waviness_steeper",
                "w_fit": free["waviness"],
                "w_se": free["waviness_se"],
                "class": free["road_class"],
                "heldout_w": h["heldout_waviness"],
                "heldout_loglik_gain_per_line": h["heldout_loglik_gain_per_line"],
                "aw_front_ratio": ride.get("ratio_front", float("nan")),
                "aw_rear_ratio": ride.get("ratio_rear", float("nan")),
            }
        )
    return rows


def _count(rows: list[dict[str, Any]], truth: str, key: str) -> str:
    """``k/n``: rows whose truth holds ``truth`` with ``key`` true, of those rows."""
    sel = [r for r in rows if truth in r["truth"]]
    return f"{sum(bool(r[key]) for r in sel)}/{len(sel)}"


def _median(rows: list[dict[str, Any]], key: str) -> float:
    vals = [r[key] for r in rows if key in r]
    return float(np.median(vals)) if vals else float("nan")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dev", action="store_true", help="tuning seeds (not the reported ones)")
    ap.add_argument(
        "--quick", action="store_true", help="one seed; bump stop, none and one out-of-library"
    )
    ap.add_argument(
        "--only-out-of-library", action="store_true", help="ride: the out-of-library cases only"
    )
    ap.add_argument("--resume", action="store_true", help="reuse rows of an interrupted run")
    ap.add_argument("--output-dir", default=None)
    args = ap.parse_args(argv)
    seeds = DEV_SEEDS if args.dev else REPORT_SEEDS
    kinds: tuple[str | None, ...] = (
        ("bump_stop", None, "seat_sensor_gain") if args.quick else KINDS + OUT_OF_LIBRARY_KINDS
    )
    if args.only_out_of_library:
        kinds = tuple(k for k in kinds if k in OUT_OF_LIBRARY_KINDS)
    ride_seeds = seeds[:1] if args.quick else seeds
    out_dir = Path(args.output_dir) if args.output_dir else DEFAULT_OUTPUT_DIR
    out_dir.mkdir(parents=True, exist_ok=True)
    name = "ride_diagnosis" + ("_dev" if args.dev else "")
    log = Path(tempfile.gettempdir()) / "suspenv_bench" / f"{name}.rows.jsonl"
    log.parent.mkdir(parents=True, exist_ok=True)
    done = {}
    if log.is_file() and not args.resume:
        log.unlink()
    if log.is_file():
        for line in log.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                done[r["case"]] = r
    rows: list[dict[str, Any]] = []
    jobs = [(k, s) for s in ride_seeds for k in kinds]
    for kind, seed in tqdm(jobs, desc="ride cases"):
        key = f"{kind or 'none'}/{seed}"
        if key in done:
            rows.append(done[key])
            continue
        row = ride_row(kind, seed)
        rows.append(row)
        with log.open("a") as fh:
            fh.write(json.dumps(row, default=float) + "\n")
    if not (args.quick or args.only_out_of_library):
        by_case = {r["case"]: r for r in rows}
        for kind in tqdm(BASELINE_KINDS, desc="numpy-loop baseline"):
            key = f"{kind or 'none'}/{seeds[0]}"
            rows.append(baseline_row(kind, seeds[0], by_case[key]))
    # road seeds: 100 x the first seed + 100.. (reported: 50200-50219, fixed before the run
    # that added the curvature view and the Whittle held-out deviance; 50100-50119 were
    # the first reported set, run before those changes)
    first = seeds[0] * 100 + 100
    road_seeds = tuple(range(first, first + (5 if args.quick else 20)))
    rows += road_rows(road_seeds)
    rows += real_road_rows()

    ride = [r for r in rows if r["part"] == "ride"]
    planted = [r for r in ride if r["truth"] != "none"]
    controls = [r for r in ride if r["truth"] == "none"]
    road = [r for r in rows if r["part"] == "road"]
    road_ool = [r for r in rows if r["part"] == "road (out of library)"]
    ool = [r for r in rows if r["part"] == "ride (out of library)"]
    speed = [r for r in rows if r["part"] == "speed baseline"]
    in_lib = planted + controls
    summary = {
        "seeds": "dev" if args.dev else "reported",
        "ride_top1_accuracy": float(np.mean([r["correct_top1"] for r in planted]))
        if planted
        else float("nan"),
        "ride_false_alarms": f"{sum(r['false_alarm'] for r in controls)}/{len(controls)}",
        "ride_heldout_rms_after_over_before_median": float(
            np.median(
                [r["heldout_scaled_rms_after"] / r["heldout_scaled_rms_before"] for r in planted]
            )
        )
        if planted
        else float("nan"),
        "ride_in_library_residual_flagged": f"{sum(r['residual_remains'] for r in in_lib)}/"
        f"{len(in_lib)}",
        "ride_out_of_library_wrong_name_confident": f"{sum(r['wrong_name_confident'] for r in ool)}"
        f"/{len(ool)}",
        "ride_out_of_library_named_any": f"{sum(r['named_any'] for r in ool)}/{len(ool)}",
        "ride_out_of_library_residual_flagged": f"{sum(r['residual_remains'] for r in ool)}/"
        f"{len(ool)}",
        "ride_out_of_library_heldout_before_median": _median(ool, "heldout_scaled_rms_before"),
        "ride_out_of_library_heldout_after_median": _median(ool, "heldout_scaled_rms_after"),
        "ride_out_of_library_excess_ratio_median": _median(ool, "excess_ratio_after"),
        "ride_wall_seconds_median": _median(ride + ool, "wall_seconds"),
        "ride_cpu_seconds_median": _median(ride + ool, "cpu_seconds"),
        "ride_cpu_seconds_max": float(max(r["cpu_seconds"] for r in ride + ool)),
        "ride_out_of_library_unexplained_by_kind": {
            k: f"{sum(r['residual_remains'] for r in ool if r['case'].startswith(k + '/'))}/"
            f"{sum(r['case'].startswith(k + '/') for r in ool)}"
            for k in dict.fromkeys(r["case"].split("/")[0] for r in ool)
        },
        "speed_baseline_cpu_seconds_median_numpy_loop": _median(speed, "cpu_seconds_numpy_loop"),
        "speed_baseline_cpu_seconds_median_compiled": _median(speed, "cpu_seconds_compiled"),
        "speed_baseline_same_named": f"{sum(r['same_named'] for r in speed)}/{len(speed)}",
        "speed_baseline_final_param_rel_diff_max": max(
            (r["final_param_rel_diff_max"] for r in speed), default=float("nan")
        ),
        "road_false_alarms_w2": f"{sum(r['false_alarm'] for r in road)}/"
        f"{sum(1 for r in road if r['truth'].startswith('w=2'))}",
        "road_detection_w2.5": _count(road, "steeper", "correct_top1"),
        "road_detection_w1.6": _count(road, "shallower", "correct_top1"),
        "road_w2.5_mean_fit": float(np.mean([r["w_fit"] for r in road if "steeper" in r["truth"]])),
        "road_out_of_library_unexplained": _count(road_ool, "", "unexplained"),
        "road_out_of_library_wrong_name_confident": _count(road_ool, "", "wrong_name_confident"),
        "road_out_of_library_unexplained_by_kind": {
            t: _count(road_ool, t, "unexplained")
            for t in dict.fromkeys(r["truth"] for r in road_ool)
        },
        "road_cpu_seconds_median": _median(road + road_ool, "cpu_seconds"),
    }
    cmd = (
        "python -m benchmarks.ride_diagnosis"
        + (" --dev" if args.dev else "")
        + (" --quick" if args.quick else "")
        + (" --only-out-of-library" if args.only_out_of_library else "")
    )
    write_result(name, rows, summary, cmd, out_dir)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
