"""Report of a road-profile diagnosis against ISO 8608 (:mod:`suspenv.diagnosis.road`).

``road_psd.png``: the measured profile's Welch PSD with the free and the standard
(w = 2) fits and the ISO 8608 class lines, and the measured/model ratio per octave band;
``road_diagnosis.md``: both fits, the likelihood-ratio test, the held-out check and the
ride consequence; ``road_diagnosis.json``. Units: spatial frequency in cycle/m, PSD in m^3.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.atomic import write_file
from suspenv.core.markdown import table_lines, text
from suspenv.diagnosis.engine import Diagnosis
from suspenv.diagnosis.road import profile_grid
from suspenv.measurements import Recording
from suspenv.models.road import displacement_psd, welch_psd
from suspenv.reports._mpl import pyplot, save_figure
from suspenv.runs.run_dir import write_json


def _fit_row(model: str, fit: dict[str, Any], waviness: str) -> list[str]:
    """One row of the table of fits: Gd(n0) and its interval in 1e-6 m^3."""
    lo, hi = fit["gd0_ci95"]
    gd0, interval = f"{fit['gd0'] * 1e6:.1f}", f"{lo * 1e6:.1f}-{hi * 1e6:.1f}"
    return [model, gd0, interval, waviness, fit["road_class"], f"{fit['loglik']:.1f}"]


def write_road_report(diag: Diagnosis, profile: Recording, out_dir: str | Path) -> list[Path]:
    """``road_diagnosis.md`` + ``road_psd.png`` (Welch PSD of ``profile``, 64 m segments,
    with both fits; residual by band) + ``road_diagnosis.json`` of a
    :func:`~suspenv.diagnosis.road.diagnose_road` diagnosis."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    spectrum = diag.findings["spectrum"].numbers
    png = _plot_psd(profile, spectrum, out / "road_psd.png")
    lines = [f"# Road profile diagnosis: {text(profile.name)}", "", f"**Verdict:** {diag.verdict}"]
    lines += ["", *_fits_md(spectrum, diag.hypotheses[0])]
    if "ride" in diag.findings:
        lines += _ride_md(diag.findings["ride"].numbers)
    lines += [
        *table_lines(
            ["octave (cycle/m)", "lines", "measured / free", "measured / w = 2"],
            (
                [f"{row['n_low']:.3g}-{row['n_high']:.3g}", row["lines"]]
                + [f"{row['measured_over_free']:.2f}", f"{row['measured_over_standard']:.2f}"]
                for row in spectrum["octave_bands"]
            ),
        ),
        "",
        f"![PSD and residual by band]({png.name})",
        "",
    ]
    md = write_file(out / "road_diagnosis.md", "\n".join(lines))
    js = write_json(out / "road_diagnosis.json", diag.to_dict())
    return [md, png, js]


def _plot_psd(profile: Recording, spectrum: dict[str, Any], png: Path) -> Path:
    """The measured PSD with both fits and the ISO 8608 class lines; the residual by band."""
    n_w, p_w = welch_psd(*profile_grid(profile), segment_length=64.0)
    f, s = spectrum["free_fit"], spectrum["standard_fit"]
    fig, (ax, ax2) = pyplot().subplots(1, 2, figsize=(12, 4.5))
    sel = n_w > 0
    ax.loglog(n_w[sel], p_w[sel], color="0.3", label=f"{profile.name} (Welch)")
    nn = np.geomspace(f["band"][0], f["band"][1], 100)
    free = displacement_psd(nn, f["gd0"], f["waviness"])
    ax.loglog(nn, free, "C3", label=f"free fit, w = {f['waviness']:.2f}")
    ax.loglog(nn, displacement_psd(nn, s["gd0"]), "C0--", label="ISO 8608 form, w = 2")
    for c in "ABCDE":
        ax.loglog(nn, displacement_psd(nn, c), color="0.8", lw=0.8)
        ax.text(nn[0], displacement_psd(nn[:1], c)[0], c, color="0.5", fontsize=8)
    ax.axvspan(*f["band"], color="C2", alpha=0.05)
    ax.set(xlabel="spatial frequency n (cycle/m)", ylabel="Gd (m^3)", title="displacement PSD")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    rows = spectrum["octave_bands"]
    centres = [np.sqrt(r["n_low"] * r["n_high"]) for r in rows]
    ax2.semilogx(centres, [r["measured_over_free"] for r in rows], "C3o-", label="free fit")
    ax2.semilogx(centres, [r["measured_over_standard"] for r in rows], "C0s--", label="w = 2")
    ax2.axhline(1.0, color="k", lw=0.8)
    ax2.set(
        xlabel="octave band centre (cycle/m)",
        ylabel="measured / model (mean per band)",
        title="residual by octave band",
    )
    ax2.legend()
    ax2.grid(True, which="both", alpha=0.3)
    return save_figure(fig, png, dpi=110, tight=True)


