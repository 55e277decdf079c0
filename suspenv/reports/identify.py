"""Files of ``suspenv identify``: ``identified.toml``, ``identify.json``, ``report.md`` and
figures (:func:`write_identify_report`).

The report's first screen is for a chassis engineer: how well each measured curve is
fitted against its noise floor, what was identified (value +- one standard error, the
truth when known), what was not and why, the next rig test to run, and what the K&C
diagnosis' residual screen finds in what is left. Units at this edge: ADAMS/Car file
units for parameters (mm, N/mm, N*mm/deg, N*m/rad, deg); curves in mm and deg.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from suspenv.core.jsonable import to_jsonable
from suspenv.methods.identifiability import K_SIGMA, TOLERANCE_PCT, summary_counts
from suspenv.methods.identify import FIT_RATIO, summary
from suspenv.reports._mpl import pyplot
from suspenv.reports.markdown import fmt, markdown_table, text

if TYPE_CHECKING:
    from suspenv.methods.identify import IdentifyResult

#: figure rows: channel, label, scale from SI
FIGURE_CHANNELS = (
    ("toe", "toe [deg] (+ toe-in)", np.rad2deg(1.0)),
    ("camber", "camber [deg] (- top inboard)", np.rad2deg(1.0)),
    ("caster", "caster [deg]", np.rad2deg(1.0)),
)
CHANNEL_WORDS = {
    "toe": "toe",
    "camber": "camber",
    "caster": "caster",
    "kpi": "KPI",
    "tyre_fz": "wheel load",
    "wheel_centre_x": "wheel centre x",
    "wheel_centre_y": "wheel centre y",
    "wheel_centre_z": "wheel centre z",
    "contact_x": "contact x",
    "contact_y": "contact y",
    "contact_z": "contact z",
}


# ------------------------------------------------------------------ figures
def _save(fig: Any, path: Path) -> Path:
    plt = pyplot()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)
    return path


def plot_curves(result: IdentifyResult, path: Path) -> Path | None:
    """Measured vs initial vs identified toe, camber and caster of the left wheel against
    wheel travel (wheel-centre height change, bump +) in each measured travel test."""
    from suspenv.measurements.knc import TESTS

    model = result.model
    tests = [t for t in model.tests if t.test in TESTS]
    chans = [(c, lab, s) for c, lab, s in FIGURE_CHANNELS if any(c in t.values for t in tests)]
    if not tests or not chans:
        return None
    res, ok, _ = model.simulate(np.vstack([model.full(result.x0), model.full(result.fit.x)]))
    plt = pyplot()
    fig, axes = plt.subplots(
        len(chans), len(tests), figsize=(4.2 * len(tests), 3.0 * len(chans)), squeeze=False
    )
    for j, t in enumerate(tests):
        if "wheel_centre_z" in t.values:
            z = t.values["wheel_centre_z"][:, 0]
            xm = (z - z[0]) * 1e3
            sim_z = t.read(res[t.test], "wheel_centre_z")[:, :, 0]
            xs = (sim_z - sim_z[:, :1]) * 1e3
            xlabel = "left wheel travel [mm] (wheel centre, bump +)"
        else:
            xm = t.drive * 1e3
            xs = np.tile(xm, (2, 1))
            xlabel = "left pad travel [mm] (bump +)"
        for i, (c, label, scale) in enumerate(chans):
            ax = axes[i, j]
            if c not in t.values:
                ax.set_visible(False)
                continue
            sim = t.read(res[t.test], c)[:, :, 0] * scale
            ax.plot(xm, t.values[c][:, 0] * scale, ".", ms=3, color="k", label="measured")
            if ok[0]:
                ax.plot(xs[0], sim[0], "-", lw=1, color="tab:gray", label="initial")
            if ok[1]:
                ax.plot(xs[1], sim[1], "-", lw=1.5, color="tab:red", label="identified")
            ax.set_ylabel(label)
            ax.set_xlabel(xlabel)
            ax.grid(alpha=0.3)
            if i == 0:
                ax.set_title(f"{t.test} travel")
            if i == 0 and j == 0:
                ax.legend(fontsize=7)
    fig.suptitle(f"{result.measurement.name}: measured vs initial vs identified (left wheel)")
    fig.tight_layout()
    return _save(fig, path)


def plot_residual(result: IdentifyResult, path: Path) -> Path:
    """RMS residual over noise per curve, initial and identified (log scale)."""
    rms = result.curve_rms()
    rms0 = result.curve_rms(result.initial_residual)
    keys = list(rms)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(max(6, 0.28 * len(keys) + 2), 3.6))
    pos = np.arange(len(keys))
    ax.bar(pos - 0.2, [rms0[k] for k in keys], 0.4, color="tab:gray", label="initial")
    ax.bar(pos + 0.2, [rms[k] for k in keys], 0.4, color="tab:red", label="identified")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.axhline(FIT_RATIO, color="k", lw=0.8, ls="--", label=f"{FIT_RATIO} x noise")
    ax.set_yscale("log")
    ax.set_xticks(pos, [f"{t} {CHANNEL_WORDS.get(c, c)}" for t, c in keys], rotation=90, fontsize=7)
    ax.set_ylabel("RMS residual / noise RMS")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, axis="y")
    return _save(fig, path)


def plot_convergence(result: IdentifyResult, path: Path) -> Path:
    """Cost (sum of squared noise-scaled residuals) after each step of each stage."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.4))
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
    return _save(fig, path)


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
            row[CHANNEL_WORDS.get(c, c)] = (
                "" if v is None else f"{v:.2f}" + ("" if v <= FIT_RATIO else " !")
            )
        rows.append(row)
    return markdown_table(rows)


