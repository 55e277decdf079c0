"""Minibus ride speed: random-road ride objectives for both load cases, per candidate.

Target: the ride part of ``MinibusRideHandling`` (class-B road at 80 km/h, 10 s record
after 1 s of settling, RK4 at 100 Hz, Wk in the frequency domain, both load cases
stacked in one integration) costs about 1-2 ms per candidate in batches of 500 on one
core. Measured in the same run: the same call one candidate at a time (the baseline,
batch 1) and batch sizes in between. Candidates are random designs of the study's
8-variable space. Both wall time and process CPU time are recorded because the
machine may be shared (CPU time is what one core spends).

Run: ``python -m suspenv.bench.minibus_ride_speed [--quick]``; writes
``docs/benchmarks/minibus_ride_speed.json``.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from tqdm import tqdm

from suspenv.bench.common import write_result
from suspenv.metrics.ride import ride_objectives_all
from suspenv.models.minibus import design_space
from suspenv.rigs.ride import RandomRoad

TARGET_MS = 2.0


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
    rows = []
    for batch in tqdm((1, 10, 100, 500), desc="ride batches", file=sys.stderr):
        Xb = X[:batch]
        wall, cpu = _best(lambda Xb=Xb: ride_objectives_all(Xb, road=road), repeat)
        rows.append(
            {
                "batch": batch,
                "ms_per_candidate_wall": 1e3 * wall / batch,
                "ms_per_candidate_cpu": 1e3 * cpu / batch,
            }
        )
    base, big = rows[0], rows[-1]
    summary = {
        "what": "ride objectives, both load cases, class B 80 km/h, 10 s + 1 s settle, RK4 100 Hz",
        "target_ms_per_candidate": TARGET_MS,
        "batch500_ms_per_candidate_cpu": big["ms_per_candidate_cpu"],
        "batch500_ms_per_candidate_wall": big["ms_per_candidate_wall"],
        "speedup_vs_batch1_cpu": base["ms_per_candidate_cpu"] / big["ms_per_candidate_cpu"],
        "speedup_vs_batch1_wall": base["ms_per_candidate_wall"] / big["ms_per_candidate_wall"],
        "meets_target_cpu": bool(big["ms_per_candidate_cpu"] <= TARGET_MS),
    }
    command = "python -m suspenv.bench.minibus_ride_speed" + (" --quick" if args.quick else "")
    write_result("minibus_ride_speed", rows, summary, command, args.output_dir)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
