"""The minibus study end to end: ``suspenv run experiments/minibus_nsga2.toml``, timed in one
run against its baselines.

The study's settings (pymoo's NSGA-II, population 500 for 60 generations: 30,000
evaluations of ``MinibusRideHandling`` with its default options), three ways, repeated
and interleaved (a load that changes during the run weighs on all alike):

- ``command, 2 workers``: the command as the README gives it (``run.workers = 2``), in a
  subprocess, its run folder in a temporary directory: the wall time of the whole command
  (interpreter start-up and imports, the loop, the CSV export, the report and its
  figures), the loop's wall time as the run records it (``summary.json``,
  ``wall_time_s``) and the rest (start-up, export, report), and the CPU time of the
  command with its worker processes;
- ``command, 1 worker``: the same with ``run.workers = 1`` (every evaluation in the
  command's own process): what the pool of 2 gains on this machine;
- ``bare pymoo loop``: pymoo's NSGA-II ask/tell loop with the same population,
  generations, operators and seed over the problem's batched evaluation, in this
  process, with no archive, run folder, pool or report: the floor the command's loop
  adds to. It evaluates the very designs the command archives, row by row (checked:
  ``bare_loop_same_designs``), so both time the same work.

The ``cores_free`` column is what two processes got at once just before each repetition
(2.0 on an idle 2-core machine): wall-time gains of the pool need idle cores. Figures are
medians over the repetitions, with the slowest beside them. The study's own results
(evaluations that succeeded, feasible designs, the Pareto front's size, the ride-focused
pick against the baseline) are read from the first 2-worker run's archive, with the
check that the 1-worker run archived the same numbers (same seed, same numbers, whatever
the pool).

Same seed, other machine: one more 2-worker run with another OpenBLAS kernel
(``OPENBLAS_CORETYPE``, :data:`OTHER_KERNEL`) records where its designs first differ and
its counts (``other_blas_kernel``): the objectives differ in their last digits between
kernels, and once a selection tie flips NSGA-II's path diverges, so the feasible and
Pareto counts of a 30,000-evaluation run are machine-dependent; a design's objectives
are not.

Target (issue 17): the whole command <= 60 s wall on 2 cores.

Run: ``python -m benchmarks.minibus_study [--repeat N] [--output-dir DIR]``; writes
``docs/benchmarks/minibus_study.json``.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import write_result
from benchmarks.overhead import cores_free
from suspenv.problems.minibus import study_outcome
from suspenv.registry import make_problem
from suspenv.runs.archive import RunArchive
from suspenv.runs.config import load_config
from suspenv.runs.run_dir import load_summary

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "experiments" / "minibus_nsga2.toml"
TARGET_S = 60.0
#: the three ways, in the order of the rows
WAYS = ("command, 2 workers", "command, 1 worker", "bare pymoo loop")
#: objective value a failed evaluation gets in the bare loop (as ``pymoo_nsga2`` does)
FAILED_F = 1e10


def run_command(
    config: Path,
    out_dir: Path,
    workers: int,
    env: dict[str, str] | None = None,
    sets: Sequence[str] = (),
) -> dict[str, Any]:
    """``suspenv run config`` with ``run.workers = workers``, the further ``--set``
    overrides ``sets`` and its run folder under ``out_dir``, in a subprocess (environment
    ``env`` added to this one's): wall time [s], loop wall time [s] from the run's
    ``summary.json``, CPU time [s] of the command and its workers, the run folder."""
    cmd = [
        sys.executable,
        "-c",
        "import sys; from suspenv.cli.main import main; sys.exit(main())",
        "run",
        str(config),
        "--set",
        f'run.output="{out_dir}"',
        "--set",
        f"run.workers={workers}",
        *(arg for item in sets for arg in ("--set", item)),
    ]
    k0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    w0 = time.perf_counter()
    done = subprocess.run(
        cmd,
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=False,
        env={**os.environ, **(env or {})},
    )
    wall = time.perf_counter() - w0
    k1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(
            f"`{' '.join(cmd[3:])}` exited with {done.returncode}:\n{done.stderr[-2000:]}"
        )
    run_dir = next(p for p in out_dir.iterdir() if (p / "summary.json").is_file())
    loop = float(load_summary(run_dir)["wall_time_s"])
    cpu = (k1.ru_utime - k0.ru_utime) + (k1.ru_stime - k0.ru_stime)
    return {"wall_s": wall, "loop_wall_s": loop, "cpu_s": cpu, "run_dir": run_dir}


def bare_pymoo_loop(cfg: dict[str, Any]) -> dict[str, Any]:
    """pymoo's NSGA-II ask/tell loop over the config's problem, batched evaluation in this
    process (population, generations, operators and seed of the config): wall and CPU
    time [s], the feasible count and every evaluated design (physical units, in order:
    the command's archive holds the same rows)."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.evaluator import Evaluator
    from pymoo.core.problem import Problem as PymooProblem
    from pymoo.core.termination import NoTermination
    from pymoo.operators.crossover.sbx import SBX
    from pymoo.operators.mutation.pm import PM
    from pymoo.problems.static import StaticProblem

    opts = cfg["strategy"]["options"]
    problem = make_problem(cfg["problem"]["name"], **cfg["problem"].get("options", {}))
    pop = int(opts["population_size"])
    generations = int(cfg["budget"]) // pop
    k = problem.n_constraints
    space = PymooProblem(
        n_var=problem.space.dim, n_obj=problem.n_objectives, n_ieq_constr=k + 1, xl=0.0, xu=1.0
    )
    algorithm = NSGA2(
        pop_size=pop,
        crossover=SBX(prob=float(opts["crossover_prob"]), eta=float(opts.get("crossover_eta", 15))),
        mutation=PM(eta=float(opts.get("mutation_eta", 20))),
    )
    c0, w0 = time.process_time(), time.perf_counter()
    algorithm.setup(space, termination=NoTermination(), seed=int(cfg["seed"]), verbose=False)
    feasible = 0
    designs = []
    for _ in range(generations):
        infill = algorithm.ask()
        designs.append(problem.space.to_physical(np.asarray(infill.get("X"))))
        batch = problem.evaluate(designs[-1])
        ok = batch.ok
        F = np.where(ok[:, None], np.nan_to_num(batch.objectives, nan=FAILED_F), FAILED_F)
        G = np.where(ok[:, None], np.nan_to_num(batch.scaled_constraints, nan=1.0), 1.0)
        feasible += int((ok & (G <= 0).all(axis=1)).sum())
        G = np.column_stack([G, (~ok).astype(float)])
        Evaluator().eval(StaticProblem(space, F=F, G=G), infill)
        algorithm.tell(infills=infill)
    wall = time.perf_counter() - w0
    return {
        "wall_s": wall,
        "loop_wall_s": wall,
        "cpu_s": time.process_time() - c0,
        "evaluations": generations * pop,
        "feasible": feasible,
        "x": np.concatenate(designs),
    }


def study_results(
    arrays: dict[str, np.ndarray], problem_name: str, options: dict[str, Any]
) -> dict[str, Any]:
    """What the study found (the report's figures, :func:`study_outcome`) from a run
    folder's archive ``arrays``."""
    problem = make_problem(problem_name, **options)
    found = study_outcome(problem, arrays)
    if found is None:
        raise RuntimeError("the study's run archived no successful evaluation")
    return {
        "evaluations": int(found.ok.size),
        "ok": int(found.ok.sum()),
        "feasible": int(found.feasible.sum()),
        "pareto_front": int(found.front.sum()),
        "objective_names": list(problem.objective_names),
        "objective_units": list(problem.objective_units or ()),
        "baseline_objectives": [float(v) for v in found.baseline],
        "ride_focused_pick_objectives": [float(v) for v in found.F[found.pick]],
        "ride_focused_pick_x": dict(
            zip(problem.space.names, (float(v) for v in found.X[found.pick]), strict=True)
        ),
    }


def _shown(path: Path) -> str:
    """``path`` relative to the repository when inside it (no machine's folders in JSON)."""
    full = path.resolve()
    return str(full.relative_to(ROOT)) if full.is_relative_to(ROOT) else str(path)


def archive_arrays(run_dir: Path) -> dict[str, np.ndarray]:
    """The arrays a run folder's archive holds (:meth:`RunArchive.arrays`)."""
    with RunArchive(run_dir) as archive:
        return archive.arrays()


def same_rows(a: dict[str, np.ndarray], b: dict[str, np.ndarray], keys: Sequence[str]) -> bool:
    """``a`` and ``b`` hold the same arrays under ``keys``, row by row (NaN equal)."""
    return all(
        a[k].shape == b[k].shape and np.array_equal(a[k], b[k], equal_nan=True) for k in keys
    )


#: the OpenBLAS kernel of the check run (``OPENBLAS_CORETYPE``; the library's runtime
#: kernel choice, so the same machine stands in for another CPU)
OTHER_KERNEL = "Sandybridge"


def kernel_check(
    a: dict[str, np.ndarray], b: dict[str, np.ndarray], cfg: dict[str, Any]
) -> dict[str, Any]:
    """How the run ``b`` (another BLAS kernel) departs from ``a``: the generation whose
    designs first differ (None: none), the largest relative objective difference before
    it, and ``b``'s feasible and Pareto counts."""
    pop = int(cfg["strategy"]["options"]["population_size"])
    differ = np.flatnonzero(np.any(a["x"] != b["x"], axis=1))
    first = int(differ[0]) if differ.size else len(a["x"])
    fa, fb = a["objectives"][:first], b["objectives"][:first]
    found = study_results(b, cfg["problem"]["name"], cfg["problem"].get("options", {}))
    return {
        "kernel": OTHER_KERNEL,
        "first_different_generation": first // pop if differ.size else None,
        "max_relative_objective_difference_before": float(
            np.max(np.abs(fa - fb) / np.maximum(np.abs(fa), 1e-300))
        ),
        "feasible": found["feasible"],
        "pareto_front": found["pareto_front"],
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="repetitions of each way")
    parser.add_argument("--config", type=Path, default=CONFIG, help=argparse.SUPPRESS)
    parser.add_argument("--output-dir", default=None, help="default docs/benchmarks")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"`--repeat >= 1` must hold, but got {args.repeat}")
    cfg = load_config(args.config)
    ways = WAYS
    runs: dict[str, list[dict[str, Any]]] = {w: [] for w in ways}
    free: list[float] = []
    loads: list[float] = []
    with tempfile.TemporaryDirectory(prefix="suspenv-minibus-study-") as tmp:
        first: dict[str, Path] = {}
        for rep in range(args.repeat):
            free.append(cores_free())
            loads.append(os.getloadavg()[0])
            for way, workers in zip(ways[:2], (2, 1), strict=True):
                out = Path(tmp) / f"{rep}-{workers}"
                out.mkdir()
                r = run_command(args.config, out, workers)
                first.setdefault(way, r.pop("run_dir"))
                runs[way].append(r)
                print(f"{way}: {r}", file=sys.stderr)
            r = bare_pymoo_loop(cfg)
            bare_x = r.pop("x")
            runs[ways[2]].append(r)
            print(f"{ways[2]}: {r}", file=sys.stderr)
        two_workers, one_worker = (archive_arrays(first[w]) for w in ways[:2])
        study = study_results(
            two_workers, cfg["problem"]["name"], cfg["problem"].get("options", {})
        )
        same = same_rows(two_workers, one_worker, ("x", "objectives"))
        same_as_bare = same_rows(two_workers, {"x": bare_x}, ("x",))
        out = Path(tmp) / "kernel"
        out.mkdir()
        kernel_dir = run_command(args.config, out, 2, {"OPENBLAS_CORETYPE": OTHER_KERNEL})
        kernel = kernel_check(two_workers, archive_arrays(kernel_dir["run_dir"]), cfg)

    def med(way: str, key: str) -> float:
        return float(statistics.median(r[key] for r in runs[way]))

    def worst(way: str, key: str) -> float:
        return float(max(r[key] for r in runs[way]))

    rows = []
    for way in ways:
        rows.append(
            {
                "way": way,
                "wall_s": med(way, "wall_s"),
                "wall_s_slowest": worst(way, "wall_s"),
                "loop_wall_s": med(way, "loop_wall_s"),
                "rest_wall_s": med(way, "wall_s") - med(way, "loop_wall_s"),
                "cpu_s": med(way, "cpu_s"),
                "repeats": len(runs[way]),
            }
        )
    two, one, bare = ways
    summary = {
        "config": _shown(args.config),
        "evaluations": int(cfg["budget"]),
        "population": int(cfg["strategy"]["options"]["population_size"]),
        "workers": 2,
        "command_wall_s": med(two, "wall_s"),
        "command_wall_s_slowest": worst(two, "wall_s"),
        "loop_wall_s": med(two, "loop_wall_s"),
        "rest_wall_s": med(two, "wall_s") - med(two, "loop_wall_s"),
        "command_cpu_s": med(two, "cpu_s"),
        "one_worker_command_wall_s": med(one, "wall_s"),
        "one_worker_loop_wall_s": med(one, "loop_wall_s"),
        "bare_loop_wall_s": med(bare, "wall_s"),
        "bare_loop_cpu_s": med(bare, "cpu_s"),
        "loop_wall_vs_bare": med(two, "loop_wall_s") / med(bare, "wall_s"),
        "one_worker_loop_wall_vs_bare": med(one, "loop_wall_s") / med(bare, "wall_s"),
        "two_workers_loop_wall_vs_one": med(two, "loop_wall_s") / med(one, "loop_wall_s"),
        "cores_free_2proc": float(statistics.median(free)),
        "load_average_1min": float(statistics.median(loads)),
        "target_s": TARGET_S,
        "meets_target": med(two, "wall_s") <= TARGET_S,
        "meets_target_slowest": worst(two, "wall_s") <= TARGET_S,
        "same_numbers_1_and_2_workers": same,
        "bare_loop_same_designs": same_as_bare,
        "study": study,
        "other_blas_kernel": kernel,
    }
    write_result(
        "minibus_study",
        rows,
        summary,
        "python -m benchmarks.minibus_study",
        args.output_dir,
    )
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
