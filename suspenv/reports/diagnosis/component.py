"""Report of a component diagnosis (damper, MR damper, friction guide, quarter car on a
rig): Markdown with PNG figures plus the JSON of the same findings.

Figures: the residual map (share and enrichment of residual energy by branch,
reversal neighbourhood, amplitude, ...), before/after overlays on held-out data,
and loop plots (force against displacement and against velocity).
Units: figures show the channel in its own unit, displacement in mm, velocity in m/s.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.atomic import write_file
from suspenv.core.markdown import fmt as _fmt
from suspenv.core.markdown import table_lines, text
from suspenv.diagnosis.component.motion import motion
from suspenv.diagnosis.engine import Diagnosis
from suspenv.reports._mpl import pyplot, save_figure
from suspenv.runs.run_dir import write_json


def residual_map(diag: Diagnosis, path: Path) -> Path:
    """Bars of residual-energy share per part (text: enrichment), one panel per dimension
    (also the ride diagnosis' map)."""
    dims = [d for d in diag.location.dimensions() if d != "frequency band"]
    dims.append("frequency band") if "frequency band" in diag.location.dimensions() else None
    fig, axes = pyplot().subplots(len(dims), 1, figsize=(7, 1.2 + 1.0 * len(dims)), squeeze=False)
    for ax, dim in zip(axes[:, 0], dims, strict=True):
        parts = diag.location.by_dimension(dim)
        y = np.arange(len(parts))
        ax.barh(y, [100 * p.share for p in parts], color="tab:red", alpha=0.7, label="share")
        ax.barh(y, [100 * p.fraction for p in parts], fill=False, edgecolor="k", label="fair")
        ax.set_yticks(y, [p.part for p in parts], fontsize=7)
        for yi, p in zip(y, parts, strict=True):
            ax.text(101, yi, f"x{p.enrichment:.2g}", va="center", fontsize=7)
        ax.set_xlim(0, 115)
        ax.set_title(dim, fontsize=8, loc="left")
        ax.tick_params(axis="x", labelsize=7)
    axes[-1, 0].set_xlabel("share of residual energy [%] (outline: share of samples)")
    return save_figure(fig, path, dpi=110, tight=True)


def _predictions(diag: Diagnosis, rec: Any) -> tuple[np.ndarray, np.ndarray]:
    c = diag.channel
    before = np.asarray(diag.base_fit.predict(rec)[c], float)
    after = np.asarray(diag.final_fit.predict(rec)[c], float)
    return before, after


def overlay(diag: Diagnosis, path: Path, max_seconds: float = 4.0) -> Path:
    """Measured vs baseline vs final on the held-out data (first few seconds)."""
    sp = diag.split
    rec = sp.heldout_recordings[0]
    mask = np.ones(len(rec.time), bool) if sp.heldout_masks is None else sp.heldout_masks[0]
    idx = np.flatnonzero(mask)
    t = np.asarray(rec.time, float)
    idx = idx[t[idx] <= t[idx[0]] + max_seconds]
    before, after = _predictions(diag, rec)
    meas = np.asarray(rec.outputs[diag.channel], float)
    unit = rec.units.get(diag.channel, "")
    fig, (a1, a2) = pyplot().subplots(2, 1, figsize=(7, 4.5), sharex=True)
    a1.plot(t[idx], meas[idx], "k", lw=1.0, label="measured")
    a1.plot(t[idx], before[idx], "tab:blue", lw=1.0, label="baseline")
    if diag.named:
        a1.plot(t[idx], after[idx], "tab:red", lw=1.0, ls="--", label="with added physics")
    a1.set_ylabel(f"{diag.channel} [{unit}]")
    a1.legend(fontsize=7)
    a1.set_title(f"held-out data ({sp.description})", fontsize=8, loc="left")
    a2.plot(t[idx], meas[idx] - before[idx], "tab:blue", lw=0.8, label="residual, baseline")
    if diag.named:
        a2.plot(t[idx], meas[idx] - after[idx], "tab:red", lw=0.8, label="residual, refit")
    a2.set_ylabel(f"residual [{unit}]")
    a2.set_xlabel("time [s]")
    a2.legend(fontsize=7)
    return save_figure(fig, path, dpi=110, tight=True)


def loops(diag: Diagnosis, path: Path) -> Path:
    """Force-displacement and force-velocity loops: measured, baseline, final."""
    sp = diag.split
    rec = sp.fit_recordings[0]
    mask = np.ones(len(rec.time), bool) if sp.fit_masks is None else sp.fit_masks[0]
    x, v = motion(rec)
    before, after = _predictions(diag, rec)
    meas = np.asarray(rec.outputs[diag.channel], float)
    unit = rec.units.get(diag.channel, "")
    fig, axes = pyplot().subplots(1, 3, figsize=(11, 3.6))
    for ax, (u, label) in zip(
        axes[:2], ((1e3 * x, "displacement [mm]"), (v, "velocity [m/s]")), strict=True
    ):
        ax.plot(u[mask], meas[mask], "k.", ms=1.0, alpha=0.4, label="measured")
        ax.plot(u[mask], before[mask], "tab:blue", lw=0.6, label="baseline")
        if diag.named:
            ax.plot(u[mask], after[mask], "tab:red", lw=0.6, label="with added physics")
        ax.set_xlabel(label)
        ax.set_ylabel(f"{diag.channel} [{unit}]")
    # the residual loop shows what the baseline leaves out (e.g. a hysteresis loop)
    axes[2].plot(1e3 * x[mask], (meas - before)[mask], "tab:blue", lw=0.5, label="baseline")
    if diag.named:
        axes[2].plot(1e3 * x[mask], (meas - after)[mask], "tab:red", lw=0.5, label="refit")
    axes[2].set_xlabel("displacement [mm]")
    axes[2].set_ylabel(f"residual [{unit}]")
    axes[2].legend(fontsize=7)
    axes[0].legend(fontsize=7, markerscale=6)
    fig.suptitle("loops on the fit data", fontsize=9)
    return save_figure(fig, path, dpi=110, tight=True)


def _significance(h: Any) -> str:
    """ "yes", "no", or "yes, then withdrawn" (judged again after the search)."""
    if not h.significant:
        return "no"
    return "yes, then withdrawn (see the verdict)" if h.withdrawn else "yes"


def _param_table(params: dict[str, dict[str, float]]) -> list[str]:
    return table_lines(
        ["parameter", "value", "std. error (corrected for correlation)"],
        ([k, _fmt(p["value"]), f"± {_fmt(p['stderr_corrected'])}"] for k, p in params.items()),
    )


def _summary_md(diag: Diagnosis) -> list[str]:
    """Title, headline, assumptions and the evidence list."""
    L = [f"# Diagnosis: {text(diag.recording)} ({diag.model})", ""]
    L += [f"**{diag.headline}.**", ""]
    if diag.assumptions:
        L += ["Assumed where the recording does not say: " + "; ".join(diag.assumptions) + ".", ""]
    base = diag.baseline
    evidence = []
    if base.get("words"):
        where = ", ".join(base.get("rig", {}).get("sources", [])) or "the family's standard"
        evidence.append(f"Baseline ({where}): {base['words']}")
    # the rig notes quote recording names: literal text, not markup
    evidence += [text(n) for n in base.get("rig_notes", [])]
    evidence.append(f"Held out: {text(diag.holdout)}")
    evidence += [e[0].upper() + e[1:] for e in diag.evidence]
    return L + ["Evidence:", ""] + [f"- {e.rstrip('.')}." for e in evidence] + [""]


def _before_after_md(diag: Diagnosis, c: Any) -> list[str]:
    """Baseline against the model with the added physics: errors, BIC, tests."""
    ch = diag.channel
    held = f"{_fmt(c.heldout_rms_after[ch])} ({-100 * c.heldout_reduction:+.0f} %)"
    box = [f"{_fmt(q)} ({p:.2g})" for q, p in (c.ljung_box_before, c.ljung_box_after)]
    return [
        "## Before / after",
        "",
        *table_lines(
            ["", "baseline", "with added physics"],
            [
                [f"held-out RMS error ({ch})", _fmt(c.heldout_rms_before[ch]), held],
                [f"fit RMS error ({ch})", _fmt(c.fit_rms_before[ch]), _fmt(c.fit_rms_after[ch])],
                ["BIC", _fmt(c.bic_before), _fmt(c.bic_after)],
                ["Ljung-Box Q (p)", *box],
            ],
        ),
        "",
        f"Likelihood-ratio test: statistic {_fmt(c.lr.statistic)} on {c.lr.dof} dof "
        f"(corrected for serial correlation {_fmt(c.lr.statistic_corrected)}, "
        f"p = {c.lr.p_value_corrected:.2g}). Held out: {text(diag.holdout)}.",
        "",
    ]


def _baseline_md(diag: Diagnosis) -> list[str]:
    """The baseline's errors alone (no comparison was made)."""
    ch = diag.channel
    b = diag.baseline
    return [
        "## Baseline",
        "",
        f"Held-out RMS error ({ch}): {_fmt(b['heldout_rms'][ch])}; fit RMS "
        f"{_fmt(b['fit_rms'][ch])}; Ljung-Box p = {b['ljung_box']['p']:.2g}. "
        f"Held out: {text(diag.holdout)}.",
        "",
    ]


def _asymmetry_md(asym: Any) -> list[str]:
    """The bump/rebound asymmetry check: sentence, fold ratios, curve fit, matched speeds."""
    L = ["## Bump/rebound asymmetry", "", asym.sentence[0].upper() + asym.sentence[1:] + ".", ""]
    if asym.fold_ratios:
        folds = ", ".join(f"{100 * r:+.1f} %" for r in asym.fold_ratios)
        gains = ", ".join(f"{-100 * g:+.1f} %" for g in asym.fold_heldout_reductions)
        L += [
            f"Rebound/bump ratio minus one by held-out cycle group: {folds} "
            f"(held-out error change: {gains}).",
            "",
        ]
    L += ["Asymmetric curve fitted against the symmetric one plus a constant force:", ""]
    L += _param_table(asym.params) + [""]
    m = asym.matched_speed
    if m is None:
        return L
    return L + [
        "Force at the velocity peak of each half-cycle, bump and rebound at matched "
        "speeds (mean ± cycle-to-cycle standard error; odd elements cancel in the "
        "even part, a gas force or offset adds a constant, a drifting zero follows "
        "the drift measured inside each speed):",
        "",
        *table_lines(
            ["speed [m/s]", "bump [N]", "rebound [N]", "even part [N]"]
            + ["rebound/bump - 1 (raw)", "drift inside [N/s]", "time [s]"],
            (
                [
                    f"{g.speed:.4g}",
                    f"{g.force_bump:.1f} ± {g.stderr_bump:.1f}",
                    f"{g.force_rebound:.1f} ± {g.stderr_rebound:.1f}",
                    f"{g.even:+.1f} ± {g.even_stderr:.1f}",
                    f"{100 * g.rebound_over_bump:+.1f} %",
                    f"{g.drift:+.2f} ± {g.drift_stderr:.2f}",
                    f"{g.time:.1f}",
                ]
                for g in m.groups
            ),
        ),
        "",
    ]


def _location_md(diag: Diagnosis, residual_map: str) -> list[str]:
    """Where the baseline's residual lives: the hot spots and the residual map."""
    L = ["## Where the residual lives (baseline)", ""]
    hot = diag.location.hotspots()
    if hot:
        L += table_lines(
            ["where", "share of residual energy", "share of samples", "enrichment"],
            (
                [f"{s.dimension}: {s.part}", f"{100 * s.share:.0f} %"]
                + [f"{100 * s.fraction:.0f} %", f"x{s.enrichment:.2g}"]
                for s in hot[:6]
            ),
        )
    else:
        L.append("The residual is spread like the samples: no part holds an unfair share.")
    return L + ["", f"![residual map]({residual_map})", ""]


def _hypotheses_md(diag: Diagnosis) -> list[str]:
    """The ranked hypotheses and the signatures of the baseline residual."""
    L = ["## Hypotheses (ranked)", ""]
    L += table_lines(
        ["#", "effect", "significant", "ΔBIC (corr.)", "LR p (corr.)", "held-out change"]
        + ["signature score"],
        (
            [
                f"{i} (round {h.round})",
                h.words,
                _significance(h),
                _fmt(h.delta_bic_corrected),
                f"{h.p_value_corrected:.2g}",
                f"{-100 * h.heldout_reduction:+.1f} %",
                f"{h.signature_score:.2f}",
            ]
            for i, h in enumerate(diag.hypotheses, 1)
        ),
    )
    L += ["", "## Signatures of the baseline residual", ""]
    for s in diag.signatures:
        L.append(f"- **{s.kind}** (score {s.score:.2f}): {s.evidence}")
    return L


def markdown(diag: Diagnosis, figures: dict[str, str]) -> str:
    """The report text (figures referenced by relative file name)."""
    L = _summary_md(diag)
    c = diag.comparison
    L += _before_after_md(diag, c) if c is not None else _baseline_md(diag)
    for h in diag.named:
        L += [f"### {h.words}", "", h.signature_evidence + ".", ""]
        L += _param_table(h.params) + [""]
    if diag.asymmetry is not None:
        L += _asymmetry_md(diag.asymmetry)
    L += _location_md(diag, figures["residual_map"])
    L += _hypotheses_md(diag)
    L += ["", "## Figures", ""]
    L += [f"![before and after on held-out data]({figures['overlay']})", ""]
    L += [f"![loops]({figures['loops']})", ""]
    L += ["## Baseline parameters", ""] + _param_table(diag.baseline["params"]) + [""]
    if diag.named:
        L += ["## Final parameters", ""] + _param_table(diag.final_params) + [""]
    L += [f"Diagnosis time: {diag.seconds:.1f} s.", ""]
    return "\n".join(L)


def write_component_report(diag: Diagnosis, out_dir: Path | str) -> list[Path]:
    """Write ``report.md``, ``diagnosis.json`` and the PNG figures into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figs = {
        "residual_map": residual_map(diag, out / "residual_map.png").name,
        "overlay": overlay(diag, out / "overlay.png").name,
        "loops": loops(diag, out / "loops.png").name,
    }
    md = write_file(out / "report.md", markdown(diag, figs))
    js = write_json(out / "diagnosis.json", diag.to_dict())
    return [md, js, *(out / f for f in figs.values())]
