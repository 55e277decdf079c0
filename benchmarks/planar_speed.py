"""Planar linkage speed: analytic 61-point sweeps in batches vs the pymunk backend.

Target: the analytic solver evaluates a 61-point travel sweep (+-60 mm) in <= 1 ms per
candidate when candidates come in batches. Measured in the same run: the analytic solver
one candidate at a time, and the pymunk simulation (the independent second solver) per
candidate. Candidates are random designs of the default ``PlanarLinkage`` problem.

Run: ``python -m benchmarks.planar_speed [--quick]``; writes
``docs/benchmarks/planar_speed.json``.
"""

from __future__ import annotations

import argparse
import functools
import sys
import time

import numpy as np
from tqdm import tqdm

from benchmarks.common import best_time, write_result
from suspenv.models.planar import solve_sweep, sweep_outputs
from suspenv.models.planar.pymunk_model import simulate_sweep
from suspenv.registry import make_problem

N_TRAVEL = 61
TARGET_MS = 1.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats (smoke run)")
    parser.add_argument("--output-dir", default=None, help="default docs/benchmarks")
    args = parser.parse_args(argv)
    repeat = 2 if args.quick else 5
    n_pymunk = 2 if args.quick else 5

    problem = make_problem("PlanarLinkage", n_travel=N_TRAVEL)
    rng = np.random.default_rng(0)
    U = rng.random((1000, problem.space.dim))
    X = problem.space.to_physical(U)
    travel = problem.travel
    rows = []

    def sweep_only(Xb: np.ndarray) -> None:
        g = problem.geometry(Xb)
        sweep_outputs(g, solve_sweep(g, travel))

    for batch in tqdm((1, 10, 100, 1000), desc="analytic batches", file=sys.stderr):
        Xb = X[:batch]
        # partial binds the batch (a lambda with Xb=Xb trips mypy issue #15459)
        t_sweep = best_time(functools.partial(sweep_only, Xb), repeat=repeat)
        t_eval = best_time(functools.partial(problem.evaluate, Xb), repeat=repeat)
        rows.append(
            {
                "solver": "analytic",
                "batch": batch,
                "ms_per_candidate_sweep": 1e3 * t_sweep / batch,
                "ms_per_candidate_evaluate": 1e3 * t_eval / batch,
            }
        )

    t_pymunk = []
    for i in tqdm(range(n_pymunk), desc="pymunk candidates", file=sys.stderr):
        g = problem.geometry(X[i : i + 1]).take(0)
        t0 = time.perf_counter()
        sweep_outputs(g, simulate_sweep(g, travel))
        t_pymunk.append(time.perf_counter() - t0)
    pymunk_ms = 1e3 * float(np.median(t_pymunk))
    rows.append(
        {
            "solver": "pymunk",
            "batch": 1,
            "ms_per_candidate_sweep": pymunk_ms,
            "ms_per_candidate_evaluate": None,  # the problem path is the same sweep
        }
    )

    batched = rows[3]["ms_per_candidate_sweep"]
    summary = {
        "travel_points": N_TRAVEL,
        "analytic_ms_per_candidate_batch1000": batched,
        "analytic_ms_per_candidate_evaluate_batch1000": rows[3]["ms_per_candidate_evaluate"],
        "analytic_ms_per_candidate_single": rows[0]["ms_per_candidate_sweep"],
        "pymunk_ms_per_candidate": pymunk_ms,
        "ratio_pymunk_over_analytic_batched": pymunk_ms / batched,
        "ratio_single_over_batched": rows[0]["ms_per_candidate_sweep"] / batched,
        "target_ms_per_candidate": TARGET_MS,
        "meets_target": bool(rows[3]["ms_per_candidate_evaluate"] <= TARGET_MS),
    }
    write_result(
        "planar_speed",
        rows,
        summary,
        "python -m benchmarks.planar_speed" + (" --quick" if args.quick else ""),
        output_dir=args.output_dir,
    )
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