def _sigma_text(result: IdentifyResult) -> str:
    parts = []
    for c, s in sorted(result.model.sigma.items()):
        unit = (
            "N" if c == "tyre_fz" else ("deg" if c in ("toe", "camber", "caster", "kpi") else "mm")
        )
        v = s if unit == "N" else (np.rad2deg(s) if unit == "deg" else s * 1e3)
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


def _first_screen(result: IdentifyResult, s: dict[str, Any]) -> list[str]:
    ident = result.identifiability
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
        f"- **Fit**: {fit_ok} of {s['n_curves']} curves within {FIT_RATIO} x their noise RMS; "
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
    if result.candidates:
        best = result.candidates[0]
        new = best.newly_identified
        if new:
            more = ", ..." if len(new) > 6 else ""
            lines.append(
                f"- **Next test**: `{best.test}`: predicted to identify {len(new)} more "
                f"parameter{'s' if len(new) != 1 else ''} ({', '.join(new[:6])}{more}) and to "
                f"determine {best.n_determined_after} combinations (now {ident.n_determined})."
            )
        else:
            lines.append(
                f"- **Next test**: `{best.test}`: no single rig test identifies another "
                f"parameter under the rule; this one determines {best.n_determined_after} "
                f"combinations (now {ident.n_determined}) and shrinks the standard errors of "
                f"those not identified by a factor {10**best.mean_log_gain:.2g} on geometric "
                "mean."
            )
    if result.rerun is not None:
        r = s["rerun"]
        worst_err = r["identified_max_error_pct_range"]
        tail = (
            f", the worst within {worst_err:.2f} % of its range of the truth"
            if worst_err is not None
            else ""
        )
        lines.append(
            f"- **Shown on the test car**: with `{r['test']}` measured too, "
            f"{r['n_identified_after']} "
            f"{'parameter is' if r['n_identified_after'] == 1 else 'parameters are'} "
            "identified (was "
            f"{r['n_identified_before']}){tail}, and {r['n_determined_after']} combinations are "
            f"determined (was {r['n_determined_before']})."
        )
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
            lines += _model_next(result, diag["named"])
        else:
            lines.append(
                "- **Remaining residual**: the K&C diagnosis names nothing (no signature above "
                f"{diag['threshold']:g} holding {100 * diag['named_share']:.0f} % of the residual)."
            )
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


