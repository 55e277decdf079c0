"""Files of ``suspenv identify``: ``identified.toml``, ``identify.json``, ``report.md`` and
figures (:func:`write_identify_report`).

The report's first screen is for a chassis engineer: how well each measured curve is
fitted against its noise floor, what was identified (value +- one standard error, the
truth when known), what was not and why, the next rig test to run, and what the K&C
diagnosis' residual screen finds in what is left. Units at this edge: ADAMS/Car file
units for parameters (mm, N/mm, N*mm/deg, N*m/rad, deg); curves in mm and deg.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from suspenv.core.atomic import write_file
from suspenv.core.markdown import markdown_table, text
from suspenv.measurements.knc import DISPLAY
from suspenv.methods.curves.identifiability import K_SIGMA, TOLERANCE_PCT, Verdict, summary_counts
from suspenv.methods.curves.identify import FIT_RATIO, summary
from suspenv.reports._mpl import pyplot, save_cropped
from suspenv.runs.run_dir import write_json

if TYPE_CHECKING:
    from suspenv.methods.curves.identify import IdentifyResult

#: axis label (unit, sign convention: the K&C sheet's, ISO 8855, each wheel's raw sign)
#: and scale from SI of every fitted channel
AXIS_LABELS = {c: (d.label(), d.scale) for c, d in DISPLAY.items()}
#: the drive of each test on the figures' abscissa: label and scale from SI
DRIVE_LABELS = {
    "m": ("left pad stroke [mm] (bump +)", 1e3),
    "N": ("load per wheel [N]", 1.0),
    "N*m": ("moment per wheel [N m]", 1.0),
}
#: a channel in words: its axis label without unit and sign
CHANNEL_WORDS = {c: d.words for c, d in DISPLAY.items()}


# ------------------------------------------------------------------ figures
def _worst_first(result: IdentifyResult) -> list[str]:
    """Fitted channels, the one with the worst curve (the answer's RMS / noise) first."""
    fit = result.final_fit
    rms = fit.model.block_rms(fit.residual)
    worst: dict[str, float] = {}
    for (_, c), v in rms.items():
        worst[c] = max(v, worst.get(c, 0.0))
    return sorted(worst, key=lambda c: -worst[c])


def plot_curves(result: IdentifyResult, path: Path) -> Path | None:
    """Every fitted channel (rows, the worst curve first) of every measured test and both
    wheels (columns): measured, the first fit and the answer (after the loop) against
    the test's drive; units and signs on the axes."""
    from suspenv.measurements.knc import DRIVE_UNIT

    first, final = result.fit, result.final_fit
    tests = final.model.tests
    chans = _worst_first(result)
    if not tests or not chans:
        return None
    sims = []
    for f in (first, final):
        res, ok, _ = f.model.simulate(f.x[None])
        sims.append((res, bool(ok[0])))
    ncol = 2 * len(tests)
    fig, axes = pyplot().subplots(
        len(chans), ncol, figsize=(2.9 * ncol, 2.1 * len(chans)), squeeze=False
    )
    rms = final.model.block_rms(final.residual)
    for j, t in enumerate(tests):
        xlabel, xs = DRIVE_LABELS[DRIVE_UNIT.get(t.test, "m")]
        for i, c in enumerate(chans):
            label, scale = AXIS_LABELS.get(c, (c, 1.0))
            for w, wheel in enumerate(("left", "right")):
                ax = axes[i, 2 * j + w]
                if c not in t.values:
                    ax.set_visible(False)
                    continue
                x = t.drive * xs
                ax.plot(x, t.values[c][:, w] * scale, ".", ms=2, color="k", label="measured")
                for (sim, solved), colour, name in zip(
                    sims, ("tab:gray", "tab:red"), ("first fit", "after the loop"), strict=True
                ):
                    if solved:
                        y = t.read(sim[t.test], c)[0, :, w] * scale
                        ax.plot(x, y, "-", lw=1, color=colour, label=name)
                ax.set_title(f"{t.test}, {wheel}: {rms[(t.test, c)]:.2f} x noise", fontsize=7)
                ax.tick_params(labelsize=6)
                ax.grid(alpha=0.3)
                if w == 0 and j == 0:
                    ax.set_ylabel(label, fontsize=7)
                if i == len(chans) - 1:
                    ax.set_xlabel(xlabel, fontsize=7)
    axes[0, 0].legend(fontsize=6)
    fig.suptitle(
        f"{result.measurement.name}: measured vs first fit vs after the loop "
        "(rows: worst curve first; RMS / noise of both wheels after the loop)",
        fontsize=9,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.985))  # room for the title
    return save_cropped(fig, path)


