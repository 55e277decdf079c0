"""Drawings of planar linkages (an RGB array for envs/videos, PNG figures) and the run
report of :class:`~suspenv.problems.planar.PlanarLinkage`.

Frame: front view of the left wheel (y outboard to the right of the picture, z up),
drawn in mm. Inputs are SI sweeps/geometries (:mod:`suspenv.models.planar.geometry`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from suspenv.core.atomic import write_file
from suspenv.core.markdown import table_lines
from suspenv.models.planar.analytic import PlanarSweep
from suspenv.models.planar.geometry import DoubleWishbone, PlanarGeometry, geometry_to_toml
from suspenv.models.planar.outputs import SweepOutputs
from suspenv.reports._mpl import pyplot, save_figure
from suspenv.runs import quality as run_quality

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from suspenv.problems.planar import PlanarLinkage

_LINKS = {
    "double_wishbone": [
        ("lower_inner", "lower_outer", "lower arm"),
        ("upper_inner", "upper_outer", "upper arm"),
        ("lower_outer", "upper_outer", "upright"),
        ("lower_inner", "spring_arm", "lower arm"),
        ("spring_arm", "lower_outer", "lower arm"),
        ("spring_body", "spring_arm", "coil-over"),
    ],
    "mcpherson": [
        ("lower_inner", "lower_outer", "lower arm"),
        ("lower_outer", "strut_lower", "upright"),
        ("strut_lower", "strut_top", "strut"),
    ],
}
_BODY_POINTS = {
    "double_wishbone": ("lower_inner", "upper_inner", "spring_body"),
    "mcpherson": ("lower_inner", "strut_top"),
}


def draw_linkage(
    ax: Axes,
    geom: PlanarGeometry,
    points: dict[str, np.ndarray],
    theta: float = 0.0,
    *,
    alpha: float = 1.0,
    label: bool = True,
) -> None:
    """Draw one pose. ``points``: name -> (2,) m for a single geometry; ``theta``: upright
    rotation (rad) used to tilt the wheel."""
    mm = {k: 1e3 * np.asarray(v, dtype=float) for k, v in points.items()}
    colours = {
        "lower arm": "tab:blue",
        "upper arm": "tab:orange",
        "upright": "tab:green",
        "coil-over": "tab:purple",
        "strut": "tab:purple",
    }
    labelled = set()
    for a, b, name in _LINKS[geom.kind]:
        style = "--" if name == "coil-over" else "-"
        web = name in labelled  # second and third sides of the lower-arm triangle
        width = (1.0 if web else 3.0) if alpha == 1 else (0.6 if web else 1.5)
        ax.plot(
            *zip(mm[a], mm[b], strict=True),
            style,
            lw=width,
            color=colours[name],
            alpha=alpha,
            label=name if label and not web else None,
        )
        labelled.add(name)
    # the upright (and, on a strut, its tube) to the wheel centre
    tube = [] if isinstance(geom, DoubleWishbone) else ["strut_lower"]
    for a in [*tube, "lower_outer"]:
        ax.plot(*zip(mm[a], mm["wheel_centre"], strict=True), "-", lw=2, c="tab:green", alpha=alpha)
    # the wheel: edge-on disc from the contact point through the wheel centre
    camber = float(geom.static_camber) - theta
    r = 1e3 * float(geom.tyre_radius)
    up = np.array([np.sin(camber), np.cos(camber)])
    c = mm["contact"]
    top = c + 2 * r * up
    ax.plot(
        *zip(c, top, strict=True),
        "-",
        lw=8,
        color="0.25",
        alpha=0.35 * alpha,
        solid_capstyle="butt",
        label="wheel" if label else None,
    )
    ax.plot(*mm["wheel_centre"], "o", color="0.2", ms=5, alpha=alpha)
    body = [mm[n] for n in _BODY_POINTS[geom.kind]]
    ax.plot(
        [p[0] for p in body],
        [p[1] for p in body],
        "ks",
        ms=7,
        alpha=alpha,
        label="body mounts" if label else None,
    )
    ax.plot(*c, "v", color="k", ms=7, alpha=alpha)


def _pose(sweep: PlanarSweep, i: int) -> tuple[dict[str, np.ndarray], float]:
    return {k: v[..., i, :] for k, v in sweep.points.items()}, float(sweep.theta[..., i])


def plot_linkage(ax: Axes, geom: PlanarGeometry, sweep: PlanarSweep) -> None:
    """The design pose (solid) with the extreme bump and rebound poses (faint), pad lines."""
    i0 = int(np.argmin(np.abs(sweep.travel)))
    for i in (0, sweep.travel.size - 1):
        pts, th = _pose(sweep, i)
        draw_linkage(ax, geom, pts, th, alpha=0.3, label=False)
    pts, th = _pose(sweep, i0)
    draw_linkage(ax, geom, pts, th)
    c = 1e3 * sweep.points["contact"]
    ax.plot(c[:, 0], c[:, 1], "r-", lw=1, label="contact-point path")
    z0 = 1e3 * float(geom.contact_point[1])
    ax.axhline(z0, color="0.5", lw=0.8)
    ax.axvline(0.0, color="0.5", lw=0.8, ls=":")
    ax.set_aspect("equal")
    ax.set_xlabel("y outboard from centreline [mm]")
    ax.set_ylabel("z up [mm]")
    ax.set_title(f"{geom.name or geom.kind}: front view, left wheel")
    ax.legend(loc="upper left", fontsize=7)


def plot_curves(
    axes: Sequence[Axes],
    outputs: Sequence[tuple[str, SweepOutputs]],
) -> None:
    """Camber, half-track, roll-centre height, motion ratio, wheel rate vs travel."""
    specs = [
        ("camber_deg", "camber [deg]"),
        ("half_track_mm", "half-track change [mm]"),
        ("roll_centre_mm", "roll-centre height [mm]"),
        ("motion_ratio", "motion ratio [-]"),
        ("wheel_rate_N_per_mm", "wheel rate [N/mm]"),
    ]
    for ax, (field, label) in zip(axes, specs, strict=False):
        for name, out in outputs:
            ax.plot(out.travel_mm, getattr(out, field), label=name)
        ax.set_xlabel("wheel travel, bump + [mm]")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    if outputs:
        axes[0].legend(fontsize=7)


def save_linkage_figure(
    path: str | Path,
    geom: PlanarGeometry,
    sweep: PlanarSweep,
    outputs: Sequence[tuple[str, SweepOutputs]],
) -> Path:
    """The linkage on the left and its curves on the right, as PNG; returns the path."""
    fig = pyplot().figure(figsize=(14, 10))
    grid = fig.add_gridspec(5, 3)
    plot_linkage(fig.add_subplot(grid[:, :2]), geom, sweep)
    axes = [fig.add_subplot(grid[i, 2]) for i in range(5)]
    plot_curves(axes, outputs)
    return save_figure(fig, path, tight=True, dpi=90)


def save_curves_figure(path: str | Path, outputs: Sequence[tuple[str, SweepOutputs]]) -> Path:
    """All five curves on one PNG; returns the path."""
    fig, axes = pyplot().subplots(1, 5, figsize=(20, 4))
    plot_curves(list(axes), outputs)
    return save_figure(fig, path, dpi=100, tight=True)


def render_rgb(
    geom: PlanarGeometry, sweep: PlanarSweep, size: tuple[int, int] = (480, 360)
) -> np.ndarray:
    """The linkage as an RGB array (H, W, 3) uint8, ``size`` = (width, height) pixels."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    width, height = size
    dpi = 100
    fig = Figure(figsize=(width / dpi, height / dpi), dpi=dpi)

    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0.1, 0.1, 0.88, 0.82))
    plot_linkage(ax, geom, sweep)
    ax.legend().set_visible(False)
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba())
    return np.ascontiguousarray(rgba[..., :3], dtype=np.uint8)


