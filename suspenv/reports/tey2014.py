"""Markdown report with PNG figures for a Tey et al. (2014) study.

``write_tey2014_report(study, run_dir)`` writes ``report.md`` and ``figures/*.png``: sensitivity
heat map, dendrogram, silhouette against the number of clusters, convergence,
rank-sum versus Euclidean winners, measured vs initial vs identified curves (when the
problem provides them), parameter profiles and recovery errors (when the truth is known),
and the tables (cophenetic correlations, clusters, Table 1, Table 2, identifiability).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.cluster import hierarchy

from suspenv.core.atomic import write_file
from suspenv.core.markdown import markdown_table
from suspenv.methods.tey2014.pipeline import PAPER_REFERENCE, study_summary
from suspenv.reports._mpl import pyplot, save_cropped
from suspenv.runs.quality import best_so_far

if TYPE_CHECKING:
    from suspenv.methods.tey2014.pipeline import RunArrays, Tey2014Study


# ---------------------------------------------------------------- figures


def plot_sensitivity(study: Tey2014Study, path: Path) -> Path:
    s = study.sensitivity
    R = s.rho_significant
    d, m = R.shape
    fig, ax = pyplot().subplots(figsize=(max(6, 0.22 * m + 3), max(4, 0.2 * d + 2)))
    im = ax.imshow(R, cmap="RdBu_r", vmin=-1, vmax=1, aspect="auto")
    ax.set_xticks(range(m), s.objective_names, rotation=90, fontsize=6)
    ax.set_yticks(range(d), s.param_names, fontsize=6)
    for j in study.kept:
        ax.get_xticklabels()[j].set_fontweight("bold")
    ax.set_title(f"Spearman rank correlation (p > {s.alpha:g} shown as 0; n = {s.n_samples})")
    fig.colorbar(im, ax=ax, shrink=0.8, label="rho")
    return save_cropped(fig, path)


def plot_dendrogram(study: Tey2014Study, path: Path) -> Path:
    c, sel = study.clustering, study.selection
    Z = c.linkage
    k = sel.k
    m = Z.shape[0] + 1
    # a threshold between the merge heights that leave exactly k clusters
    h = np.sort(Z[:, 2])
    thr = 0.5 * (h[m - k - 1] + h[m - k]) if 0 < k < m else h[-1]
    labels = [("* " if i in study.kept else "") + n for i, n in enumerate(c.names)]
    fig, ax = pyplot().subplots(figsize=(max(6, 0.25 * m + 2), 4.5))
    hierarchy.dendrogram(Z, labels=labels, color_threshold=thr, ax=ax, leaf_font_size=6)
    ax.axhline(thr, color="k", ls=":", lw=0.8)
    ax.set_ylabel("Euclidean distance of Spearman vectors")
    ax.set_title(
        f"{c.method} linkage (cophenetic {c.cophenetic[c.method]:.3f}); {k} clusters, * = kept"
    )
    return save_cropped(fig, path)


def plot_silhouette(study: Tey2014Study, path: Path) -> Path:
    sel = study.selection
    fig, ax = pyplot().subplots(figsize=(6.5, 3.8))
    ax.plot(sel.n_clusters, sel.mean_silhouette, "o-", ms=3, label="mean silhouette")
    ax.set_xlabel("number of clusters")
    ax.set_ylabel("mean silhouette")
    ax2 = ax.twinx()
    ax2.plot(sel.n_clusters, sel.rank_score, "s--", ms=3, color="tab:red", label="RS + RC")
    ax2.set_ylabel("RS + RC (rank method)", color="tab:red")
    ax.axvline(sel.k_silhouette, color="tab:blue", ls=":", lw=1)
    ax.axvline(sel.k_rank, color="tab:red", ls=":", lw=1)
    ax.set_title(f"best silhouette at k = {sel.k_silhouette}; rank method k = {sel.k_rank}")
    return save_cropped(fig, path)


def _run_curve(run: RunArrays, quality, cols: list[int] | None) -> tuple[np.ndarray, np.ndarray]:
    F = run.objectives if cols is None else run.objectives[:, cols]
    tot = np.where(run.valid, quality(F), np.nan)
    best = best_so_far(tot)
    return tot, np.where(np.isfinite(best), best, np.nan)  # nothing drawn before the first


def plot_convergence(study: Tey2014Study, path: Path) -> Path:
    kept = study.kept
    q = study.quality.subset(kept)
    fig, ax = pyplot().subplots(figsize=(6.5, 4))
    tot, best = _run_curve(study.cmaes, q, None)  # the CMA-ES archive holds the kept columns
    n = np.arange(1, tot.size + 1)
    ax.plot(n, tot, ".", ms=2, color="0.7", label="each CMA-ES evaluation")
    ax.plot(n, best, color="tab:blue", label="CMA-ES on kept objectives: best so far")
    if study.all_objectives is not None:
        _, best_all = _run_curve(study.all_objectives, q, kept)
        ax.plot(
            np.arange(1, best_all.size + 1),
            best_all,
            color="tab:orange",
            label="CMA-ES on all objectives: best so far",
        )
    doe_tot = np.where(study.doe.valid, q(study.doe.objectives[:, kept]), np.nan)
    ax.axhline(np.nanmin(doe_tot), color="k", ls=":", lw=1, label="best design of experiments")
    init = q(study.evaluations["initial"].objectives[:, kept])[0]
    ax.axhline(init, color="tab:red", ls="--", lw=1, label="initial model")
    if "truth" in study.evaluations:
        truth = q(study.evaluations["truth"].objectives[:, kept])[0]
        ax.axhline(truth, color="tab:green", ls="-.", lw=1, label="truth (symmetric)")
    finite = tot[np.isfinite(tot)]
    if finite.size:
        lo = min(np.nanmin(best), init) - 2.0
        ax.set_ylim(lo, max(np.percentile(finite, 95), init) + 2.0)
    ax.set_xlabel("evaluations")
    ax.set_ylabel("rank-sum of kept objectives, normalised on the DoE")
    ax.legend(fontsize=7)
    return save_cropped(fig, path)


def plot_rank_vs_euclidean(study: Tey2014Study, path: Path) -> Path:
    c = study.comparison
    a, b = c.winner_profiles
    m = a.size
    fig, (ax1, ax2) = pyplot().subplots(
        1, 2, figsize=(max(9, 0.3 * m + 5), 4), gridspec_kw={"width_ratios": [2, 1]}
    )
    pos = np.arange(m)
    ax1.bar(pos - 0.2, a, 0.4, label=f"rank-sum winner (design {c.best_rank_sum})")
    ax1.bar(pos + 0.2, b, 0.4, label=f"Euclidean winner (design {c.best_euclidean})")
    ax1.set_xticks(pos, c.names, rotation=90, fontsize=6)
    ax1.set_ylabel("normalised mismatch [0, 10]")
    ax1.legend(fontsize=7)
    ax1.set_title(f"better on {c.wins_rank_sum} vs {c.wins_euclidean} of {m} objectives")
    ax2.plot(c.euclidean, c.rank_sum, ".", color="0.5", ms=4)
    ax2.plot(
        c.euclidean[c.best_rank_sum], c.rank_sum[c.best_rank_sum], "o", label="rank-sum winner"
    )
    ax2.plot(
        c.euclidean[c.best_euclidean], c.rank_sum[c.best_euclidean], "s", label="Euclidean winner"
    )
    ax2.set_xlabel("Euclidean distance of raw mismatches")
    ax2.set_ylabel("rank-sum")
    ax2.set_title(f"{c.rank_sum.size} random designs")
    ax2.legend(fontsize=7)
    return save_cropped(fig, path)


def plot_curves(study: Tey2014Study, folder: Path) -> list[Path]:
    p = study.problem
    model = getattr(p, "curves", None)
    measured = getattr(p, "measured_curves", None)
    if not (callable(model) and callable(measured)):
        return []
    meas = measured()
    xlabel = str(getattr(p, "curve_abscissa", "test input"))
    init = model(study.designs["initial"])
    ident = model(study.designs["identified"])
    paths = []
    for test, channels in meas.items():
        names = list(channels)
        ncol = min(3, len(names))
        nrow = int(np.ceil(len(names) / ncol))
        fig, axes = pyplot().subplots(nrow, ncol, figsize=(4.2 * ncol, 3.2 * nrow), squeeze=False)
        for ax, ch in zip(axes.flat, names, strict=False):
            xm, ym = channels[ch]
            ax.plot(xm, ym, "k.-", ms=2, lw=0.8, label="measured (both branches)")
            if ch in init.get(test, {}):
                ax.plot(*init[test][ch], "--", color="tab:red", lw=1, label="initial")
            if ch in ident.get(test, {}):
                ax.plot(*ident[test][ch], "-", color="tab:blue", lw=1.2, label="identified")
            ax.set_title(ch, fontsize=8)
            ax.set_xlabel(xlabel, fontsize=7)
            ax.tick_params(labelsize=7)
        for ax in list(axes.flat)[len(names) :]:
            ax.axis("off")
        axes.flat[0].legend(fontsize=6)
        fig.suptitle(test)
        fig.subplots_adjust(hspace=0.45, wspace=0.3)
        safe = "".join(ch if ch.isalnum() else "_" for ch in test).strip("_")
        paths.append(save_cropped(fig, folder / f"curves_{safe}.png"))
    return paths


def plot_profiles(study: Tey2014Study, path: Path) -> Path | None:
    """Heat map: rise of the scaled mismatch as each parameter sweeps its range (one row each)."""
    prof = study.profiles
    if prof is None:
        return None
    d, p = prof.score.shape
    flat = prof.flat(study.options["flat_tol"])
    rise = prof.score - prof.center_score
    sp = study.problem.space
    fig, ax = pyplot().subplots(figsize=(6.5, max(3.0, 0.2 * d + 1.5)))
    im = ax.imshow(
        np.log10(np.maximum(rise, 0.0) + 1e-3),
        aspect="auto",
        cmap="viridis",
        extent=(0.0, 1.0, d - 0.5, -0.5),
        interpolation="nearest",
    )
    x_id = np.clip(sp.to_unit(study.identification.mean[None, :])[0], 0, 1)
    ax.plot(x_id, np.arange(d), "w|", ms=8, label="identified")
    truth = study.designs.get("truth")
    if truth is not None:
        x_t = np.clip(sp.to_unit(truth[None, :])[0], 0, 1)
        ax.plot(x_t, np.arange(d), "rx", ms=4, label="truth")
    ax.set_yticks(
        range(d),
        [n + ("  (flat)" if f else "") for n, f in zip(prof.names, flat, strict=True)],
        fontsize=6,
    )
    for lab, f in zip(ax.get_yticklabels(), flat, strict=True):
        lab.set_color("tab:red" if f else "k")
    ax.set_xlabel("position in the parameter's range (0 = low, 1 = high)")
    ax.set_title(f"profiles: rise of scaled mismatch ({p} points per parameter)", fontsize=9)
    ax.legend(fontsize=6, loc="upper right")
    fig.colorbar(im, ax=ax, label="log10(rise + 0.001)")
    return save_cropped(fig, path)


def plot_recovery(study: Tey2014Study, path: Path) -> Path | None:
    if study.recovery is None:
        return None
    sp = study.problem.space
    rng = sp.upper - sp.lower
    err = np.array([r["error"] for r in study.recovery]) / rng * 100
    std = study.identification.std / rng * 100
    d = err.size
    fig, ax = pyplot().subplots(figsize=(max(6, 0.22 * d + 2), 3.6))
    ax.bar(range(d), err, yerr=std, capsize=2)
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xticks(range(d), sp.names, rotation=90, fontsize=6)
    ax.set_ylabel("identified - truth [% of range]")
    ax.set_title(f"recovery error (bars) and std of the best {study.options['top']} (whiskers)")
    return save_cropped(fig, path)


# ----------------------------------------------------------------- tables


def identifiability_rows(study: Tey2014Study) -> list[dict[str, Any]]:
    sp = study.problem.space
    rng = sp.upper - sp.lower
    rows = []
    prof, local = study.profiles, study.local
    flat = prof.flat(study.options["flat_tol"]) if prof is not None else None
    top_norm = local.column_norm.max() if local is not None and local.column_norm.size else 0.0
    tol = study.options["flat_tol"]
    share = local.null_share(tol) if local is not None and local.signed else None
    for i, n in enumerate(sp.names):
        row: dict[str, Any] = {
            "parameter": n,
            "std_best_%_range": 100 * study.identification.std[i] / rng[i],
            "spearman_significant": int(study.sensitivity.significant[i].sum()),
        }
        if prof is not None:
            row["profile_rise"] = float(prof.rise[i])
        if local is not None:
            row["local_sensitivity_rel"] = (
                float(local.column_norm[i] / top_norm) if top_norm else 0.0
            )
        if share is not None:
            row["null_share"] = float(share[i])
        if flat is not None:
            if flat[i]:
                row["verdict"] = "NOT identified (flat profile)"
            elif share is not None and share[i] > 0.5:
                row["verdict"] = "weak near the identified design (flat combination)"
            else:
                row["verdict"] = "identified"
        rows.append(row)
    return rows


def flat_direction_lines(study: Tey2014Study, max_lines: int = 8, terms: int = 4) -> list[str]:
    """The flat directions as readable combinations (empty when there are too many)."""
    local = study.local
    if local is None or not local.signed:
        return []
    rows = local.flat_directions(study.options["flat_tol"])
    if rows.shape[0] > max_lines:
        return []
    lines = []
    for v in rows:
        order = np.argsort(-np.abs(v))[:terms]
        parts = [f"{v[i]:+.2f}·{study.problem.space.names[i]}" for i in order if abs(v[i]) > 0.05]
        lines.append("- " + " ".join(parts))
    return lines


def _figures(study: Tey2014Study, fig_dir: Path) -> dict[str, Path | None]:
    """The report's figures by key (None: a figure its study has no data for)."""
    return {
        "sensitivity": plot_sensitivity(study, fig_dir / "sensitivity_heatmap.png"),
        "dendrogram": plot_dendrogram(study, fig_dir / "dendrogram.png"),
        "silhouette": plot_silhouette(study, fig_dir / "silhouette.png"),
        "convergence": plot_convergence(study, fig_dir / "convergence.png"),
        "rank": plot_rank_vs_euclidean(study, fig_dir / "rank_sum_vs_euclidean.png"),
        "profiles": plot_profiles(study, fig_dir / "profiles.png"),
        "recovery": plot_recovery(study, fig_dir / "recovery.png"),
    }


