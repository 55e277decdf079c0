"""The Tey et al. (2014) identification method end to end, as the pipeline "tey2014".

Steps (each a reusable function in :mod:`suspenv.methods`):

1. Latin hypercube design of experiments (``study.doe_samples``, default 500), run
   through :func:`suspenv.runs.loop.optimize` with the "lhs" strategy, so every evaluation
   is archived in ``doe/archive.sqlite`` and a killed run resumes.
2. Spearman sensitivity of every parameter with every objective over the valid designs;
   p > ``study.alpha`` (0.05) is treated as no correlation.
3. Hierarchical clustering of the objectives by their Spearman vectors (Euclidean), the
   linkage chosen by cophenetic correlation among average, complete, single, weighted.
4. Number of clusters by mean silhouette and by the paper's RS + RC rank method
   (``study.k_criterion``); one representative objective per cluster
   (``study.representative``).
5. CMA-ES (population 42, ``budget`` evaluations, default 2250) on the dynamic rank-sum
   of the kept objectives. Infeasible designs are removed before ranking, as in the paper,
   but still told to CMA-ES, ranked after every feasible one (by violation); failed
   designs rank last (see :mod:`suspenv.core.scalarize`). Archived in ``cmaes/``.
6. The whole CMA-ES archive re-ranked with the rank-sum; the best ``study.top`` (20)
   designs give the parameters as mean and standard deviation (Table 1); per-objective
   improvement of the identified model (the mean design) over the initial one (Table 2).
7. Rank-sum versus Euclidean distance on ``study.compare_designs`` (100) random designs
   of the design of experiments (Figs 9-10 of the paper).
8. Beyond the paper, when the problem offers the hooks: recovery error against
   ``truth_design()``; identifiability by parameter profiles over their whole ranges and
   a finite-difference sensitivity at the identified design (signed when the problem has
   ``residuals(X)``); measured vs initial vs identified curves from ``curves(x)`` and
   ``measured_curves()``. With ``study.all_objectives_run = true``, a second CMA-ES run
   on all objectives shows what the clustering buys.

Problem hooks (all optional): ``initial_design() -> (d,)`` (default: the space's
reference), ``truth_design() -> (d,)``, ``residuals(X) -> (n, m)``, ``curves(x)`` and
``measured_curves()`` returning ``{test: {channel: (abscissa, ordinate)}}``.
"""

from __future__ import annotations

import importlib
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core import options as check
from suspenv.core.atomic import write_file
from suspenv.core.errors import ValidationError
from suspenv.core.jsonable import json_text
from suspenv.core.laps import Laps
from suspenv.core.problem import Problem
from suspenv.core.result import EvaluationBatch
from suspenv.methods.tey2014.cluster_count import (
    CRITERIA,
    REPRESENTATIVE_RULES,
    ClusterSelection,
    select_objectives,
)
from suspenv.methods.tey2014.clustering import LINKAGE_METHODS, ClusteringResult, cluster_objectives
from suspenv.methods.tey2014.identification import (
    FixedRankSum,
    IdentificationResult,
    LocalSensitivity,
    ProfileScan,
    identify,
    improvement_table,
    local_sensitivity,
    objective_scale,
    profile_scan,
    recovery_table,
)
from suspenv.methods.tey2014.rank_sum import ScalarisationComparison, compare_rank_sum_euclidean
from suspenv.methods.tey2014.sensitivity import SensitivityResult, spearman_matrix
from suspenv.methods.tey2014.strategy_comparison import (
    QUALITY_NAME,
    STRATEGY_OPTIONS,
    RunArrays,
    compare_strategies,
    optimize_arrays,
)
from suspenv.models.mcpherson.params import PARAMETER_NAMES, reference_design
from suspenv.problems.views import ObjectiveSubset, WithSignedResponses
from suspenv.registry import make_problem, make_strategy, report_function
from suspenv.runs.config import plots_wanted
from suspenv.runs.quality import best_so_far, curve_items

