"""Run directories read for analysis: one :class:`RunRecord` per run, and tidy tables.

A run directory holds ``summary.json`` (every pipeline writes one; see
:func:`suspenv.runs.run_dir.load_summary`), usually ``config.resolved.toml`` and an
``archive.sqlite`` of every evaluation (a ``tey2014`` run keeps its CMA-ES evaluations in
``cmaes/archive.sqlite`` and its design of experiments in ``doe/archive.sqlite``).

:func:`tidy` and :func:`runs_table` return plain dicts of equal-length NumPy arrays in long
("tidy") form, one row per (run, evaluation) or per run: ``pandas.DataFrame(tidy(dirs))``
and ``xarray.Dataset.from_dataframe`` take them as they are; neither library is needed
here.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import tomllib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.analysis.indicators import (
    HV_MAX_OBJECTIVES,
    KNOWN_FRONTS,
    feasible_front,
    hypervolume_curve,
    normalisation,
    normalise,
    reference_point,
)
from suspenv.analysis.performance import as_curve
from suspenv.core.errors import ValidationError
from suspenv.core.jsonable import json_default
from suspenv.registry import STRATEGY_RESERVED, problem_class, strategy_class
from suspenv.runs.archive import RunArchive, value_columns
from suspenv.runs.quality import feasible, scalar_recorded
from suspenv.runs.run_dir import load_summary

#: strategy options that say where a run keeps its state, not how it searches (optuna's
#: study name defaults to one per seed); left out of the strategy configuration
STATE_OPTIONS = frozenset({"seed", "storage", "study_name", "resume"})


def config_hash(obj: Any) -> str:
    """First 8 hex digits of the SHA-256 of the canonical JSON of ``obj`` (sorted keys, no
    whitespace, tuples as lists): stable across processes and platforms."""
    text = json.dumps(obj, sort_keys=True, separators=(",", ":"), default=json_default)
    return hashlib.sha256(text.encode()).hexdigest()[:8]


def _defaults(cls: Any, skip: frozenset[str]) -> dict[str, Any] | None:
    """Keyword defaults of a class's constructor (None when it cannot be read)."""
    try:
        sig = inspect.signature(cls.__init__)
    except (TypeError, ValueError):
        return None
    out = {}
    for p in sig.parameters.values():
        if p.name in skip or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        if p.default is not p.empty:
            out[p.name] = p.default
    return out


@cache
def _defaults_json(kind: str, name: str) -> str | None:
    """JSON of the constructor defaults of the ``kind`` ("problem" or "strategy") named
    ``name``; None when it is not registered or cannot be read, or for a strategy plug-in
    (``module:Class``: its code is not imported by the analysis)."""
    if kind == "strategy" and ":" in name:
        return None
    try:
        if kind == "problem":
            d = _defaults(problem_class(name), frozenset({"self"}))
        else:
            d = _defaults(strategy_class(name), frozenset({"self", *STRATEGY_RESERVED}))
    except ValidationError:
        return None
    return None if d is None else json.dumps(d, default=json_default, sort_keys=True)


@cache
def _problem_resolved(name: str, dim: int, m: int, k: int) -> str | None:
    """JSON of the options strategy ``name`` resolves with none given, on a problem of
    ``dim`` variables, ``m`` objectives and ``k`` constraints (None: it cannot be built
    here; a ``module:Class`` plug-in is never imported by the analysis)."""
    if ":" in name:
        return None
    try:
        cls = strategy_class(name)
        options = getattr(cls(dim=dim, n_objectives=m, n_constraints=k, seed=0), "options", None)
        return None if options is None else json.dumps(options(), default=json_default)
    except (ValidationError, TypeError, ValueError, ImportError):
        return None