def _cophenetic_rows(cophenetic: dict[str, float], is_paper: bool) -> list[dict[str, Any]]:
    """One row per linkage, with the paper's value beside it on the paper's problem."""
    rows: list[dict[str, Any]] = []
    for k, v in cophenetic.items():
        row: dict[str, Any] = {"linkage": k, "cophenetic correlation": v}
        if is_paper:
            row["paper"] = PAPER_REFERENCE["cophenetic"][k]
        rows.append(row)
    return rows


def _clustering_md(
    study: Tey2014Study, img: Callable[[str, str], str], is_paper: bool
) -> list[str]:
    """Section 2: cophenetic correlations, dendrogram, silhouette, the clusters kept."""
    sel, c, paper = study.selection, study.clustering, PAPER_REFERENCE
    md = ["## 2. Clustering of objectives\n"]
    md.append(markdown_table(_cophenetic_rows(c.cophenetic, is_paper)))
    md.append(f"\nChosen linkage: **{c.method}**.\n\n")
    md.append(img("dendrogram", "dendrogram"))
    md.append(img("silhouette", "silhouette against number of clusters"))
    md.append(
        f"Best mean silhouette at k = {sel.k_silhouette} "
        f"({sel.silhouette_at(sel.k_silhouette):.3f}); rank method (min RS + RC) k = "
        f"{sel.k_rank} ({sel.silhouette_at(sel.k_rank):.3f}). Used: **k = {sel.k}** "
        f"({sel.criterion}). Singleton silhouette = {sel.singleton_value:g}. Representative "
        f"rule: {sel.rule}."
        + (
            f" The paper: {paper['k']} clusters of {paper['n_objectives']} objectives, mean "
            f"silhouette {paper['mean_silhouette']}."
            if is_paper
            else ""
        )
        + "\n\n"
    )
    md.append(
        markdown_table(
            [
                {"cluster": i + 1, "kept": sel.names[sel.kept[i]], "members": ", ".join(members)}
                for i, members in enumerate(sel.clusters())
            ]
        )
    )
    return md