def write_planar_report(problem: PlanarLinkage, run_dir: Path, archive: Any) -> list[Path]:
    """Best design of a run as a geometry TOML (``planar_best.toml``), a figure against the
    baseline and target curves (``planar_best.png``) and a Markdown note
    (``planar_report.md``); returns the paths (none without a successful evaluation)."""
    arrays = archive.arrays()
    objectives = np.asarray(arrays["objectives"], float)
    ok = np.asarray(arrays["ok"], bool)
    feasible = run_quality.feasible(ok, arrays["constraints"])
    q = run_quality.quality(problem, objectives)
    best = None if q is None else run_quality.best_row(q, run_quality.shown_rows(ok, feasible))
    if best is None:
        return []
    x = np.asarray(arrays["x"], float)[best]
    run_dir = Path(run_dir)
    geom, sw, out = problem.single_sweep(x)
    geom = replace(geom, name=f"{problem.baseline.name} (optimised)")
    toml_path = write_file(run_dir / "planar_best.toml", geometry_to_toml(geom))
    _, _, base_out = problem.single_sweep(problem.space.reference())
    curves = [("optimised", out), ("baseline", base_out)]
    if problem.target_outputs is not None:
        curves.append(("target", problem.target_outputs))
    fig_path = save_linkage_figure(run_dir / "planar_best.png", geom, sw, curves)
    i0 = problem.n_travel // 2
    pair = (base_out, out)  # the two columns of the outputs table
    unit = "" if problem.objective_units[0] == "-" else f" {problem.objective_units[0]}"
    lines = [
        f"# PlanarLinkage: best design ({problem.objective_names[0]} = "
        f"{objectives[best, 0]:.4g}{unit})",
        "",
        f"Baseline `{problem.geometry_name}`; "
        + (
            f"target curves of `{problem.target_name}`."
            if problem.target_name
            else f"target camber gain {problem.target_camber_gain:g} deg/m."
        ),
        f"Evaluation {best} of {len(ok)}; feasible: {bool(feasible[best])}.",
        "",
        *table_lines(
            ["variable", "baseline [mm]", "best [mm]"],
            (
                [name, f"{b:.2f}", f"{v:.2f}"]
                for name, b, v in zip(
                    problem.space.names, problem.space.reference(), x, strict=True
                )
            ),
        ),
        "",
        *table_lines(
            ["output at design", "baseline", "best"],
            [
                ["camber gain [deg/m]", *(f"{float(o.camber_gain_deg_per_m):.3f}" for o in pair)],
                ["roll-centre height [mm]", *(f"{o.roll_centre_mm[i0]:.1f}" for o in pair)],
                [
                    "max half-track change [mm]",
                    *(f"{abs(o.half_track_mm).max():.2f}" for o in pair),
                ],
                ["motion ratio", *(f"{o.motion_ratio[i0]:.3f}" for o in pair)],
            ],
        ),
        "",
        f"![linkage and curves]({fig_path.name})",
        "",
        f"Plot again: `suspenv planar {toml_path} --plot`",
        "",
    ]
    md_path = write_file(run_dir / "planar_report.md", "\n".join(lines))
    return [toml_path, fig_path, md_path]
