"""Report of a K&C diagnosis: Markdown, JSON and PNG figures.

Figures (matplotlib, Agg backend): the residual map (test x channel x branch x side,
in noise units), the loops of every test (measured vs baseline vs final model,
channels against each side's pad travel) and the left-minus-right differences
(same three). Plot units: toe and camber in deg, wheel load in N, contact-patch
motion in mm, pad travel in mm.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.diagnosis.knc.locate import BRANCHES
from suspenv.diagnosis.knc.recording import CHANNELS, SIDES, rig_test

#: plot scale and unit per channel
PLOT_UNITS = {
    "toe": (np.rad2deg(1.0), "deg"),
    "camber": (np.rad2deg(1.0), "deg"),
    "tyre_fz": (1.0, "N"),
    "contact_lateral": (1e3, "mm"),
    "contact_x": (1e3, "mm"),
}


#: channels drawn in the loop figures (the others are in the residual map and the JSON)
LOOP_CHANNELS = ("tyre_fz", "toe", "camber", "contact_lateral")


def loop_width(rec: Any, values: np.ndarray) -> float:
    """Opening of a loop at the static position: rising minus falling branch (channel unit)."""
    from suspenv.diagnosis.knc.recording import half_loops

    down, up = half_loops(rec, values)
    i0 = int(rec.meta["steps"]) // 2
    return float(up[i0] - down[i0])


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_residual_map(diag: Any, path: Path) -> Path:
    plt = _plt()
    cells = diag.location.cells
    tests = sorted({k[0] for k in cells})
    rows = [(t, c) for t in tests for c in CHANNELS]
    cols = [(b, s) for s in SIDES for b in BRANCHES]
    M = np.array([[cells.get((t, c, b, s), np.nan) for b, s in cols] for t, c in rows])
    fig, ax = plt.subplots(figsize=(6.5, 0.35 * len(rows) + 1.5))
    im = ax.imshow(M, cmap="viridis", aspect="auto")
    ax.set_xticks(range(len(cols)), [f"{s}\n{b}" for b, s in cols])
    ax.set_yticks(range(len(rows)), [f"{t}: {c}" for t, c in rows])
    for i in range(M.shape[0]):
        for j in range(M.shape[1]):
            ax.text(j, i, f"{M[i, j]:.1f}", ha="center", va="center", color="w", fontsize=7)
    fig.colorbar(im, ax=ax, label="baseline residual RMS / noise level")
    ax.set_title("Where the baseline misses (fit data)")
    fig.subplots_adjust(left=0.35, right=0.95, bottom=0.12, top=0.92)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def _curves(fit: Any, rec: Any) -> dict[str, np.ndarray]:
    return fit.model.simulate(fit.theta, rec)


def plot_loops(diag: Any, rec: Any, path: Path) -> Path:
    plt = _plt()
    base = _curves(diag.base_fit, rec)
    final = _curves(diag.final_fit, rec)
    amp = float(rec.meta["amplitude"])
    chans = LOOP_CHANNELS
    fig, axes = plt.subplots(len(chans), 2, figsize=(9, 2.2 * len(chans)), sharex=True)
    for i, c in enumerate(chans):
        k, unit = PLOT_UNITS[c]
        for j, s in enumerate(SIDES):
            ax = axes[i, j]
            x = rec.inputs[f"pad_{s}"] * 1e3
            key = f"{c}_{s}"
            ax.plot(x, rec.outputs[key] * k, "k.", ms=3, label="measured")
            ax.plot(x, base[key] * k, "-", color="tab:orange", lw=1, label="baseline")
            ax.plot(x, final[key] * k, "-", color="tab:blue", lw=1, label="final model")
            ax.set_ylabel(f"{c} [{unit}]")
            if i == 0:
                ax.set_title(f"{rig_test(rec)} travel, {s} wheel")
    for ax in axes[-1]:
        ax.set_xlabel(f"own pad travel [mm] (amplitude {amp * 1e3:g} mm)")
    axes[0, 0].legend(fontsize=7)
    fig.subplots_adjust(left=0.1, right=0.98, bottom=0.08, top=0.94, wspace=0.3, hspace=0.3)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def plot_left_right(diag: Any, recs: list[Any], path: Path) -> Path:
    plt = _plt()
    fig, axes = plt.subplots(len(recs), 3, figsize=(11, 2.6 * len(recs)), squeeze=False)
    for i, rec in enumerate(recs):
        base = _curves(diag.base_fit, rec)
        final = _curves(diag.final_fit, rec)
        x = rec.inputs["stroke"] * 1e3
        for j, c in enumerate(("toe", "camber", "tyre_fz")):
            k, unit = PLOT_UNITS[c]
            ax = axes[i, j]
            for data, style, label in (
                (rec.outputs, "k.", "measured"),
                (base, "-", "baseline"),
                (final, "-", "final model"),
            ):
                d = (np.asarray(data[f"{c}_left"]) - np.asarray(data[f"{c}_right"])) * k
                ax.plot(x, d, style, ms=3, lw=1, label=label)
            ax.set_title(f"{rig_test(rec)}: {c} left - right [{unit}]", fontsize=9)
            ax.set_xlabel("stroke [mm]")
    axes[0, 0].legend(fontsize=7)
    fig.subplots_adjust(left=0.1, right=0.98, bottom=0.08, top=0.94, wspace=0.3, hspace=0.3)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def _table(rows: list[list[str]], head: list[str]) -> str:
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out)


def write_knc_report(diag: Any, out_dir: str | Path) -> list[Path]:
    """Write ``report.md``, ``diagnosis.json`` and the figures into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [plot_residual_map(diag, out / "residual_map.png")]
    recs = list(diag.fit_recordings) + list(diag.heldout_recordings)
    for rec in recs:
        paths.append(plot_loops(diag, rec, out / f"loops_{rig_test(rec)}.png"))
    paths.append(plot_left_right(diag, recs, out / "left_right.png"))
    (out / "diagnosis.json").write_text(json.dumps(diag.to_dict(), indent=2, default=float))
    paths.append(out / "diagnosis.json")

    lines = [
        "# K&C diagnosis",
        "",
        f"**Verdict:** {diag.verdict}",
        "",
        f"Fit data: {diag.recording}. Held out: {diag.holdout}. Time: {diag.seconds:.1f} s.",
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
                    "yes" if h.significant else "no",
                    ", ".join(f"{k.split('.')[-1]}={v['value']:.4g}" for k, v in h.params.items()),
                ]
                for h in diag.hypotheses
            ],
            ["round", "effect", "LR (corr.)", "p (corr.)", "dBIC", "held-out", "sig.", "params"],
        ),
        "",
    ]
    if diag.comparison is not None:
        c = diag.comparison
        lines += [
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
    lines += ["## Loops", ""]
    lines += [f"![{rig_test(r)}](loops_{rig_test(r)}.png)" for r in recs]
    lines += ["", "## Left - right", "", "![left-right](left_right.png)", ""]
    (out / "report.md").write_text("\n".join(lines))
    paths.append(out / "report.md")
    return paths