def plot_residual(result: IdentifyResult, path: Path) -> Path:
    """RMS residual over noise per curve: the initial model, the first fit and the
    answer after the loop (log scale), the worst curve after the loop first."""
    final = result.final_fit
    after = final.model.block_rms(final.residual)
    bars = [
        ("initial", result.curve_rms(result.initial_residual), "tab:gray"),
        ("first fit", result.curve_rms(), "tab:blue"),
    ]
    if result.loop is not None:
        bars.append(("after the loop", after, "tab:red"))
    keys = sorted(after, key=lambda k: -after[k])
    fig, ax = pyplot().subplots(figsize=(max(6, 0.3 * len(keys) + 2), 3.8))
    pos = np.arange(len(keys))
    w = 0.8 / len(bars)
    for k, (name, rms, colour) in enumerate(bars):
        ax.bar(
            pos + (k - (len(bars) - 1) / 2) * w, [rms[q] for q in keys], w, color=colour, label=name
        )
    ax.axhline(1.0, color="k", lw=0.8)
    ax.axhline(FIT_RATIO, color="k", lw=0.8, ls="--", label=f"{FIT_RATIO} x noise")
    ax.set_yscale("log")
    ax.set_xticks(pos, [f"{t} {CHANNEL_WORDS.get(c, c)}" for t, c in keys], rotation=90, fontsize=7)
    ax.set_ylabel("RMS residual / noise RMS (both wheels)")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, axis="y")
    return save_cropped(fig, path)


def plot_convergence(result: IdentifyResult, path: Path) -> Path:
    """Cost (sum of squared noise-scaled residuals) after each step of each stage."""
    fig, ax = pyplot().subplots(figsize=(6, 3.4))
    k = 0
    for s in result.fit.stages:
        h = np.asarray(s.history, float)
        ax.plot(np.arange(k, k + h.size), h, label=s.name)
        k += h.size
    ax.axhline(result.model.size, color="k", lw=0.8, ls="--", label="number of residuals")
    ax.set_yscale("log")
    ax.set_xlabel("generation (CMA-ES), then evaluation (least squares)")
    ax.set_ylabel("cost = sum of (residual / noise)^2")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return save_cropped(fig, path)


# ------------------------------------------------------------------ markdown
def _curve_table(result: IdentifyResult) -> str:
    rms = result.curve_rms()
    tests = list(dict.fromkeys(t for t, _ in rms))
    chans = list(dict.fromkeys(c for _, c in rms))
    rows = []
    for t in tests:
        row: dict[str, Any] = {"test": t}
        for c in chans:
            v = rms.get((t, c))
            row[CHANNEL_WORDS.get(c, c)] = "" if v is None else _rms_text(v)
        rows.append(row)
    return markdown_table(rows)


def _rms_text(v: float) -> str:
    """An RMS / noise, marked `!` above :data:`FIT_RATIO`."""
    return f"{v:.2f}" + ("" if v <= FIT_RATIO else " !")


def _sigma_text(result: IdentifyResult) -> str:
    parts = []
    for c, s in sorted(result.model.sigma.items()):
        unit, v = DISPLAY[c].unit, s * DISPLAY[c].scale
        src = result.measurement.noise_source.get(c, "")
        parts.append(f"{CHANNEL_WORDS.get(c, c)} {v:.3g} {unit}" + (f" ({src})" if src else ""))
    return "; ".join(parts)


