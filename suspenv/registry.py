"""Registries by name, resolved lazily from ``"module:attribute"`` entry points.

Every registered problem is also a Gymnasium env ``suspenv/<Name>-v0`` (see
:mod:`suspenv.envs`), and every registered strategy is covered by the contract tests
for free. Users add their own with :func:`register_problem` / :func:`register_strategy`.

The entry points are also the one seam through which a lower layer calls a higher one
without importing it: runs reach problems, strategies and pipelines, and problems, runs
and methods reach the report writers of :mod:`suspenv.reports` (which import them), by
name (:func:`report_function`). ``tests/test_architecture.py`` checks every target exists.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.metadata
import importlib.util
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from suspenv.core.errors import ValidationError
from suspenv.core.options import check_keywords, did_you_mean, option_names

_PROBLEMS: dict[str, str | Callable[..., Any]] = {
    "Sphere": "suspenv.problems.toy:Sphere",
    "ZDT1": "suspenv.problems.toy:ZDT1",
    "CarSideImpact": "suspenv.problems.carside:CarSideImpact",
    "KCIdentification": "suspenv.problems.kc_identification:KCIdentification",
    "MinibusRideHandling": "suspenv.problems.minibus:MinibusRideHandling",
    "PlanarLinkage": "suspenv.problems.planar:PlanarLinkage",
}

_STRATEGIES: dict[str, str | Callable[..., Any]] = {
    "cmaes": "suspenv.strategies.cmaes:CMAES",
    "nsga2": "suspenv.strategies.nsga2:NSGA2",
    "pymoo_nsga2": "suspenv.strategies.pymoo_nsga2:PymooNSGA2",
    "random": "suspenv.strategies.random_search:RandomSearch",
    "lhs": "suspenv.strategies.lhs:LatinHypercube",
    "optuna_tpe": "suspenv.strategies.optuna_samplers:OptunaTPE",
    "optuna_cmaes": "suspenv.strategies.optuna_samplers:OptunaCMAES",
    "optuna_nsga3": "suspenv.strategies.optuna_samplers:OptunaNSGA3",
    "optuna_gp": "suspenv.strategies.optuna_samplers:OptunaGP",
    "nevergrad": "suspenv.strategies.nevergrad_adapter:Nevergrad",
    "de": "suspenv.strategies.differential_evolution:DifferentialEvolution",
}

_PIPELINES: dict[str, str | Callable[..., Any]] = {
    "optimize": "suspenv.runs.optimize_pipeline:run_optimize_pipeline",
    "tey2014": "suspenv.methods.tey2014.pipeline:run_tey2014_pipeline",
    "identify": "suspenv.methods.curves.identify:run_identify_pipeline",
    "diagnosis_benchmark": "benchmarks.diagnosis_benchmark:run_benchmark_pipeline",
}

#: checks of a pipeline's config, run before any work: ``check(config) -> config`` raises
#: ValidationError naming the rule and the value, and returns the config with every
#: default the pipeline will use filled in
_PIPELINE_CHECKS: dict[str, str | Callable[..., Any]] = {
    "optimize": "suspenv.runs.optimize_pipeline:check_optimize_config",
    "tey2014": "suspenv.methods.tey2014.pipeline:check_tey2014_config",
    "identify": "suspenv.methods.curves.identify:check_identify_config",
    "diagnosis_benchmark": "benchmarks.diagnosis_benchmark:check_benchmark_config",
}

#: report writers and drawings; keyed by problem name for a problem's own run report
_REPORTS: dict[str, str | Callable[..., Any]] = {
    "run_figures": "suspenv.reports.run:write_run_figures",
    # `suspenv compare`: suspenv.analysis computes, this writes the files and figures
    "comparison": "suspenv.reports.analysis:write_comparison",
    "tey2014": "suspenv.reports.tey2014:write_tey2014_report",
    "identify": "suspenv.reports.identify:write_identify_report",
    "KCIdentification": "suspenv.reports.kc_identification:write_kc_report",
    "MinibusRideHandling": "suspenv.reports.minibus:write_minibus_run_report",
    "PlanarLinkage": "suspenv.reports.planar:write_planar_report",
    "planar_rgb": "suspenv.reports.planar:render_rgb",
}


def _resolve(kind: str, table: dict[str, Any], name: str) -> Any:
    try:
        target = table[name]
    except KeyError:
        hint = did_you_mean(name, table, cutoff=0.4)
        raise ValidationError(
            f"unknown {kind} {name!r}{hint} (known: {', '.join(sorted(table))})"
        ) from None
    if isinstance(target, str):
        module, _, attr = target.partition(":")
        target = getattr(importlib.import_module(module), attr)
        table[name] = target
    return target


def _register(table: dict[str, Any], kind: str, name: str, target: Any, overwrite: bool) -> None:
    if not name or not isinstance(name, str):
        raise ValidationError(f"{kind} name must be a non-empty string, but got {name!r}")
    if name in table and not overwrite:
        raise ValidationError(f"{kind} {name!r} is already registered (pass overwrite=True)")
    table[name] = target


# ----------------------------------------------------------------- problems
def register_problem(name: str, target: str | Callable[..., Any], overwrite: bool = False) -> None:
    """Register a problem class (or ``"module:Class"``) under ``name``."""
    _register(_PROBLEMS, "problem", name, target, overwrite)


def problem_class(name: str) -> Any:
    return _resolve("problem", _PROBLEMS, name)


def make_problem(name: str, **options: Any) -> Any:
    """Build the problem registered as ``name`` with keyword options.

    Option names the problem does not take are refused with the nearest valid name and
    the list of valid ones; the problem's constructor checks the values.
    """
    cls = problem_class(name)
    valid = option_names(cls)
    if valid is not None:
        check_keywords(f"problem {name!r}", options, valid)
    return cls(**options)


def list_problems() -> list[str]:
    return sorted(_PROBLEMS)


# --------------------------------------------------------------- strategies
def register_strategy(name: str, target: str | Callable[..., Any], overwrite: bool = False) -> None:
    """Register a strategy class (or ``"module:Class"``) under ``name``."""
    _register(_STRATEGIES, "strategy", name, target, overwrite)


#: the entry-point group through which an installed package registers its strategies
#: (``[project.entry-points."suspenv.strategies"] mine = "my_package.module:Mine"``)
ENTRY_POINT_GROUP = "suspenv.strategies"

#: the methods of the strategy seam (:mod:`suspenv.strategies.base`)
SEAM = ("ask", "tell", "stop")
#: strategy constructor arguments that come from the problem and the run, not the options
STRATEGY_RESERVED = ("dim", "n_objectives", "n_constraints", "seed")


def _installed_strategies() -> None:
    """Add the strategies installed packages register (:data:`ENTRY_POINT_GROUP`); a name
    registered here already keeps its target. Imports nothing until one is used."""
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        _STRATEGIES.setdefault(ep.name, ep.value)


def strategy_class(name: str) -> Any:
    """The strategy class registered (or installed) as ``name``, or a plug-in named by
    where its code is: ``"strategies/centre.py:Centre"`` (a file, relative to the
    working directory) or ``"package.module:Class"``. A plug-in is a class with the
    seam's methods (:data:`SEAM`; a subclass of :class:`suspenv.strategies.base.Strategy`).
    Naming code runs it: a config may do so only when the user allows it (``suspenv run
    --allow-code``)."""
    if ":" in name:  # a plug-in: checked for the seam's methods (SEAM)
        return _plugin(name)
    if name not in _STRATEGIES:
        _installed_strategies()
    return _resolve("strategy", _STRATEGIES, name)


def _plugin(name: str) -> Any:
    where, _, attr = name.rpartition(":")
    if where.endswith(".py"):
        path = Path(where).resolve()
        if not path.is_file():
            raise ValidationError(f"strategy {name!r}: no file {str(path)!r}")
        digest = hashlib.sha256(str(path).encode()).hexdigest()[:8]
        module_name = f"suspenv_plugin_{path.stem}_{digest}"
        module = sys.modules.get(module_name)
        if module is None:
            spec = importlib.util.spec_from_file_location(module_name, path)
            assert spec is not None and spec.loader is not None
            module = importlib.util.module_from_spec(spec)
            sys.modules[module_name] = module  # pickled designs and pools find it
            spec.loader.exec_module(module)
    else:
        try:
            module = importlib.import_module(where)
        except ImportError as exc:
            raise ValidationError(f"strategy {name!r}: cannot import {where!r} ({exc})") from None
    cls = getattr(module, attr, None)
    if not (isinstance(cls, type) and all(callable(getattr(cls, m, None)) for m in SEAM)):
        raise ValidationError(
            f"strategy {name!r}: {attr!r} in {where!r} must be a class with the methods "
            f"{', '.join(SEAM)} (a subclass of suspenv.strategies.base.Strategy), but got "
            f"{cls!r}"
        )
    return cls


def list_strategies() -> list[str]:
    """Registered and installed strategy names (plug-ins named by path are not listed)."""
    _installed_strategies()
    return sorted(_STRATEGIES)


# ---------------------------------------------------------------- pipelines
def pipeline_function(name: str) -> Any:
    return _resolve("pipeline", _PIPELINES, name)


def pipeline_check(name: str) -> Callable[[dict[str, Any]], dict[str, Any]] | None:
    """The config check of pipeline ``name`` (None when it has none). A check runs before
    a run directory is made, raises ValidationError for any bad key or value, and returns
    the config with every default the pipeline uses filled in."""
    pipeline_function(name)  # an unknown pipeline is an error with suggestions
    if name not in _PIPELINE_CHECKS:
        return None
    check: Callable[[dict[str, Any]], dict[str, Any]] = _resolve(
        "pipeline check", _PIPELINE_CHECKS, name
    )
    return check


def list_pipelines() -> list[str]:
    return sorted(_PIPELINES)


# ------------------------------------------------------------------ reports
def report_function(name: str) -> Any:
    """The report writer or drawing registered as ``name`` (imported on first use)."""
    return _resolve("report", _REPORTS, name)


def make_strategy(name: str, problem: Any, seed: int = 0, **options: Any) -> Any:
    """Build strategy ``name`` for ``problem`` (its dimension, objective and constraint counts).

    Options unknown to the strategy are reported with the nearest valid name and the list
    of valid ones (``dim``, ``n_objectives``, ``n_constraints`` and ``seed`` come from the
    problem and the run, never from the options); the strategy checks the values.
    """
    cls = strategy_class(name)
    valid = option_names(cls, STRATEGY_RESERVED)
    if valid is not None:
        check_keywords(f"strategy {name!r}", options, valid)
    return cls(
        dim=problem.space.dim,
        n_objectives=problem.n_objectives,
        n_constraints=problem.n_constraints,
        seed=seed,
        **options,
    )
