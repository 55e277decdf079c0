"""Figures of a comparison of runs (``suspenv compare``), as COCO and IOHanalyzer draw them.

- ``convergence.png``: best-so-far against evaluations per group: median, 25-75 % band
  and min-max range over seeds (fixed-budget view); also written as ``compare.png``,
  the name of the first version.
- ``ecdf.png``: runtime ECDF over all (run, target) pairs, evaluations on a log axis.
- ``fixed_target.png``: ERT against target precision.
- ``profile.png``: Dolan-Moré performance profile over (problem, target) instances.
- ``hypervolume.png``: hypervolume of the feasible non-dominated set against evaluations
  (multi-objective problems compared by hypervolume), with the reference front's value.

:func:`write_comparison` is the whole ``suspenv compare``: the computation
(:func:`suspenv.analysis.compare.compare`), ``compare.json`` / ``compare.md`` and these
figures.
"""

from __future__ import annotations

import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.analysis.compare import (
    Comparison,
    ProblemComparison,
    compare,
    write_compare_files,
)
from suspenv.analysis.ioh import write_ioh
from suspenv.analysis.performance import curve_matrix, curve_quantiles, runtime_ecdf
from suspenv.core.jsonable import to_jsonable
from suspenv.reports._mpl import pyplot, save_figure


def _axes(n: int, width: float = 5.2, height: float = 3.8) -> tuple[Any, list[Any]]:
    cols = min(n, 3)
    rows = int(np.ceil(n / cols))
    fig, axes = pyplot().subplots(rows, cols, figsize=(width * cols, height * rows), squeeze=False)
    flat = list(axes.ravel())
    for ax in flat[n:]:
        ax.set_visible(False)
    return fig, flat[:n]


def _log_ok(values: np.ndarray) -> bool:
    v = values[np.isfinite(values)]
    return bool(v.size) and bool((v > 0).all())


def _finish(ax: Any, title: str) -> None:
    """The small title, light grid and legend of every comparison panel."""
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)


def plot_convergence(comparison: Comparison, path: Path) -> Path:
    """Median best-so-far with 25-75 % band and min-max range per group, per problem.
    Quantiles count runs without a feasible value yet as +inf (the median never rises)."""
    fig, axes = _axes(len(comparison.problems))
    for ax, p in zip(axes, comparison.problems, strict=True):
        shown = []
        for g in p.groups:
            M = curve_matrix(g.curves, min(g.lengths()))
            q = curve_quantiles(M)
            x = np.arange(1, M.shape[1] + 1)

            def fin(a: np.ndarray) -> np.ndarray:
                return np.where(np.isfinite(a), a, np.nan)

            (line,) = ax.plot(x, fin(q[0.5]), lw=1.6, label=f"{g.label} (n={len(g.runs)})")
            if len(g.runs) > 1:
                ax.fill_between(x, fin(q[0.25]), fin(q[0.75]), color=line.get_color(), alpha=0.25)
                ax.plot(x, fin(q[0.0]), color=line.get_color(), lw=0.6, ls=":")
                ax.plot(x, fin(q[1.0]), color=line.get_color(), lw=0.6, ls=":")
            shown.append(M)
        allv = np.concatenate([m.ravel() for m in shown]) if shown else np.zeros(0)
        if _log_ok(allv):
            ax.set_yscale("log")
        ax.set(xlabel="evaluations", ylabel=f"best {p.measure_name}")
        _finish(ax, f"{p.name}: median, 25-75 % (band), min-max (dotted)")
    return save_figure(fig, path, tight=True, dpi=110)


def plot_ecdf(comparison: Comparison, path: Path) -> Path:
    """Runtime ECDF per group: fraction of (run, target) pairs reached within x
    evaluations (log axis), like COCO's and IOHanalyzer's."""
    fig, axes = _axes(len(comparison.problems))
    for ax, p in zip(axes, comparison.problems, strict=True):
        top = max(max(g.lengths()) for g in p.groups)
        x = np.unique(np.geomspace(1, max(top, 2), 300).round())
        for g in p.groups:
            y = runtime_ecdf(p.runtimes[g.label], x)
            ax.step(x, y, where="post", label=g.label)
        ax.set_xscale("log")
        ax.set_ylim(-0.02, 1.02)
        ax.set(xlabel="evaluations", ylabel="fraction of (run, target) pairs")
        _finish(ax, f"{p.name}: runtime ECDF, {len(p.targets)} targets")
    return save_figure(fig, path, tight=True, dpi=110)


