"""Export to the IOHprofiler data format that IOHanalyzer reads.

Layout (the JSON format of IOHexperimenter 0.3.x, checked against the files its
``ioh.logger.Analyzer`` writes)::

    ioh/<algorithm>/IOHprofiler_f<id>_<function>.json
    ioh/<algorithm>/data_f<id>_<function>/IOHprofiler_f<id>_DIM<d>.dat

One folder per algorithm (a group: ``strategy[hash]``, safe for file names), one JSON file
per function (a problem configuration: ``<problem>_<hash>``, ids 1, 2, ... in the order
of the comparison), one ``.dat`` file per dimension. The JSON holds ``version``,
``suite`` ("suspenv"), ``function_id``, ``function_name``, ``maximization`` (false),
``algorithm`` ({name, info}: info is the strategy options as JSON), ``attributes``
(["evaluations", "raw_y"]) and ``scenarios``: [{dimension, path, runs: [{instance,
evals, best: {evals, y, x}}]}]. Every run is instance 1 (seeds are repetitions on one
problem instance). A ``.dat`` file holds the runs in order, each starting with the line
``evaluations raw_y`` followed by ``<evaluations> <value>`` at the first evaluation,
at every improvement of the compared measure (its best-so-far) and at the last
evaluation the run used, values in
Python's shortest round-trip form (they parse back to the same float64). A run that
stopped before its budget ends at the evaluations it used, and its ``evals`` says so:
the export is true to each run (``compare`` keeps such a run's best up to the budget
only for its fixed-budget view). Runs with no feasible value are left out
(``compare.json`` lists them).
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from suspenv.analysis.compare import Comparison

#: the IOHexperimenter version whose JSON layout this export follows
FORMAT_VERSION = "0.3.22"
HEADER = "evaluations raw_y"


def safe_name(text: str) -> str:
    """Letters, digits, ``_`` and ``-`` only (a file-name part)."""
    return re.sub(r"[^A-Za-z0-9_-]+", "_", text).strip("_") or "x"


def dat_lines(curve: np.ndarray) -> list[str]:
    """``evaluations value`` lines of one run: the first evaluation (``inf`` when it has no
    feasible value: IOHprofiler's readers start a new run at evaluation 1), each
    improvement of the best-so-far and the last evaluation."""
    c = np.asarray(curve, dtype=float)
    if not np.isfinite(c).any():
        return []
    lines = [] if np.isfinite(c[0]) else [f"1 {float(c[0])!r}"]
    prev = np.inf
    for i, v in enumerate(c):
        if np.isfinite(v) and v < prev:
            lines.append(f"{i + 1} {float(v)!r}")
            prev = v
    if lines and not lines[-1].startswith(f"{c.size} "):
        lines.append(f"{c.size} {float(c[-1])!r}")
    return lines


def write_ioh(comparison: Comparison, folder: str | Path) -> Path:
    """Write the comparison's measure curves in the IOHprofiler format; returns the folder."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for fid, p in enumerate(comparison.problems, start=1):
        fname = safe_name(f"{p.config['problem']}_{p.problem_hash}")
        for g in p.groups:
            algo = folder / safe_name(g.label)
            data_dir = algo / f"data_f{fid}_{fname}"
            data_dir.mkdir(parents=True, exist_ok=True)
            by_dim: dict[int, list[tuple[Any, np.ndarray]]] = {}
            for r, c in zip(g.runs, g.curves, strict=True):
                used = c[: r.evaluations_used]  # not the budget: what the run evaluated
                if np.isfinite(used).any():
                    by_dim.setdefault(int(r.dimension or 0), []).append((r, used))
            scenarios = []
            for dim, items in sorted(by_dim.items()):
                dat = data_dir / f"IOHprofiler_f{fid}_DIM{dim}.dat"
                text, runs = [], []
                for r, c in items:
                    text += [HEADER, *dat_lines(c)]
                    best_i = int(np.argmax(c <= c[-1]))
                    runs.append(
                        {
                            "instance": 1,
                            "evals": int(c.size),
                            "best": {
                                "evals": best_i + 1,
                                "y": float(c[-1]),
                                "x": _best_x(r, best_i, p.measure),
                            },
                        }
                    )
                dat.write_text("\n".join(text) + "\n")
                scenarios.append(
                    {
                        "dimension": dim,
                        "path": dat.relative_to(algo).as_posix(),
                        "runs": runs,
                    }
                )
            meta = {
                "version": FORMAT_VERSION,
                "suite": "suspenv",
                "function_id": fid,
                "function_name": fname,
                "maximization": False,
                "algorithm": {
                    "name": g.label,
                    "info": json.dumps(g.options, sort_keys=True, default=str),
                },
                "attributes": ["evaluations", "raw_y"],
                "scenarios": scenarios,
            }
            (algo / f"IOHprofiler_f{fid}_{fname}.json").write_text(
                json.dumps(meta, indent=1) + "\n"
            )
    return folder


def _best_x(run: Any, index: int, measure: str) -> list[float]:
    """The design of the best evaluation for a scalar quality (none for a hypervolume)."""
    if measure != "quality":
        return []
    a = run.arrays()
    if a is None or index >= len(a["x"]):
        return []
    return [float(v) for v in a["x"][index]]
