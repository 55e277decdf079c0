"""Framework overhead per evaluation: suspenv's loop vs a bare pycma ask/tell loop.

Same problem (a 49-D sphere, as many parameters as the K&C identification), same
population (42) and number of generations, measured side by side in one run:

- ``bare cma``: ``es.ask(); f = ...; es.tell()`` with pycma's own bound handling;
- ``strategy``: suspenv's CMAES adapter driven by hand (ask, evaluate, tell);
- ``optimize, no archive``: the full loop without a run directory;
- ``optimize + archive``: the full loop writing every evaluation to SQLite.

Run: ``python -m suspenv.bench.overhead [--generations N] [--output DIR]``.
Targets: framework overhead (optimize + archive minus bare cma) <= 0.2 ms per evaluation,
and the whole loop <= 3x the bare cma loop.
"""

from __future__ import annotations

import argparse
import tempfile
import time

import cma
import numpy as np

from suspenv.bench.common import write_result
from suspenv.problems.toy import Sphere
from suspenv.runs.loop import optimize
from suspenv.strategies.cmaes import CMAES

DIM, POP = 49, 42


def _bare(generations: int) -> float:
    es = cma.CMAEvolutionStrategy(
        [0.5] * DIM,
        0.25,
        {"popsize": POP, "bounds": [0, 1], "seed": 1, "verbose": -9, "verb_log": 0, "verb_disp": 0},
    )
    t0 = time.perf_counter()
    for _ in range(generations):
        X = np.asarray(es.ask())
        f = ((2 * X - 1 - 0.3) ** 2).sum(axis=1)
        es.tell(list(X), f.tolist())
    return time.perf_counter() - t0


def _strategy(generations: int) -> float:
    p = Sphere(DIM)
    s = CMAES(DIM, seed=1, popsize=POP)
    t0 = time.perf_counter()
    for _ in range(generations):
        U = s.ask()
        s.tell(U, p.evaluate_unit(U))
    return time.perf_counter() - t0


def _loop(generations: int, archive: bool) -> float:
    p = Sphere(DIM)
    s = CMAES(DIM, seed=1, popsize=POP)
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        optimize(p, s, budget=generations * POP, run_dir=d if archive else None)
        return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--generations", type=int, default=150)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--output", default=None, help="folder for overhead.json")
    args = ap.parse_args(argv)
    n = args.generations * POP
    cases = {
        "bare cma": lambda: _bare(args.generations),
        "strategy": lambda: _strategy(args.generations),
        "optimize, no archive": lambda: _loop(args.generations, False),
        "optimize + archive": lambda: _loop(args.generations, True),
    }
    best = {k: float("inf") for k in cases}
    for _ in range(args.repeat):  # interleaved, so drift hits every case alike
        for k, fn in cases.items():
            best[k] = min(best[k], fn())
    rows = [
        {
            "case": k,
            "evaluations": n,
            "total_s": t,
            "ms_per_eval": 1e3 * t / n,
            "ratio_vs_bare": t / best["bare cma"],
        }
        for k, t in best.items()
    ]
    full, bare = best["optimize + archive"], best["bare cma"]
    overhead_ms = 1e3 * (full - bare) / n
    summary = {
        "dimension": DIM,
        "population": POP,
        "generations": args.generations,
        "ms_per_eval_bare_cma": 1e3 * bare / n,
        "ms_per_eval_full_loop": 1e3 * full / n,
        "framework_overhead_ms_per_eval": overhead_ms,
        "ratio_full_loop_vs_bare": full / bare,
        "target_overhead_ms_per_eval": 0.2,
        "target_ratio": 3.0,
        "meets_targets": bool(overhead_ms <= 0.2 and full / bare <= 3.0),
    }
    write_result("overhead", rows, summary, "python -m suspenv.bench.overhead", args.output)


if __name__ == "__main__":
    main()