def _combination(loadings: list[tuple[str, float]]) -> str:
    """A parameter combination as text: ``0.71 tie_rod_outer_z - 0.70 tie_rod_inner_z``
    (loadings on the unit-cube scale)."""
    parts = []
    for i, (name, v) in enumerate(loadings[:4]):
        sign = "-" if v < 0 else ("+" if i else "")
        parts.append(f"{sign} {abs(v):.2f} `{name}`".strip())
    return " ".join(parts) + (" + ..." if len(loadings) > 4 else "")


#: what to add to the model when the residual screen names a signature family
_MODEL_NEXT = {
    "lr_asymmetry": "fit the sides apart (`suspenv identify ... --sides both`, or "
    '`sides = "both"` in `[identify]`)',
    "loop": "give the model the named hysteresis or friction (`[[effects]]` in the vehicle "
    "file, `model_effects` in a config) or let `suspenv diagnose` refit it",
    "sensor_offset": "check the wheel-load zero of the rig (a constant offset is not "
    "suspension physics)",
    "sensor_gain": "check the wheel-load calibration (a residual proportional to the load)",
    "progressive": "give the model the progressive element (a bump stop or progressive "
    "bushing: `[[effects]]` in the vehicle file) or let `suspenv diagnose` refit it",
}


def _model_next(result: IdentifyResult, named: list[dict[str, Any]]) -> list[str]:
    """The first-screen line saying what to change in the model for each named family
    (none for a family the model already covers)."""
    todo = []
    for n in named:
        family = n.get("family", "")
        if family == "lr_asymmetry" and result.model.two_sided:
            continue
        if family in _MODEL_NEXT:
            todo.append(_MODEL_NEXT[family])
    if not todo:
        return []
    return [f"- **Then**: {'; '.join(todo)}."]


def _loop_lines(s: dict[str, Any]) -> list[str]:
    """The first screen's opening: the fit before and after the loop, the held-out test."""
    out = []
    loop = s.get("loop")
    if loop is not None:
        out.append(
            f"- **Fit, before -> after the loop**: {loop['curves_within_1_5_noise_before']} -> "
            f"**{loop['curves_within_1_5_noise_after']} of {len(loop['curves'])}** curves "
            f"within {FIT_RATIO} x their noise RMS (worst {s['worst_curve_rms_over_noise']:.2f}"
            f" -> {loop['worst_curve_rms_over_noise_after']:.2f} x noise). Added: "
            f"{'; '.join(text(c) for c in loop['changes'])}; "
            f"{loop['n_parameters']} parameters refitted together ({text(loop['stop'])})."
        )
    h = s.get("held_out")
    if h is not None:
        out.append(
            f"- **Held-out test** `{h['test']}` ({text(h['source'])}): predicted within "
            f"**{h['worst_after']:.2f} x its noise** (worst channel; first fit "
            f"{h['worst_before']:.2f}). Held out because: {text(h['why'])}."
        )
    return out


