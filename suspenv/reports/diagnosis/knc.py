"""Report of a K&C diagnosis: Markdown, JSON and PNG figures.

Figures: the residual map (test x channel x branch x side,
in noise units), the loops of every test (measured vs baseline vs final model,
channels against each side's pad travel) and the left-minus-right differences
(same three). Plot units: toe and camber in deg, wheel load in N, contact-patch
motion in mm, pad travel in mm.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.atomic import write_file
from suspenv.core.markdown import markdown_table, text
from suspenv.diagnosis.knc.locate import BRANCHES
from suspenv.measurements.knc import (
    CHANNELS,
    DISPLAY,
    SIDES,
    drive_label,
    half_loops,
    mirrored,
    reading_drive,
    rig_test,
)
from suspenv.reports._mpl import pyplot, save_figure
from suspenv.runs.run_dir import write_json

#: plot scale and unit per recorded channel
PLOT_UNITS = {c: (DISPLAY[c].scale, DISPLAY[c].unit) for c in CHANNELS}


#: channels drawn in the loop figures (the others are in the residual map and the JSON)
LOOP_CHANNELS = ("tyre_fz", "toe", "camber")


def plot_residual_map(diag: Any, path: Path) -> Path:
    cells = diag.location.cells
    tests = sorted({k[0] for k in cells})
    rows = [(t, c) for t in tests for c in CHANNELS]
    cols = [(b, s) for s in SIDES for b in BRANCHES]
    M = np.array([[cells.get((t, c, b, s), np.nan) for b, s in cols] for t, c in rows])
    fig, ax = pyplot().subplots(figsize=(6.5, 0.35 * len(rows) + 1.5))
    im = ax.imshow(M, cmap="viridis", aspect="auto")
    ax.set_xticks(range(len(cols)), [f"{s}\n{b}" for b, s in cols])
    ax.set_yticks(range(len(rows)), [f"{t}: {c}" for t, c in rows])
    for i in range(M.shape[0]):
        for j in range(M.shape[1]):
            ax.text(j, i, f"{M[i, j]:.1f}", ha="center", va="center", color="w", fontsize=7)
    fig.colorbar(im, ax=ax, label="baseline residual RMS / noise level")
    ax.set_title("Where the baseline misses (fit data)")
    fig.subplots_adjust(left=0.35, right=0.95, bottom=0.12, top=0.92)
    return save_figure(fig, path, dpi=90)


def plot_loops(diag: Any, recs: list[Any], path: Path) -> Path:
    """Loops of every test: measured (dots), baseline, final model; left solid, right dashed."""
    chans = LOOP_CHANNELS
    fig, axes = pyplot().subplots(
        len(chans), len(recs), figsize=(3.6 * len(recs), 2.3 * len(chans)), squeeze=False
    )
    for j, rec in enumerate(recs):
        base = diag.base_fit.predict(rec)
        final = diag.final_fit.predict(rec)
        xlabel, factor = drive_label(rec)
        for i, c in enumerate(chans):
            k, unit = PLOT_UNITS[c]
            ax = axes[i, j]
            for s, ls in zip(SIDES, ("-", "--"), strict=True):
                x = reading_drive(rec, s) * float(rec.meta["amplitude"]) * factor
                key = f"{c}_{s}"
                ax.plot(x, rec.outputs[key] * k, "k.", ms=3)
                ax.plot(x, base[key] * k, ls, color="tab:orange", lw=1)
                ax.plot(x, final[key] * k, ls, color="tab:blue", lw=1)
            ax.set_ylabel(f"{c} [{unit}]", fontsize=8)
            if i == 0:
                ax.set_title(rig_test(rec), fontsize=9)
            if i == len(chans) - 1:
                ax.set_xlabel(xlabel, fontsize=8)
    axes[0, 0].plot([], [], "k.", label="measured")
    axes[0, 0].plot([], [], color="tab:orange", label="baseline")
    axes[0, 0].plot([], [], color="tab:blue", label="final model")
    axes[0, 0].legend(fontsize=7, title="left -, right --", title_fontsize=7)
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.07, top=0.95, wspace=0.35, hspace=0.3)
    return save_figure(fig, path, dpi=80)


def _midline(rec: Any, values: np.ndarray) -> np.ndarray:
    down, up = half_loops(rec, values)
    return 0.5 * (down + up)


def left_minus_right(rec: Any, data: dict[str, np.ndarray], channel: str) -> np.ndarray:
    """Left minus right loop mid-line at equal *own* pad travel (grid order).

    Parallel travel and longitudinal force: same grid point; opposite travel and
    lateral force: the right wheel's own drive is the mirrored one, so its grid is
    reversed. Zero for a symmetric axle.
    """
    left = _midline(rec, np.asarray(data[f"{channel}_left"], float))
    right = _midline(rec, np.asarray(data[f"{channel}_right"], float))
    return left - (right[::-1] if mirrored(rec) else right)


def plot_left_right(diag: Any, recs: list[Any], path: Path) -> Path:
    """Left minus right (loop mid-lines at equal own travel) of the two-sided tests."""
    recs = [r for r in recs if rig_test(r) != "single"]
    fig, axes = pyplot().subplots(
        max(len(recs), 1), 3, figsize=(11, 2.6 * max(len(recs), 1)), squeeze=False
    )
    for i, rec in enumerate(recs):
        base = diag.base_fit.predict(rec)
        final = diag.final_fit.predict(rec)
        xlabel, factor = drive_label(rec)
        grid = np.linspace(-1.0, 1.0, int(rec.meta["steps"]) + 1) * rec.meta["amplitude"] * factor
        for j, c in enumerate(("toe", "camber", "tyre_fz")):
            k, unit = PLOT_UNITS[c]
            ax = axes[i, j]
            ax.plot(grid, left_minus_right(rec, rec.outputs, c) * k, "k.", label="measured")
            ax.plot(grid, left_minus_right(rec, base, c) * k, color="tab:orange", label="baseline")
            ax.plot(
                grid, left_minus_right(rec, final, c) * k, color="tab:blue", label="final model"
            )
            ax.set_title(f"{rig_test(rec)}: {c} left - right [{unit}]", fontsize=9)
            ax.set_xlabel(xlabel, fontsize=8)
    axes[0, 0].legend(fontsize=7)
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.1, top=0.92, wspace=0.3, hspace=0.5)
    return save_figure(fig, path, dpi=80)


def _table(rows: list[list[str]], head: list[str]) -> str:
    """Pre-formatted cells as a Markdown table (no trailing newline)."""
    return markdown_table([dict(zip(head, r, strict=True)) for r in rows], head).rstrip("\n")


def write_knc_report(diag: Any, out_dir: str | Path) -> list[Path]:
    """Write ``report.md``, ``diagnosis.json`` and the figures into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [plot_residual_map(diag, out / "residual_map.png")]
    recs = list(diag.fit_recordings) + list(diag.heldout_recordings)
    paths.append(plot_loops(diag, recs, out / "loops.png"))
    paths.append(plot_left_right(diag, recs, out / "left_right.png"))
    paths.append(write_json(out / "diagnosis.json", diag.to_dict()))
    lines = _findings_md(diag)
    if diag.comparison is not None:
        lines += _comparison_md(diag.comparison)
    if diag.detection_limits:
        lines += _limits_md(diag.detection_limits)
    lines += ["## Loops", ""]
    lines += ["![loops](loops.png)"]
    lines += [
        "",
        "## Left - right",
        "",
        "Loop mid-lines at equal own pad travel; zero for a symmetric axle.",
        "",
        "![left-right](left_right.png)",
        "",
    ]
    paths.append(write_file(out / "report.md", "\n".join(lines)))
    return paths