def write_identify_report(result: IdentifyResult, out: Path, figures: bool = True) -> list[Path]:
    """Write ``identified.toml``, ``identify.json``, ``report.md`` and ``figures/*.png``
    into ``out`` (created); returns the paths written."""
    from suspenv.models.mcpherson.vehicle_file import dump_vehicle

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files: list[Path] = []
    toml = out / "identified.toml"
    toml.write_text(dump_vehicle(result.identified_vehicle))
    files.append(toml)
    s = summary(result)
    js = out / "identify.json"
    js.write_text(json.dumps(to_jsonable(s), indent=2) + "\n")
    files.append(js)
    figs: dict[str, Path] = {}
    if figures:
        fdir = out / "figures"
        p = plot_curves(result, fdir / "curves.png")
        if p is not None:
            figs["curves"] = p
        figs["residual"] = plot_residual(result, fdir / "residual.png")
        figs["convergence"] = plot_convergence(result, fdir / "convergence.png")
        files += list(figs.values())
    lines = _first_screen(result, s)
    ident = result.identifiability
    rows = []
    for v in ident.verdicts:
        if not v.identified:
            continue
        row: dict[str, Any] = {
            "parameter": v.name,
            "value": v.value,
            "+- (1 s.e.)": v.stderr,
            "unit": v.unit,
            "s.e. % range": v.stderr_pct,
        }
        if v.truth is not None:
            row["truth"] = v.truth
            row["error % range"] = v.error_pct
        rows.append(row)
    lines += [
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
    if "curves" in figs:
        lines += ["", "![measured vs initial vs identified](figures/curves.png)"]
    lines += [
        "",
        "## Fit per curve",
        "",
        "RMS of (identified - measured) over the noise RMS, both wheels and both loading "
        f"branches (1 = at the noise floor; `!` above {FIT_RATIO}). Noise: {_sigma_text(result)}.",
        "",
        _curve_table(result),
    ]
    if "residual" in figs:
        lines += ["![residual per curve](figures/residual.png)", ""]
    rows = []
    for v in ident.verdicts:
        if v.identified:
            continue
        row = {
            "parameter": v.name,
            "value": v.value,
            "unit": v.unit,
            "s.e. % range": v.stderr_pct,
            "verdict": v.kind,
            "why": v.reason.split(": ", 1)[-1],
        }
        if v.truth is not None:
            row["truth"] = v.truth
        rows.append(row)
    lines += ["## Not identified", "", markdown_table(rows)]
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
            "measurement lacks added (its Jacobian at the identified design, the same noise "
            "model, the rig's default amplitude).",
            "",
            markdown_table(rows),
        ]
    if result.rerun is not None:
        r = s["rerun"]
        lines += [
            f"Re-run on the test car with `{r['test']}` measured (simulated, same noise "
            f"model), least squares from the identified design: {r['n_identified_before']} -> "
            f"{r['n_identified_after']} identified parameters; worst curve "
            f"{r['worst_curve_rms_over_noise']:.2f} x noise; {r['stop']}.",
            "",
        ]
        rows = []
        for v in result.rerun.identifiability.verdicts:
            if v.identified:
                rows.append(
                    {
                        "parameter": v.name,
                        "value": v.value,
                        "+- (1 s.e.)": v.stderr,
                        "truth": v.truth if v.truth is not None else "",
                        "error % range": v.error_pct if v.error_pct is not None else "",
                    }
                )
        lines += [markdown_table(rows)]
    diag = result.diagnosis
    if diag is not None and "skipped" not in diag:
        rows = [
            {"signature": d["kind"], "score": d["score"], "evidence": d["evidence"]}
            for d in diag["signatures"]
        ]
        cells = sorted(diag["residual_map"]["cells"], key=lambda c: -c["rms"])[:6]
        lines += [
            "## Remaining residual: the K&C diagnosis' screen",
            "",
            "Signature scores of the identified model's residual (about N(0, 1) under pure "
            f"noise; named stepwise above {diag['threshold']:g} when the pattern holds "
            f"{100 * diag['named_share']:.0f} % of the residual; "
            "suspenv.diagnosis.knc.signatures).",
            "",
            markdown_table(rows),
            "Largest residual cells (RMS in noise units estimated from the residual's roughness):",
            "",
            markdown_table(cells, ["test", "channel", "branch", "side", "rms"]),
        ]
    rows = [s_.to_dict() for s_ in result.fit.stages]
    lines += ["## Stages", "", markdown_table(rows)]
    if "convergence" in figs:
        lines += ["![convergence](figures/convergence.png)", ""]
    rep = out / "report.md"
    rep.write_text("\n".join(lines) + "\n")
    files.append(rep)
    return files



__all__ = ["fmt", "summary", "write_identify_report"]
