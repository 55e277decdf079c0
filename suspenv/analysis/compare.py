"""Runs compared: grouped by their full configuration, checked for poolability, measured.

:func:`compare` is the computation behind ``suspenv compare`` (figures are drawn by
:mod:`suspenv.reports.analysis`; :func:`write_compare_files` writes ``compare.json`` and
``compare.md``, :func:`suspenv.analysis.ioh.write_ioh` the IOHprofiler export).
Definitions, formulas and rules are in ``docs/analysis.md``; in short:

- A *problem configuration* is (problem name, options with defaults filled in, objective
  names, quality name, what the quality was normalised on, pipeline); a *strategy
  configuration* is (strategy name, options as the user configured them, without the
  seed and where the run keeps its state; the values the run resolved are kept beside).
  Each has an 8-hex hash; a group is one strategy configuration on one
  problem configuration, labelled ``name[hash]``.
- Runs of different problem configurations are never pooled: refused, naming the
  differences, unless ``suite=True`` (then every problem is reported on its own and a
  performance profile compares the strategies across them). Runs of one group with
  different budgets are refused unless ``allow_unequal_budgets``; different budgets
  between groups are flagged, and fixed-budget numbers are taken at the common budget.
- The measure compared is the run's quality (``summary.json``), except for
  multi-objective runs without a scalar quality (:mod:`suspenv.runs.quality`; or with a
  recorded plain sum of objectives): their measure is the
  hypervolume deficit ``HV_ref - HV(run)`` against a reference front (analytic where
  known, else given, else the non-dominated union of all compared runs).
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.analysis.indicators import (
    HV_MAX_OBJECTIVES,
    feasible_front,
    hypervolume,
    hypervolume_curve,
    igd,
    normalisation,
    normalise,
    reference_point,
)
from suspenv.analysis.load import (
    RunRecord,
    load_run,
    load_runs,
    reference_front,
    sums_objectives,
)
from suspenv.analysis.performance import (
    curve_matrix,
    curve_quantiles,
    ecdf_area,
    ert,
    fixed_budget,
    make_targets,
    performance_profile,
    runtime_matrix,
)
from suspenv.analysis.stats import rank_tests
from suspenv.core.atomic import write_file
from suspenv.core.errors import ValidationError
from suspenv.core.markdown import fmt, inline, markdown_table
from suspenv.core.options import choice, integer, number, optional
from suspenv.runs.config import config_differences, flatten_config
from suspenv.runs.run_dir import write_json

#: known optima of a problem's plain quality (the objective itself), by problem name
KNOWN_OPTIMA: dict[str, float] = {"Sphere": 0.0}

MEASURES = ("auto", "quality", "hypervolume")


@dataclass
class Group:
    """The runs of one strategy configuration on one problem configuration."""

    strategy: str
    strategy_hash: str
    options: dict[str, Any]
    runs: list[RunRecord]
    differs: dict[str, Any] = field(default_factory=dict)
    curves: list[np.ndarray] = field(default_factory=list)  # measure curves, one per run
    hv_curves: list[np.ndarray] = field(default_factory=list)  # hypervolume, one per run

    @property
    def label(self) -> str:
        return f"{self.strategy}[{self.strategy_hash}]"

    @property
    def seeds(self) -> list[int]:
        return sorted(r.seed for r in self.runs if r.seed is not None)

    @property
    def budgets(self) -> list[int]:
        return sorted({_length(r) for r in self.runs})

    def lengths(self) -> list[int]:
        return [_length(r) for r in self.runs]


@dataclass
class ProblemComparison:
    """One problem configuration: its groups and everything measured on them."""

    problem_hash: str
    config: dict[str, Any]
    groups: list[Group]
    measure: str  # "quality" or "hypervolume deficit"
    measure_name: str
    f_opt: float | None
    targets: np.ndarray
    common_budget: int
    flags: list[str]
    result: dict[str, Any] = field(default_factory=dict)
    runtimes: dict[str, np.ndarray] = field(default_factory=dict)  # label -> (runs, targets)
    ert: dict[str, np.ndarray] = field(default_factory=dict)  # label -> (targets,)
    hv_reference: float | None = None

    @property
    def name(self) -> str:
        return f"{self.config['problem']}[{self.problem_hash}]"


@dataclass
class Comparison:
    """The whole comparison: :attr:`result` is what ``compare.json`` holds."""

    problems: list[ProblemComparison]
    result: dict[str, Any]
    profile: dict[str, Any] | None = None


def _length(r: RunRecord) -> int:
    """Evaluations a run stands for: its budget when it stopped early (its best stays),
    else the evaluations its curve covers."""
    return max(r.evaluations_used, r.budget or 0)


def _refuse_mixed_problems(by_problem: dict[str, list[RunRecord]]) -> None:
    keys = list(by_problem)
    first = by_problem[keys[0]][0]
    lines = []
    for k in keys[1:]:
        other = by_problem[k][0]
        diff = config_differences(first.problem_config, other.problem_config)
        lines.append(
            f"{first.problem}[{keys[0]}] ({len(by_problem[keys[0]])} runs, e.g. "
            f"{first.name}) vs {other.problem}[{k}] ({len(by_problem[k])} runs, e.g. "
            f"{other.name}): " + "; ".join(diff)
        )
    why = ""
    norms = {by_problem[k][0].normalisation for k in keys}
    if len(norms) > 1 and None not in norms:
        sources = "; ".join(
            f"{by_problem[k][0].name}: {by_problem[k][0].normalisation_source}" for k in keys
        )
        why = (
            f". Their quality {first.quality_name!r} is normalised on a design of "
            f"experiments ({sources}); values normalised differently are not comparable "
            "(a tey2014 run with another seed draws another design of experiments), so "
            "these runs cannot be pooled or ranked against each other"
        )
    raise ValidationError(
        f"compare pools runs of one problem configuration, but got {len(keys)}: "
        + " | ".join(lines)
        + why
        + ". Pass suite=True (`--suite`) to compare strategies per problem and across "
        "problems by a performance profile"
    )


def _group(runs: list[RunRecord], allow_unequal_budgets: bool) -> list[Group]:
    by: dict[str, list[RunRecord]] = defaultdict(list)
    for r in runs:
        by[r.strategy_hash].append(r)
    groups = [Group(rs[0].strategy, h, rs[0].strategy_options, rs) for h, rs in by.items()]
    _mark_differences(groups)
    if not allow_unequal_budgets:
        for g in groups:
            _refuse_unequal_budgets(g)
    groups.sort(key=lambda g: (g.strategy, g.strategy_hash))
    return groups


def _mark_differences(groups: list[Group]) -> None:
    """Several configurations of one strategy: set each group's ``differs`` to the
    options that tell them apart."""
    by_name: dict[str, list[Group]] = defaultdict(list)
    for g in groups:
        by_name[g.strategy].append(g)
    for gs in by_name.values():
        if len(gs) < 2:
            continue
        flat = [flatten_config(g.options) for g in gs]
        keys = sorted({k for f in flat for k in f})
        varying = [k for k in keys if len({json.dumps(f.get(k), default=str) for f in flat}) > 1]
        for g, f in zip(gs, flat, strict=True):
            g.differs = {k: f.get(k) for k in varying}


def _refuse_unequal_budgets(g: Group) -> None:
    """Runs of one group stand for equal budgets (:func:`_length`), else refused."""
    budgets = defaultdict(list)
    for r in g.runs:
        budgets[_length(r)].append(r.seed)
    if len(budgets) > 1:
        detail = ", ".join(
            f"{b} evaluations (seeds {sorted(s for s in seeds if s is not None)})"
            for b, seeds in sorted(budgets.items())
        )
        raise ValidationError(
            f"group {g.label} pools runs with different budgets: {detail}; runs of one "
            "group must have equal budgets (pass allow_unequal_budgets=True / "
            "`--allow-unequal-budgets` to pool them, compared at the smallest)"
        )


def _lookup(table: Any, problem: str, problem_hash: str) -> Any:
    """A per-problem argument: a scalar/array for all, or a mapping by hash or name."""
    if isinstance(table, Mapping):
        if problem_hash in table:
            return table[problem_hash]
        return table.get(problem)
    return table


def _choose_measure(runs: list[RunRecord], measure: str) -> tuple[str, str]:
    r0 = runs[0]
    multi = len(r0.objective_names) >= 2
    if measure == "quality":
        return "quality", ""
    missing = [r.name for r in runs if r.arrays() is None]
    m = len(r0.objective_names)
    if measure == "hypervolume":
        if not multi or m > HV_MAX_OBJECTIVES:
            raise ValidationError(
                f"measure 'hypervolume' needs 2 to {HV_MAX_OBJECTIVES} objectives, but "
                f"{r0.problem} has {m}: {r0.objective_names}"
            )
        if missing:
            raise ValidationError(
                f"measure 'hypervolume' needs each run's archive, missing for {missing}"
            )
        return "hypervolume deficit", ""
    if sums_objectives(r0):
        what = f"{r0.quality_name!r} (a plain sum)" if r0.quality_name else "no scalar quality"
        if m > HV_MAX_OBJECTIVES:
            return "quality", (
                f"{m} objectives compared by {what}: hypervolumes are computed for at most "
                f"{HV_MAX_OBJECTIVES} objectives"
            )
        if missing:
            return "quality", (
                f"multi-objective runs compared by {what}: the archives needed for the "
                f"hypervolume are missing for {missing}"
            )
        return "hypervolume deficit", ""
    return "quality", ""


def _multiobjective(
    pc: ProblemComparison, runs: list[RunRecord], given_front: Any, curves: bool
) -> dict[str, Any]:
    """Final hypervolume and IGD per run (and hypervolume curves when ``curves``)."""
    m = len(runs[0].objective_names)
    front, source, exact = reference_front(runs, given_front)
    ideal, nadir = normalisation(front)
    ref = reference_point(m)
    Rn = normalise(front, ideal, nadir)
    do_hv = m <= HV_MAX_OBJECTIVES
    hv_ref = None
    if do_hv:
        hv_ref = exact if exact is not None else hypervolume(Rn, ref)
    pc.hv_reference = hv_ref
    info: dict[str, Any] = {
        "reference_front": source,
        "ideal": ideal.tolist(),
        "nadir": nadir.tolist(),
        "reference_point_normalised": ref.tolist(),
        "reference_point": (ideal + ref * (nadir - ideal)).tolist(),
        "hv_reference": hv_ref,
        "hv_reference_rule": (
            "exact analytic value" if exact is not None else "hypervolume of the reference front"
        ),
        "hypervolume": "computed"
        if do_hv
        else f"not computed for more than {HV_MAX_OBJECTIVES} objectives",
        "groups": [],
    }
    for g in pc.groups:
        hv_final, igd_final = [], []
        for r in g.runs:
            a, feas = r.arrays(), r.feasible()
            if a is None or feas is None:
                hv_final.append(float("nan"))
                igd_final.append(float("nan"))
                continue
            Fn = normalise(a["objectives"], ideal, nadir)
            fr = feasible_front(Fn, feas)
            igd_final.append(igd(fr, Rn) if len(fr) else float("inf"))
            if do_hv and curves:
                c = hypervolume_curve(Fn, feas, ref)
                g.hv_curves.append(c)
                hv_final.append(float(c[-1]) if c.size else 0.0)
            elif do_hv:
                hv_final.append(hypervolume(fr, ref) if len(fr) else 0.0)
            else:
                hv_final.append(float("nan"))
        info["groups"].append(
            {
                "group": g.label,
                "hypervolume": hv_final,
                "igd": igd_final,
                "hypervolume_median": _nanmedian(hv_final),
                "igd_median": _nanmedian(igd_final),
            }
        )
    return info


def _nanmedian(v: Sequence[float]) -> float | None:
    a = np.asarray(v, dtype=float)
    a = a[~np.isnan(a)]
    return float(np.median(a)) if a.size else None


def _analyse_problem(
    runs: list[RunRecord],
    allow_unequal_budgets: bool,
    measure: str,
    f_opt: Any,
    reference_front: Any,
    targets: Any,
    n_targets: int,
    alpha: float,
) -> ProblemComparison:
    """Everything measured on the runs of one problem configuration (``pc.result``:
    that problem's part of ``compare.json``)."""
    r0 = runs[0]
    phash = r0.problem_hash
    groups = _group(runs, allow_unequal_budgets)
    kind, note = _choose_measure(runs, measure)
    flags = [note] if note else []
    pc = ProblemComparison(phash, r0.problem_config, groups, kind, "", None, np.zeros(0), 0, flags)
    multi_info = _multiobjective_info(pc, runs, _lookup(reference_front, r0.problem, phash))
    _measure_curves(pc, r0, f_opt)
    pc.common_budget = min(_length(r) for r in runs)
    unequal = _flag_runs(pc, runs)
    pc.targets = _targets(pc, _lookup(targets, r0.problem, phash), n_targets)
    budgets = sorted({max(1, int(round(pc.common_budget * f))) for f in (0.1, 0.25, 0.5, 1.0)})
    fb_rows, ft_rows, table_rows = [], [], []
    samples, seeds = {}, {}
    for g in groups:
        M = curve_matrix(g.curves, pc.common_budget)
        fb_rows += [{"group": g.label, **row} for row in fixed_budget(M, budgets)]
        ft_rows += _fixed_target_rows(pc, g)
        samples[g.label] = M[:, -1].tolist()
        seeds[g.label] = [r.seed if r.seed is not None else -1 for r in g.runs]
        table_rows.append(_table_row(pc, g, r0, M[:, -1], unequal))
    pc.result = {
        "problem": r0.problem,
        "hash": phash,
        "config": pc.config,
        "normalisation_source": r0.normalisation_source,
        "measure": pc.measure_name,
        "measure_kind": pc.measure,
        "f_opt": pc.f_opt,
        "common_budget": pc.common_budget,
        "flags": flags,
        "groups": [_group_json(g) for g in groups],
        "table": table_rows,
        "fixed_budget": fb_rows,
        "targets": pc.targets.tolist(),
        "fixed_target": ft_rows,
        "multiobjective": multi_info,
        "rank_tests": rank_tests(samples, seeds, alpha),
    }
    return pc


def _multiobjective_info(
    pc: ProblemComparison, runs: list[RunRecord], given_front: Any
) -> dict[str, Any] | None:
    """The hypervolume and IGD part of a multi-objective problem (:func:`_multiobjective`;
    hypervolume curves when the measure is the deficit), what was skipped when an
    archive is missing; None for one objective."""
    if len(runs[0].objective_names) < 2:
        return None
    missing = [r.name for r in runs if r.arrays() is None]
    if missing:
        return {"skipped": f"no archive matching the quality curve for {missing}"}
    return _multiobjective(pc, runs, given_front, pc.measure != "quality")


def _targets(pc: ProblemComparison, given: Any, n_targets: int) -> np.ndarray:
    """The fixed-target view's targets, hardest last: ``given`` ones, else
    :func:`~suspenv.analysis.performance.make_targets` over the final measures."""
    if given is not None:
        return np.sort(np.asarray(given, dtype=float).ravel())[::-1]
    finals = [float(c[-1]) for g in pc.groups for c in g.curves if c.size]
    return make_targets(finals, pc.f_opt, n_targets)


def _measure_curves(pc: ProblemComparison, r0: RunRecord, f_opt: Any) -> None:
    """Each group's measure curves, one per run and as long as the run's
    :func:`_length` (a run that stopped early keeps its best up to its budget), the
    measure's name and its optimum ``pc.f_opt`` (given, known, or for the hypervolume
    deficit ``min(0, lowest final deficit)``)."""
    if pc.measure == "quality":
        pc.measure_name = r0.quality_name
        given = _lookup(f_opt, r0.problem, pc.problem_hash)
        # the objective itself (the default quality; its name before "objective")
        plain = r0.quality_name in ("objective", "objective (sum if several)")
        if given is None and plain and r0.normalisation is None:
            given = KNOWN_OPTIMA.get(r0.problem) if len(r0.objective_names) == 1 else None
        pc.f_opt = None if given is None else float(given)
        for g in pc.groups:
            g.curves = [r.curve for r in g.runs]
    else:
        pc.measure_name = "hypervolume deficit (HV_ref - HV)"
        assert pc.hv_reference is not None
        for g in pc.groups:
            g.curves = [pc.hv_reference - c for c in g.hv_curves]
        lowest = min(float(c[-1]) for g in pc.groups for c in g.curves if c.size)
        pc.f_opt = min(0.0, lowest)
    for g in pc.groups:
        g.curves = [curve_matrix([c], _length(r))[0] for c, r in zip(g.curves, g.runs, strict=True)]


def _any_feasible(r: RunRecord, measure: str) -> bool:
    """Whether a run has a feasible evaluation: a finite best quality, or, compared by
    hypervolume (no scalar quality, so no quality curve), a feasible archived row."""
    if measure == "quality":
        return bool(np.isfinite(r.final))
    feas = r.feasible()
    return feas is not None and bool(feas.any())


def _flag_runs(pc: ProblemComparison, runs: list[RunRecord]) -> bool:
    """Add to ``pc.flags`` what limits the comparison (unequal budgets, runs stopped
    early or without a feasible evaluation, single runs); True when budgets differ."""
    per_group_budget = {g.label: g.budgets for g in pc.groups}
    unequal = len({b for bs in per_group_budget.values() for b in bs}) > 1
    if unequal:
        pc.flags.append(
            "unequal budgets: "
            + ", ".join(f"{k} {v}" for k, v in per_group_budget.items())
            + f"; fixed-budget results and rank tests are taken at the common budget "
            f"{pc.common_budget}"
        )
    stopped = [r.name for r in runs if r.budget and r.evaluations_used < r.budget]
    if stopped:
        pc.flags.append(
            f"stopped before their budget (best kept to the budget): {', '.join(stopped)}"
        )
    none = [r.name for r in runs if not _any_feasible(r, pc.measure)]
    if none:
        pc.flags.append(f"no feasible evaluation: {', '.join(none)}")
    for g in pc.groups:
        if len(g.runs) < 2:
            pc.flags.append(f"{g.label} has a single run: no spread, no rank test power")
    return unequal


def _fixed_target_rows(pc: ProblemComparison, g: Group) -> list[dict[str, Any]]:
    """Runtimes to each target of one group (stored in ``pc.runtimes`` and ``pc.ert``)
    and the fixed-target rows: ERT and successes per target."""
    rt = runtime_matrix(g.curves, pc.targets)
    e = ert(rt, [r.evaluations_used for r in g.runs])
    pc.runtimes[g.label] = rt
    pc.ert[g.label] = e
    return [
        {
            "group": g.label,
            "target": float(t),
            "ert": float(e[j]),
            "successes": int(np.isfinite(rt[:, j]).sum()),
            "runs": len(g.runs),
        }
        for j, t in enumerate(pc.targets)
    ]


def _table_row(
    pc: ProblemComparison, g: Group, r0: RunRecord, at_common: np.ndarray, unequal: bool
) -> dict[str, Any]:
    """One group's row of the table: the runs' summaries, and the measure's quantiles at
    the common budget (``at_common``: one value per run)."""
    best = np.array([r.best_quality for r in g.runs])
    wall = [r.summary.get("wall_time_s") for r in g.runs]
    wall_f = [float(w) for w in wall if isinstance(w, int | float)]
    q = curve_quantiles(at_common.reshape(-1, 1))
    return {
        # the fields of the first `suspenv compare` (kept for its callers)
        "strategy": g.strategy,
        "runs": len(g.runs),
        "seeds": g.seeds,
        "evaluations": int(np.median([r.evaluations_used for r in g.runs])),
        "best_median": _finite_or_nan(np.median(best)) if len(best) else float("nan"),
        "best_min": _finite_or_nan(best.min()),
        "best_max": _finite_or_nan(best.max()),
        "wall_time_median_s": float(np.median(wall_f)) if wall_f else None,
        # what the comparison adds
        "group": g.label,
        "hash": g.strategy_hash,
        "problem": r0.problem,
        "problem_hash": pc.problem_hash,
        "differs": g.differs,
        "budgets": g.budgets,
        "unequal_budget": unequal,
        "measure": pc.measure_name,
        "budget_compared": pc.common_budget,
        "median": float(q[0.5][0]),
        "q25": float(q[0.25][0]),
        "q75": float(q[0.75][0]),
        "min": float(q[0.0][0]),
        "max": float(q[1.0][0]),
        "ecdf_area": ecdf_area(pc.runtimes[g.label], max(g.lengths())),
    }


def _group_json(g: Group) -> dict[str, Any]:
    """One group in ``compare.json``: its configuration and each run's final measure."""
    return {
        "group": g.label,
        "strategy": g.strategy,
        "hash": g.strategy_hash,
        "options": g.options,
        "resolved_options": g.runs[0].strategy_resolved,
        "differs": g.differs,
        "seeds": g.seeds,
        "budgets": g.budgets,
        "runs": [
            {
                "run": str(r.path),
                "seed": r.seed,
                "budget": r.budget,
                "evaluations": r.evaluations_used,
                "final": float(c[-1]) if c.size else None,
                "summary_best_quality": _finite_or_nan(r.best_quality),
            }
            for r, c in zip(g.runs, g.curves, strict=True)
        ],
    }


def _finite_or_nan(v: Any) -> float:
    v = float(v)
    return v if np.isfinite(v) else float("nan")


def compare(
    runs: Sequence[str | Path | RunRecord],
    *,
    suite: bool = False,
    allow_unequal_budgets: bool = False,
    measure: str = "auto",
    f_opt: float | Mapping[str, float] | None = None,
    reference_front: np.ndarray | Mapping[str, np.ndarray] | None = None,
    targets: Sequence[float] | Mapping[str, Sequence[float]] | None = None,
    n_targets: int = 21,
    alpha: float = 0.05,
) -> Comparison:
    """Compare finished runs (see the module docstring and ``docs/analysis.md``).

    ``f_opt``, ``reference_front`` and ``targets`` apply to every problem, or are mappings
    keyed by problem hash or problem name. ``measure``: "auto", "quality" or
    "hypervolume". Raises :class:`ValidationError` for runs that may not be pooled.
    """
    check_options(f_opt, n_targets, alpha, measure)
    recs = load_runs(runs)
    by_problem: dict[str, list[RunRecord]] = defaultdict(list)
    for r in recs:
        by_problem[r.problem_hash].append(r)
    if len(by_problem) > 1 and not suite:
        _refuse_mixed_problems(by_problem)
    problems = [
        _analyse_problem(
            rs, allow_unequal_budgets, measure, f_opt, reference_front, targets, n_targets, alpha
        )
        for rs in by_problem.values()
    ]
    profile = _profile(problems)
    first = problems[0]
    result: dict[str, Any] = {
        # the keys of the first `suspenv compare` (kept for its callers)
        "problem": first.config["problem"]
        if len(problems) == 1
        else sorted({p.config["problem"] for p in problems}),
        "quality_name": recs[0].quality_name,
        "table": [row for p in problems for row in p.result["table"]],
        # what the comparison adds
        "problems": [p.result for p in problems],
        "performance_profile": profile,
        "definitions": DEFINITIONS,
    }
    return Comparison(problems, result, profile)


#: targets of a suite instance that knows the truth's quality, as multiples of it (last:
#: the truth's level, the easier ones lead up to it)
TARGET_FACTORS = (10.0, 5.0, 3.0, 2.0, 1.5, 1.2, 1.1, 1.05, 1.0)


def compare_suite(folder: str | Path, **options: Any) -> Comparison:
    """Compare every run of a suite run's output ``folder`` (its ``suite.json``, written by
    :func:`suspenv.suite.runner.run_suite`) as :func:`compare` with ``suite=True``, passing
    per instance (keyed by the problem hash of its runs) what it knows: ``optimum`` ->
    ``f_opt``; ``target`` (the truth's quality) -> :data:`TARGET_FACTORS` times it;
    ``front`` -> the reference front. Keywords go to :func:`compare`."""
    from suspenv.suite.fronts import load_front
    from suspenv.suite.runner import SUITE_FILE

    path = Path(folder) / SUITE_FILE
    if not path.is_file():
        raise ValidationError(
            f"{str(folder)!r} holds no {SUITE_FILE} (made by `suspenv suite run`)"
        )
    data = json.loads(path.read_text())
    cards = {card["name"]: card for card in data["instances"]}
    f_opt: dict[str, float] = {}
    targets: dict[str, list[float]] = {}
    fronts: dict[str, np.ndarray] = {}
    runs = []
    for run in data["runs"]:
        record = load_run(run["run_dir"])
        runs.append(record)
        known = cards[f"{run['function']}/i{run['instance']}"]["known"]
        key = record.problem_hash
        if known["kind"] == "optimum":
            f_opt[key] = float(known["f"])
        elif known["kind"] == "target":
            targets[key] = [float(known["f"]) * k for k in TARGET_FACTORS]
        elif known["kind"] == "front":
            fronts[key] = load_front(known["front"]).points
    return compare(
        runs,
        suite=True,
        f_opt=f_opt or None,
        targets=targets or None,
        reference_front=fronts or None,
        **options,
    )


def check_options(f_opt: Any, n_targets: Any, alpha: Any, measure: str = "auto") -> None:
    """The comparison's options, checked before any run is read. Rules: ``f_opt`` finite
    (each value of a mapping too), ``n_targets`` an integer >= 1, ``0 < alpha < 1``,
    ``measure`` one of :data:`MEASURES`."""
    values = f_opt.values() if isinstance(f_opt, Mapping) else [f_opt]
    for v in values:
        optional(number, "compare", "f_opt", v)
    integer("compare", "n_targets", n_targets, lo=1)
    number("compare", "alpha", alpha, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    choice("compare", "measure", measure, MEASURES)


DEFINITIONS = {
    "grouping": "group = strategy name + options as configured (seed and state location "
    "excluded; an option the strategy resolves from the problem, such as CMA-ES's "
    "population, counts only when set to another value; the values used are listed as "
    "resolved_options), hash = first 8 hex of SHA-256 of canonical JSON; problem = name + "
    "options with defaults + objectives + quality + normalisation + pipeline",
    "best_so_far": "running minimum of the measure over evaluations; +inf before the first "
    "feasible value; quantiles over runs count +inf as the worst value",
    "fixed_budget": "quantiles over runs of the best-so-far at 10, 25, 50, 100 % of the "
    "common budget (the smallest run length of the problem)",
    "targets": "f_opt + 10^k log-spaced between the worst and best final value (f_opt known), "
    "else log- or linearly spaced between them",
    "runtime": "evaluations until the best-so-far first reaches the target (inf if never)",
    "ert": "sum over runs of (runtime if reached else evaluations used) / number of runs "
    "that reached the target",
    "ecdf": "fraction of (run, target) pairs reached within x evaluations",
    "performance_profile": "Dolan & More 2002: ratio of a strategy's ERT to the best ERT "
    "per (problem, target) instance; rho(tau) = fraction of instances with ratio <= tau",
    "hypervolume": "normalised objectives (ideal/nadir of the reference front), reference "
    "point 1.1 in each; measure = HV_ref - HV(run) for multi-objective runs without a "
    "scalar quality",
    "igd": "mean over reference-front points of the distance to the nearest point of the "
    "run's final feasible non-dominated set, normalised objectives",
    "json": "non-finite numbers are written as null (inf: never reached / no value)",
}


def _profile(problems: list[ProblemComparison]) -> dict[str, Any] | None:
    """Performance profile over (problem, target) instances with ERT as the cost, for the
    strategy configurations (by hash) seen on any problem; a strategy absent from a
    problem fails its instances."""
    solvers: dict[str, str] = {}
    for p in problems:
        for g in p.groups:
            solvers.setdefault(g.strategy_hash, g.label)
    if len(solvers) < 2:
        return None
    keys = list(solvers)
    rows, names = [], []
    for p in problems:
        by = {g.strategy_hash: g.label for g in p.groups}
        for j, t in enumerate(p.targets):
            rows.append([p.ert[by[k]][j] if k in by else np.inf for k in keys])
            names.append(f"{p.name} target {t:.4g}")
    if len(rows) < 1:
        return None
    taus, rho, ratios = performance_profile(np.array(rows))
    return {
        "cost": "ERT (evaluations)",
        "instances": names,
        "solvers": [solvers[k] for k in keys],
        "taus": taus.tolist(),
        "rho": rho.tolist(),
        "ratios": ratios.tolist(),
        "n_problems": len(problems),
    }


# --------------------------------------------------------------------------- output
def _cell(v: Any) -> str:
    """A value of the comparison as Markdown text: numbers by
    :func:`suspenv.core.markdown.fmt` (``inf`` never reached, ``–`` none), dicts and
    lists spelled out, text from run directories escaped by
    :func:`suspenv.core.markdown.inline`."""
    if v is None:
        return "–"
    if isinstance(v, dict):
        return ", ".join(f"{inline(k)}={_cell(x)}" for k, x in v.items())
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_cell(x) for x in v) + "]"
    if isinstance(v, bool | int | float | np.number):
        return fmt(v, missing="–", inf="inf")
    return inline(v)


def _md_table(rows: Sequence[Mapping[str, Any]], cols: Sequence[str]) -> str:
    return markdown_table([{c: _cell(r.get(c)) for c in cols} for r in rows], cols)


#: columns of compare.md's groups and fixed-budget tables (SPREAD: over the runs)
SPREAD = ("median", "q25", "q75", "min", "max")
GROUP_COLUMNS = ("group", "hash", "runs", "seeds", "budgets", *SPREAD, "ecdf_area", "differs")
FIXED_BUDGET_COLUMNS = ("group", "budget", "n_with_value", *SPREAD)


def _ert_table(p: ProblemComparison) -> str:
    """ERT and successes of each group at up to six targets, spread over them."""
    tg = p.targets
    pick = sorted(set(np.linspace(0, len(tg) - 1, min(6, len(tg))).round().astype(int)))
    rows = []
    for g in p.groups:
        row: dict[str, Any] = {"group": g.label}
        for j in pick:
            k = int(np.isfinite(p.runtimes[g.label][:, j]).sum())  # ERT inf iff k = 0
            row[f"{tg[j]:.3g}"] = f"{fmt(p.ert[g.label][j], inf='inf')} ({k}/{len(g.runs)})"
        rows.append(row)
    return _md_table(rows, ["group"] + [f"{tg[j]:.3g}" for j in pick])


def _multiobjective_md(mo: dict[str, Any] | None) -> list[str]:
    """The hypervolume and IGD section (none for a single-objective problem)."""
    if not mo:
        return []
    if "skipped" in mo:
        return [f"\n### Hypervolume and IGD\n\nNot computed: {_cell(mo['skipped'])}.\n"]
    return [
        f"\n### Hypervolume and IGD\n\nReference front: {_cell(mo['reference_front'])}; "
        f"reference point {_cell(mo['reference_point'])}; HV_ref "
        + (
            f"{_cell(mo['hv_reference'])} ({mo['hv_reference_rule']}).\n\n"
            if mo["hv_reference"] is not None
            else f"– (hypervolume {mo['hypervolume']}).\n\n"
        ),
        _md_table(mo["groups"], ["group", "hypervolume_median", "igd_median"]),
    ]


def _rank_tests_md(rt: dict[str, Any]) -> list[str]:
    """The rank-test section: the Friedman test (or why it was skipped) and the pairs."""
    md = [f"\n### Rank tests ({rt['correction']}, alpha {rt['alpha']})\n\n"]
    fr = rt["friedman"]
    if fr and "p" in fr:
        md.append(
            f"Friedman: chi2 = {fr['statistic']:.4g}, p = {fr['p']:.4g} over seeds "
            f"{fr['seeds']}.\n\n"
        )
    elif fr:
        md.append(f"Friedman test skipped: {_cell(fr['skipped'])}.\n\n")
    md.append(_md_table(rt["pairs"], ["a", "b", "n_a", "n_b", "p", "p_holm", "a12", "verdict"]))
    return md


def _problem_md(p: ProblemComparison) -> list[str]:
    """One problem's part of ``compare.md``."""
    r = p.result
    config = json.dumps(p.config, default=str).replace("`", "'")
    md = [
        f"\n## {_cell(p.name)}: {_cell(r['measure'])}\n",
        f"Problem configuration: `{config}`\n",
    ]
    if r["normalisation_source"]:
        md.append(f"\nQuality normalised on: {_cell(r['normalisation_source'])}\n")
    md += [f"\n**Flag:** {_cell(f)}\n" for f in r["flags"]]
    rows = [
        {
            **row,
            "budgets": ", ".join(map(str, row["budgets"]))
            + (" (unequal)" if row["unequal_budget"] else ""),
        }
        for row in r["table"]
    ]
    return [
        *md,
        "\n### Groups (at the common budget)\n\n",
        _md_table(rows, GROUP_COLUMNS),
        "\n### Fixed budget\n\n",
        _md_table(r["fixed_budget"], FIXED_BUDGET_COLUMNS),
        "\n### Fixed target: ERT (evaluations)\n\n",
        _ert_table(p),
        *_multiobjective_md(r["multiobjective"]),
        *_rank_tests_md(r["rank_tests"]),
    ]


def _profile_md(prof: dict[str, Any]) -> list[str]:
    """The performance profile's fraction of instances within a few factors tau."""
    taus = [1.0, 2.0, 4.0, 10.0]
    rows = []
    for s, rho_s in zip(prof["solvers"], prof["rho"], strict=True):
        t = np.asarray(prof["taus"])
        rho = np.asarray(rho_s)
        row = {"strategy": s}
        for tau in taus:
            i = int(np.searchsorted(t, tau, side="right")) - 1
            row[f"tau={tau:g}"] = float(rho[i]) if i >= 0 else 0.0
        rows.append(row)
    return [
        f"\n## Performance profile\n\nCost: {prof['cost']}, {len(prof['instances'])} "
        f"(problem, target) instances over {prof['n_problems']} problem(s); fraction "
        "of instances solved within a factor tau of the best:\n\n",
        _md_table(rows, ["strategy"] + [f"tau={t:g}" for t in taus]),
    ]


def markdown(comparison: Comparison) -> str:
    """``compare.md``: per problem the groups, fixed-budget, ERT, multi-objective and
    rank-test tables; the performance profile."""
    md = ["# Runs compared\n", "Lower is better everywhere. Definitions: docs/analysis.md.\n"]
    for p in comparison.problems:
        md += _problem_md(p)
    if comparison.profile:
        md += _profile_md(comparison.profile)
    return "\n".join(md) + "\n"


def write_compare_files(
    comparison: Comparison, out: str | Path, written: Sequence[Path] = ()
) -> list[Path]:
    """Write ``compare.md`` and then ``compare.json``, whose ``files`` names these two and
    the files already ``written`` for the comparison (figures, the IOHprofiler export of
    :func:`suspenv.analysis.ioh.write_ioh`); returns all their paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "compare.json", write_file(out / "compare.md", markdown(comparison))]
    paths += written
    comparison.result["files"] = sorted({p.name for p in paths})
    write_json(paths[0], comparison.result)
    return paths
