"""Run strategies over suite instances: one ordinary run directory per (instance, strategy,
seed), through :func:`suspenv.runs.runner.run_experiment`, so every run resumes, locks,
validates and archives like any other; ``suite.json`` beside them lists the instance cards
and the run directories (what :mod:`suspenv.analysis` and the baseline table read).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from suspenv.core.errors import ValidationError
from suspenv.runs.config import validate
from suspenv.runs.runner import check_config, run_experiment
from suspenv.suite.instances import SUITE_VERSION, build, selection

#: the file that lists a suite run's instances and run directories
SUITE_FILE = "suite.json"


def suite_config(
    function: str,
    instance: int,
    strategy: str,
    seed: int,
    output: Path,
    budget: int,
    strategy_options: Mapping[str, Any] | None = None,
    workers: int = 1,
) -> dict[str, Any]:
    """The experiment config of one suite run, checked (problem and strategy built, every
    option validated) with its defaults filled in."""
    inst = build(function, instance)
    config = {
        "name": f"{function}-i{instance}-{run_label(strategy)}",
        "seed": seed,
        "budget": budget,
        "description": f"suite {SUITE_VERSION}: {inst.name} with {strategy}",
        "problem": {"name": inst.function.problem, "options": inst.function.options_for(instance)},
        "strategy": {"name": strategy, "options": dict(strategy_options or {})},
        "run": {"output": str(output), "plots": False, "progress": False, "workers": workers},
    }
    # a plug-in named on the command line (``path.py:Class``) is the user's own choice
    return check_config(validate(config, allow_code=True))


def run_label(strategy: str) -> str:
    """A strategy as part of a run name: a registered name as it is, a plug-in
    (``strategies/centre.py:Centre``) by its file or module and class (``centre-Centre``)."""
    if ":" not in strategy:
        return strategy
    where, _, cls = strategy.rpartition(":")
    stem = Path(where).stem if where.endswith(".py") else where.rpartition(".")[2]
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", f"{stem}-{cls}")


def run_suite(
    strategies: Sequence[str],
    seeds: Sequence[int],
    output: str | Path,
    functions: Sequence[str] | None = None,
    budget_scale: float = 1.0,
    strategy_options: Mapping[str, Mapping[str, Any]] | None = None,
    workers: int = 1,
    progress: bool = True,
) -> dict[str, Any]:
    """Run every strategy with every seed on the selected instances (all by default).
    A strategy is a registered name or a plug-in ``path.py:Class`` / ``module:Class``
    (:func:`suspenv.registry.strategy_class`).

    ``budget_scale`` multiplies each instance's budget (for quick looks; the table of a
    full run uses 1). Writes ``<output>/suite.json`` and returns its content.
    """
    if not strategies or not seeds:
        raise ValidationError("a suite run needs at least one strategy and one seed")
    if not (0 < budget_scale <= 10) or not math.isfinite(budget_scale):
        raise ValidationError(
            f"`0 < budget_scale <= 10` must hold, but got budget_scale={budget_scale!r}"
        )
    output = Path(output)
    pairs = selection(list(functions) if functions else None)
    jobs = [(f, i, s, seed) for f, i in pairs for s in strategies for seed in seeds]
    configs = []
    for f, i, s, seed in jobs:  # every config checked before any run starts
        budget = max(1, round(build(f, i).function.budget * budget_scale))
        configs.append(
            suite_config(f, i, s, seed, output, budget, (strategy_options or {}).get(s), workers)
        )
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(jobs), unit="run", desc="suite")
    runs = []
    for (f, i, s, seed), config in zip(jobs, configs, strict=True):
        run_dir, summary = run_experiment(config)
        runs.append(
            {
                "function": f,
                "instance": i,
                "strategy": s,
                "seed": seed,
                "run_dir": str(run_dir),
                "budget": config["budget"],
                "n_evaluations": summary.get("n_evaluations"),
            }
        )
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    result = {
        "suite_version": SUITE_VERSION,
        "budget_scale": budget_scale,
        "strategies": list(strategies),
        "seeds": list(seeds),
        "instances": [build(f, i).describe() for f, i in pairs],
        "runs": runs,
    }
    output.mkdir(parents=True, exist_ok=True)
    (output / SUITE_FILE).write_text(json.dumps(result, indent=2) + "\n")
    return result