#: the ``[study]`` table of a config, with its defaults (the paper's settings)
STUDY_DEFAULTS: dict[str, Any] = {
    "doe_samples": 500,
    "doe_batch": 100,
    "alpha": 0.05,
    "sensitivity_on": "responses",  # "responses" (signed, the paper's) or "mismatches"
    "linkage_methods": list(LINKAGE_METHODS),
    "k_criterion": "rank",
    "k_min": 2,
    "k_max": 0,  # 0: number of objectives - 1
    "singleton_silhouette": 0.0,
    "representative": "medoid",
    "start": "initial",  # CMA-ES initial mean: "initial" model or "centre" of the box
    "top": 20,
    "compare_designs": 100,
    "profile_points": 9,
    "flat_tol": 0.05,  # flat: full-range effect below this many DoE spreads (summed)
    "fd_step": 0.001,
    "all_objectives_run": False,
    "identifiability_on": "all",  # objectives for profiles/flat directions: "all" or "kept"
    "compare_strategies": [],  # e.g. ["cmaes", "random", "lhs", "nsga2"] on the kept objectives
    "compare_seeds": [1, 2, 3],
    "compare_budget": 0,  # 0: same as `budget`
    "report": True,
}

DEFAULT_BUDGET = 2250


#: the paper's Table 1 standard deviations [mm] of the hard points' x, y, z (the other
#: parameters': :func:`_paper_table1`)
_PAPER_POINT_STD = {
    "lower_ball_joint": (0.04, 0.04, 0.17),
    "lca_front_bush": (0.31, 0.03, 0.16),
    "lca_rear_bush": (0.20, 0.12, 0.15),
    "strut_axis_point": (0.25, 0.01, 0.07),
    "strut_top": (0.07, 0.02, 0.08),
    "tie_rod_inner": (1.02, 0.17, 0.33),
    "tie_rod_outer": (0.42, 0.14, 0.37),
    "arb_drop_link": (0.11, 0.11, 1.66),
}


def _paper_table1() -> dict[str, tuple[float, float | None]]:
    """The paper's Table 1: parameter -> (mean of the best 20, std or None if not given).
    The means are the reference vehicle's design (suspenv's reference is the paper's
    identified axle); the paper gives the std of the hard points and the anti-roll bar."""
    std = {
        f"{point}_{axis}": sd
        for point, sds in _PAPER_POINT_STD.items()
        for axis, sd in zip("xyz", sds, strict=True)
    }
    std["arb_torsion"] = 0.03
    means = zip(PARAMETER_NAMES, reference_design(), strict=True)
    return {name: (float(mean), std.get(name)) for name, mean in means}


#: what the paper reported for its McPherson axle (spec: kc_identification.md)
PAPER_REFERENCE: dict[str, Any] = {
    "problem": "KCIdentification",
    "cophenetic": {"average": 0.957, "weighted": 0.956, "single": 0.949, "complete": 0.925},
    "k": 30,
    "mean_silhouette": 0.97,
    "n_objectives": 40,
    "table1": _paper_table1(),
}


@dataclass
class Tey2014Study:
    """Everything the method computed (input of :mod:`suspenv.reports.tey2014`)."""

    problem: Problem
    options: dict[str, Any]
    doe: RunArrays
    sensitivity: SensitivityResult
    clustering: ClusteringResult
    selection: ClusterSelection
    scale: np.ndarray  # (m,) DoE spread of every objective
    quality: FixedRankSum  # rank-sum normalised once on the DoE (all objectives)
    cmaes: RunArrays
    identification: IdentificationResult
    designs: dict[str, np.ndarray]  # named physical designs: initial, identified, best, truth
    evaluations: dict[str, EvaluationBatch]  # full-problem evaluation of each named design
    improvement: list[dict[str, Any]]
    comparison: ScalarisationComparison
    recovery: list[dict[str, Any]] | None = None
    profiles: ProfileScan | None = None
    local: LocalSensitivity | None = None
    all_objectives: RunArrays | None = None
    all_identification: IdentificationResult | None = None
    strategy_comparison: dict[str, Any] | None = None
    sensitivity_source: str = "mismatches"
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def kept(self) -> list[int]:
        return [int(i) for i in self.selection.kept]


