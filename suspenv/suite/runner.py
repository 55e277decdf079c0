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
from suspenv.core.options import number
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


#: the shortest budget a suite run may give an instance, in evaluations per variable
MIN_EVALUATIONS_PER_VARIABLE = 10


def scaled_budgets(pairs: Sequence[tuple[str, int]], budget_scale: float) -> dict[str, int]:
    """Each instance's budget times ``budget_scale`` (rounded). Rules: ``0 < budget_scale
    <= 10``, and every scaled budget at least :data:`MIN_EVALUATIONS_PER_VARIABLE` times
    the instance's dimension (a shorter run hardly leaves its first batches)."""
    number("suite", "budget_scale", budget_scale, lo=0.0, hi=10.0, lo_open=True)
    out, need = {}, {}
    for f, i in pairs:
        inst = build(f, i)
        out[inst.name] = round(inst.function.budget * budget_scale)
        need[inst.name] = (MIN_EVALUATIONS_PER_VARIABLE * inst.problem.space.dim, inst)
    short = [k for k in out if out[k] < need[k][0]]
    if short:
        least = max(need[k][0] / need[k][1].function.budget for k in need)
        k = short[0]
        raise ValidationError(
            f"budget_scale={budget_scale!r} gives {k} {out[k]} evaluations for "
            f"{need[k][1].problem.space.dim} variables, but a suite budget must be at least "
            f"{MIN_EVALUATIONS_PER_VARIABLE} evaluations per variable ({need[k][0]}; "
            f"{len(short)} instance(s) short): use budget_scale >= "
            f"{math.ceil(least * 1000) / 1000:g} for these instances"
        )
    return out


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
    for what, items in (("strategies", strategies), ("seeds", seeds)):
        if len(set(items)) != len(items):
            raise ValidationError(
                f"the {what} of a suite run must be distinct (a repeated one would be "
                f"counted twice), but got {list(items)}"
            )
    output = Path(output)
    pairs = selection(list(functions) if functions else None)
    budgets = scaled_budgets(pairs, budget_scale)
    jobs = [(f, i, s, seed) for f, i in pairs for s in strategies for seed in seeds]
    configs = []
    for f, i, s, seed in jobs:  # every config checked before any run starts
        budget = budgets[f"{f}/i{i}"]
        configs.append(
            suite_config(f, i, s, seed, output, budget, (strategy_options or {}).get(s), workers)
        )
    from tqdm.auto import tqdm

    runs = []
    with tqdm(total=len(jobs), unit="run", desc="suite", disable=not progress) as bar:
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
            bar.update(1)
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
