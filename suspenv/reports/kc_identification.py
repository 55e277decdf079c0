"""Run report of a :class:`~suspenv.problems.kc_identification.KCIdentification` optimisation.

``kc_report.md``: the 40 objectives of the test vehicle (targets) against the initial
model and the run's best design; ``kc_curves.png``: the measured loops (dots) against the
best design's curves (lines), left wheel, against the pad stroke (mm).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from suspenv.core.atomic import write_file
from suspenv.core.markdown import table_lines
from suspenv.reports._mpl import pyplot, save_figure
from suspenv.runs import quality as run_quality

if TYPE_CHECKING:
    from suspenv.problems.kc_identification import KCIdentification

#: loops: {test: {channel label: (pad stroke [mm], value)}}
Curves = dict[str, dict[str, tuple[np.ndarray, np.ndarray]]]


def write_kc_report(problem: KCIdentification, run_dir: Path, archive: Any) -> list[Path]:
    """``kc_report.md`` (targets vs initial vs best model per objective) and
    ``kc_curves.png`` (measured loops vs the best design's curves); returns the paths
    (none when the run has no valid design)."""
    a = archive.arrays()
    # the run's best (no constraints: every ok row is feasible)
    best = run_quality.best_row(problem.quality(a["objectives"]), np.asarray(a["ok"], bool))
    if best is None:
        return []
    run_dir = Path(run_dir)
    x_best = a["x"][best]
    F0, _, _ = problem.simulate(problem.initial_design()[None, :])
    Fb, _, _ = problem.simulate(x_best[None, :])
    per_objective = (problem.objective_names, problem.objective_units, problem.targets)
    lines = [
        "# K&C identification: best design of the run",
        "",
        f"{len(a['ok'])} evaluations, {int(np.sum(a['ok']))} valid; best is evaluation "
        f"{best}. Targets: test vehicle with concealed "
        f"{', '.join(problem.concealed) or 'nothing'}"
        f" (seed {problem.truth_seed}); a loop's number is the mean of its two branches.",
        "",
        *table_lines(
            ["objective", "unit", "measured", "initial model", "best model", "|best - measured|"],
            (
                [name, unit, f"{t:.5g}", f"{f0:.5g}", f"{fb:.5g}", f"{abs(fb - t):.3g}"]
                for name, unit, t, f0, fb in zip(*per_objective, F0[0], Fb[0], strict=True)
            ),
        ),
    ]
    lines += ["", "Best design (ADAMS/Car units, left side):", ""]
    lines += [
        f"- {n} = {v:.6g} {u}"
        for n, v, u in zip(problem.space.names, x_best, problem.space.units, strict=True)
    ]
    lines += ["", "![curves](kc_curves.png)", ""]
    md = write_file(run_dir / "kc_report.md", "\n".join(lines))
    png = run_dir / "kc_curves.png"
    plot_measured_vs_model(problem.measured_curves(), problem.curves(x_best), png)
    return [md, png]


def plot_measured_vs_model(measured: Curves, model: Curves, path: Path) -> None:
    """Measured loops (dots) against a model's curves (lines), left wheel."""
    from suspenv.problems.kc_identification import CURVE_CHANNELS

    tests = list(measured)
    labels = [k for k, (c, _) in CURVE_CHANNELS.items() if c in ("toe", "camber", "tyre_fz")]
    fig, axes = pyplot().subplots(
        len(labels), len(tests), figsize=(4 * len(tests), 8), constrained_layout=True, squeeze=False
    )
    for j, test in enumerate(tests):
        for i, label in enumerate(labels):
            ax = axes[i, j]
            xm, ym = measured[test][label]
            xs, ys = model[test][label]
            ax.plot(xm, ym, "k.", ms=3, label="measured")
            ax.plot(xs, ys, "-", lw=1.2, label="model")
            ax.set_xlabel(f"{test}: pad stroke [mm]")
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
    axes[0, 0].legend()
    save_figure(fig, path, dpi=100)