def _table1_rows(study: Tey2014Study, is_paper: bool) -> list[dict[str, Any]]:
    """Table 1: each parameter's identified mean and std, its start, the paper's values on
    the paper's problem and the recovery error against a known truth."""
    p, paper = study.problem, PAPER_REFERENCE
    rec = {r["parameter"]: r for r in (study.recovery or [])}
    t1 = []
    for r in study.identification.rows():
        row = {
            "parameter": r["parameter"],
            "unit": r["unit"],
            "mean": r["mean"],
            "std": r["std"],
            "initial": float(study.designs["initial"][p.space.index(str(r["parameter"]))]),
        }
        if is_paper and r["parameter"] in paper["table1"]:
            row["paper mean"], row["paper std"] = paper["table1"][r["parameter"]]
            row["paper std"] = float("nan") if row["paper std"] is None else row["paper std"]
        if rec:
            q = rec[r["parameter"]]
            row.update(
                {"truth": q["truth"], "error": q["error"], "error % range": q["error_%_range"]}
            )
        t1.append(row)
    return t1


def _flat_directions_md(study: Tey2014Study) -> list[str]:
    """The signed local sensitivity's flat directions (or why they are not resolved)."""
    p, local = study.problem, study.local
    md: list[str] = []
    if local is not None and local.signed:
        tol = study.options["flat_tol"]
        m_used = local.jacobian.shape[0]
        nullity = local.nullity(tol)
        sv = local.singular_values
        md.append(
            f"\nSigned sensitivity of {m_used} objectives to {p.space.dim} parameters at the "
            f"identified design: {nullity} flat directions (gain at most {tol:g} per full range; "
            f"at least {max(p.space.dim - m_used, 0)} because there are fewer objectives than "
            "parameters). Largest and smallest gains (singular values): "
            + f"{sv[0]:.3g}; "
            + ", ".join(f"{v:.2g}" for v in sv[-6:])
            + ". `null_share` is the part of each parameter inside that flat subspace "
            "(1: it can change, alone or compensated by others, with no first-order effect).\n"
        )
        lines = flat_direction_lines(study)
        if lines:
            md.append("\nFlat directions (combinations the data cannot see):\n\n")
            md.append("\n".join(lines) + "\n")
    elif local is not None:
        md.append(
            "\nThe problem gives mismatch magnitudes only (no `residuals` hook), so flat "
            "combinations of parameters are not resolved; per-parameter evidence above.\n"
        )
    return md


