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
import time

import numpy as np
from tqdm import tqdm

from suspenv.bench.common import write_result
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

    def timed(fn) -> tuple[float, float]:
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        return time.perf_counter() - w0, time.process_time() - c0

    wall, cpu = [], []
    last = {}
    for _ in tqdm(range(repeat), desc=f"batches of {args.batch}", file=sys.stderr):
        w, c = timed(lambda: last.update(batch=problem.evaluate(X)))
        wall.append(w)
        cpu.append(c)
    batched_ms = 1e3 * min(cpu) / args.batch
    batched_wall_ms = 1e3 * min(wall) / args.batch

    s_wall, s_cpu = [], []
    for i in tqdm(range(n_single), desc="one at a time", file=sys.stderr):
        w, c = timed(lambda i=i: problem.evaluate(X[i : i + 1]))
        s_wall.append(w)
        s_cpu.append(c)
    single_ms = 1e3 * float(np.median(s_cpu))
    single_wall_ms = 1e3 * float(np.median(s_wall))
    valid = int(last["batch"].ok.sum())

    rows = [
        {
            "mode": f"batch of {args.batch}",
            "cpu_ms_per_candidate": batched_ms,
            "wall_ms_per_candidate": batched_wall_ms,
            "repeats": repeat,
        },
        {
            "mode": "one at a time",
            "cpu_ms_per_candidate": single_ms,
            "wall_ms_per_candidate": single_wall_ms,
            "repeats": n_single,
        },
    ]
    summary = {
        "batch": args.batch,
        "valid_candidates": valid,
        "ms_per_candidate_batched": batched_ms,
        "ms_per_candidate_single": single_ms,
        "wall_ms_per_candidate_batched": batched_wall_ms,
        "batching_gain": single_ms / batched_ms,
        "target_ms": TARGET_MS,
        "meets_target": bool(batched_ms <= TARGET_MS),
        "meets_stretch": bool(batched_ms <= STRETCH_MS),
        "speedup_vs_paper_20s": 1e3 * PAPER_S / batched_ms,
        "steps_per_test": 61,
        "tests": 3,
        "load_average_1min": os.getloadavg()[0],
    }
    cmd = "python -m suspenv.bench.knc_speed" + (" --quick" if args.quick else "")
    write_result("knc_speed", rows, summary, cmd, args.output_dir)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
