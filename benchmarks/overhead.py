"""Framework overhead: suspenv's loop against the bare library loops, in one run.

Three libraries, each on a cheap problem (the evaluation costs next to nothing, so every
microsecond the framework adds shows), each measured side by side with the same
strategy driven by suspenv's :func:`~suspenv.runs.loop.optimize` with its SQLite archive:

- ``pycma``: ``es.ask(); f = ...; es.tell()`` with pycma's own bound handling, a 49-D
  sphere (as many parameters as the K&C identification), population 42, 150 generations;
  against suspenv's ``cmaes``;
- ``pymoo``: pymoo's NSGA-II ask/tell loop (``algorithm.ask()``, a vectorised ZDT1,
  ``algorithm.tell()``), 30-D, population 100, 100 generations; against ``pymoo_nsga2``;
- ``optuna``: optuna's batched ask/tell loop with an ``NSGAIISampler`` on a 10-D ZDT1
  (a generation of ``study.ask`` with fixed distributions, evaluated as one array, then
  ``study.tell`` per trial), population 50, 30 generations; against ``nsga2`` (optuna's
  NSGA-II, one generation per ask). For information also ``study.optimize`` (one
  ``trial.suggest_float`` per parameter, one design a call), row ``study.optimize``.

Each suspenv case is also run without an archive (``run_dir=None``), which splits the
overhead into the loop's and the archive's share. Timing: process CPU time (the machine
may be shared, and CPU time is what the loop costs), and wall time for information; the
cases are repeated interleaved (drift hits every case alike) and the median of the
repetitions is reported, ratios against the bare loop of the same library measured in
the same run.

The workers study (rows ``library = "workers"``): CMA-ES, population 42, in-process
(``workers=1``) against a process pool of 2 with the default chunking (one chunk per
worker per batch) and with chunks of 5 and 1 designs, on a cheap problem (the sphere), the
K&C identification (a large fixed cost per call) and ``Burn`` (5 ms per call plus 20 ms
per design of pure CPU); CPU of the main process and the pool's workers, wall time, pool
start included. Each row also records the cores two processes got at once just before
(:func:`cores_free`): wall-time gains need idle cores, CPU time does not; and the
problem's own CPU per batch in-process (:func:`_evaluation_ms`), the part a pool divides
(the rest of a batch is the strategy's and the loop's, in the main process).

Run: ``python -m benchmarks.overhead [--repeat N] [--scale S] [--workers-repeat N]
[--output DIR]``; ``--only-workers`` prints the workers study alone.
Target (issue 44): each suspenv loop with its archive <= 1.1x its bare library loop.
"""

from __future__ import annotations

import argparse
import functools
import logging
import os
import resource
import statistics
import tempfile
import time
import warnings
from collections.abc import Callable
from typing import Any

import cma
import numpy as np
import optuna

from benchmarks.common import write_result
from suspenv.problems.toy import ZDT1, Sphere
from suspenv.runs.loop import optimize
from suspenv.strategies.cmaes import CMAES
from suspenv.strategies.nsga2 import NSGA2
from suspenv.strategies.pymoo_nsga2 import PymooNSGA2

#: pycma case: dimension, population, generations
CMA_DIM, CMA_POP, CMA_GEN = 49, 42, 150
#: pymoo case
PYMOO_DIM, PYMOO_POP, PYMOO_GEN = 30, 100, 100
#: optuna case
OPTUNA_DIM, OPTUNA_POP, OPTUNA_GEN = 10, 50, 30
#: whole loop (with archive) against the bare library loop (issue 44)
TARGET_RATIO = 1.1
#: framework overhead per evaluation against bare pycma [ms]
TARGET_OVERHEAD_MS = 0.2


def _zdt1_unit(U: np.ndarray) -> np.ndarray:
    """ZDT1 on [0, 1]^d (suspenv's ZDT1 box is the unit cube, so U is X)."""
    f1 = U[:, 0]
    g = 1.0 + 9.0 * U[:, 1:].sum(axis=1) / (U.shape[1] - 1)
    return np.column_stack([f1, g * (1.0 - np.sqrt(f1 / g))])