def _before_after(result: IdentifyResult, s: dict[str, Any]) -> list[str]:
    """Section: each curve's RMS / noise initial, first fit, after the loop; the
    held-out test's prediction; the places tried for each named pattern."""
    loop, h = s.get("loop"), s.get("held_out")
    if loop is None and h is None:
        return []
    lines = ["## Before and after the loop", ""]
    if loop is not None:
        init = result.curve_rms(result.initial_residual)
        rows = [
            {
                "test": r["test"],
                "channel": CHANNEL_WORDS.get(r["channel"], r["channel"]),
                "initial": init[(r["test"], r["channel"])],
                "first fit": r["before"],
                "after the loop": _rms_text(r["after"]),
            }
            for r in sorted(loop["curves"], key=lambda r: -r["after"])
        ]
        lines += [
            "RMS residual over the noise RMS per curve (both wheels, both branches; `!` above "
            f"{FIT_RATIO}), worst after the loop first.",
            "",
            markdown_table(rows),
        ]
        tried = [
            {
                "pattern": c["family"],
                "place tried (effect alone, design free to first order)": text(c["words"]),
                "cost": c["cost"],
                "fitted": ", ".join(f"{k} = {v:.4g}" for k, v in c["values"].items()),
            }
            for c in loop["candidates"]
        ]
        if tried:
            lines += [
                "Places tried for each named pattern (the least cost is kept):",
                "",
                markdown_table(tried),
            ]
    if h is not None:
        rows = [
            {
                "channel": CHANNEL_WORDS.get(c, c),
                "first fit": v,
                "after the loop": h["rms_over_noise_after"][c],
            }
            for c, v in h["rms_over_noise_before"].items()
        ]
        lines += [
            f"Held-out test `{h['test']}` ({text(h['source'])}), predicted, never fitted: RMS "
            "over noise per channel.",
            "",
            markdown_table(rows),
        ]
    return lines


def _pair(v: Any, digits: int = 4) -> str:
    """Left / right values as text ("" when None)."""
    if v is None:
        return ""
    return " / ".join(f"{x:.{digits}g}" for x in v)


def _sheet_section(s: dict[str, Any]) -> list[str]:
    """The K&C sheet: every metric measured, identified with its 95 % interval, or
    predicted; the truth beside it on the test car."""
    sheet = s.get("sheet")
    if not sheet:
        return []
    rows = []
    for r in sheet["rows"]:
        row = {
            "metric": r["name"],
            "unit": r["unit"],
            "sign": r["sign"],
            "measured L / R": _pair(r["measured"]) or text(r["needs"]),
            "identified L / R": _pair(r["identified"]),
            "95 % +- L / R": _pair(r["ci95_half_width"], 2),
            "R - L (95 %)": f"{r['asymmetry']:.3g} +- {r['asymmetry_ci95_half_width']:.2g}",
        }
        if "truth" in r:
            row["truth L / R"] = _pair(r["truth"])
            row["in 95 %"] = " / ".join("yes" if b else "NO" for b in r["truth_inside_ci95"])
        rows.append(row)
    lines = [
        "## K&C sheet of the identified car",
        "",
        "Per wheel (left / right); the identified value is the answer's model on the rig's "
        "tests (predicted where the measurement lacks the test), its 95 % interval by the "
        "delta method from the fit's covariance (suspenv.methods.curves.knc_sheet); the measured "
        "value is the same reduction of the measured loops. Definitions and signs: "
        "docs/knc.md.",
        "",
    ]
    if sheet.get("coverage") is not None:
        lines += [
            f"Test car: the 95 % intervals hold the truth for {100 * sheet['coverage']:.0f} % "
            f"of {sheet['n_values']} values (metric x wheel).",
            "",
        ]
    return lines + [markdown_table(rows), ""]


def _next_test_lines(result: IdentifyResult) -> list[str]:
    """The next rig test to measure: the first candidate (none without candidates)."""
    if not result.candidates:
        return []
    first_n = result.identifiability.n_determined  # the next test is the first fit's
    best = result.candidates[0]
    new = best.newly_identified
    if new:
        more = ", ..." if len(new) > 6 else ""
        return [
            f"- **Next test**: `{best.test}`: predicted to identify {len(new)} more "
            f"parameter{'s' if len(new) != 1 else ''} ({', '.join(new[:6])}{more}) and to "
            f"determine {best.n_determined_after} combinations (now {first_n})."
        ]
    return [
        f"- **Next test**: `{best.test}`: no single rig test identifies another "
        f"parameter under the rule; this one determines {best.n_determined_after} "
        f"combinations (now {first_n}) and shrinks the standard errors of "
        f"those not identified by a factor {10**best.mean_log_gain:.2g} on geometric "
        "mean."
    ]


