"""Ride objective noise: seed-to-seed scatter of every minibus ride objective, both methods.

For the study's pick, the baseline and three random designs of the 8-variable space,
every ride measure of ``MinibusRideHandling`` (f1 = aw_front no load + 1.5 x full load,
f2 = the same at the rear, and the four per-load-case weighted RMS values that the
constraints use) is evaluated on ``--seeds`` road realisations (default 20) with each
ride method at its default settings:

- ``time``: the study's 10 s record of the nonlinear model (one seeded road);
- ``spectral`` (the problem's default): the spectral integral of the equivalent-linear
  model; it takes no seed, so its scatter is exactly 0 (measured anyway).

Scatter = coefficient of variation (sample std / mean, in %) over the seeds, per design;
the table gives the reference design (the study's pick) and the largest over designs.

Accuracy against the nonlinear model's expectation ("truth", unless ``--quick``): the
nonlinear time-domain model averaged over 6 independent 200 s records (1200 s; standard
error of the truth's mean square per value reported), compared with the spectral value
and with the mean of the 10 s time-domain values.

Run: ``python -m benchmarks.ride_noise [--quick]``; writes
``docs/benchmarks/ride_noise.json``.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np
from tqdm import tqdm

from benchmarks.common import write_result
from suspenv.metrics.iso2631 import weighted_rms_fft
from suspenv.models.minibus import BASELINE_DESIGN, STUDY_PICK, design_space
from suspenv.models.minibus.vehicle import LOAD_CASES
from suspenv.models.road import RandomRoad
from suspenv.problems.minibus import MinibusRideHandling
from suspenv.rigs.ride import random_road_run

MEASURES = (
    "aw_front_no_load",
    "aw_front_full_load",
    "aw_rear_no_load",
    "aw_rear_full_load",
)
OBJECTIVES = ("f1_ride_front", "f2_ride_rear") + MEASURES
TARGET_CV_PERCENT = 1.0


def _designs() -> np.ndarray:
    rng = np.random.default_rng(11)
    return np.vstack([STUDY_PICK, BASELINE_DESIGN, design_space().to_physical(rng.random((3, 8)))])


def _ride_values(problem: MinibusRideHandling, X: np.ndarray) -> dict[str, np.ndarray]:
    from suspenv.problems.minibus_ride import ride_objectives_all

    ride = ride_objectives_all(
        X, LOAD_CASES, problem.road, problem.vehicle, dtype=np.float64, method=problem.ride_method
    )
    m = {f"{k}_{lc}": ride[lc][k] for lc in LOAD_CASES for k in ("aw_front", "aw_rear")}
    w = problem.load_weight
    m["f1_ride_front"] = m["aw_front_no_load"] + w * m["aw_front_full_load"]
    m["f2_ride_rear"] = m["aw_rear_no_load"] + w * m["aw_rear_full_load"]
    return m


def _truth(X: np.ndarray, n_records: int = 6, duration_s: float = 200.0) -> dict:
    """Nonlinear model, mean square over independent long records: (mean, se) per measure."""
    ms = []
    for k in tqdm(range(n_records), desc="truth records", file=sys.stderr):
        rec = random_road_run(X, LOAD_CASES, RandomRoad(duration_s=duration_s, seed=1000 + k))
        af = weighted_rms_fft(rec.acc_front, 100.0) ** 2
        ar = weighted_rms_fft(rec.acc_rear, 100.0) ** 2
        n = X.shape[0]
        ms.append(np.concatenate([af[:n], af[n:], ar[:n], ar[n:]]))
    a = np.array(ms)
    mean, se = a.mean(axis=0), a.std(axis=0, ddof=1) / np.sqrt(len(a))
    n = X.shape[0]
    return {
        name: (mean[i * n : (i + 1) * n], se[i * n : (i + 1) * n])
        for i, name in enumerate(MEASURES)
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5 seeds, no truth (smoke run)")
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--output-dir", default=None, help="default docs/benchmarks")
    args = parser.parse_args(argv)
    n_seeds = 5 if args.quick else args.seeds
    X = _designs()
    values: dict[str, dict[str, np.ndarray]] = {}
    for method in ("spectral", "time"):
        per_seed = []
        for seed in tqdm(range(n_seeds), desc=f"{method} seeds", file=sys.stderr):
            p = MinibusRideHandling(ride_method=method, road_seed=seed)
            per_seed.append(_ride_values(p, X))
        values[method] = {k: np.array([d[k] for d in per_seed]) for k in OBJECTIVES}
    truth = None if args.quick else _truth(X)
    rows: list[dict[str, Any]] = []
    for method in ("spectral", "time"):
        for name in OBJECTIVES:
            v = values[method][name]  # (seeds, designs)
            mean = v.mean(axis=0)
            cv = 100.0 * v.std(axis=0, ddof=1) / mean
            row: dict[str, Any] = {
                "method": method,
                "objective": name,
                "value_study_pick": float(mean[0]),
                "cv_percent_study_pick": float(cv[0]),
                "cv_percent_max_over_designs": float(cv.max()),
            }
            if truth is not None and name in truth:
                t_mean, t_se = truth[name]
                # the method's expected value: its root mean square over the seeds
                dev = 100.0 * (np.sqrt((v**2).mean(axis=0) / t_mean) - 1.0)
                row["truth_study_pick"] = float(np.sqrt(t_mean[0]))
                row["truth_se_percent_max"] = float(np.max(50.0 * t_se / t_mean))
                row["dev_from_truth_percent_min"] = float(dev.min())
                row["dev_from_truth_percent_max"] = float(dev.max())
            rows.append(row)
    spec_cv = max(r["cv_percent_max_over_designs"] for r in rows if r["method"] == "spectral")
    time_cv = max(r["cv_percent_max_over_designs"] for r in rows if r["method"] == "time")
    summary = {
        "what": "seed-to-seed CV (%) of every ride objective over "
        f"{n_seeds} road seeds, study's pick + baseline + 3 random designs",
        "default_method": MinibusRideHandling().ride_method,
        "target_cv_percent": TARGET_CV_PERCENT,
        "spectral_max_cv_percent": spec_cv,
        "time_max_cv_percent": time_cv,
        "default_meets_target": bool(
            (spec_cv if MinibusRideHandling().ride_method == "spectral" else time_cv)
            <= TARGET_CV_PERCENT
        ),
    }
    command = "python -m benchmarks.ride_noise" + (" --quick" if args.quick else "")
    write_result("ride_noise", rows, summary, command, args.output_dir)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