# ---------------------------------------------------------------------- bare loops
def _bare_cma(gen: int) -> None:
    es = cma.CMAEvolutionStrategy(
        [0.5] * CMA_DIM,
        0.25,
        {
            "popsize": CMA_POP,
            "bounds": [0, 1],
            "seed": 1,
            "verbose": -9,
            "verb_log": 0,
            "verb_disp": 0,
        },
    )
    for _ in range(gen):
        X = np.asarray(es.ask())
        f = ((2 * X - 1 - 0.3) ** 2).sum(axis=1)
        es.tell(list(X), f.tolist())


def _bare_pymoo(gen: int) -> None:
    from pymoo.algorithms.moo import nsga2 as pymoo_nsga2
    from pymoo.core.evaluator import Evaluator
    from pymoo.core.problem import Problem as PymooProblem
    from pymoo.core.termination import NoTermination
    from pymoo.problems.static import StaticProblem

    problem = PymooProblem(n_var=PYMOO_DIM, n_obj=2, xl=0.0, xu=1.0)
    algorithm = pymoo_nsga2.NSGA2(pop_size=PYMOO_POP)
    algorithm.setup(problem, termination=NoTermination(), seed=1, verbose=False)
    for _ in range(gen):
        pop = algorithm.ask()
        F = _zdt1_unit(np.asarray(pop.get("X")))
        Evaluator().eval(StaticProblem(problem, F=F), pop)
        algorithm.tell(infills=pop)


def _optuna_study() -> optuna.Study:
    optuna.logging.set_verbosity(logging.WARNING)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        sampler = optuna.samplers.NSGAIISampler(population_size=OPTUNA_POP, seed=1)
    return optuna.create_study(sampler=sampler, directions=["minimize", "minimize"])


def _bare_optuna(gen: int) -> None:
    """optuna's batched ask/tell loop: a generation of trials asked with fixed
    distributions, evaluated as one array, told one by one."""
    study = _optuna_study()
    dists: dict[str, optuna.distributions.BaseDistribution] = {
        f"u{i}": optuna.distributions.FloatDistribution(0.0, 1.0) for i in range(OPTUNA_DIM)
    }
    for _ in range(gen):
        trials = [study.ask(dists) for _ in range(OPTUNA_POP)]
        F = _zdt1_unit(np.array([list(t.params.values()) for t in trials]))
        for trial, f in zip(trials, F.tolist(), strict=True):
            study.tell(trial, f)


def _optuna_optimize(gen: int) -> None:
    """``study.optimize``: one ``trial.suggest_float`` per parameter, one design a call."""
    study = _optuna_study()

    def objective(trial: optuna.trial.Trial) -> tuple[float, float]:
        u = np.array([trial.suggest_float(f"u{i}", 0.0, 1.0) for i in range(OPTUNA_DIM)])
        f = _zdt1_unit(u[None, :])[0]
        return float(f[0]), float(f[1])

    study.optimize(objective, n_trials=gen * OPTUNA_POP)


# -------------------------------------------------------------- suspenv's loops
def _suspenv(library: str, gen: int, archive: bool) -> None:
    if library == "pycma":
        p: Sphere | ZDT1 = Sphere(CMA_DIM)
        s: CMAES | PymooNSGA2 | NSGA2 = CMAES(CMA_DIM, seed=1, popsize=CMA_POP)
        budget = gen * CMA_POP
    elif library == "pymoo":
        p = ZDT1(PYMOO_DIM)
        s = PymooNSGA2(PYMOO_DIM, 2, seed=1, population_size=PYMOO_POP)
        budget = gen * PYMOO_POP
    else:
        p = ZDT1(OPTUNA_DIM)
        s = NSGA2(OPTUNA_DIM, 2, seed=1, population_size=OPTUNA_POP)
        budget = gen * OPTUNA_POP
    with tempfile.TemporaryDirectory() as d:
        optimize(p, s, budget=budget, run_dir=d if archive else None)