def _beyond_md(study: Tey2014Study, s: dict[str, Any], run_dir: Path) -> list[str]:
    """Sections 9 and 10 when the study ran them: CMA-ES on all objectives, and the
    strategies compared on the kept objectives."""
    md: list[str] = []
    if "all_objectives_run" in s:
        a = s["all_objectives_run"]
        md.append("\n## 9. What clustering buys: CMA-ES on all objectives\n")
        md.append(
            markdown_table(
                [
                    {
                        "run": "kept objectives",
                        "rank-sum (kept)": s["fixed_rank_sum_kept"]["identified"],
                        "rank-sum (all)": s["fixed_rank_sum_all"]["identified"],
                        "recovery error mean % range": s.get("recovery_error_%_range", {}).get(
                            "mean", float("nan")
                        ),
                    },
                    {
                        "run": "all objectives",
                        "rank-sum (kept)": a["fixed_rank_sum_kept"],
                        "rank-sum (all)": a["fixed_rank_sum_all"],
                        "recovery error mean % range": a.get(
                            "recovery_error_%_range_mean", float("nan")
                        ),
                    },
                ]
            )
        )
    if study.strategy_comparison is not None:
        cmp_png = run_dir / "compare" / "compare.png"
        md.append("\n## 10. Strategies compared on the kept objectives\n")
        md.append(
            f"Quality: {study.strategy_comparison['quality_name']} (lower is better); best "
            "over each run, median and range over seeds. Run directories under `compare/` "
            "(`suspenv compare compare/*-seed*` redraws this).\n\n"
        )
        if cmp_png.is_file():
            md.append(f"![strategy comparison]({cmp_png.relative_to(run_dir).as_posix()})\n\n")
        md.append(
            markdown_table(
                study.strategy_comparison["table"],
                [
                    "strategy",
                    "runs",
                    "evaluations",
                    "best_median",
                    "best_min",
                    "best_max",
                    "wall_time_median_s",
                ],
            )
        )
    return md


