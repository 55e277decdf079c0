"""The "best" of a run: the one definition, by the problem's quality measure.

* Feasible (:func:`suspenv.core.result.feasible`): the evaluation succeeded and every
  constraint is <= 0 (NaN is a violation).
* Quality: :meth:`suspenv.core.problem.Problem.quality` (lower is better): the objective
  itself for one objective; None for several, unless the problem defines a scalar of its
  own. Several objectives in their own units have no scalar best (a sum would weigh them
  by accident of unit): a multi-objective run is reported by its front
  (:func:`front_size`) and compared by hypervolume (:mod:`suspenv.analysis.compare`).
* Shown in a report: the best (or the front) of the feasible evaluations, of the
  successful ones when none is feasible (:func:`shown_rows`).
* Best so far: the running minimum of the quality over feasible evaluations with a
  finite quality, +inf before the first: "no value yet" is the worst value, as
  IOHexperimenter and COCO start a minimisation's best-so-far (pandas' ``cummin``
  instead leaves NaN at every missing row), so quantiles over runs never rise
  (:mod:`suspenv.analysis.performance`). Summaries store it as None before the first
  (:func:`curve_items`); figures draw nothing there. The best row is the first that
  attains it.

The run loop's bookkeeping, the run summary (``best_quality``, ``quality_curve``,
``best_*``, ``front_size``), the Tey 2014 study, ``suspenv show``, ``tidy``, ``compare``
and the reports all read these.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from suspenv.core.result import feasible  # the rule, shared with EvaluationBatch.feasible

#: quality names of a plain sum of several objectives, as recorded by runs written before
#: this definition (the problem base class's and the minibus problem's; KCIdentification's
#: before its RMS in standard errors): such a recorded quality is never shown as a "best"
#: (:func:`scalar_recorded`)
SUM_QUALITIES = frozenset({"objective (sum if several)", "sum of objectives"})


def scalar_recorded(quality_name: str | None, n_objectives: int) -> bool:
    """Whether a run's recorded quality (its summary's ``quality_name``) is a scalar best:
    always for one objective; for several, only a quality that is not a plain sum."""
    return n_objectives <= 1 or bool(quality_name) and quality_name not in SUM_QUALITIES


def quality(problem: Any, F: np.ndarray) -> np.ndarray | None:
    """The problem's quality of each row of ``F`` (n, m), or None when it has none."""
    q = problem.quality(np.asarray(F, dtype=float).reshape(-1, problem.n_objectives))
    return None if q is None else np.asarray(q, dtype=float)


def best_so_far(values: np.ndarray, feasible: np.ndarray | None = None) -> np.ndarray:
    """Running minimum over evaluations of the finite ``values`` (n,) in ``feasible`` rows
    (every row when None); +inf before the first."""
    keep = np.isfinite(values) if feasible is None else feasible & np.isfinite(values)
    return np.minimum.accumulate(np.where(keep, values, np.inf))


def curve_items(curve: np.ndarray) -> dict[str, Any]:
    """The run summary's "best" of a best-so-far ``curve`` (n,): ``quality_curve`` (None
    before the first finite value, as JSON has no infinity) and ``best_quality`` (its
    last value; None without one)."""
    stored = [float(v) if np.isfinite(v) else None for v in curve]
    return {"best_quality": stored[-1] if stored else None, "quality_curve": stored}


def quality_curve(problem: Any, arrays: dict[str, np.ndarray]) -> np.ndarray | None:
    """Best-so-far quality after each archived evaluation (None: no scalar quality)."""
    q = quality(problem, arrays["objectives"])
    if q is None:
        return None
    return best_so_far(q, feasible(arrays["ok"], arrays["constraints"]))


def best_row(q: np.ndarray, feasible: np.ndarray) -> int | None:
    """Index of the first feasible row with the least finite quality ``q`` (None: none)."""
    v = np.where(feasible & np.isfinite(q), q, np.inf)
    if not v.size or not np.isfinite(v.min()):
        return None
    return int(v.argmin())


def shown_rows(ok: np.ndarray, feasible: np.ndarray) -> np.ndarray:
    """The evaluations a report draws its best design or front from: the feasible ones,
    or the successful ones (``ok``) when none is feasible (the report then says so)."""
    return feasible if feasible.any() else ok


def front_size(F: np.ndarray, feasible: np.ndarray) -> int:
    """Feasible evaluations with finite objectives that no other such evaluation dominates."""
    from suspenv.core.pareto import nondominated  # pymoo: only where a front is counted

    return int(nondominated(F, feasible).sum()) if len(F) else 0