def _rerun_lines(result: IdentifyResult, s: dict[str, Any]) -> list[str]:
    """The test car measured again with the next test (none without a rerun)."""
    if result.rerun is None:
        return []
    r = s["rerun"]
    worst_err = r["identified_max_error_pct_range"]
    tail = (
        f", the worst within {worst_err:.2f} % of its range of the truth"
        if worst_err is not None
        else ""
    )
    return [
        f"- **Shown on the test car**: with `{r['test']}` measured too, "
        f"{r['n_identified_after']} "
        f"{'parameter is' if r['n_identified_after'] == 1 else 'parameters are'} "
        "identified (was "
        f"{r['n_identified_before']}){tail}, and {r['n_determined_after']} combinations are "
        f"determined (was {r['n_determined_before']})."
    ]


def _residual_lines(result: IdentifyResult) -> list[str]:
    """What the K&C diagnosis names in the remaining residual, before and after the loop."""
    lines: list[str] = []
    diag = result.diagnosis
    if diag is not None:
        if "skipped" in diag:
            lines.append(f"- **Remaining residual**: not screened ({text(diag['skipped'])}).")
        elif diag["named"]:
            named = "; ".join(
                f"{n['words']} ({100 * n['share_of_residual']:.0f} % of it; candidates: "
                f"{', '.join(n['kinds'])})"
                for n in diag["named"]
            )
            lines.append(f"- **Remaining residual**: the K&C diagnosis names: {named}.")
            lines.append(f"  {text(diag['residual_map']['summary'])}.")
            if result.loop is None:  # the loop carries these changes out itself
                lines += _model_next(result, diag["named"])
        else:
            lines.append(
                "- **Remaining residual**: the K&C diagnosis names nothing (no signature above "
                f"{diag['threshold']:g} holding {100 * diag['named_share']:.0f} % of the residual)."
            )
    after = result.loop_diagnosis
    if after is not None and "skipped" not in after:
        names = "; ".join(n["words"] for n in after["named"]) or "nothing"
        lines.append(f"- **Residual after the loop**: the K&C diagnosis names {names}.")
    return lines


def _first_screen(result: IdentifyResult, s: dict[str, Any]) -> list[str]:
    ident = result.final_identifiability
    counts = summary_counts(ident.verdicts)
    fit_ok = s["curves_within_1_5_noise"]
    worst = max(s["curves"], key=lambda r: r["rms_over_noise"])
    lines = [
        f"# K&C identification: {text(result.measurement.name)}",
        "",
        f"Vehicle file: **{text(result.vehicle.name)}**; start: {result.start}; "
        f"{len(result.model.tests)} rig tests, {result.model.size} residuals, "
        f"{result.model.dim} parameters "
        f"({'left and right sides apart' if result.model.two_sided else 'left = right'}).",
        "",
        *(f"- **Data warning**: {text(w)}" for w in result.measurement.meta.get("warnings", ())),
        *_loop_lines(s),
        f"- **{'First fit' if result.loop is not None else 'Fit'}**: {fit_ok} of "
        f"{s['n_curves']} curves within {FIT_RATIO} x noise; "
        f"worst: {worst['test']} {CHANNEL_WORDS.get(worst['channel'], worst['channel'])} "
        f"({worst['rms_over_noise']:.2f} x noise). Answer: the {result.fit.final.name}, "
        f"{result.fit.final.stop}.",
        f"- **Identified**: {counts['identified']} of {len(ident.verdicts)} parameters "
        f"({K_SIGMA:g} standard errors within {TOLERANCE_PCT:g} % of their range).",
        f"- **Not identified**: {counts.get('flat', 0)} flat (no measured curve sees them), "
        f"{counts.get('correlated', 0)} correlated (others make up for them).",
        f"- **Determined combinations**: the curves fix {ident.n_determined} independent "
        f"combinations of the {len(ident.verdicts)} parameters to the same rule"
        + (f", e.g. {_combination(ident.directions[0][1])}" if ident.directions else "")
        + ".",
    ]
    lines += _next_test_lines(result)
    lines += _rerun_lines(result, s)
    lines += _residual_lines(result)
    if result.truth is not None and "recovery_error_pct_range" in s:
        e = s["recovery_error_pct_range"]
        if e["identified_max"] is not None:
            lines.append(
                f"- **Against the truth** (test car): identified parameters within "
                f"{e['identified_max']:.2f} % of their range (mean {e['identified_mean']:.2f} %); "
                f"all 49: mean {e['all_mean']:.1f} %."
            )
    lines.append(
        f"- Run: {result.timings.get('total', 0.0):.0f} s wall, {result.cpu_seconds:.0f} s "
        + (
            "CPU (two processes: the polish from the start runs beside the global stage)."
            if result.options.get("global_evaluations") and result.options.get("workers", 1) > 1
            else "CPU."
        )
    )
    return lines