def write_tey2014_report(study: Tey2014Study, run_dir: Path, figures: bool = True) -> Path:
    """Write ``report.md`` (and its figures unless ``figures`` is False) into ``run_dir``."""
    run_dir = Path(run_dir)
    fig_dir = run_dir / "figures"
    figs = _figures(study, fig_dir) if figures else {}
    curve_figs = plot_curves(study, fig_dir) if figures else []
    s = study_summary(study)

    def img(key: str, caption: str) -> str:
        f = figs.get(key)
        return f"![{caption}]({f.relative_to(run_dir).as_posix()})\n" if f else ""

    is_paper = study.problem.name == PAPER_REFERENCE["problem"]
    md = _intro_md(study, s, img)
    md += _clustering_md(study, img, is_paper)
    md += _results_md(study, s, img, is_paper)
    if curve_figs:
        md.append("\n## 7. Measured vs initial vs identified curves\n")
        for f in curve_figs:
            md.append(f"![{f.stem}]({f.relative_to(run_dir).as_posix()})\n")
    md += _identifiability_md(study, s, img)
    md += _flat_directions_md(study)
    md += _beyond_md(study, s, run_dir)
    md.append("\n## Timings (s)\n")
    md.append(markdown_table([{"step": k, "seconds": v} for k, v in study.timings.items()]))
    return write_file(run_dir / "report.md", "\n".join(md))