def plot_fixed_target(comparison: Comparison, path: Path) -> Path:
    """ERT against target (distance to ``f_opt`` when it is known), harder targets right."""
    fig, axes = _axes(len(comparison.problems))
    for ax, p in zip(axes, comparison.problems, strict=True):
        t = p.targets - (p.f_opt or 0.0) if p.f_opt is not None else p.targets
        for g in p.groups:
            e = p.ert[g.label]
            ax.plot(t, np.where(np.isfinite(e), e, np.nan), marker="o", ms=3, label=g.label)
        if _log_ok(t):
            ax.set_xscale("log")
            ax.tick_params(axis="x", which="minor", labelbottom=False)
        if len(t):
            ax.invert_xaxis()
        ert_all = np.concatenate([p.ert[g.label] for g in p.groups]) if p.groups else t
        if _log_ok(ert_all):  # no target reached (every run failed): a linear axis
            ax.set_yscale("log")
        else:
            ax.text(0.5, 0.5, "no target reached", transform=ax.transAxes, ha="center")
        ax.set(
            xlabel="target - f_opt" if p.f_opt is not None else "target", ylabel="ERT (evaluations)"
        )
        _finish(ax, f"{p.name}: expected running time")
    return save_figure(fig, path, tight=True, dpi=110)


def plot_profile(comparison: Comparison, path: Path) -> Path | None:
    """Performance profile rho_s(tau) over (problem, target) instances (ERT ratios)."""
    prof = comparison.profile
    if not prof:
        return None
    fig, ax = pyplot().subplots(figsize=(6.2, 4))
    taus = np.asarray(prof["taus"], dtype=float)
    right = max(2.0, float(taus.max()) * 1.5)
    for name, rho in zip(prof["solvers"], prof["rho"], strict=True):
        ax.step(np.r_[taus, right], np.r_[rho, rho[-1]], where="post", label=name)
    ax.set_xscale("log", base=2)
    ax.set_ylim(-0.02, 1.02)
    ax.set(xlabel="tau (ERT / best ERT)", ylabel="fraction of instances")
    _finish(ax, f"Performance profile: {len(prof['instances'])} (problem, target) instances")
    return save_figure(fig, path, tight=True, dpi=110)


def plot_hypervolume(comparison: Comparison, path: Path) -> Path | None:
    """Hypervolume against evaluations: median and 25-75 % band per group."""
    probs: list[ProblemComparison] = [
        p for p in comparison.problems if any(g.hv_curves for g in p.groups)
    ]
    if not probs:
        return None
    fig, axes = _axes(len(probs))
    for ax, p in zip(axes, probs, strict=True):
        for g in p.groups:
            if not g.hv_curves:
                continue
            n = min(len(c) for c in g.hv_curves)
            M = np.vstack([c[:n] for c in g.hv_curves])
            x = np.arange(1, n + 1)
            (line,) = ax.plot(x, np.median(M, axis=0), label=f"{g.label} (n={len(M)})")
            if len(M) > 1:
                lo, hi = np.quantile(M, [0.25, 0.75], axis=0)
                ax.fill_between(x, lo, hi, color=line.get_color(), alpha=0.25)
        if p.hv_reference is not None:
            ax.axhline(p.hv_reference, color="k", lw=0.8, ls="--", label="reference front")
        ax.set(xlabel="evaluations", ylabel="hypervolume (normalised)")
        _finish(ax, f"{p.name}: hypervolume, median and 25-75 %")
    return save_figure(fig, path, tight=True, dpi=110)


def write_comparison_figures(comparison: Comparison, out: Path) -> list[Path]:
    """Every figure of a comparison into ``out``; returns the paths written."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    convergence = plot_convergence(comparison, out / "convergence.png")
    paths = [
        convergence,
        Path(shutil.copyfile(convergence, out / "compare.png")),
        plot_ecdf(comparison, out / "ecdf.png"),
        plot_fixed_target(comparison, out / "fixed_target.png"),
        plot_profile(comparison, out / "profile.png"),
        plot_hypervolume(comparison, out / "hypervolume.png"),
    ]
    return [p for p in paths if p is not None]  # no profile, no hypervolume: None


def write_comparison(
    runs: Sequence[str | Path],
    out: str | Path,
    figures: bool = True,
    ioh: bool = False,
    **options: Any,
) -> dict[str, Any]:
    """``suspenv compare``: compare the runs (keywords of
    :func:`suspenv.analysis.compare.compare`), write ``compare.json``, ``compare.md``,
    the figures (unless ``figures=False``) and the IOHprofiler export (``ioh=True``) into
    ``out``; returns the content of ``compare.json``."""
    return write_compared(compare(runs, **options), out, figures=figures, ioh=ioh)


def write_compared(
    comparison: Comparison, out: str | Path, figures: bool = True, ioh: bool = False
) -> dict[str, Any]:
    """Write a finished comparison (files, figures, export) into ``out``; returns the
    content of ``compare.json``."""
    out = Path(out)
    written: list[Path] = []
    if ioh:
        written.append(write_ioh(comparison, out / "ioh"))
    if figures:
        written += write_comparison_figures(comparison, out)
    write_compare_files(comparison, out, written)
    result: dict[str, Any] = to_jsonable(comparison.result)
    return result
