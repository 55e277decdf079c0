"""The "optimize" pipeline: one problem, one strategy, one budget -> a run directory.

Writes ``archive.sqlite`` (every evaluation, as it happens), ``evaluations.csv``,
``summary.json``, ``config.resolved.toml``, ``versions.json`` and figures
(``convergence.png``; ``pareto_pairs.png`` and ``pareto_parallel.png`` for several
objectives), then any report the problem writes itself.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.experiments import plots
from suspenv.optimize import optimize
from suspenv.recording.archive import RunArchive
from suspenv.registry import make_problem, make_strategy


@contextlib.contextmanager
def make_executor(run: dict[str, Any]) -> Iterator[Executor | None]:
    """None (in-process), a process pool (``workers > 1``) or a Dask cluster's executor."""
    address = run.get("dask_scheduler")
    if address:
        from distributed import Client

        with Client(address) as client:
            yield client.get_executor()
    elif run.get("workers", 1) > 1:
        with ProcessPoolExecutor(max_workers=run["workers"]) as pool:
            yield pool
    else:
        yield None


def quality_curve(problem: Any, arrays: dict[str, np.ndarray]) -> np.ndarray:
    """Best-so-far of the problem's quality measure over evaluations."""
    F = arrays["objectives"]
    feasible = arrays["ok"].copy()
    if arrays["constraints"].size:
        feasible &= np.nan_to_num(arrays["constraints"], nan=1.0).max(axis=1) <= 0
    q = problem.quality(F) if len(F) else np.zeros(0)
    return plots.best_so_far(np.asarray(q, float), feasible)


def write_run_outputs(
    problem: Any, run_dir: Path, config: dict[str, Any], result: Any, strategy: Any
) -> dict[str, Any]:
    """Summary JSON, CSV export and figures of a finished run; returns the summary."""
    with RunArchive(run_dir) as archive:
        arrays = archive.arrays()
        archive.to_csv(run_dir / "evaluations.csv")
        names = list(problem.objective_names)
        feasible = arrays["ok"].copy()
        if arrays["constraints"].size:
            feasible &= np.nan_to_num(arrays["constraints"], nan=1.0).max(axis=1) <= 0
        curve = quality_curve(problem, arrays)
        figures = []
        if config["run"].get("plots", True) and len(arrays["ok"]):
            figures.append(
                plots.plot_convergence(
                    arrays["objectives"], feasible, names, run_dir / "convergence.png"
                )
            )
            if len(names) > 1 and feasible.sum() > 1:
                figures.append(
                    plots.plot_pareto_pairs(
                        arrays["objectives"], feasible, names, run_dir / "pareto_pairs.png"
                    )
                )
                figures.append(
                    plots.plot_parallel(
                        arrays["objectives"], feasible, names, run_dir / "pareto_parallel.png"
                    )
                )
        figures += problem.write_report(run_dir, archive)
    finite = np.isfinite(curve)
    summary = {
        "name": config["name"],
        "seed": config["seed"],
        "problem": problem.name,
        "problem_options": config["problem"].get("options", {}),
        "strategy": config["strategy"]["name"],
        "strategy_options": strategy.options() if hasattr(strategy, "options") else {},
        "budget": config["budget"],
        **result.as_dict(),
        "n_ok": int(arrays["ok"].sum()),
        "n_feasible": int(feasible.sum()),
        "objective_names": names,
        "quality_name": problem.quality_name,
        "best_quality": float(curve[finite][-1]) if finite.any() else None,
        "quality_curve": [float(v) if np.isfinite(v) else None for v in curve],
        "figures": [str(Path(f).name) for f in figures],
    }
    (run_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary


def run_optimize_pipeline(config: dict[str, Any], run_dir: Path) -> dict[str, Any]:
    """Run the config's strategy on its problem; write every output into ``run_dir``."""
    problem = make_problem(config["problem"]["name"], **config["problem"].get("options", {}))
    strategy = make_strategy(
        config["strategy"]["name"],
        problem,
        seed=config["seed"],
        **config["strategy"].get("options", {}),
    )
    with make_executor(config["run"]) as executor:
        result = optimize(
            problem,
            strategy,
            config["budget"],
            run_dir=run_dir,
            seed=config["seed"],
            executor=executor,
            chunk_size=config["run"].get("chunk_size"),
            progress=config["run"].get("progress", True),
            meta={"config": config},
        )
    return write_run_outputs(problem, run_dir, config, result, strategy)
