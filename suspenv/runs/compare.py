"""Finished runs side by side: their summaries, and strategies x seeds compared.

``suspenv show`` and ``suspenv compare`` are the command-line faces;
:mod:`suspenv.methods.tey2014.strategy_comparison` compares strategies with it. The comparison
itself is :mod:`suspenv.analysis` (figures: :mod:`suspenv.reports.analysis`), reached
through the report registry because both sit above this layer.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from suspenv.core.errors import ValidationError
from suspenv.registry import report_function


def load_summary(run_dir: str | Path) -> dict[str, Any]:
    """The ``summary.json`` of a finished run directory."""
    path = Path(run_dir) / "summary.json"
    if not path.is_file():
        raise ValidationError(
            f"{str(run_dir)!r} is not a finished run directory (no summary.json); "
            "a run that died can be resumed with `suspenv run CONFIG`"
        )
    try:
        summary = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError) as exc:
        raise ValidationError(
            f"{str(path)!r} is damaged (not valid JSON: {exc}); restore it from a copy, "
            "or start the run anew with `suspenv run CONFIG --overwrite`"
        ) from None
    if not isinstance(summary, dict):
        raise ValidationError(
            f"{str(path)!r} must hold a JSON object, but holds a {type(summary).__name__}"
        )
    return summary


def compare_runs(runs: Sequence[str | Path], out: str | Path, **options: Any) -> dict[str, Any]:
    """Compare finished runs: groups by full strategy configuration, per problem
    configuration; refuses to pool unlike runs (see ``docs/analysis.md``).

    Writes into ``out``: ``compare.json`` (groups with hash, options, seeds, budgets and
    flags; fixed-budget, fixed-target (ERT) and multi-objective tables; rank tests),
    ``compare.md``, and the figures ``convergence.png`` (also as ``compare.png``),
    ``ecdf.png``, ``fixed_target.png``, ``profile.png`` and, for multi-objective runs,
    ``hypervolume.png``; ``ioh/`` with ``ioh=True``. Returns the JSON content: its
    ``table`` rows keep the fields of the first version (strategy, runs, seeds,
    evaluations, best_median, best_min, best_max, wall_time_median_s).

    ``options`` (keywords of :func:`suspenv.analysis.compare.compare` and
    :func:`suspenv.reports.analysis.write_comparison`): suite, allow_unequal_budgets,
    measure, f_opt, reference_front, targets, n_targets, alpha, figures, ioh.
    """
    # suspenv.reports.analysis.write_comparison, which computes with suspenv.analysis
    # (both sit above runs, so they are reached by name)
    result: dict[str, Any] = report_function("comparison")(runs, out, **options)
    return result