# ------------------------------------------------------------------- workers
class Burn(Sphere):
    """The sphere at a stated CPU cost: ``fixed_ms`` per call plus ``per_design_ms`` per
    design, spent spinning (process CPU time), so the cost of a call is known exactly."""

    name = "Burn"

    def __init__(self, dim: int = 8, fixed_ms: float = 5.0, per_design_ms: float = 20.0):
        super().__init__(dim)
        self.fixed_ms, self.per_design_ms = fixed_ms, per_design_ms

    def _evaluate(self, X: np.ndarray) -> Any:
        until = time.process_time() + 1e-3 * (self.fixed_ms + self.per_design_ms * len(X))
        while time.process_time() < until:
            pass
        return super()._evaluate(X)


#: the workers study: problem (a registered name or a class here), its options, CMA-ES
#: options, generations
WORKER_CASES: dict[str, tuple[str | type, dict[str, Any], dict[str, Any], int]] = {
    "Sphere (cheap)": ("Sphere", {"dim": 49}, {"popsize": 42}, 40),
    "KCIdentification": ("KCIdentification", {}, {"popsize": 42}, 4),
    "Burn 5 ms/call + 20 ms/design": (Burn, {}, {"popsize": 42}, 3),
}


def _workers_run(case: str, workers: int, chunk_size: int | None) -> dict[str, float]:
    """One run of a workers-study case: CPU of this process and of the pool's workers
    (reaped when the pool shuts down), wall time, pool start included."""
    from suspenv.registry import make_problem, make_strategy
    from suspenv.runs.executors import executor_workers, make_executor

    name, options, strategy_options, gen = WORKER_CASES[case]
    problem = make_problem(name, **options) if isinstance(name, str) else name(**options)
    strategy = make_strategy("cmaes", problem, seed=1, **strategy_options)
    run = {"workers": workers}
    load = os.getloadavg()[0]
    c0, w0 = time.process_time(), time.perf_counter()
    k0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as d, make_executor(run) as executor:
        optimize(
            problem,
            strategy,
            gen * strategy_options["popsize"],
            run_dir=d,
            executor=executor,
            workers=executor_workers(run),
            chunk_size=chunk_size,
        )
    k1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    children = (k1.ru_utime - k0.ru_utime) + (k1.ru_stime - k0.ru_stime)
    return {
        "wall_s": time.perf_counter() - w0,
        "cpu_main_s": time.process_time() - c0,
        "cpu_workers_s": children,
        "load": load,
    }


def _evaluation_ms(case: str, repeat: int = 5) -> float:
    """CPU milliseconds of one in-process call of the case's problem on a batch of its
    population (random designs; the median of ``repeat`` calls after a warm-up): the
    part of a batch that a pool divides among its workers."""
    import numpy as np

    from suspenv.registry import make_problem

    name, options, strategy_options, _ = WORKER_CASES[case]
    problem = make_problem(name, **options) if isinstance(name, str) else name(**options)
    rng = np.random.default_rng(0)
    X = problem.space.to_physical(rng.random((strategy_options["popsize"], problem.space.dim)))
    problem.evaluate(X)
    return 1e3 * statistics.median(_measure(lambda: problem.evaluate(X))[0] for _ in range(repeat))


def _spin(seconds: float) -> float:
    until = time.process_time() + seconds
    while time.process_time() < until:
        pass
    return seconds


def cores_free(workers: int = 2, seconds: float = 0.5) -> float:
    """Cores ``workers`` processes get at once right now: each spins ``seconds`` of CPU;
    the CPU they got together divided by the wall time (2.0 on an idle 2-core machine,
    about 1.0 when other processes keep one core busy)."""
    import multiprocessing as mp

    with mp.get_context("fork").Pool(workers) as pool:
        pool.map(_spin, [0.05] * workers)  # start-up out of the measurement
        w0 = time.perf_counter()
        pool.map(_spin, [seconds] * workers)
        return workers * seconds / (time.perf_counter() - w0)