def _figures(result: IdentifyResult, out: Path) -> dict[str, Path]:
    fdir = out / "figures"
    figs: dict[str, Path] = {}
    p = plot_curves(result, fdir / "curves.png")
    if p is not None:
        figs["curves"] = p
    figs["residual"] = plot_residual(result, fdir / "residual.png")
    figs["convergence"] = plot_convergence(result, fdir / "convergence.png")
    return figs


#: a verdict's table cells by column (:func:`_verdict_rows`)
_VERDICT_CELLS: dict[str, Callable[[Verdict], Any]] = {
    "parameter": lambda v: v.name,
    "value": lambda v: v.value,
    "+- (1 s.e.)": lambda v: v.stderr,
    "unit": lambda v: v.unit,
    "s.e. % range": lambda v: v.stderr_pct,
    "verdict": lambda v: v.kind,
    "why": lambda v: v.reason.split(": ", 1)[-1],
    "truth": lambda v: v.truth,
    "error % range": lambda v: v.error_pct,
}


def _verdict_rows(
    verdicts: Sequence[Verdict], identified: bool, columns: Sequence[str]
) -> list[dict[str, Any]]:
    """Table rows of the verdicts that are (``identified``) or are not identified: the
    cells ``columns`` of :data:`_VERDICT_CELLS`, a cell without a value (no truth) left
    out."""
    rows = []
    for v in verdicts:
        if v.identified == identified:
            cells = {c: _VERDICT_CELLS[c](v) for c in columns}
            rows.append({c: x for c, x in cells.items() if x is not None})
    return rows


def _identified_section(result: IdentifyResult) -> list[str]:
    ident = result.final_identifiability
    columns = ("parameter", "value", "+- (1 s.e.)", "unit", "s.e. % range")
    rows = _verdict_rows(ident.verdicts, True, (*columns, "truth", "error % range"))
    return [
        "",
        "## Identified",
        "",
        f"Rule: {K_SIGMA:g} standard errors within {TOLERANCE_PCT:g} % of the parameter's "
        "range, in file units and on the fit's scale (log for stiffnesses); covariance "
        f"s^2 (J'J)^-1 with s^2 = {ident.scale2:.3g} (max of 1 and chi2/dof). See "
        "docs/identify.md.",
        "",
        markdown_table(rows),
    ]


def _not_identified_section(result: IdentifyResult) -> list[str]:
    columns = ("parameter", "value", "unit", "s.e. % range", "verdict", "why", "truth")
    rows = _verdict_rows(result.final_identifiability.verdicts, False, columns)
    return ["## Not identified", "", markdown_table(rows)]