def _intro_md(study: Tey2014Study, s: dict[str, Any], img: Callable[[str, str], str]) -> list[str]:
    """What was run (budgets, options) and section 1, the sensitivity."""
    p = study.problem
    md = [f"# Identification study (Tey et al. 2014 method): {p.name}\n"]
    md.append(
        f"{p.space.dim} parameters, {p.n_objectives} objectives (mismatches to measured targets). "
        f"Design of experiments: {s['doe_evaluations']} Latin hypercube designs "
        f"({s['doe_valid']} valid). CMA-ES: {s['cmaes_evaluations']} evaluations "
        f"({s['cmaes_valid']} valid) on the rank-sum of {len(study.kept)} kept objectives. "
        "Infeasible designs are removed before ranking (as in the paper) and told to CMA-ES "
        "ranked after all feasible ones; failed designs rank last.\n"
    )
    opts = p.config()
    if opts:
        md.append(
            "Problem options: " + ", ".join(f"`{k} = {v!r}`" for k, v in opts.items()) + ".\n"
        )
    md.append("## 1. Sensitivity (Spearman)\n")
    md.append(
        "Spearman rank correlation of every parameter with every objective's "
        f"{study.sensitivity_source} over the {study.sensitivity.n_samples} valid designs; p > "
        f"{study.sensitivity.alpha:g} shown as 0.\n\n"
    )
    md.append(img("sensitivity", "sensitivity heat map"))
    ins = s["insensitive_parameters"]
    md.append(
        f"Parameters with no significant correlation to any objective: "
        f"{', '.join(ins) if ins else 'none'}.\n"
    )
    return md


