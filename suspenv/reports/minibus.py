"""Run report of the minibus ride and handling study (:mod:`suspenv.problems.minibus`).

``minibus_report.md``: the Pareto front's size, the ride-focused pick
(:func:`~suspenv.problems.minibus.ride_focused_pick`) against the baseline and the study's
pick (objectives and variables), and the suspension report of the three designs
(:mod:`suspenv.reports.suspension`). With figures (the run's ``plots``, default true):
``minibus_parallel.png`` (objectives and variables of the front, the three designs
marked), ``suspension_elements.png``, and a link to the run's own pair plot
``pareto_pairs.png`` (:func:`suspenv.reports.run.write_run_figures`: the same picture
without the marks, so it is not drawn twice). Without figures nothing is drawn and
matplotlib is not imported.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.atomic import write_file
from suspenv.core.markdown import table_lines
from suspenv.models.minibus.vehicle import BASELINE_DESIGN, STUDY_PICK
from suspenv.problems.minibus import MinibusRideHandling, StudyOutcome, study_outcome
from suspenv.reports.run import plot_parallel
from suspenv.reports.suspension import write_suspension_report
from suspenv.runs.config import plots_wanted
from suspenv.runs.quality import shown_rows


def write_minibus_run_report(
    problem: MinibusRideHandling, run_dir: Path, archive: Any
) -> list[Path]:
    """:func:`write_minibus_report` from a run archive (the problem's ``write_report``),
    with figures unless the run's config (kept in the archive's meta) has ``plots =
    false``."""
    plots = plots_wanted(archive.meta().get("config") or {})
    return write_minibus_report(problem, Path(run_dir), archive.arrays(), plots=plots)


def write_minibus_report(
    problem: MinibusRideHandling, run_dir: Path, arrays: dict[str, np.ndarray], plots: bool = True
) -> list[Path]:
    """Write the minibus report files into ``run_dir`` from archive arrays; return paths.
    ``plots``: draw the figures (the module docstring); False: the Markdown files only."""
    run_dir.mkdir(parents=True, exist_ok=True)
    found = study_outcome(problem, arrays)
    if found is None:
        return []
    F_refs = {
        "baseline": found.baseline,
        "study pick": problem.evaluate(np.atleast_2d(STUDY_PICK)).objectives[0],
    }
    F, X, pick = found.F, found.X, found.pick
    designs = {"baseline": BASELINE_DESIGN, "study pick": STUDY_PICK, "ride-focused pick": X[pick]}
    figures: list[Path] = []
    links: list[str] = []
    if plots:
        figures = [_parallel_figure(problem, found, F_refs, run_dir)]
        pairs = run_dir / "pareto_pairs.png"  # the run's, when it drew one
        if pairs.exists():
            links.append(f"![Pareto front, pairs (the run's figure)]({pairs.name})")
        links.append(f"![Pareto front, parallel coordinates]({figures[0].name})")
    susp = write_suspension_report(designs, run_dir, problem.vehicle, plots=plots)
    ok, feasible, front = found.ok, found.feasible, found.front
    names, units = problem.objective_names, problem.objective_units
    lines = [
        "# Minibus ride and handling: results",
        "",
        f"{int(ok.sum())} successful evaluations of {len(ok)}, {int(feasible.sum())} feasible, "
        f"{int(front.sum())} on the Pareto front"
        + ("" if feasible.any() else " (no feasible design: front of successful ones)")
        + ".",
        f"Options: {problem.config()}.",
        "",
        "**Ride-focused pick.** Among the Pareto designs whose handling objectives f3, f4 "
        "and f5 are each no worse than the baseline's (centre of every range), the one with "
        "the smallest ride score f1/f1_baseline + f2/f2_baseline; if none keeps the baseline "
        "handling, the smallest ride score on the whole front.",
        "",
        *table_lines(
            ["objective", "unit", "baseline", "study pick", "ride-focused pick"],
            (
                [name, unit, *(f"{v:.4g}" for v in values)]
                for name, unit, *values in zip(
                    names, units, F_refs["baseline"], F_refs["study pick"], F[pick], strict=True
                )
            ),
        ),
        "",
        *table_lines(
            ["variable", "unit", "baseline", "study pick", "ride-focused pick"],
            (
                [p.name, p.unit, *(f"{v:.4g}" for v in values)]
                for p, *values in zip(
                    problem.space.parameters, BASELINE_DESIGN, STUDY_PICK, X[pick], strict=True
                )
            ),
        ),
        "",
        *(line for link in links for line in (link, "")),
        "Suspension report before/after: [suspension_report.md](suspension_report.md).",
        "",
    ]
    md = write_file(run_dir / "minibus_report.md", "\n".join(lines))
    return [md, *figures, *susp]


def _parallel_figure(
    problem: MinibusRideHandling,
    found: StudyOutcome,
    F_refs: dict[str, np.ndarray],
    run_dir: Path,
) -> Path:
    """The Pareto front in parallel coordinates of objectives and variables, the
    baseline and the study's pick (``F_refs``: their objectives) marked as extra rows,
    not drawn with the front, and the ride-focused pick marked."""
    F, X, front, pick = found.F, found.X, found.front, found.pick
    pool = shown_rows(found.ok, found.feasible)  # the evaluations the front is taken from
    n = len(F)
    F_all = np.vstack([F, *F_refs.values()])
    U_all = problem.space.to_unit(np.vstack([X, BASELINE_DESIGN, STUDY_PICK]))
    return plot_parallel(
        F_all,
        np.concatenate([pool, [False, False]]),
        problem.objective_names,
        run_dir / "minibus_parallel.png",
        front=front[pool],
        marks={"baseline": n, "study pick": n + 1, "ride-focused pick": int(pick)},
        designs=(U_all, problem.space.names),
    )