def _next_test_section(result: IdentifyResult, s: dict[str, Any]) -> list[str]:
    lines: list[str] = []
    if result.candidates:
        rows = [
            {
                "test": g.test,
                "newly identified": len(g.newly_identified),
                "which": ", ".join(g.newly_identified),
                "determined combinations": g.n_determined_after,
                "mean log10 s.e. reduction (not identified)": g.mean_log_gain,
            }
            for g in result.candidates
        ]
        lines += [
            "## Next test",
            "",
            "Predicted standard errors with each rig test suspenv simulates and the "
            "measurement lacks added (its Jacobian at the first fit's design, the same noise "
            "model, the rig's default amplitude).",
            "",
            markdown_table(rows),
        ]
    if result.rerun is not None:
        r = s["rerun"]
        lines += [
            f"Re-run on the test car with `{r['test']}` measured (simulated, same noise "
            f"model), least squares from the first fit's design: {r['n_identified_before']} "
            f"-> {r['n_identified_after']} identified parameters; worst curve "
            f"{r['worst_curve_rms_over_noise']:.2f} x noise; {r['stop']}.",
            "",
        ]
        columns = ("parameter", "value", "+- (1 s.e.)", "truth", "error % range")
        rows = _verdict_rows(result.rerun.identifiability.verdicts, True, columns)
        lines += [markdown_table(rows, columns)]
    return lines


def _diagnosis_section(result: IdentifyResult) -> list[str]:
    diag = result.diagnosis
    if diag is None or "skipped" in diag:
        return []
    rows = [
        {"signature": d["kind"], "score": d["score"], "evidence": d["evidence"]}
        for d in diag["signatures"]
    ]
    cells = sorted(diag["residual_map"]["cells"], key=lambda c: -c["rms"])[:6]
    return [
        "## Residual of the first fit: the K&C diagnosis' screen",
        "",
        "Signature scores of the first fit's residual (about N(0, 1) under pure "
        f"noise; named stepwise above {diag['threshold']:g} when the pattern holds "
        f"{100 * diag['named_share']:.0f} % of the residual; "
        "suspenv.diagnosis.knc.signatures).",
        "",
        markdown_table(rows),
        "Largest residual cells (RMS in noise units estimated from the residual's roughness):",
        "",
        markdown_table(cells, ["test", "channel", "branch", "side", "rms"]),
    ]


def write_identify_report(result: IdentifyResult, out: Path, figures: bool = True) -> list[Path]:
    """Write ``identified.toml``, ``identify.json``, ``report.md`` and ``figures/*.png``
    into ``out`` (created); returns the paths written."""
    from suspenv.models.mcpherson.vehicle_file import dump_vehicle

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    toml = write_file(out / "identified.toml", dump_vehicle(result.identified_vehicle))
    s = summary(result)
    js = write_json(out / "identify.json", s)
    figs = _figures(result, out) if figures else {}
    lines = _first_screen(result, s) + [""]
    if "residual" in figs:  # the fit before and after the loop: the first thing seen
        lines += ["![fit per curve: initial, first fit, after the loop](figures/residual.png)", ""]
    lines += _sheet_section(s) + _before_after(result, s)
    if "curves" in figs:
        lines += ["", "![measured vs first fit vs after the loop](figures/curves.png)", ""]
    lines += _identified_section(result)
    lines += [
        "",
        "## Fit per curve (first fit)",
        "",
        "RMS of (identified - measured) over the noise RMS, both wheels and both loading "
        f"branches (1 = at the noise floor; `!` above {FIT_RATIO}). Noise: {_sigma_text(result)}.",
        "",
        _curve_table(result),
    ]
    lines += _not_identified_section(result) + _next_test_section(result, s)
    lines += _diagnosis_section(result)
    rows = [s_.to_dict() for s_ in result.fit.stages]
    if result.loop is not None:
        rows += [s_.to_dict() for s_ in result.loop.fit.stages]
    lines += ["## Stages", "", markdown_table(rows)]
    if "convergence" in figs:
        lines += ["![convergence](figures/convergence.png)", ""]
    rep = write_file(out / "report.md", "\n".join(lines) + "\n")
    return [toml, js, *figs.values(), rep]