def configured_strategy_options(
    name: str, options: dict[str, Any], shape: tuple[int, int, int] | None
) -> dict[str, Any]:
    """A strategy's identity: the options as the user configured them.

    An option whose constructor default is None is resolved by the strategy from the
    problem (CMA-ES's population from the dimension, NSGA-II's mutation probability
    1/d): it is None here unless its value differs from what the strategy resolves on a
    problem of this ``shape`` (dim, objectives, constraints) with no option given. So
    one configuration keeps one hash on problems of every size; an option set to
    exactly the value its default resolves to on that problem counts as the default.
    The resolved values are kept beside (:attr:`RunRecord.strategy_resolved`)."""
    if ":" in name:
        return dict(options)
    defaults = json.loads(_defaults_json("strategy", name) or "{}")
    auto = {k for k, v in defaults.items() if v is None}
    resolved = _problem_resolved(name, *shape) if shape is not None else None
    base = json.loads(resolved) if resolved is not None else {}
    out = dict(options)
    for key in auto & set(out):
        if out[key] is None or (key in base and base[key] == out[key]):
            out[key] = None
    return out


def resolved_problem_options(name: str, options: dict[str, Any]) -> dict[str, Any]:
    """A problem's options with its constructor's defaults filled in (``{}`` and
    ``{"dim": 10}`` are the same Sphere); as given when the problem is not registered."""
    d = _defaults_json("problem", name)
    base = json.loads(d) if d is not None else {}
    return {**base, **json.loads(json.dumps(options, default=json_default))}


def resolved_strategy_options(
    name: str, options: dict[str, Any], recorded: bool = False
) -> dict[str, Any]:
    """A strategy's options without :data:`STATE_OPTIONS`: as ``recorded`` by the strategy
    itself at run time (``summary.json``'s ``strategy_options``), else the given ones
    with the constructor's current defaults filled in."""
    d = None if recorded else _defaults_json("strategy", name)
    base = json.loads(d) if d is not None else {}
    merged = {**base, **json.loads(json.dumps(options, default=json_default))}
    return {k: v for k, v in merged.items() if k not in STATE_OPTIONS}


@dataclass
class RunRecord:
    """One finished run, as the analysis sees it.

    ``strategy_options`` are the options as configured (the strategy's identity, see
    :func:`configured_strategy_options`), ``strategy_resolved`` the values the run used.
    ``curve`` is the best-so-far quality after each evaluation it covers (``+inf`` before
    the first feasible value); ``evaluations_used`` is its length (for a ``tey2014`` run
    the CMA-ES evaluations after the design of experiments). ``normalisation`` identifies
    what a DoE-normalised quality was normalised on (None for other qualities).
    """

    path: Path
    summary: dict[str, Any]
    config: dict[str, Any]
    pipeline: str
    problem: str
    problem_options: dict[str, Any]
    objective_names: list[str]
    quality_name: str
    strategy: str
    strategy_options: dict[str, Any]
    seed: int | None
    budget: int | None
    curve: np.ndarray
    normalisation: str | None
    normalisation_source: str | None
    dimension: int | None
    archive_dir: Path | None
    strategy_resolved: dict[str, Any] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict, repr=False)
    _arrays: dict[str, np.ndarray] | None = field(default=None, repr=False)

    @property
    def name(self) -> str:
        return self.path.name

    @property
    def evaluations_used(self) -> int:
        return int(self.curve.size)

    @property
    def final(self) -> float:
        return float(self.curve[-1]) if self.curve.size else float("inf")

    @property
    def best_quality(self) -> float:
        """The best quality of the run; NaN when none was feasible or the run has no
        scalar quality (:func:`sums_objectives`)."""
        return self.final if np.isfinite(self.final) and not sums_objectives(self) else np.nan

    @property
    def problem_config(self) -> dict[str, Any]:
        """What defines the problem being compared: name, resolved options, objectives,
        the quality measure and what it was normalised on, the pipeline."""
        return {
            "problem": self.problem,
            "options": self.problem_options,
            "objectives": list(self.objective_names),
            "quality": self.quality_name,
            "normalisation": self.normalisation,
            "pipeline": self.pipeline,
        }

    @property
    def problem_hash(self) -> str:
        return config_hash(self.problem_config)

    @property
    def strategy_hash(self) -> str:
        """Hash of what defines the strategy: its name and configured options (seed
        excluded)."""
        return config_hash({"strategy": self.strategy, "options": self.strategy_options})

    def arrays(self) -> dict[str, np.ndarray] | None:
        """Every evaluation of the curve (:meth:`RunArchive.arrays`), or None when the run
        has no archive whose length matches its curve."""
        if self._arrays is None and self.archive_dir is not None:
            with RunArchive(self.archive_dir) as archive:
                a = archive.arrays()
            if len(a["ok"]) == self.curve.size:
                self._arrays = a
            else:
                self.archive_dir = None
        return self._arrays

    def feasible(self) -> np.ndarray | None:
        """Feasible evaluations (ok, finite objectives, every constraint <= 0)."""
        a = self.arrays()
        if a is None:
            return None
        return feasible(a["ok"], a["constraints"]) & np.isfinite(a["objectives"]).all(axis=1)


