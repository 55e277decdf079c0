"""Finished runs side by side: their summaries, and strategies x seeds compared.

``suspenv show`` and ``suspenv compare`` are the command-line faces;
:mod:`suspenv.methods.strategy_comparison` compares strategies with it.
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

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
    return json.loads(path.read_text())


def compare_runs(runs: Sequence[str | Path], out: str | Path) -> dict[str, Any]:
    """Compare finished runs of one problem, grouped by strategy (several seeds each).

    Writes ``compare.json`` (per strategy: runs, seeds, median evaluations, median / min /
    max of the best quality, median wall time) and ``compare.png`` (median and range of
    the best-so-far curves, :func:`suspenv.reports.run.plot_compare`) into ``out``;
    returns the JSON content.
    """
    summaries = [load_summary(r) for r in runs]
    problems = {s["problem"] for s in summaries}
    if len(problems) > 1:
        raise ValidationError(f"compare needs runs of one problem, but got {sorted(problems)}")
    groups: dict[str, list[dict]] = defaultdict(list)
    for s in summaries:
        groups[s["strategy"]].append(s)
    table = []
    curves = {}
    for strat, ss in groups.items():
        best = np.array(
            [s["best_quality"] if s["best_quality"] is not None else np.nan for s in ss]
        )
        evals = [s["n_evaluations"] for s in ss]
        table.append(
            {
                "strategy": strat,
                "runs": len(ss),
                "seeds": sorted(s["seed"] for s in ss),
                "evaluations": int(np.median(evals)),
                "best_median": float(np.nanmedian(best)),
                "best_min": float(np.nanmin(best)),
                "best_max": float(np.nanmax(best)),
                "wall_time_median_s": float(np.median([s["wall_time_s"] for s in ss])),
            }
        )
        curves[strat] = [
            np.array([np.inf if v is None else v for v in s["quality_curve"]]) for s in ss
        ]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    ylabel = f"best {summaries[0].get('quality_name', 'quality')}"
    report_function("run_comparison")(curves, ylabel, out / "compare.png")
    result = {
        "problem": problems.pop(),
        "quality_name": summaries[0].get("quality_name"),
        "table": table,
    }
    (out / "compare.json").write_text(json.dumps(result, indent=2) + "\n")
    return result