# --------------------------------------------------------------- config


def study_options(config: dict[str, Any]) -> dict[str, Any]:
    """The ``[study]`` table merged over :data:`STUDY_DEFAULTS`; unknown keys are errors."""
    given = dict(config.get("study", {}) or {})
    unknown = sorted(set(given) - set(STUDY_DEFAULTS))
    if unknown:
        raise ValidationError(
            f"config: unknown key study.{unknown[0]} (known: {', '.join(sorted(STUDY_DEFAULTS))})"
        )
    opts = {**STUDY_DEFAULTS, **given}
    least = {"doe_samples": 2, "doe_batch": 1, "top": 1, "compare_designs": 2, "profile_points": 0}
    for key, lo in least.items():
        opts[key] = check.integer("config", f"study.{key}", opts[key], lo)
    choices = {
        "k_criterion": CRITERIA,
        "representative": REPRESENTATIVE_RULES,
        "sensitivity_on": ("responses", "mismatches"),
        "identifiability_on": ("all", "kept"),
        "start": ("initial", "centre"),
    }
    for key, allowed in choices.items():
        opts[key] = check.choice("config", f"study.{key}", opts[key], allowed)
    opts["compare_strategies"] = list(
        check.texts("config", "study.compare_strategies", opts["compare_strategies"])
    )
    seeds = opts["compare_seeds"]
    if not isinstance(seeds, list) or not seeds:
        raise ValidationError(
            f"config: `study.compare_seeds` must be a non-empty list of integers >= 0, but got "
            f"{seeds!r}"
        )
    opts["compare_seeds"] = [
        check.integer("config", f"study.compare_seeds[{i}]", v, 0) for i, v in enumerate(seeds)
    ]
    return opts


def build_problem(config: dict[str, Any]) -> Problem:
    """The config's problem: a registered name, or ``"module:Class"`` where the user
    allowed a config to run code (``suspenv run --allow-code``)."""
    section = config.get("problem", {}) or {}
    name = section.get("name")
    if not isinstance(name, str) or not name:
        raise ValidationError(f"config: `problem.name` must be a string, but got {name!r}")
    options = section.get("options", {}) or {}
    if ":" in name:  # allowed by the user when the config was loaded (runs.config)
        module, _, attr = name.partition(":")
        return getattr(importlib.import_module(module), attr)(**options)
    return make_problem(name, **options)


def check_tey2014_config(config: dict[str, Any]) -> dict[str, Any]:
    """Check a "tey2014" config before any work: the ``[study]`` table, the problem and the
    main strategy with their options. Returns the config with the study's defaults and
    the problem's evaluation timeout filled in."""
    from suspenv.runs.evaluation import FaultPolicy

    opts = study_options(config)
    problem = build_problem(config)
    _main_strategy(problem, config, opts, initial_design(problem))
    budget = check.integer("config", "budget", config.get("budget", DEFAULT_BUDGET), 1)
    run = dict(config.get("run", {}) or {})
    run["timeout_s"] = FaultPolicy.for_run(run, problem).timeout_s
    return {**config, "budget": budget, "study": opts, "run": run}


def initial_design(problem: Problem) -> np.ndarray:
    hook = getattr(problem, "initial_design", None)
    return np.asarray(hook() if callable(hook) else problem.reference_design(), dtype=float)


def truth_design(problem: Problem) -> np.ndarray | None:
    hook = getattr(problem, "truth_design", None)
    return None if not callable(hook) else np.asarray(hook(), dtype=float)


# ------------------------------------------------------------ the steps