def _read_config(path: Path) -> dict[str, Any]:
    f = path / "config.resolved.toml"
    if not f.is_file():
        return {}
    try:
        return tomllib.loads(f.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ValidationError(f"{str(f)!r} is not valid TOML: {exc}") from None


def _archive_hash(path: Path) -> str:
    with RunArchive(path) as archive:
        a = archive.arrays()
    h = hashlib.sha256()
    for k in ("x", "objectives", "constraints"):
        h.update(np.ascontiguousarray(a[k], dtype="<f8").tobytes())
    h.update(np.asarray(a["ok"], dtype="u1").tobytes())
    return h.hexdigest()[:8]


def _normalisation(path: Path, pipeline: str, quality_name: str) -> tuple[str | None, str | None]:
    """What a quality normalised on a design of experiments was normalised on.

    A ``tey2014`` run: its own ``doe/archive.sqlite`` (content hash). A run of a strategy
    comparison inside a tey2014 run (``<run>/compare/<strategy>-seed<s>``): the parent's
    DoE. Otherwise, for a quality named DoE-normalised: the folder the run sits in (the
    runs of one comparison share a normalisation, runs from elsewhere may not).
    """
    if pipeline != "tey2014" and "doe-normalised" not in quality_name.lower():
        return None, None
    candidates = [path / "doe" / RunArchive.FILENAME]
    if path.parent.name == "compare":
        candidates.append(path.parent.parent / "doe" / RunArchive.FILENAME)
    for c in candidates:
        if c.is_file():
            return f"doe:{_archive_hash(c)}", f"design of experiments {c.parent}"
    folder = str(path.resolve().parent)
    return f"folder:{config_hash(folder)}", f"the runs of folder {folder} (no DoE archive found)"


def _archive(path: Path, pipeline: str) -> tuple[Path | None, dict[str, Any]]:
    """(folder, meta) of the archive of the evaluations behind the quality curve (a
    tey2014 run: its CMA-ES stage); (None, {}) without one."""
    folder = path / "cmaes" if pipeline == "tey2014" else path
    if not (folder / RunArchive.FILENAME).is_file():
        return None, {}
    with RunArchive(folder) as archive:
        return folder, archive.meta()


def _dimension(s: dict[str, Any], meta: dict[str, Any]) -> int | None:
    """The run's number of design variables: from its summary's ``best_x`` or
    ``n_parameters``, else its archive's parameter names (None: unknown)."""
    if isinstance(s.get("best_x"), dict):
        return len(s["best_x"])
    if isinstance(s.get("n_parameters"), int):
        return int(s["n_parameters"])
    return len(meta["parameter_names"]) if meta.get("parameter_names") else None


def _quality_curve(path: Path, s: dict[str, Any], quality_name: str) -> list[Any]:
    """The summary's stored best-so-far quality per evaluation; a run without a scalar
    quality stands for its length alone (all None)."""
    curve = s.get("quality_curve")
    if curve is None and not quality_name and isinstance(s.get("n_evaluations"), int):
        curve = [None] * s["n_evaluations"]  # no scalar quality: the run's length only
    if not isinstance(curve, list):
        raise ValidationError(
            f"run {str(path)!r}: summary.json has no `quality_curve` list (best-so-far per "
            "evaluation), so it cannot be compared"
        )
    return curve


def load_run(run_dir: str | Path) -> RunRecord:
    """Read one finished run directory (``summary.json`` required)."""
    path = Path(run_dir)
    s = load_summary(path)
    config = _read_config(path)
    pipeline = str(config.get("pipeline") or ("tey2014" if "kept_objectives" in s else "optimize"))
    problem = str(s.get("problem") or (config.get("problem") or {}).get("name") or "?")
    raw_p = s.get("problem_options")
    if raw_p is None:
        raw_p = (config.get("problem") or {}).get("options") or {}
    archive_dir, meta = _archive(path, pipeline)
    names = s.get("objective_names") or s.get("kept_objectives") or meta.get("objective_names")
    strategy = str(s.get("strategy") or (config.get("strategy") or {}).get("name") or "?")
    # None: several objectives without a quality (suspenv.runs.quality); absent: "quality"
    quality_name = str(s.get("quality_name", "quality") or "")
    norm, source = _normalisation(path, pipeline, quality_name)
    dimension = _dimension(s, meta)
    shape = None
    if dimension is not None:
        shape = (dimension, len(names or []) or 1, len(meta.get("constraint_names") or []))
    s_opts, s_used = _strategy_options(strategy, s, config, pipeline, shape)
    curve = _quality_curve(path, s, quality_name)
    budget = s.get("budget", config.get("budget"))
    seed = s.get("seed", config.get("seed"))
    return RunRecord(
        path=path,
        summary=s,
        config=config,
        pipeline=pipeline,
        problem=problem,
        problem_options=resolved_problem_options(problem, dict(raw_p)),
        objective_names=[str(n) for n in (names or [])],
        quality_name=quality_name,
        strategy=strategy,
        strategy_options=s_opts,
        seed=None if seed is None else int(seed),
        budget=None if budget is None else int(budget),
        curve=as_curve(curve),
        normalisation=norm,
        normalisation_source=source,
        dimension=dimension,
        archive_dir=archive_dir,
        strategy_resolved=s_used,
        meta=meta,
    )


def _strategy_options(
    strategy: str,
    summary: dict[str, Any],
    config: dict[str, Any],
    pipeline: str,
    shape: tuple[int, int, int] | None,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """(configured options: the identity, options the run used), state options left out.
    The run's own record (``summary.json``'s ``strategy_options``) when it has one, else
    its config's options with the constructor's defaults filled in."""
    recorded = summary.get("strategy_options")
    if isinstance(recorded, dict):
        used = resolved_strategy_options(strategy, recorded, recorded=True)
    else:
        given = dict((config.get("strategy") or {}).get("options") or {})
        used = resolved_strategy_options(strategy, given)
    if pipeline == "tey2014" and "study" in config:
        used["study"] = config["study"]
    return configured_strategy_options(strategy, used, shape), used


def reference_front(runs: list[RunRecord], given: Any) -> tuple[np.ndarray, str, float | None]:
    """The reference front of multi-objective runs of one problem: (front in raw
    objectives, where it comes from, exact HV in normalised space or None). Given, else
    the problem's analytic front, else the non-dominated union of the runs."""
    r0 = runs[0]
    if given is not None:
        front = np.atleast_2d(np.asarray(given, dtype=float))
        if front.shape[1] != len(r0.objective_names):
            raise ValidationError(
                f"the reference front of {r0.problem} must have {len(r0.objective_names)} "
                f"columns ({r0.objective_names}), but got shape {front.shape}"
            )
        return front, "given by the caller", None
    known = KNOWN_FRONTS.get(r0.problem)
    if known is not None and tuple(r0.objective_names) == known.objectives:
        front = known.sample(1001)
        exact = None
        if known.exact_hypervolume is not None:
            exact = known.exact_hypervolume(reference_point(front.shape[1]))
        return front, f"{known.source}, sampled at 1001 points", exact
    parts = []
    for r in runs:
        a, feas = r.arrays(), r.feasible()
        if a is not None and feas is not None:
            parts.append(a["objectives"][feas])
    F = np.vstack(parts) if parts else np.zeros((0, len(r0.objective_names)))
    front = feasible_front(F, np.ones(len(F), bool))
    if not len(front):
        raise ValidationError(
            f"no run of {r0.problem} has a feasible evaluation: there is no reference front"
        )
    return (
        front,
        f"non-dominated union of the {len(runs)} compared runs ({len(front)} points)",
        None,
    )


def sums_objectives(r: RunRecord) -> bool:
    """True when a run of two or more objectives has no scalar quality, or a plain sum of
    them in mixed units (:func:`suspenv.runs.quality.scalar_recorded`): its progress is
    then measured by the hypervolume, never by that sum."""
    return not scalar_recorded(r.quality_name, len(r.objective_names))


def load_runs(runs: Iterable[str | Path | RunRecord]) -> list[RunRecord]:
    """:func:`load_run` of each (records pass through); duplicates refused."""
    out = [r if isinstance(r, RunRecord) else load_run(r) for r in runs]
    seen: dict[Path, int] = {}
    for i, r in enumerate(out):
        key = r.path.resolve()
        if key in seen:
            raise ValidationError(
                f"run {str(r.path)!r} is given twice (positions {seen[key] + 1} and {i + 1}); "
                "a run counted twice would weigh double"
            )
        seen[key] = i
    if not out:
        raise ValidationError("compare needs at least one run directory, but got none")
    return out


def runs_table(runs: Sequence[str | Path | RunRecord]) -> dict[str, np.ndarray]:
    """One row per run: run, path, problem, problem_hash, strategy, strategy_hash, group
    (``strategy[hash]``), seed, budget, evaluations, best_quality (NaN: none feasible, or
    no scalar quality, :func:`sums_objectives`), quality_name. Long form:
    ``pandas.DataFrame(runs_table(dirs))``."""
    recs = load_runs(runs)
    return {
        "run": np.array([r.name for r in recs], dtype=object),
        "path": np.array([str(r.path) for r in recs], dtype=object),
        "problem": np.array([r.problem for r in recs], dtype=object),
        "problem_hash": np.array([r.problem_hash for r in recs], dtype=object),
        "strategy": np.array([r.strategy for r in recs], dtype=object),
        "strategy_hash": np.array([r.strategy_hash for r in recs], dtype=object),
        "group": np.array([f"{r.strategy}[{r.strategy_hash}]" for r in recs], dtype=object),
        "seed": np.array([-1 if r.seed is None else r.seed for r in recs], dtype=int),
        "budget": np.array([-1 if r.budget is None else r.budget for r in recs], dtype=int),
        "evaluations": np.array([r.evaluations_used for r in recs], dtype=int),
        "best_quality": np.array([r.best_quality for r in recs], dtype=float),
        "quality_name": np.array([r.quality_name for r in recs], dtype=object),
    }


def tidy(runs: Sequence[str | Path | RunRecord], objectives: bool = True) -> dict[str, np.ndarray]:
    """One row per (run, evaluation), long form, for ``pandas.DataFrame(tidy(dirs))``.

    Columns: run, problem, problem_hash, strategy, strategy_hash, group, seed,
    evaluation (1-based), and the run's progress: ``best_so_far`` (the best quality so
    far, NaN before the first feasible value, and NaN for a run without a scalar quality,
    :func:`sums_objectives`) and, for multi-objective
    runs, ``hypervolume`` (of the feasible evaluations so far, objectives normalised by
    the ideal and nadir of the reference front, :func:`reference_front`, reference point
    1.1 in each; NaN for other runs and for more than
    :data:`~suspenv.analysis.indicators.HV_MAX_OBJECTIVES` objectives, where the exact
    volume costs too much). With ``objectives`` and an archive matching the
    curve also ok, feasible and the value columns of ``evaluations.csv``
    (:func:`suspenv.runs.archive.value_columns`: ``design:<name> [<unit>]``,
    ``objective:<name> [<unit>]``, ``constraint:<name>``); NaN where a run has none.
    """
    recs = load_runs(runs)
    per_run = runs_table(recs)
    sizes = [r.curve.size for r in recs]
    keys = ("run", "problem", "problem_hash", "strategy", "strategy_hash", "group", "seed")
    out = {k: np.repeat(per_run[k], sizes) for k in keys}
    cols: dict[str, list[np.ndarray]] = {"evaluation": [], "best_so_far": [], "hypervolume": []}
    hv = _hypervolume_progress(recs)
    names: dict[str, None] = {}
    if objectives:
        for r in recs:
            names.update(dict.fromkeys(_columns(r)))
        cols.update({"ok": [], "feasible": [], **{k: [] for k in names}})
    for r in recs:
        n = r.curve.size
        cols["evaluation"].append(np.arange(1, n + 1))
        best = np.where(np.isfinite(r.curve), r.curve, np.nan)
        cols["best_so_far"].append(np.full(n, np.nan) if sums_objectives(r) else best)
        cols["hypervolume"].append(hv.get(r.path, np.full(n, np.nan)))
        if objectives:
            a, feas = r.arrays(), r.feasible()
            cols["ok"].append(a["ok"] if a is not None else np.zeros(n, bool))
            cols["feasible"].append(feas if feas is not None else np.zeros(n, bool))
            own = _columns(r)
            for name in names:
                col = np.full(n, np.nan)
                if a is not None and name in own:
                    part, j = own[name]
                    col = a[part][:, j]
                cols[name].append(col)
    return {**out, **{k: np.concatenate(v) if v else np.zeros(0) for k, v in cols.items()}}


def _columns(r: RunRecord) -> dict[str, tuple[str, int]]:
    """A run's tidy value columns (:func:`suspenv.runs.archive.value_columns`): name ->
    (array of :meth:`RunRecord.arrays`, column); none without a matching archive."""
    a = r.arrays()
    return {} if a is None else {c: (key, j) for c, key, j in value_columns(r.meta, a)}


def _hypervolume_progress(recs: Sequence[RunRecord]) -> dict[Path, np.ndarray]:
    """Hypervolume after each evaluation of every run with an archive and 2 to
    :data:`HV_MAX_OBJECTIVES` objectives, per problem against its :func:`reference_front`
    (normalised, reference point 1.1)."""
    by: dict[str, list[RunRecord]] = {}
    for r in recs:
        if 2 <= len(r.objective_names) <= HV_MAX_OBJECTIVES and r.arrays() is not None:
            by.setdefault(r.problem_hash, []).append(r)
    out: dict[Path, np.ndarray] = {}
    for group in by.values():
        try:
            front, _, _ = reference_front(group, None)
        except ValidationError:  # no feasible evaluation anywhere: no front, no volume
            continue
        ideal, nadir = normalisation(front)
        ref = reference_point(front.shape[1])
        for r in group:
            a, feas = r.arrays(), r.feasible()
            assert a is not None and feas is not None
            out[r.path] = hypervolume_curve(normalise(a["objectives"], ideal, nadir), feas, ref)
    return out
