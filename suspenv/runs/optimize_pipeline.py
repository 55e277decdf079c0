"""The "optimize" pipeline: one problem, one strategy, one budget -> a run directory.

Writes ``archive.sqlite`` (every evaluation, as it happens), ``evaluations.csv``,
``summary.json``, ``config.resolved.toml``, ``versions.json`` and figures
(``convergence.png``; ``pareto_pairs.png`` and ``pareto_parallel.png`` for several
objectives, drawn by :mod:`suspenv.reports.run`), then any report the problem writes itself.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.registry import make_problem, make_strategy, report_function
from suspenv.runs.archive import RunArchive
from suspenv.runs.evaluation import FaultPolicy
from suspenv.runs.executors import executor_workers, make_executor
from suspenv.runs.loop import optimize


def best_so_far(values: np.ndarray, feasible: np.ndarray) -> np.ndarray:
    """Running minimum over evaluations of feasible values (inf before the first)."""
    v = np.where(feasible & np.isfinite(values), values, np.inf)
    return np.minimum.accumulate(v)


def quality_curve(problem: Any, arrays: dict[str, np.ndarray]) -> np.ndarray:
    """Best-so-far of the problem's quality measure over evaluations."""
    F = arrays["objectives"]
    feasible = arrays["ok"].copy()
    if arrays["constraints"].size:
        feasible &= np.nan_to_num(arrays["constraints"], nan=1.0).max(axis=1) <= 0
    q = problem.quality(F) if len(F) else np.zeros(0)
    return best_so_far(np.asarray(q, float), feasible)


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
        figures: list[Path] = []
        if config["run"].get("plots", True) and len(arrays["ok"]):
            write_figures = report_function("run_figures")
            figures += write_figures(arrays["objectives"], feasible, names, run_dir)
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


def check_optimize_config(config: dict[str, Any]) -> dict[str, Any]:
    """Build the config's problem and strategy (every option checked by their constructors)
    and fill ``run.timeout_s`` with the problem's own when the config leaves it out.

    Runs before a run directory exists: a bad option leaves nothing behind."""
    problem = make_problem(config["problem"]["name"], **config["problem"].get("options", {}))
    make_strategy(
        config["strategy"]["name"],
        problem,
        seed=config["seed"],
        **config["strategy"].get("options", {}),
    )
    out = {**config, "run": dict(config["run"])}
    out["run"]["timeout_s"] = FaultPolicy.for_run(config["run"], problem).timeout_s
    return out


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
            workers=executor_workers(config["run"]),
            chunk_size=config["run"].get("chunk_size"),
            progress=config["run"].get("progress", True),
            meta={"config": config},
            faults=FaultPolicy.for_run(config["run"], problem),
        )
    return write_run_outputs(problem, run_dir, config, result, strategy)