def workers_study(repeat: int) -> list[dict[str, Any]]:
    """``workers`` 1 against 2 (default chunking, one chunk per worker per batch) and 2 with
    chunks of 1 and 5 designs (the fixed cost per chunk), interleaved, medians."""
    configs = [(1, None), (2, None), (2, 5), (2, 1)]
    rows = []
    for case in WORKER_CASES:
        runs: dict[tuple[int, int | None], list[dict[str, float]]] = {c: [] for c in configs}
        try:
            _workers_run(case, 1, None)  # warm-up (imports, caches)
        except Exception as exc:  # noqa: BLE001 - a problem being edited: say so, go on
            print(f"workers study: {case} skipped ({type(exc).__name__}: {exc})")
            continue
        free: list[float] = []
        for _ in range(repeat):
            free.append(cores_free())
            for c in configs:
                runs[c].append(_workers_run(case, *c))
        _, _, so, gen = WORKER_CASES[case]
        n = gen * so["popsize"]
        evaluation = _evaluation_ms(case)
        base = statistics.median(r["wall_s"] for r in runs[(1, None)])
        base_cpu = statistics.median(r["cpu_main_s"] + r["cpu_workers_s"] for r in runs[(1, None)])
        for (workers, chunk), rs in runs.items():
            wall = statistics.median(r["wall_s"] for r in rs)
            cpu = statistics.median(r["cpu_main_s"] + r["cpu_workers_s"] for r in rs)
            rows.append(
                {
                    "library": "workers",
                    "case": f"{case}: workers={workers}, chunk="
                    + ("default" if chunk is None else str(chunk)),
                    "evaluations": n,
                    "batch": so["popsize"],
                    "wall_s": wall,
                    "cpu_s": cpu,
                    "ms_per_eval_wall": 1e3 * wall / n,
                    "ms_per_eval_cpu": 1e3 * cpu / n,
                    "wall_vs_workers_1": wall / base,
                    "cpu_vs_workers_1": cpu / base_cpu,
                    # the problem's own CPU per batch in-process (what a pool divides)
                    "evaluation_ms_per_batch": evaluation,
                    # other processes' demand on the machine's cores when the runs began
                    "load_1min": statistics.median(r["load"] for r in rs),
                    # cores two processes got at once, measured before each repetition
                    "cores_free_2proc": statistics.median(free),
                }
            )
    return rows