def _fits_md(spectrum: dict[str, Any], t: Any) -> list[str]:
    """Both fits, the likelihood-ratio test ``t`` and the held-out check."""
    f, s, h = spectrum["free_fit"], spectrum["standard_fit"], spectrum["heldout"]
    return [
        *table_lines(
            ["model", "Gd(n0) (1e-6 m^3)", "95 % interval", "w", "class", "log-likelihood"],
            [
                _fit_row("free", f, f"{f['waviness']:.3f} +- {f['waviness_se']:.3f}"),
                _fit_row("ISO 8608 (w = 2)", s, "2"),
            ],
        ),
        "",
        f"Band {f['band'][0]:g}-{f['band'][1]:g} cycle/m, {f['n_lines']} Fourier lines "
        f"(Whittle likelihood of the pre-whitened profile). Likelihood ratio "
        f"{t.lr_statistic_corrected:.2f} (chi^2, 1 dof): p = {t.p_value_corrected:.3g}; "
        f"BIC change {t.delta_bic_corrected:+.1f}.",
        "",
        f"Held-out check ({h['description']}): fitted w {h['fit_waviness']:.2f} +- "
        f"{h['fit_waviness_se']:.2f}, held-out w {h['heldout_waviness']:.2f} +- "
        f"{h['heldout_waviness_se']:.2f} (z = {h['waviness_agreement_z']:+.2f}); held-out "
        f"log-likelihood per line: free {h['heldout_loglik_per_line_free']:.4f}, w = 2 "
        f"{h['heldout_loglik_per_line_standard']:.4f} (gain "
        f"{h['heldout_loglik_gain_per_line']:+.4f}).",
        "",
    ]


def _ride_md(r: dict[str, Any]) -> list[str]:
    """The ride consequence: the minibus on the measured spectrum against w = 2."""
    lines = [
        f"Ride consequence (reference minibus, study pick, no load, {r['speed_kmh']:g} km/h,"
        f" mean of {len(r['seeds'])} road seeds): Wk-weighted RMS front "
        f"{r['aw_front_measured_spectrum']:.3f} m/s^2 on the measured spectrum vs "
        f"{r['aw_front_standard']:.3f} on the w = 2 fit (x{r['ratio_front']:.2f}; spread "
        f"over seeds +-{r['aw_front_standard_seed_std']:.3f}); rear "
        f"{r['aw_rear_measured_spectrum']:.3f} vs {r['aw_rear_standard']:.3f} "
        f"(x{r['ratio_rear']:.2f}).",
    ]
    if "aw_front_measured_profile_in_phase" in r:
        lines.append(
            f"On the measured profile itself (both tracks in phase): front "
            f"{r['aw_front_measured_profile_in_phase']:.3f}, rear "
            f"{r['aw_rear_measured_profile_in_phase']:.3f} m/s^2; a w = 2 road in phase: "
            f"front {r['aw_front_standard_in_phase']:.3f}, rear "
            f"{r['aw_rear_standard_in_phase']:.3f} m/s^2."
        )
    return lines + [""]
