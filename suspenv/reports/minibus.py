"""Run report of the minibus ride and handling study (:mod:`suspenv.problems.minibus`).

``minibus_report.md``: the Pareto front's size, the ride-focused pick
(:func:`~suspenv.problems.minibus.ride_focused_pick`) against the baseline and the study's
pick (objectives and variables), ``minibus_pareto_pairs.png`` and
``minibus_parallel.png``, and the suspension report of the three designs
(:mod:`suspenv.reports.suspension`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.problem import Problem
from suspenv.models.minibus.vehicle import BASELINE_DESIGN, STUDY_PICK
from suspenv.problems.minibus import MinibusRideHandling, study_outcome
from suspenv.reports._mpl import add_polylines, pyplot, save_figure
from suspenv.reports.suspension import write_suspension_report
from suspenv.runs.run_dir import write_file


def write_minibus_run_report(
    problem: MinibusRideHandling, run_dir: Path, archive: Any
) -> list[Path]:
    """:func:`write_minibus_report` from a run archive (the problem's ``write_report``)."""
    return write_minibus_report(problem, Path(run_dir), archive.arrays())


def _plot_pairs(
    F: np.ndarray,
    ok: np.ndarray,
    front: np.ndarray,
    marks: dict[str, np.ndarray],
    names: tuple[str, ...],
    path: Path,
) -> Path:
    plt = pyplot()
    m = F.shape[1]
    fig = plt.figure(figsize=(2.4 * (m - 1), 2.4 * (m - 1)))
    colours = ("k", "tab:red", "tab:green", "tab:purple")
    for r in range(1, m):
        for c in range(r):
            ax = fig.add_subplot(m - 1, m - 1, (r - 1) * (m - 1) + c + 1)
            ax.scatter(F[ok, c], F[ok, r], s=2, c="0.8", rasterized=True)
            ax.scatter(F[front, c], F[front, r], s=4, c="tab:blue", rasterized=True)
            for (label, f), col in zip(marks.items(), colours, strict=False):
                ax.scatter(f[c], f[r], marker="*", s=90, c=col, label=label, zorder=5)
            if r == m - 1:
                ax.set_xlabel(names[c], fontsize=8)
            if c == 0:
                ax.set_ylabel(names[r], fontsize=8)
            ax.tick_params(labelsize=7)
    handles, labels = fig.axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper right")
    fig.suptitle("Pareto front (blue) among successful evaluations (grey)")
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.07, top=0.94, wspace=0.35, hspace=0.3)
    return save_figure(fig, path, dpi=100)


def _plot_parallel(
    F: np.ndarray,
    X: np.ndarray,
    front: np.ndarray,
    marks: dict[str, tuple[np.ndarray, np.ndarray]],
    problem: Problem,
    path: Path,
) -> Path:
    plt = pyplot()
    lo = np.nanmin(F[front], axis=0)
    hi = np.nanmax(F[front], axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    fig, axes = plt.subplots(1, 2, figsize=(14, 4.5), gridspec_kw={"width_ratios": [5, 8]})
    Fn = (F[front] - lo) / span
    Un = problem.space.to_unit(X[front])
    add_polylines(axes[0], Fn, colors="tab:blue", alpha=0.08, lw=0.7)
    add_polylines(axes[1], Un, colors="tab:blue", alpha=0.08, lw=0.7)
    colours = ("k", "tab:red", "tab:green", "tab:purple")
    for (label, (f, x)), col in zip(marks.items(), colours, strict=False):
        axes[0].plot(np.arange(F.shape[1]), (f - lo) / span, c=col, lw=2.2, label=label)
        axes[1].plot(np.arange(X.shape[1]), problem.space.to_unit(x)[0], c=col, lw=2.2, label=label)
    axes[0].set_xticks(range(F.shape[1]), problem.objective_names, rotation=20, fontsize=8)
    axes[0].set_ylabel("objective, 0 = best on front, 1 = worst")
    axes[1].set_xticks(range(X.shape[1]), problem.space.names)
    axes[1].set_ylabel("design variable, 0 = range min, 1 = max")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    fig.suptitle("Parallel coordinates of the Pareto front")
    fig.subplots_adjust(left=0.06, right=0.99, bottom=0.18, top=0.9, wspace=0.15)
    return save_figure(fig, path, dpi=100)


def write_minibus_report(
    problem: MinibusRideHandling, run_dir: Path, arrays: dict[str, np.ndarray]
) -> list[Path]:
    """Write the minibus report files into ``run_dir`` from archive arrays; return paths."""
    run_dir.mkdir(parents=True, exist_ok=True)
    found = study_outcome(problem, arrays)
    if found is None:
        return []
    F, X, ok, feasible, front, pick = (
        found.F,
        found.X,
        found.ok,
        found.feasible,
        found.front,
        found.pick,
    )
    refs = {"baseline": BASELINE_DESIGN, "study pick": STUDY_PICK}
    F_refs = {
        "baseline": found.baseline,
        "study pick": problem.evaluate(np.atleast_2d(STUDY_PICK)).objectives[0],
    }
    names = problem.objective_names
    marks_f = {**F_refs, "ride-focused pick": F[pick]}
    marks_fx = {k: (F_refs[k], refs[k]) for k in refs}
    marks_fx["ride-focused pick"] = (F[pick], X[pick])
    pairs = _plot_pairs(F, ok, front, marks_f, names, run_dir / "minibus_pareto_pairs.png")
    par = _plot_parallel(F, X, front, marks_fx, problem, run_dir / "minibus_parallel.png")
    designs = {"baseline": BASELINE_DESIGN, "study pick": STUDY_PICK, "ride-focused pick": X[pick]}
    susp = write_suspension_report(designs, run_dir, problem.vehicle)
    units = problem.objective_units
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
        "| objective | unit | baseline | study pick | ride-focused pick |",
        "|---|---|---|---|---|",
    ]
    for j, name in enumerate(names):
        lines.append(
            f"| {name} | {units[j]} | {F_refs['baseline'][j]:.4g} | "
            f"{F_refs['study pick'][j]:.4g} | {F[pick, j]:.4g} |"
        )
    lines += [
        "",
        "| variable | unit | baseline | study pick | ride-focused pick |",
        "|---|---|---|---|---|",
    ]
    for j, p in enumerate(problem.space.parameters):
        lines.append(
            f"| {p.name} | {p.unit} | {BASELINE_DESIGN[j]:.4g} | {STUDY_PICK[j]:.4g} | "
            f"{X[pick, j]:.4g} |"
        )
    lines += [
        "",
        f"![Pareto front, pairs]({pairs.name})",
        "",
        f"![Pareto front, parallel coordinates]({par.name})",
        "",
        "Suspension report before/after: [suspension_report.md](suspension_report.md).",
        "",
    ]
    md = run_dir / "minibus_report.md"
    write_file(md, "\n".join(lines))
    return [md, pairs, par, *susp]