def _run(
    problem: Problem,
    strategy: Any,
    budget: int,
    run_dir: Path,
    seed: int,
    run_cfg: dict[str, Any],
    label: str,
) -> RunArrays:
    """``optimize`` into ``run_dir`` (resumes an archive there); the archive as arrays."""
    from suspenv.runs.archive import RunArchive

    path = Path(run_dir) / RunArchive.FILENAME
    if path.is_file():
        with RunArchive(run_dir) as old:
            names = old.meta().get("objective_names")
        if names is not None and list(names) != list(problem.objective_names):
            raise ValidationError(
                f"{label}: the archive in {str(run_dir)!r} holds other objectives ({names}) "
                f"than this study's ({list(problem.objective_names)}); the study options "
                "changed since it was written. Use a new run directory"
            )

    _, runs = optimize_arrays(
        problem,
        strategy,
        budget,
        run_dir,
        seed,
        run_cfg,
        chunk_size=run_cfg.get("chunk_size"),
        meta={"study_step": label},
    )
    return runs


def _strategy_section(config: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """The config's strategy name (default "cmaes") and its own options (a copy)."""
    strat = config.get("strategy", {}) or {}
    return strat.get("name") or "cmaes", dict(strat.get("options") or {})


def _main_strategy(problem: Problem, config: dict, opts: dict, x0: np.ndarray) -> Any:
    """The config's strategy (CMA-ES on the rank-sum by default, with the strategy
    comparison's CMA-ES options unless ``[strategy.options]`` says otherwise), started
    at ``x0``."""
    name, own = _strategy_section(config)
    options = {**(STRATEGY_OPTIONS["cmaes"] if name == "cmaes" else {}), **own}
    if name == "cmaes" and opts["start"] == "initial" and "x0" not in options:
        options["x0"] = [float(v) for v in np.clip(problem.space.to_unit(x0[None, :])[0], 0, 1)]
    return make_strategy(name, problem, seed=int(config.get("seed", 0)), **options)


def _sensitivity_targets(
    problem: Problem, doe: RunArrays, signed: np.ndarray, valid: np.ndarray, opts: dict[str, Any]
) -> tuple[np.ndarray, str]:
    """What the Spearman step correlates with, and a phrase saying what it is.

    The paper correlates the parameters with the objectives themselves, i.e. the simulated
    K&C numbers (here: their signed residuals, which rank identically); a mismatch
    |simulated - measured| is V-shaped in a parameter whose true value lies inside its
    range, which hides a monotone influence from a rank correlation. Signed responses come
    from the design of experiments' archive when the problem returns them (extras
    ``residuals`` or ``simulated``), else from its ``residuals(X)`` method (one more pass
    over the valid designs); a problem with neither falls back to the mismatches.
    """
    if opts["sensitivity_on"] == "mismatches":
        return doe.objectives[valid], "mismatches"
    if np.isfinite(signed[valid]).all():
        return signed[valid], "signed responses"
    hook = getattr(problem, "residuals", None)
    if callable(hook):
        X = doe.x[valid]
        step = int(opts["doe_batch"])
        R = np.vstack([np.asarray(hook(X[i : i + step]), float) for i in range(0, len(X), step)])
        if np.isfinite(R).all():
            return R, "signed responses"
    return doe.objectives[valid], "mismatches (the problem gives no signed responses)"


def _compare_options(config: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """The config's own strategy options also apply to that strategy in the comparison."""
    name, options = _strategy_section(config)
    options.pop("x0", None)  # every compared strategy starts from its own default
    return {name: options} if options else {}


@dataclass
class _Setup:
    """What every step of a study reads: the config, its problem and its options."""

    config: dict[str, Any]
    run_dir: Path
    opts: dict[str, Any]  # the study's options (:func:`study_options`)
    seed: int
    budget: int
    run_cfg: dict[str, Any]
    problem: Problem

    def run(self, problem: Problem, strategy: Any, budget: int, label: str) -> RunArrays:
        """:func:`_run` into ``run_dir/label``."""
        return _run(problem, strategy, budget, self.run_dir / label, self.seed, self.run_cfg, label)


def run_study(config: dict[str, Any], run_dir: Path) -> Tey2014Study:
    """Run every step of the method; archives go to ``run_dir/doe`` and ``run_dir/cmaes``."""
    su = _Setup(
        config,
        Path(run_dir),
        study_options(config),
        int(config.get("seed", 0)),
        int(config.get("budget", DEFAULT_BUDGET)),
        {"workers": 1, **(config.get("run", {}) or {})},
        build_problem(config),
    )
    problem, opts = su.problem, su.opts
    lap = Laps()

    # 1. design of experiments
    doe, signed = _design_of_experiments(su)
    lap("design_of_experiments")

    # 2. sensitivity over the valid designs
    valid = doe.valid
    targets, sensitivity_source = _sensitivity_targets(problem, doe, signed, valid, opts)
    sens = spearman_matrix(
        doe.x[valid], targets, opts["alpha"], problem.space.names, problem.objective_names
    )
    scale = objective_scale(doe.objectives[valid])
    quality = FixedRankSum.fit(doe.objectives[valid])
    lap("sensitivity")

    # 3-4. clustering and the kept objectives
    clus, sel = _clustering(su, sens)
    kept = [int(i) for i in sel.kept]
    lap("clustering")

    # 5. CMA-ES on the rank-sum of the kept objectives
    x_init = initial_design(problem)
    sub = ObjectiveSubset(problem, kept)
    cma_run = su.run(sub, _main_strategy(sub, config, opts, x_init), su.budget, "cmaes")
    lap("optimisation")

    # 6. re-ranked archive, Table 1 and Table 2
    ident = identify(cma_run.x, cma_run.objectives, cma_run.valid, problem.space, opts["top"])
    designs, evaluations, improvement = _identified(problem, x_init, ident, kept)
    lap("identification")

    # 7. rank-sum versus Euclidean distance on random designs (the first valid DoE rows)
    rows = np.flatnonzero(valid)[: opts["compare_designs"]]
    comparison = compare_rank_sum_euclidean(
        doe.objectives[rows][:, kept], [problem.objective_names[i] for i in kept]
    )
    lap("rank_sum_comparison")

    # 8. beyond the paper
    study = Tey2014Study(
        problem,
        opts,
        doe,
        sens,
        clus,
        sel,
        scale,
        quality,
        cma_run,
        ident,
        designs,
        evaluations,
        improvement,
        comparison,
        timings=lap.times,
    )
    study.sensitivity_source = sensitivity_source
    _beyond_the_paper(su, study, sub, lap)
    return study


def _beyond_the_paper(su: _Setup, study: Tey2014Study, sub: Problem, lap: Laps) -> None:
    """Step 8 (identifiability), the run on all objectives and the comparison of
    strategies on ``sub`` (the kept objectives) when the options ask, each timed."""
    opts = su.opts
    _identifiability(su, study)
    lap("identifiability")
    if opts["all_objectives_run"]:  # a second CMA-ES run: what the clustering buys
        strategy_all = _main_strategy(su.problem, su.config, opts, study.designs["initial"])
        a = su.run(su.problem, strategy_all, su.budget, "cmaes_all_objectives")
        study.all_objectives = a
        study.all_identification = identify(
            a.x, a.objectives, a.valid, su.problem.space, opts["top"]
        )
        lap("all_objectives_run")
    if opts["compare_strategies"]:
        study.strategy_comparison = compare_strategies(
            sub,
            opts["compare_strategies"],
            opts["compare_seeds"],
            opts["compare_budget"] or su.budget,
            study.quality.subset(study.kept),
            su.run_dir / "compare",
            su.run_cfg,
            options=_compare_options(su.config),
        )
        lap("strategy_comparison")


def _design_of_experiments(su: _Setup) -> tuple[RunArrays, np.ndarray]:
    """Step 1: the Latin hypercube designs, their objectives (the signed responses split
    off) and the signed responses (n, m)."""
    opts = su.opts
    lhs = make_strategy(
        "lhs", su.problem, seed=su.seed, n_samples=opts["doe_samples"], batch_size=opts["doe_batch"]
    )
    doe = su.run(WithSignedResponses(su.problem), lhs, opts["doe_samples"], "doe")
    m = su.problem.n_objectives
    signed = doe.objectives[:, m:]
    doe.objectives = doe.objectives[:, :m]
    return doe, signed


def _clustering(su: _Setup, sens: SensitivityResult) -> tuple[ClusteringResult, ClusterSelection]:
    """Steps 3-4: the objectives clustered by their Spearman vectors; the kept ones."""
    problem, opts = su.problem, su.opts
    clus = cluster_objectives(
        sens.objective_vectors, problem.objective_names, opts["linkage_methods"]
    )
    sel = select_objectives(
        clus,
        k_min=opts["k_min"],
        k_max=opts["k_max"] or None,
        criterion=opts["k_criterion"],
        rule=opts["representative"],
        singleton_value=opts["singleton_silhouette"],
    )
    return clus, sel


def _identified(
    problem: Problem, x_init: np.ndarray, ident: IdentificationResult, kept: list[int]
) -> tuple[dict[str, np.ndarray], dict[str, EvaluationBatch], list[dict[str, Any]]]:
    """Step 6: the named designs (initial, identified, best and the truth if known), their
    full-problem evaluations and Table 2 (initial against identified)."""
    designs = {"initial": x_init, "identified": ident.mean, "best": ident.best}
    truth = truth_design(problem)
    if truth is not None:
        designs["truth"] = truth
    names = list(designs)
    full = problem.evaluate(np.vstack([designs[n] for n in names]))
    evaluations = {n: full.take([i]) for i, n in enumerate(names)}
    improvement = improvement_table(full.objectives[0], full.objectives[1], problem.objective_names)
    for row, i in zip(improvement, range(problem.n_objectives), strict=True):
        row["kept"] = i in kept
    return designs, evaluations, improvement


def _identifiability(su: _Setup, study: Tey2014Study) -> None:
    """Step 8: the recovery error against the truth (if known); parameter profiles and
    the local sensitivity at the identified design."""
    problem, opts, ident = su.problem, su.opts, study.identification
    truth = study.designs.get("truth")
    if truth is not None:
        study.recovery = recovery_table(ident, truth, problem.space)
    if opts["profile_points"] >= 2:
        # what the data can identify: all objectives (or only the kept ones, if asked)
        cols = (
            study.kept
            if opts["identifiability_on"] == "kept"
            else list(range(problem.n_objectives))
        )
        study.profiles = profile_scan(
            problem,
            ident.mean,
            cols,
            study.scale[cols],
            opts["profile_points"],
            opts["doe_batch"],
            bool(su.run_cfg.get("progress", False)),
        )
        study.local = local_sensitivity(
            problem, ident.mean, cols, study.scale[cols], opts["fd_step"]
        )


def study_summary(study: Tey2014Study) -> dict[str, Any]:
    """A JSON-ready summary of the study (also the pipeline's return value)."""
    p = study.problem
    kept = study.kept
    ev = study.evaluations

    def total(name: str, cols: list[int]) -> float:
        return float(study.quality.subset(cols)(ev[name].objectives[:, cols])[0])

    everything = list(range(p.n_objectives))
    out: dict[str, Any] = {
        "problem": p.name,
        "n_parameters": p.space.dim,
        "n_objectives": p.n_objectives,
        "doe_evaluations": int(study.doe.ok.size),
        "doe_valid": int(study.doe.valid.sum()),
        "cmaes_evaluations": int(study.cmaes.ok.size),
        "cmaes_valid": int(study.cmaes.valid.sum()),
        "sensitivity_on": study.sensitivity_source,
        "insensitive_parameters": study.sensitivity.insensitive_parameters(),
        "cophenetic": study.clustering.cophenetic,
        "linkage": study.clustering.method,
        "k_silhouette": study.selection.k_silhouette,
        "k_rank": study.selection.k_rank,
        "k": study.selection.k,
        "mean_silhouette_at_k": study.selection.silhouette_at(study.selection.k),
        "kept_objectives": list(study.selection.kept_names),
        "fixed_rank_sum_kept": {n: total(n, kept) for n in ev},
        "fixed_rank_sum_all": {n: total(n, everything) for n in ev},
        "identified": {r["parameter"]: [r["mean"], r["std"]] for r in study.identification.rows()},
        "rank_sum_comparison": study.comparison.summary(),
        "timings_s": study.timings,
    }
    if study.strategy_comparison is not None:
        out["strategy_comparison"] = study.strategy_comparison["table"]
    flat = None if study.profiles is None else study.profiles.flat(study.options["flat_tol"])
    if study.recovery is not None:
        err = np.array([r["error_%_range"] for r in study.recovery])
        out["recovery_error_%_range"] = {"mean": float(err.mean()), "max": float(err.max())}
        if flat is not None:
            for key, mask in (("identifiable", ~flat), ("flat", flat)):
                out["recovery_error_%_range"][f"mean_{key}"] = (
                    float(err[mask].mean()) if mask.any() else float("nan")
                )
    if flat is not None:
        out["flat_parameters"] = [n for n, f in zip(p.space.names, flat, strict=True) if f]
    if study.all_identification is not None:
        x = study.all_identification.mean
        b = p.evaluate(x[None, :])
        out["all_objectives_run"] = {
            "fixed_rank_sum_kept": float(study.quality.subset(kept)(b.objectives[:, kept])[0]),
            "fixed_rank_sum_all": float(study.quality(b.objectives)[0]),
        }
        t = truth_design(p)
        if t is not None:
            rows = recovery_table(study.all_identification, t, p.space)
            out["all_objectives_run"]["recovery_error_%_range_mean"] = float(
                np.mean([r["error_%_range"] for r in rows])
            )
    return out


def run_tey2014_pipeline(config: dict[str, Any], run_dir: Path) -> dict[str, Any]:
    """Pipeline "tey2014": run the study, write ``study.json`` and the report into run_dir."""
    t0 = time.perf_counter()
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    study = run_study(config, run_dir)
    files: list[str] = []
    if study.options["report"]:
        # suspenv.reports.tey2014.write_tey2014_report (reports sit above methods)
        write_report = report_function("tey2014")
        t1 = time.perf_counter()
        plots = plots_wanted(config)
        report = write_report(study, run_dir, figures=plots)
        study.timings["report"] = time.perf_counter() - t1
        files = [str(report.relative_to(run_dir))]
    summary = study_summary(study)
    wall = time.perf_counter() - t0
    kept = study.kept
    tot = study.quality.subset(kept)(study.cmaes.objectives)  # kept columns only
    strategy, _ = _strategy_section(config)
    # the keys every run summary has (``suspenv show`` / ``suspenv compare``)
    summary.update(
        name=config.get("name"),
        seed=int(config.get("seed", 0)),
        strategy=strategy,
        budget=int(config.get("budget", DEFAULT_BUDGET)),
        n_evaluations=int(study.doe.ok.size + study.cmaes.ok.size),
        n_ok=int(study.doe.ok.sum() + study.cmaes.ok.sum()),
        n_feasible=int(study.doe.valid.sum() + study.cmaes.valid.sum()),
        wall_time_s=wall,
        pipeline_wall_time_s=wall,
        quality_name=QUALITY_NAME,
        **curve_items(best_so_far(tot, study.cmaes.valid)),
        report=files[0] if files else None,
    )
    # strict JSON, as every run writer: an undefined number (NaN, inf) is null
    text = json_text(summary)
    write_file(run_dir / "study.json", text)
    write_file(run_dir / "summary.json", text)
    return summary
