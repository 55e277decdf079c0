"""Standard run figures: convergence, Pareto front (pairwise), parallel coordinates, and
the best-so-far spread of several runs (``suspenv compare``)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from suspenv.core.pareto import nondominated
from suspenv.reports._mpl import pyplot
from suspenv.runs.optimize_pipeline import best_so_far


def write_run_figures(
    objectives: np.ndarray, feasible: np.ndarray, names: Sequence[str], run_dir: Path
) -> list[Path]:
    """``convergence.png``; with several objectives and more than one feasible evaluation
    also ``pareto_pairs.png`` and ``pareto_parallel.png``. Returns the paths written."""
    run_dir = Path(run_dir)
    figures = [plot_convergence(objectives, feasible, names, run_dir / "convergence.png")]
    if len(names) > 1 and feasible.sum() > 1:
        figures.append(plot_pareto_pairs(objectives, feasible, names, run_dir / "pareto_pairs.png"))
        figures.append(plot_parallel(objectives, feasible, names, run_dir / "pareto_parallel.png"))
    return figures


def plot_convergence(
    objectives: np.ndarray, feasible: np.ndarray, names: Sequence[str], path: Path
) -> Path:
    """Best-so-far of every objective against evaluations (log scale where positive)."""
    plt = pyplot()
    m = objectives.shape[1]
    fig, axes = plt.subplots(1, m, figsize=(4.2 * m, 3.4), squeeze=False)
    n = np.arange(1, objectives.shape[0] + 1)
    for j, ax in enumerate(axes[0]):
        b = best_so_far(objectives[:, j], feasible)
        ax.plot(n, np.where(np.isfinite(b), b, np.nan), lw=1.5)
        ax.set_xlabel("evaluations")
        ax.set_ylabel(f"best {names[j]}")
        if np.all(b[np.isfinite(b)] > 0) and np.isfinite(b).any():
            ax.set_yscale("log")
        ax.grid(alpha=0.3)
    fig.suptitle("Convergence (best feasible so far)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_pareto_pairs(
    objectives: np.ndarray, feasible: np.ndarray, names: Sequence[str], path: Path
) -> Path:
    """Pairwise scatter of all feasible evaluations, non-dominated set highlighted."""
    plt = pyplot()
    F = objectives[feasible]
    m = objectives.shape[1]
    fig, axes = plt.subplots(m, m, figsize=(2.6 * m, 2.6 * m), squeeze=False)
    front = nondominated(F) if len(F) else np.zeros(0, bool)
    for i in range(m):
        for j in range(m):
            ax = axes[i, j]
            if i == j:
                ax.hist(F[:, i], bins=30, color="0.7")
                ax.set_title(names[i], fontsize=8)
            else:
                ax.scatter(F[:, j], F[:, i], s=3, c="0.75", lw=0)
                ax.scatter(F[front, j], F[front, i], s=6, c="tab:red", lw=0)
            ax.tick_params(labelsize=6)
            if i == m - 1:
                ax.set_xlabel(names[j], fontsize=8)
            if j == 0:
                ax.set_ylabel(names[i], fontsize=8)
    fig.suptitle("Feasible evaluations (grey) and non-dominated set (red)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def plot_parallel(
    objectives: np.ndarray,
    feasible: np.ndarray,
    names: Sequence[str],
    path: Path,
    highlight: int | None = None,
) -> Path:
    """Parallel coordinates of the non-dominated set, each objective min-max scaled."""
    plt = pyplot()
    F = objectives[feasible]
    front = F[nondominated(F)] if len(F) else F
    lo, hi = front.min(0), front.max(0)
    S = (front - lo) / np.where(hi > lo, hi - lo, 1.0)
    fig, ax = plt.subplots(figsize=(1.6 * len(names) + 2, 3.6))
    for row in S:
        ax.plot(range(len(names)), row, c="tab:blue", alpha=0.25, lw=0.8)
    if highlight is not None:
        h = (objectives[highlight] - lo) / np.where(hi > lo, hi - lo, 1.0)
        ax.plot(range(len(names)), h, c="tab:red", lw=2.5, label="pick")
        ax.legend()
    ax.set_xticks(range(len(names)), names)
    ax.set_ylabel("scaled objective (0 = best on front)")
    ax.set_title(f"Non-dominated set ({len(front)} designs)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_compare(curves: dict[str, list[np.ndarray]], ylabel: str, path: Path) -> Path:
    """Median and min-max band of best-so-far curves per label (several seeds each)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4))
    for label, runs in curves.items():
        n = min(len(r) for r in runs)
        A = np.vstack([r[:n] for r in runs])
        A = np.where(np.isfinite(A), A, np.nan)
        cols = np.isfinite(A).any(axis=0)  # skip evaluations before any run has a value
        x = np.arange(1, n + 1)[cols]
        A = A[:, cols]
        ax.plot(x, np.nanmedian(A, axis=0), label=f"{label} (n={len(runs)})")
        if len(runs) > 1:
            ax.fill_between(x, np.nanmin(A, axis=0), np.nanmax(A, axis=0), alpha=0.2)
    ax.set_xlabel("evaluations")
    ax.set_ylabel(ylabel)
    finite = [
        np.nanmin(r[np.isfinite(r)]) for rs in curves.values() for r in rs if np.isfinite(r).any()
    ]
    if finite and min(finite) > 0:
        ax.set_yscale("log")
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title("Best so far: median and range over seeds")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