def _findings_md(diag: Any) -> list[str]:
    """Verdict, where the baseline misses, the signatures and the hypotheses."""
    return [
        "# K&C diagnosis",
        "",
        f"**Verdict:** {diag.verdict}",
        "",
        f"Fit data: {text(diag.recording)}. Held out: {text(diag.holdout)}. "
        f"Time: {diag.seconds:.1f} s.",
        "",
        "## Where the baseline misses",
        "",
        diag.location.summary(),
        "",
        "![residual map](residual_map.png)",
        "",
        "## Signatures (score test, ~N(0,1) under noise)",
        "",
        _table(
            [[s.kind, f"{s.score:.1f}", s.evidence] for s in diag.signatures],
            ["family", "score", "evidence"],
        ),
        "",
        "## Hypotheses",
        "",
        _table(
            [
                [
                    str(h.round),
                    h.words,
                    f"{h.lr_statistic_corrected:.1f}",
                    f"{h.p_value_corrected:.2g}",
                    f"{h.delta_bic_corrected:.1f}",
                    f"{100 * h.heldout_reduction:+.1f} %",
                    _heldout_z(h),
                    "yes" if h.significant else "no",
                    ", ".join(f"{k.split('.')[-1]}={v['value']:.4g}" for k, v in h.params.items()),
                ]
                for h in diag.hypotheses
            ],
            [
                "round",
                "effect",
                "LR (corr.)",
                "p (corr.)",
                "dBIC",
                "held-out",
                "held-out z",
                "sig.",
                "params",
            ],
        ),
        "",
        "Held-out: reduction of the scaled held-out RMS error. Held-out z: the held-out "
        "gain in noise units against a real effect of the fitted size (0: as expected; "
        "below -2: the held-out test refutes the refit).",
        "",
    ]


def _comparison_md(c: Any) -> list[str]:
    """Held-out RMS error per channel, baseline against the final model."""
    return [
        "## Held-out error, baseline vs final model",
        "",
        _table(
            [
                [k, f"{c.heldout_rms_before[k]:.4g}", f"{c.heldout_rms_after[k]:.4g}"]
                for k in c.heldout_rms_before
            ],
            ["channel (SI)", "baseline", "final"],
        ),
        "",
        f"Scaled held-out error reduction: {100 * c.heldout_reduction:.1f} %.",
        "",
    ]


def _limits_md(limits: dict[str, Any]) -> list[str]:
    """The smallest element of each candidate the fitted tests would have seen."""
    return [
        "## What these tests could not have seen",
        "",
        "Smallest element each candidate would need for a 5-sigma trace in the fitted "
        "tests (the part of its signature the baseline parameters cannot follow):",
        "",
        _table(
            [
                [
                    c,
                    v["parameter"],
                    f"{v['limit']:.3g}",
                    f"{v['snr_at_reference']:.1f} at {v['reference']:g}",
                ]
                for c, v in limits.items()
            ],
            ["candidate", "parameter", "limit [N]", "snr at reference [N]"],
        ),
        "",
    ]


def _heldout_z(h: Any) -> str:
    c = h.comparison
    return f"{c.heldout_z:+.1f}" if c is not None and np.isfinite(c.heldout_z) else "n/a"
