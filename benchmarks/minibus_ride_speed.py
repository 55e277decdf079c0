"""Minibus ride speed: random-road ride objectives for both load cases, per candidate.

Both ride methods of ``MinibusRideHandling``, and the spectral method's previous
algorithm, are measured in the same run, at batch sizes 1 (one design at a time), 10,
100 and 500 (random designs of the study's 8-variable space, both load cases):

- ``spectral`` (the default): exact spectral integral of the equivalent-linear ride
  model (:func:`suspenv.metrics.ride.ride_spectral`): batched eigen-decompositions and
  modal frequency responses of the model's decoupled symmetric and antisymmetric
  halves, a few statistical-linearisation passes on a 150-point grid, then the
  objectives on a 400-point grid;
- ``spectral_full`` (the spectral method's previous algorithm, the same values to
  round-off): the modal expansion of the whole 14-state model over every wheel input
  (``ride_spectral(..., split=False)``);
- ``time`` (the study's definition, the baseline): the nonlinear model integrated by
  RK4 at 100 Hz over a 10 s record after 1 s of settling, Wk in the frequency domain,
  float64 as the problem runs it.

Both wall time and process CPU time are recorded because the machine may be shared
(CPU time is what the process spends; BLAS threads add to it). The methods are timed
in turn at each batch size (best of the repeats; the spectral ones get more repeats at
small batches), so a load that changes during the run weighs on all of them.

Run: ``python -m benchmarks.minibus_ride_speed [--quick]``; writes
``docs/benchmarks/minibus_ride_speed.json``.
"""

from __future__ import annotations

import argparse
import functools
import sys
import time

import numpy as np
from tqdm import tqdm

from benchmarks.common import write_result
from suspenv.metrics.ride import ride_spectral
from suspenv.models.minibus import design_space
from suspenv.models.road import RandomRoad
from suspenv.problems.minibus_ride import ride_objectives_all

#: ride budget per candidate (ms, CPU) at batch 500 and at batch 1: a small fraction of
#: the whole problem's targets (1 ms batched, 5 ms one design at a time)
TARGET_MS_BATCH500 = 1.0
TARGET_MS_BATCH1 = 5.0
BATCHES = (1, 10, 100, 500)


def _best(fn, repeat: int) -> tuple[float, float]:
    """Best wall and best CPU time (s) of ``fn`` over ``repeat`` calls."""
    wall, cpu = float("inf"), float("inf")
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall = min(wall, time.perf_counter() - t0)
        cpu = min(cpu, time.process_time() - c0)
    return wall, cpu


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats (smoke run)")
    parser.add_argument("--output-dir", default=None, help="default docs/benchmarks")
    args = parser.parse_args(argv)
    repeat = 1 if args.quick else 3
    road = RandomRoad()
    rng = np.random.default_rng(0)
    X = design_space().to_physical(rng.random((500, 8)))
    methods = ("spectral", "spectral_full", "time")

    def call(Xb: np.ndarray, method: str) -> None:
        if method == "spectral_full":
            ride_spectral(Xb, road=road, split=False)
        else:
            ride_objectives_all(Xb, road=road, dtype=np.float64, method=method)

    best: dict[tuple[str, int], tuple[float, float]] = {}
    for batch in tqdm(BATCHES, desc="ride batches", file=sys.stderr):
        Xb = X[:batch]
        for method in methods:
            call(Xb, method)  # warm-up
        # the methods in turn, so a load that changes during the run weighs on all; the
        # fast ones get more repeats at small batches
        reps = {m: repeat if m == "time" else max(repeat, (20 * repeat) // batch) for m in methods}
        for r in range(max(reps.values())):
            for method in methods:
                if r < reps[method]:
                    wall, cpu = _best(functools.partial(call, Xb, method), 1)
                    w0, c0 = best.get((method, batch), (float("inf"), float("inf")))
                    best[method, batch] = (min(w0, wall), min(c0, cpu))
    rows = [
        {
            "method": method,
            "batch": batch,
            "ms_per_candidate_wall": 1e3 * best[method, batch][0] / batch,
            "ms_per_candidate_cpu": 1e3 * best[method, batch][1] / batch,
        }
        for method in methods
        for batch in BATCHES
    ]

    def get(method: str, batch: int) -> dict:
        return next(r for r in rows if r["method"] == method and r["batch"] == batch)

    s1, s500 = get("spectral", 1), get("spectral", 500)
    f1, f500 = get("spectral_full", 1), get("spectral_full", 500)
    t1, t500 = get("time", 1), get("time", 500)
    summary = {
        "what": "ride objectives, both load cases, class B 80 km/h; spectral (default, "
        "split halves) vs spectral_full (whole-model expansion, before) vs time (10 s + "
        "1 s settle, RK4 100 Hz, float64)",
        "target_ms_per_candidate_batch500_cpu": TARGET_MS_BATCH500,
        "target_ms_per_candidate_batch1_cpu": TARGET_MS_BATCH1,
        "spectral_batch1_ms_cpu": s1["ms_per_candidate_cpu"],
        "spectral_batch500_ms_cpu": s500["ms_per_candidate_cpu"],
        "spectral_full_batch1_ms_cpu": f1["ms_per_candidate_cpu"],
        "spectral_full_batch500_ms_cpu": f500["ms_per_candidate_cpu"],
        "speedup_vs_spectral_full_batch1_cpu": f1["ms_per_candidate_cpu"]
        / s1["ms_per_candidate_cpu"],
        "speedup_vs_spectral_full_batch500_cpu": f500["ms_per_candidate_cpu"]
        / s500["ms_per_candidate_cpu"],
        "time_batch1_ms_cpu": t1["ms_per_candidate_cpu"],
        "time_batch500_ms_cpu": t500["ms_per_candidate_cpu"],
        "speedup_batch1_cpu": t1["ms_per_candidate_cpu"] / s1["ms_per_candidate_cpu"],
        "speedup_batch500_cpu": t500["ms_per_candidate_cpu"] / s500["ms_per_candidate_cpu"],
        "meets_batch1_target_cpu": bool(s1["ms_per_candidate_cpu"] <= TARGET_MS_BATCH1),
        "meets_batch500_target_cpu": bool(s500["ms_per_candidate_cpu"] <= TARGET_MS_BATCH500),
    }
    command = "python -m benchmarks.minibus_ride_speed" + (" --quick" if args.quick else "")
    write_result("minibus_ride_speed", rows, summary, command, args.output_dir)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
