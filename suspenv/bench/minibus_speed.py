"""Minibus speed: time per candidate of a full MinibusRideHandling evaluation.

A full evaluation is what the problem does for every candidate: both load cases of the
random-road ride run (class B, 80 km/h, 10 s), the steady-state circular test and the
closed-loop slalom, then the 5 objectives and 6 constraints. Candidates are random
designs of the study's box in batches of 500 (the study's NSGA-II population); measured
in the same run, the same candidates one at a time (the baseline), which gives the
batching gain, and the share of each part (ride, steady circle, slalom) in the batched
time. Target <= 5 ms per candidate on one core, so the study's 30,000 evaluations take
<= 3 minutes on 2 cores. suspenv limits BLAS to one thread, so the process's CPU time
is one core's time; it is the reported figure (best of the repeats), with the wall time
beside it (which a loaded machine inflates).

Run: ``python -m suspenv.bench.minibus_speed [--quick]``; writes
``docs/benchmarks/minibus_speed.json``.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np
from tqdm import tqdm

from suspenv.bench.common import time_batch_vs_single, wall_and_cpu, write_result
from suspenv.metrics.handling import slalom
from suspenv.metrics.ride import ride_objectives_all
from suspenv.models.minibus.handling_model import HandlingParams, handling_parameters
from suspenv.models.minibus.vehicle import LOAD_CASES
from suspenv.registry import make_problem
from suspenv.rigs.handling import steady_circle

TARGET_MS = 5.0
STUDY_EVALUATIONS = 30_000


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats (smoke run)")
    parser.add_argument("--batch", type=int, default=500, help="designs per batch")
    parser.add_argument("--output-dir", default=None, help="default docs/benchmarks")
    args = parser.parse_args(argv)
    repeat = 1 if args.quick else 3
    n_single = 3 if args.quick else 8

    problem = make_problem("MinibusRideHandling")
    rng = np.random.default_rng(0)
    X = problem.space.to_physical(rng.random((args.batch, problem.space.dim)))

    t = time_batch_vs_single(problem, X, repeat, n_single)
    batched_ms = t.batched_cpu_ms

    # parts of the batched evaluation (one repeat each, CPU time)
    def handling_params() -> HandlingParams:
        return HandlingParams.stack([handling_parameters(X, lc) for lc in LOAD_CASES])

    P = handling_params()
    parts = {
        "ride (both loads)": lambda: ride_objectives_all(X, LOAD_CASES, problem.road),
        "steady circle (both loads)": lambda: steady_circle(handling_params(), problem.circle),
        "slalom (both loads)": lambda: slalom(P, problem.slalom_config),
    }
    part_ms = {}
    for name, fn in tqdm(parts.items(), desc="parts", file=sys.stderr):
        part_ms[name] = 1e3 * wall_and_cpu(fn)[1] / args.batch

    full_rows = t.rows(
        f"full evaluation, batch of {args.batch}", "full evaluation, one at a time (baseline)"
    )
    rows = [
        full_rows[0],
        *(
            {
                "mode": f"  part: {name}, batch of {args.batch}",
                "cpu_ms_per_candidate": ms,
                "wall_ms_per_candidate": float("nan"),
                "repeats": 1,
            }
            for name, ms in part_ms.items()
        ),
        full_rows[1],
    ]
    study_minutes_2_cores = STUDY_EVALUATIONS * batched_ms / 1e3 / 60 / 2
    summary = {
        "batch": args.batch,
        "valid_candidates": t.valid,
        "ms_per_candidate_batched": batched_ms,
        "ms_per_candidate_single": t.single_cpu_ms,
        "wall_ms_per_candidate_batched": t.batched_wall_ms,
        "batching_gain": t.gain,
        "target_ms": TARGET_MS,
        "meets_target": bool(batched_ms <= TARGET_MS),
        "study_30000_evaluations_minutes_on_2_cores_estimate": study_minutes_2_cores,
        "load_average_1min": os.getloadavg()[0],
    }
    cmd = "python -m suspenv.bench.minibus_speed" + (" --quick" if args.quick else "")
    write_result("minibus_speed", rows, summary, cmd, args.output_dir)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