def _results_md(
    study: Tey2014Study, s: dict[str, Any], img: Callable[[str, str], str], is_paper: bool
) -> list[str]:
    """Sections 3-6: convergence, Tables 1 and 2, rank-sum against Euclidean distance."""
    md = ["\n## 3. Optimisation\n"]
    md.append(img("convergence", "convergence"))
    md.append(
        "## 4. Identified parameters (Table 1: mean and std of the best "
        f"{len(study.identification.top_rows)} re-ranked designs)\n"
    )
    md.append(markdown_table(_table1_rows(study, is_paper)))
    md.append("\n## 5. Improvement per objective (Table 2)\n")
    md.append(
        markdown_table(
            study.improvement, ["objective", "kept", "initial", "identified", "improvement_%"]
        )
    )
    tot = s["fixed_rank_sum_all"]
    md.append(
        "\nRank-sum of all objectives with the normalisation frozen on the design of experiments "
        "(each objective 0 at the DoE's best, 10 at its worst): "
        + ", ".join(f"{k} {v:.4g}" for k, v in tot.items())
        + ".\n"
    )
    md.append("\n## 6. Rank-sum versus Euclidean distance (paper Figs 9-10)\n")
    md.append(
        f"The first {study.comparison.rank_sum.size} valid designs of the design of experiments "
        "(random Latin hypercube points), scored on the kept objectives by the rank-sum and by "
        "the Euclidean norm of the raw mismatches; each score's winner, objective by objective "
        "(normalised to [0, 10] over these designs; lower is better).\n\n"
    )
    md.append(img("rank", "rank-sum vs euclidean"))
    md.append(
        markdown_table([{"quantity": k, "value": v} for k, v in s["rank_sum_comparison"].items()])
    )
    return md


def _identifiability_md(
    study: Tey2014Study, s: dict[str, Any], img: Callable[[str, str], str]
) -> list[str]:
    """Section 8: the recovery error and the evidence per parameter."""
    md = ["\n## 8. Beyond the paper: recovery and identifiability\n"]
    md.append(img("recovery", "recovery error"))
    if study.recovery is not None:
        r = s["recovery_error_%_range"]
        md.append(
            f"Recovery error against the known truth: mean {r['mean']:.3g} %, max "
            f"{r['max']:.3g} % of the parameter ranges"
            + (
                f"; mean {r['mean_identifiable']:.3g} % over the parameters with a rising "
                f"profile, {r['mean_flat']:.3g} % over the flat ones (below).\n\n"
                if "mean_flat" in r
                else ".\n\n"
            )
        )
    md.append(img("profiles", "profiles"))
    which = "kept" if study.options["identifiability_on"] == "kept" else "all"
    md.append(
        f"Evidence per parameter ({which} objectives), in DoE-spread units (each objective's "
        "mismatch divided by its spread over the design of experiments, summed): "
        "`profile_rise` is how much that sum rises when the parameter alone sweeps its whole "
        f"range (below {study.options['flat_tol']:g}: flat); `local_sensitivity_rel` the "
        "finite-difference sensitivity at the identified design relative to the most "
        "sensitive parameter; `std_best_%_range` the spread of the best designs.\n\n"
    )
    md.append(markdown_table(identifiability_rows(study)))
    return md
