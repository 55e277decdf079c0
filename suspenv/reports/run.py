"""Standard run figures: convergence, Pareto front (pairwise), parallel coordinates
(runs compared are drawn by :mod:`suspenv.reports.analysis`).

The default figures scale with the number of objectives ``m`` and of evaluations ``n``:

* ``convergence.png``: one panel per objective; up to 5 objectives in one row, more in a
  grid of :data:`CONVERGENCE_COLUMNS` columns.
* ``pareto_pairs.png``: pairwise scatter of the feasible evaluations with the
  non-dominated set (over all m objectives) highlighted. Above
  :data:`MAX_PAIR_OBJECTIVES` (8) objectives a pair plot of all of them is unreadable
  and costly (40 objectives: 1600 panels, 10400 x 10400 px, 94 s and 1.6 GB), so it
  shows the 8 objectives with the largest relative spread
  ``(P90 - P10) / (|P50| + P90 - P10)`` over the feasible evaluations (unit-free; ties:
  the first in order), and a note says so.
* ``pareto_parallel.png``: parallel coordinates of the non-dominated set over all
  objectives (one line collection; labels turned upright above 8 objectives).
* Above :data:`MAX_POINTS` (5000) rows a scatter or parallel plot draws a subsample:
  ``numpy.random.default_rng(SUBSAMPLE_SEED)`` picks :data:`MAX_POINTS` rows without
  replacement (histograms and the non-dominated set itself use every row); the title
  and a note say so.
* No figure exceeds :data:`MAX_PIXELS` pixels on a side (the dpi is lowered instead).

:func:`write_run_figures` reports what it is about to draw through ``progress`` and
appends these notes to ``notes`` (the optimize pipeline prints the first when drawing
takes long and stores the second in ``summary.json``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.pareto import nondominated
from suspenv.reports._mpl import add_polylines, pyplot, save_figure
from suspenv.runs.quality import best_so_far

#: above this many objectives the pair plot shows this many (largest relative spread)
MAX_PAIR_OBJECTIVES = 8
#: scatter points / parallel-coordinate lines drawn at most (a seeded subsample above)
MAX_POINTS = 5000
#: seed of that subsample (``numpy.random.default_rng``)
SUBSAMPLE_SEED = 0
#: no figure is larger than this many pixels on either side
MAX_PIXELS = 4000
#: columns of the convergence grid above 5 objectives
CONVERGENCE_COLUMNS = 8
#: colours of the marked designs (``marks``), in order
MARK_COLOURS = ("k", "tab:orange", "tab:green", "tab:purple")

Progress = Callable[[str], None]


def write_run_figures(
    objectives: np.ndarray,
    feasible: np.ndarray,
    names: Sequence[str],
    run_dir: Path,
    progress: Progress | None = None,
    notes: list[str] | None = None,
) -> list[Path]:
    """``convergence.png``; with several objectives and more than one feasible evaluation
    also ``pareto_pairs.png`` and ``pareto_parallel.png``. Returns the paths written.

    ``progress(text)`` is called before each figure with what it draws; ``notes`` (a list)
    receives a sentence for everything left out or subsampled, and why."""
    run_dir = Path(run_dir)
    say = progress or (lambda text: None)
    notes = notes if notes is not None else []
    objectives = np.asarray(objectives, dtype=float)
    feasible = np.asarray(feasible, dtype=bool)
    m, n = objectives.shape[1], objectives.shape[0]
    say(f"convergence.png ({m} panels, {n} evaluations)")
    figures = [plot_convergence(objectives, feasible, names, run_dir / "convergence.png")]
    if m > 1 and feasible.sum() > 1:
        F = objectives[feasible]
        front = nondominated(F)
        keep = pair_objectives(F)
        if len(keep) < m:
            notes.append(
                f"pareto_pairs.png shows {len(keep)} of the {m} objectives, those with the "
                "largest relative spread (P90 - P10) / (|P50| + P90 - P10): "
                f"{', '.join(names[j] for j in keep)}; a pair plot of all {m} would have "
                f"{m * m} panels (about {260 * m} x {260 * m} px); pareto_parallel.png "
                f"shows all {m}"
            )
        limit = MAX_POINTS
        for what, count, whose in (
            ("pareto_pairs.png", len(F), "feasible evaluations"),
            ("pareto_parallel.png", int(front.sum()), "designs of the non-dominated set"),
        ):
            if count > limit:
                notes.append(
                    f"{what} draws {limit} of the {count} {whose} (seeded subsample, "
                    f"numpy.random.default_rng({SUBSAMPLE_SEED})); the non-dominated set is "
                    "computed from all feasible evaluations"
                )
        say(f"pareto_pairs.png ({len(keep)} x {len(keep)} panels, {min(len(F), limit)} points)")
        figures.append(
            plot_pareto_pairs(
                objectives, feasible, names, run_dir / "pareto_pairs.png", keep, front
            )
        )
        say(f"pareto_parallel.png ({m} axes, {min(int(front.sum()), limit)} lines)")
        figures.append(
            plot_parallel(objectives, feasible, names, run_dir / "pareto_parallel.png", front=front)
        )
    return figures


def pair_objectives(F: np.ndarray) -> list[int]:
    """Columns of F (n, m) the pair plot shows: all when m <= :data:`MAX_PAIR_OBJECTIVES`,
    else the :data:`MAX_PAIR_OBJECTIVES` with the largest relative spread
    ``(P90 - P10) / (|P50| + P90 - P10)`` over the finite values (unit-free, in [0, 1]; a
    constant column 0), in their original order."""
    m = F.shape[1]
    if m <= MAX_PAIR_OBJECTIVES:
        return list(range(m))
    spread = np.zeros(m)
    for j in range(m):
        col = F[np.isfinite(F[:, j]), j]
        if col.size:
            p10, p50, p90 = np.percentile(col, [10.0, 50.0, 90.0])
            width = p90 - p10
            spread[j] = width / (abs(p50) + width) if width > 0 else 0.0
    order = np.argsort(-spread, kind="stable")[:MAX_PAIR_OBJECTIVES]
    return sorted(int(j) for j in order)


def subsample(rows: np.ndarray, limit: int | None = None) -> np.ndarray:
    """``rows`` (indices) when at most ``limit`` (default :data:`MAX_POINTS`), else ``limit``
    of them drawn without replacement by ``numpy.random.default_rng(SUBSAMPLE_SEED)``, in
    order."""
    limit = MAX_POINTS if limit is None else limit
    rows = np.asarray(rows)
    if rows.size <= limit:
        return rows
    rng = np.random.default_rng(SUBSAMPLE_SEED)
    return np.sort(rng.choice(rows, size=limit, replace=False))


def _save(fig: Any, path: Path, dpi: float, tight: bool = False) -> Path:
    """Save and close (:func:`~suspenv.reports._mpl.save_figure`) at ``dpi``, lowered so
    that neither side exceeds :data:`MAX_PIXELS`."""
    return save_figure(fig, path, tight, dpi=min(dpi, MAX_PIXELS / max(fig.get_size_inches())))


def plot_convergence(
    objectives: np.ndarray, feasible: np.ndarray, names: Sequence[str], path: Path
) -> Path:
    """Best-so-far of every objective against evaluations (log scale where positive);
    one row up to 5 objectives, a grid of :data:`CONVERGENCE_COLUMNS` columns above."""
    m = objectives.shape[1]
    if m <= 5:
        rows, cols, size = 1, m, (4.2, 3.4)
    else:
        cols = min(CONVERGENCE_COLUMNS, m)
        rows, size = math.ceil(m / cols), (3.0, 2.4)
    grid = rows > 1
    fig, axes = pyplot().subplots(
        rows, cols, figsize=(size[0] * cols, size[1] * rows), squeeze=False, sharex=grid
    )
    n = np.arange(1, objectives.shape[0] + 1)
    for j, ax in enumerate(axes.flat):
        if j >= m:
            ax.set_visible(False)
            continue
        b = best_so_far(objectives[:, j], feasible)
        ax.plot(n, np.where(np.isfinite(b), b, np.nan), lw=1.5)
        if np.all(b[np.isfinite(b)] > 0) and np.isfinite(b).any():
            ax.set_yscale("log")
        if grid:  # small panels: title instead of axis labels, no minor ticks (cost)
            ax.set_title(f"best {names[j]}", fontsize=7)
            ax.tick_params(labelsize=6)
            ax.minorticks_off()
            if j >= m - cols:
                ax.set_xlabel("evaluations", fontsize=7)
                ax.xaxis.set_tick_params(labelbottom=True)
        else:
            ax.set_xlabel("evaluations")
            ax.set_ylabel(f"best {names[j]}")
        ax.grid(alpha=0.3)
    fig.suptitle("Convergence (best feasible so far)")
    if grid:  # fixed margins: tight_layout would lay out every tick label twice
        fig.subplots_adjust(
            left=0.04,
            right=0.99,
            bottom=0.5 / (size[1] * rows),
            top=1 - 0.75 / (size[1] * rows),
            wspace=0.35,
            hspace=0.45,
        )
    return _save(fig, path, 110, tight=not grid)


def plot_pareto_pairs(
    objectives: np.ndarray,
    feasible: np.ndarray,
    names: Sequence[str],
    path: Path,
    columns: Sequence[int] | None = None,
    front: np.ndarray | None = None,
) -> Path:
    """Pairwise scatter of the feasible evaluations, non-dominated set (over all
    objectives) highlighted; ``columns``: the objectives shown (default all); ``front``:
    the non-dominated mask over the feasible rows when already known. Above
    :data:`MAX_POINTS` rows the scatter draws a seeded subsample (see :func:`subsample`)."""
    F = objectives[feasible]
    cols = list(range(objectives.shape[1])) if columns is None else list(columns)
    k = len(cols)
    if front is None:
        front = nondominated(F) if len(F) else np.zeros(0, bool)
    grey = subsample(np.arange(len(F)))
    red = subsample(np.flatnonzero(front))
    # a column shows one objective on x in every row (the diagonal's histogram too)
    fig, axes = pyplot().subplots(k, k, figsize=(2.6 * k, 2.6 * k), squeeze=False, sharex="col")
    for a, i in enumerate(cols):
        for b, j in enumerate(cols):
            ax = axes[a, b]
            if a == b:
                ax.hist(F[:, i], bins=30, color="0.7")
                ax.set_title(names[i], fontsize=8)
            else:
                ax.scatter(F[grey, j], F[grey, i], s=3, c="0.75", lw=0)
                ax.scatter(F[red, j], F[red, i], s=6, c="tab:red", lw=0)
            ax.tick_params(labelsize=6)
            if a == k - 1:
                ax.set_xlabel(names[j], fontsize=8)
            if b == 0:
                ax.set_ylabel(names[i], fontsize=8)
    title = "Feasible evaluations (grey) and non-dominated set (red)"
    if k < objectives.shape[1]:
        title += f": {k} of {objectives.shape[1]} objectives (largest relative spread)"
    if len(grey) < len(F):
        title += f"; {len(grey)} of {len(F)} evaluations drawn (seeded subsample)"
    fig.suptitle(title, fontsize=10 if k > 3 else None)
    side = 2.6 * k  # fixed margins in inches: tight_layout would lay out every label twice
    fig.subplots_adjust(
        left=0.75 / side,
        right=1 - 0.15 / side,
        bottom=0.6 / side,
        top=1 - 0.7 / side,
        wspace=0.35,
        hspace=0.3,
    )
    return _save(fig, path, 100)


def plot_parallel(
    objectives: np.ndarray,
    feasible: np.ndarray,
    names: Sequence[str],
    path: Path,
    front: np.ndarray | None = None,
    marks: Mapping[str, int] | None = None,
    designs: tuple[np.ndarray, Sequence[str]] | None = None,
) -> Path:
    """Parallel coordinates of the non-dominated set, each objective min-max scaled over it
    (at most :data:`MAX_POINTS` lines: a seeded subsample above); ``front``: the
    non-dominated mask over the feasible rows when already known; ``marks``: label -> row
    of ``objectives`` drawn as a thick line (:data:`MARK_COLOURS`); ``designs``: the
    unit-cube designs of every row (n, d) and the variables' names, drawn in a second
    panel (0 = range min, 1 = max)."""
    rows = np.flatnonzero(feasible)
    if front is None:
        front = nondominated(objectives[rows]) if len(rows) else np.zeros(0, bool)
    rows = rows[front]
    lo, hi = objectives[rows].min(0), objectives[rows].max(0)
    span = np.where(hi > lo, hi - lo, 1.0)
    drawn = subsample(rows)
    m = len(names)
    many = m > MAX_PAIR_OBJECTIVES
    width = min(0.5 * m + 2, 24.0) if many else 1.6 * m + 2
    panels = [((objectives - lo) / span, names, "scaled objective (0 = best on front)")]
    if designs is not None:
        panels.append((designs[0], designs[1], "design variable, 0 = range min, 1 = max"))
        width += 1.2 * len(designs[1])
    fig, axes = pyplot().subplots(
        1,
        len(panels),
        figsize=(width, 5.0 if many else 3.6),
        squeeze=False,
        gridspec_kw={"width_ratios": [len(p[1]) for p in panels]},
    )
    for ax, (values, labels, ylabel) in zip(axes[0], panels, strict=True):
        add_polylines(ax, values[drawn], colors="tab:blue", alpha=0.25, lw=0.8)
        for (label, row), colour in zip((marks or {}).items(), MARK_COLOURS, strict=False):
            ax.plot(range(len(labels)), values[row], c=colour, lw=2.2, label=label)
        ax.set_xlim(-0.2, len(labels) - 0.8)
        if not marks:  # marked designs may lie off the front's range
            ax.set_ylim(-0.05, 1.05)
        if len(labels) > MAX_PAIR_OBJECTIVES:
            ax.set_xticks(range(len(labels)), labels, rotation=90, fontsize=7)
        else:
            ax.set_xticks(range(len(labels)), labels)
        ax.set_ylabel(ylabel)
        if marks:
            ax.legend(fontsize=8, loc="upper right")
    title = f"Non-dominated set ({len(rows)} designs)"
    if len(drawn) < len(rows):
        title += f"; {len(drawn)} drawn (seeded subsample)"
    fig.suptitle(title)
    return _save(fig, path, 110, tight=True)
