"""McPherson K&C speed: time per candidate of a full KCIdentification evaluation.

A full evaluation is what the identification problem does for every candidate: the
compliant full-axle model, three rig tests (parallel, opposite, single wheel travel,
+-40 mm, 30 steps), each a loop design -> bump -> rebound -> design (both sweep
directions, 61 solved steps per test), and all 40 objectives. Candidates are random
designs of the 49-parameter space (the population of an optimiser), in batches of 42
(the paper's CMA-ES population). Measured in the same run: the same candidates one at
a time, which gives the batching gain. Target <= 10 ms per candidate (the paper's
simulator took about 20 s); stretch <= 2 ms. BLAS is limited to one thread by suspenv,
so the process's CPU time is one core's time; it is the reported figure (best of the
repeats), with the wall time beside it (which a loaded machine inflates).

Run: ``python -m suspenv.bench.knc_speed [--quick]``; writes
``docs/benchmarks/knc_speed.json``.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

from suspenv.bench.common import time_batch_vs_single, write_result
from suspenv.registry import make_problem

TARGET_MS = 10.0
STRETCH_MS = 2.0
PAPER_S = 20.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats (smoke run)")
    parser.add_argument("--batch", type=int, default=42, help="designs per batch")
    parser.add_argument("--output-dir", default=None, help="default docs/benchmarks")
    args = parser.parse_args(argv)
    repeat = 1 if args.quick else 3
    n_single = 3 if args.quick else 8

    problem = make_problem("KCIdentification")
    rng = np.random.default_rng(0)
    X = problem.space.to_physical(rng.random((args.batch, problem.space.dim)))

    t = time_batch_vs_single(problem, X, repeat, n_single)
    rows = t.rows(f"batch of {args.batch}", "one at a time")
    summary = {
        "batch": args.batch,
        "valid_candidates": t.valid,
        "ms_per_candidate_batched": t.batched_cpu_ms,
        "ms_per_candidate_single": t.single_cpu_ms,
        "wall_ms_per_candidate_batched": t.batched_wall_ms,
        "batching_gain": t.gain,
        "target_ms": TARGET_MS,
        "meets_target": bool(t.batched_cpu_ms <= TARGET_MS),
        "meets_stretch": bool(t.batched_cpu_ms <= STRETCH_MS),
        "speedup_vs_paper_20s": 1e3 * PAPER_S / t.batched_cpu_ms,
        "steps_per_test": 61,
        "tests": 3,
        "load_average_1min": os.getloadavg()[0],
    }
    cmd = "python -m suspenv.bench.knc_speed" + (" --quick" if args.quick else "")
    write_result("knc_speed", rows, summary, cmd, args.output_dir)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