def _measure(fn: Callable[[], None]) -> tuple[float, float]:
    """(process CPU seconds, wall seconds) of one call."""
    c0, w0 = time.process_time(), time.perf_counter()
    fn()
    return time.process_time() - c0, time.perf_counter() - w0


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=21, help="interleaved repetitions")
    ap.add_argument("--scale", type=float, default=1.0, help="generations times this")
    ap.add_argument("--output", default=None, help="folder for overhead.json")
    ap.add_argument(
        "--workers-repeat", type=int, default=3, help="repetitions of the workers study (0: skip)"
    )
    ap.add_argument("--only-workers", action="store_true", help="run the workers study only")
    args = ap.parse_args(argv)
    if args.only_workers:
        from benchmarks.common import format_table

        print(format_table(workers_study(max(args.workers_repeat, 1))))
        return
    gens = {
        lib: max(2, round(g * args.scale))
        for lib, g in (("pycma", CMA_GEN), ("pymoo", PYMOO_GEN), ("optuna", OPTUNA_GEN))
    }
    pops = {"pycma": CMA_POP, "pymoo": PYMOO_POP, "optuna": OPTUNA_POP}
    bare = {"pycma": _bare_cma, "pymoo": _bare_pymoo, "optuna": _bare_optuna}
    cases: dict[tuple[str, str], Callable[[], None]] = {}
    for lib, g in gens.items():
        cases[(lib, "bare")] = functools.partial(bare[lib], g)
        cases[(lib, "suspenv, no archive")] = functools.partial(_suspenv, lib, g, False)
        cases[(lib, "suspenv + archive")] = functools.partial(_suspenv, lib, g, True)
    cases[("optuna", "study.optimize")] = functools.partial(_optuna_optimize, gens["optuna"])
    for fn in cases.values():  # warm-up: imports, caches
        fn()
    load = [os.getloadavg()[0]]  # other processes' demand on the shared cores
    cpu: dict[tuple[str, str], list[float]] = {k: [] for k in cases}
    wall: dict[tuple[str, str], list[float]] = {k: [] for k in cases}
    ratios: dict[tuple[str, str], list[float]] = {k: [] for k in cases}
    order = list(cases)
    for rep in range(args.repeat):  # interleaved, so drift hits every case alike
        for k in order if rep % 2 == 0 else order[::-1]:  # and alternating, to cancel it
            c, w = _measure(cases[k])
            cpu[k].append(c)
            wall[k].append(w)
        for k in cases:  # ratio within this repetition, against this repetition's bare
            ratios[k].append(cpu[k][-1] / cpu[(k[0], "bare")][-1])
        load.append(os.getloadavg()[0])
    rows = []
    for (lib, case), cs in cpu.items():
        n = gens[lib] * pops[lib]
        c = statistics.median(cs)
        rows.append(
            {
                "library": lib,
                "case": case,
                "evaluations": n,
                "cpu_s": c,
                "wall_s": statistics.median(wall[(lib, case)]),
                "ms_per_eval": 1e3 * c / n,
                "overhead_ms_per_eval": 1e3 * (c - statistics.median(cpu[(lib, "bare")])) / n,
                "ratio_vs_bare": statistics.median(ratios[(lib, case)]),
                # the least disturbed estimate on a shared machine: best against best
                "ratio_of_best": min(cs) / min(cpu[(lib, "bare")]),
                "ratio_min": min(ratios[(lib, case)]),
                "ratio_max": max(ratios[(lib, case)]),
            }
        )
    by = {(r["library"], r["case"]): r for r in rows}
    full = {lib: by[(lib, "suspenv + archive")] for lib in gens}
    worst = max(r["ratio_vs_bare"] for r in full.values())
    summary = {
        "repeat": args.repeat,
        "timing": "process CPU time, median of interleaved repetitions",
        # 1-minute load average before the repetitions and after each one (2 cores)
        "load_1min_median": statistics.median(load),
        "load_1min_max": max(load),
        "dimension": CMA_DIM,
        "population": CMA_POP,
        "generations": gens["pycma"],
        "ms_per_eval_bare_cma": by[("pycma", "bare")]["ms_per_eval"],
        "ms_per_eval_full_loop": full["pycma"]["ms_per_eval"],
        "framework_overhead_ms_per_eval": full["pycma"]["overhead_ms_per_eval"],
        "ratio_full_loop_vs_bare": full["pycma"]["ratio_vs_bare"],
        "ratio_vs_bare_pycma": full["pycma"]["ratio_vs_bare"],
        "ratio_vs_bare_pymoo": full["pymoo"]["ratio_vs_bare"],
        "ratio_vs_bare_optuna": full["optuna"]["ratio_vs_bare"],
        "overhead_ms_per_eval_pymoo": full["pymoo"]["overhead_ms_per_eval"],
        "overhead_ms_per_eval_optuna": full["optuna"]["overhead_ms_per_eval"],
        # for information: against optuna's one-design-a-call loop
        "ratio_vs_optuna_study_optimize": statistics.median(
            a / b
            for a, b in zip(
                cpu[("optuna", "suspenv + archive")], cpu[("optuna", "study.optimize")], strict=True
            )
        ),
        "worst_ratio": worst,
        "ratio_of_best_pycma": full["pycma"]["ratio_of_best"],
        "ratio_of_best_pymoo": full["pymoo"]["ratio_of_best"],
        "ratio_of_best_optuna": full["optuna"]["ratio_of_best"],
        "target_overhead_ms_per_eval": TARGET_OVERHEAD_MS,
        "target_ratio": TARGET_RATIO,
        "meets_targets": bool(
            worst <= TARGET_RATIO and full["pycma"]["overhead_ms_per_eval"] <= TARGET_OVERHEAD_MS
        ),
    }
    if args.workers_repeat > 0:
        rows += workers_study(args.workers_repeat)
    write_result("overhead", rows, summary, "python -m benchmarks.overhead", args.output)


if __name__ == "__main__":
    main()
