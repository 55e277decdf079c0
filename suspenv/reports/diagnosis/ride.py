"""Report of a minibus ride diagnosis: Markdown + PNG (time-history overlays, PSD overlays,
the residual map of :func:`~suspenv.reports.diagnosis.component.residual_map`) and JSON.
Not the ride report of designs (:mod:`suspenv.reports.minibus_ride`).

Units: accelerations m/s^2, time s, frequency Hz; PSDs one-sided ((m/s^2)^2/Hz).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from suspenv.core.atomic import write_file
from suspenv.core.markdown import table_lines, text
from suspenv.diagnosis.engine import Diagnosis
from suspenv.diagnosis.ride.residual import NOISE_BAND_HZ, ResidualCheck
from suspenv.metrics.ride import acceleration_psd
from suspenv.reports._mpl import pyplot, save_figure
from suspenv.reports.diagnosis.component import residual_map
from suspenv.runs.run_dir import write_json


def time_overlays(diag: Diagnosis, path: Path) -> Path:
    """Measured vs baseline vs final model, every channel of every pulse recording."""
    recs = [
        r for r in diag.split.fit_recordings + diag.split.heldout_recordings if r.test == "pulse"
    ]
    chans = diag.base_fit.channels
    fig, axes = pyplot().subplots(
        len(recs),
        len(chans),
        figsize=(4.2 * len(chans), 2.6 * len(recs)),
        squeeze=False,
        sharex="row",
    )
    for i, rec in enumerate(recs):
        pb, pf = diag.base_fit.predict(rec), diag.final_fit.predict(rec)
        held = rec in diag.split.heldout_recordings
        for j, c in enumerate(chans):
            ax = axes[i, j]
            ax.plot(rec.time, rec.outputs[c], color="0.6", lw=2.2, label="measured")
            ax.plot(rec.time, pb[c], "C0", lw=1.0, label="baseline")
            if diag.named:
                ax.plot(rec.time, pf[c], "C3--", lw=1.0, label="with named effect")
            ax.set_title(f"{rec.name}{' (held out)' if held else ''}: {c}", fontsize=9)
            ax.grid(True, alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    for ax in axes[:, 0]:
        ax.set_ylabel("acceleration (m/s^2)")
    axes[0, 0].legend(fontsize=7)
    return save_figure(fig, path, dpi=100, tight=True)


def psd_overlays(diag: Diagnosis, path: Path) -> Path | None:
    """Acceleration PSDs of the random-road recordings: measured vs both models."""
    recs = [
        r
        for r in diag.split.fit_recordings + diag.split.heldout_recordings
        if r.test == "random_road"
    ]
    if not recs:
        return None
    chans = diag.base_fit.channels
    fig, axes = pyplot().subplots(
        len(recs), len(chans), figsize=(4.2 * len(chans), 3.0 * len(recs)), squeeze=False
    )
    for i, rec in enumerate(recs):
        fs = 1.0 / rec.sample_interval
        pb, pf = diag.base_fit.predict(rec), diag.final_fit.predict(rec)
        for j, c in enumerate(chans):
            ax = axes[i, j]
            for y, style, label in (
                (rec.outputs[c], "0.4", "measured"),
                (pb[c], "C0", "baseline"),
                (pf[c], "C3", "with named effect"),
            ):
                if label.startswith("with") and not diag.named:
                    continue
                f, p = acceleration_psd(np.asarray(y, float), fs, segment_s=2.0)
                ax.semilogy(f, p, color=style, lw=1.0, label=label)
            ax.set(title=f"{rec.name}: {c}", xlabel="frequency (Hz)", xlim=(0, 25))
            ax.grid(True, alpha=0.3)
    axes[0, 0].set_ylabel("PSD ((m/s^2)^2/Hz)")
    axes[0, 0].legend(fontsize=7)
    return save_figure(fig, path, dpi=100, tight=True)


def write_ride_diagnosis_report(diag: Diagnosis, out_dir: str | Path) -> list[Path]:
    """``ride_diagnosis.md``, ``.json`` and the PNG figures into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figs = [
        time_overlays(diag, out / "ride_time.png"),
        residual_map(diag, out / "ride_residual.png"),
    ]
    psd = psd_overlays(diag, out / "ride_psd.png")
    if psd:
        figs.append(psd)
    lines = _findings_md(diag)
    if diag.residual is not None:
        lines += _residual_left_md(diag.residual)
    lines += [
        "",
        "## Parameters (final model)",
        "",
        *table_lines(
            ["parameter", "value", "std. error (corrected)"],
            (
                [k, f"{v['value']:.5g}", f"{v['stderr_corrected']:.2g}"]
                for k, v in diag.final_params.items()
            ),
        ),
        "",
    ]
    lines += [f"![{p.stem}]({p.name})" for p in figs]
    md = write_file(out / "ride_diagnosis.md", "\n".join(lines) + "\n")
    js = write_json(out / "ride_diagnosis.json", diag.to_dict())
    return [md, js, *figs]


def _findings_md(diag: Diagnosis) -> list[str]:
    """Verdict, where the baseline residual lives, the candidates and their refits."""
    return [
        "# Ride diagnosis",
        "",
        f"Recordings fitted: {text(diag.recording)}. Held out: {text(diag.holdout)}.",
        "",
        f"**Verdict:** {diag.verdict}",
        "",
        "## Where the baseline residual lives",
        "",
        *table_lines(
            ["dimension", "part", "share of residual energy", "fair share", "enrichment"],
            (
                [s.dimension, s.part, f"{s.share:.3f}", f"{s.fraction:.3f}", f"{s.enrichment:.2f}"]
                for dim in diag.location.dimensions()
                for s in diag.location.by_dimension(dim)
            ),
        ),
        "",
        "## Candidates (screen score = partial R^2 beyond the base parameters)",
        "",
        *table_lines(
            ["candidate", "score", "p"],
            ([s.kind, f"{s.score:.3f}", f"{s.p_value:.2g}"] for s in diag.signatures),
        ),
        "",
        *table_lines(
            ["refitted", "significant", "corrected p", "dBIC", "held-out RMS reduction"],
            (
                [h.words, h.significant, f"{h.p_value_corrected:.2g}"]
                + [f"{h.delta_bic_corrected:.1f}", f"{100 * h.heldout_reduction:.1f} %"]
                for h in diag.hypotheses
            ),
        ),
    ]


def _residual_left_md(res: ResidualCheck) -> list[str]:
    """What the final model leaves on the held-out recordings, against the noise floor."""
    summary = {
        "held-out scaled RMS before": f"{res.heldout_before:.4f}",
        "after": f"{res.heldout_after:.4f}",
        "noise floor": f"{res.noise_floor:.4f}",
        "after / floor": f"{res.excess_ratio:.2f}",
        "explained share of the model error": f"{100 * res.explained_share:.0f} %",
        "Ljung-Box p": f"{res.ljung_box_p:.2g}",
        "residual remains": res.residual_remains,
        "confident": res.confident,
    }
    return [
        "",
        "## What is left (held-out recordings)",
        "",
        res.sentence(),
        "",
        *table_lines(list(summary), [list(summary.values())]),
        "",
        f"Noise floor: white sensor noise measured above {NOISE_BAND_HZ:g} Hz in the "
        "residual, where the ride response is negligible. A residual remains when the "
        f"error left exceeds {res.excess_limit:g} x the floor and is not white (Ljung-Box "
        f"p < {res.whiteness_alpha:g}).",
    ]
