"""Strategies compared on the kept objectives, several seeds each, through ``suspenv compare``.

Every (strategy, seed) run is an ordinary run directory (``archive.sqlite`` and a
``summary.json`` with a best-so-far quality curve), so ``suspenv compare DIR...`` reads
them; :func:`compare_strategies` calls the same comparison (the registered report
``comparison``, :func:`suspenv.reports.analysis.write_comparison`) and returns its table.

Quality (lower is better): the rank-sum of the kept objectives with its min-max
normalisation frozen on the design of experiments
(:class:`~suspenv.methods.tey2014.identification.FixedRankSum`), over feasible designs; the same
measure for every strategy. Defaults: CMA-ES with population 42 on the rank-sum; NSGA-II with
population 42 on the kept objectives; random search and Latin hypercube in batches of 42.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.problem import Problem
from suspenv.methods.tey2014.identification import FixedRankSum
from suspenv.registry import make_strategy, report_function
from suspenv.runs.quality import best_so_far, curve_items, feasible
from suspenv.runs.run_dir import write_json

#: options per strategy unless the caller overrides them
STRATEGY_OPTIONS: dict[str, dict[str, Any]] = {
    "cmaes": {"popsize": 42, "sigma0": 0.25, "scalarizer": "rank_sum"},
    "nsga2": {"population_size": 42},
    "random": {"batch_size": 42, "scalarizer": "rank_sum"},
    "lhs": {"batch_size": 42},
}

QUALITY_NAME = "DoE-normalised rank-sum"


@dataclass
class RunArrays:
    """Evaluations of one optimisation run (archive order)."""

    unit: np.ndarray
    x: np.ndarray
    objectives: np.ndarray
    constraints: np.ndarray
    ok: np.ndarray
    batch: np.ndarray

    @property
    def valid(self) -> np.ndarray:
        """Feasible designs whose every objective is finite (n,)."""
        return feasible(self.ok, self.constraints) & np.isfinite(self.objectives).all(axis=1)


def optimize_arrays(
    problem: Problem,
    strategy: Any,
    budget: int,
    run_dir: Path,
    seed: int,
    run_cfg: dict[str, Any],
    **options: Any,
) -> tuple[Any, RunArrays]:
    """:func:`suspenv.runs.loop.optimize` into ``run_dir`` with the executor, workers,
    progress and fault policy of ``run_cfg`` (``options``: further keywords of
    ``optimize``); returns its result and the archive's evaluations."""
    from suspenv.runs.archive import RunArchive
    from suspenv.runs.evaluation import FaultPolicy
    from suspenv.runs.executors import executor_workers, make_executor
    from suspenv.runs.loop import optimize

    with make_executor(run_cfg) as executor:
        result = optimize(
            problem,
            strategy,
            budget,
            run_dir=run_dir,
            seed=seed,
            executor=executor,
            workers=executor_workers(run_cfg),
            progress=bool(run_cfg.get("progress", False)),
            faults=FaultPolicy.for_run(run_cfg, problem),
            **options,
        )
    with RunArchive(run_dir) as archive:
        a = archive.arrays()
    columns = a["unit"], a["x"], a["objectives"], a["constraints"], a["ok"], a["batch"]
    return result, RunArrays(*columns)


def run_one(
    problem: Problem,
    strategy_name: str,
    seed: int,
    budget: int,
    quality: FixedRankSum,
    run_dir: Path,
    run_cfg: dict[str, Any],
    options: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """One run into ``run_dir``; writes and returns its ``summary.json`` content."""
    opts = {**STRATEGY_OPTIONS.get(strategy_name, {}), **(options or {})}
    if strategy_name == "lhs":
        opts.setdefault("n_samples", int(budget))
    strategy = make_strategy(strategy_name, problem, seed=int(seed), **opts)
    result, runs = optimize_arrays(problem, strategy, int(budget), run_dir, int(seed), run_cfg)
    summary = {
        "name": run_dir.name,
        "seed": int(seed),
        "problem": problem.name,
        "strategy": strategy_name,
        "strategy_options": strategy.options() if hasattr(strategy, "options") else opts,
        "budget": int(budget),
        **result.as_dict(),
        "n_ok": int(runs.ok.sum()),
        "n_feasible": int(runs.valid.sum()),
        "objective_names": list(problem.objective_names),
        "quality_name": QUALITY_NAME,
        **curve_items(best_so_far(quality(runs.objectives), runs.valid)),
    }
    write_json(run_dir / "summary.json", summary)
    return summary


def compare_strategies(
    problem: Problem,
    strategies: Sequence[str],
    seeds: Sequence[int],
    budget: int,
    quality: FixedRankSum,
    out_dir: Path,
    run_cfg: dict[str, Any] | None = None,
    options: dict[str, dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """Run every strategy with every seed into ``out_dir/<strategy>-seed<seed>``, then compare.

    Returns the ``suspenv compare`` result (table rows per strategy: median, min and max
    of the best quality over seeds) with the run directories; the spread plot is
    ``out_dir/compare.png``.
    """
    out_dir = Path(out_dir)
    run_cfg = {"workers": 1, "progress": False, **(run_cfg or {})}
    dirs = []
    for name in strategies:
        for seed in seeds:
            d = out_dir / f"{name}-seed{seed}"
            run_one(problem, name, seed, budget, quality, d, run_cfg, (options or {}).get(name))
            dirs.append(d)
    result: dict[str, Any] = report_function("comparison")(dirs, out_dir)
    result["runs"] = [str(d.relative_to(out_dir)) for d in dirs]
    return result
