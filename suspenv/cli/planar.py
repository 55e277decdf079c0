"""``suspenv planar GEOMETRY.toml [--plot] [--out DIR]``: a front-view linkage's curves.

Prints camber, half-track change, roll-centre height, motion ratio and wheel rate over
the travel sweep; ``--plot`` draws the linkage and its curves to PNG files
(``<geometry>.png``, ``<geometry>_curves.png``, the name made a plain file name) in
``--out`` (``--overwrite``: :func:`suspenv.cli.main.add_output_options`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from suspenv.cli.main import add_output_options
from suspenv.core.errors import LockupError, ValidationError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "planar",
        help="front-view linkage (double wishbone / McPherson): curves and drawing",
        description="Solve a planar linkage over its travel and print (and plot) camber, "
        "half-track change, roll-centre height, motion ratio and wheel rate. GEOMETRY is a "
        "TOML file (format: suspenv/data/planar/README.md) or a bundled example name.",
    )
    p.add_argument("geometry", nargs="?", help="geometry TOML file or bundled example name")
    p.add_argument("--plot", action="store_true", help="write PNG figures")
    add_output_options(p, "planar_plots", "figures (with --plot)", "folder for the figures")
    p.add_argument("--travel", type=float, default=60.0, help="sweep +-TRAVEL mm (default 60)")
    p.add_argument("--points", type=int, default=61, help="travel points (default 61)")
    p.add_argument(
        "--solver",
        choices=("analytic", "pymunk", "both"),
        default="analytic",
        help="analytic (default), pymunk, or both side by side",
    )
    p.add_argument("--list", action="store_true", help="list the bundled example geometries")
    p.set_defaults(func=_planar)


def _planar(args: argparse.Namespace) -> int:
    from suspenv.models.planar import bundled_geometries, load_geometry, solve_sweep, sweep_outputs

    if args.list or not args.geometry:
        print("bundled planar geometries (use the name or a TOML path):")
        for name in bundled_geometries():
            print(f"  {name}")
        return 0 if args.list else 2
    if not args.travel > 0 or args.points < 3:
        raise ValidationError(
            f"`--travel > 0` and `--points >= 3` must hold, but got travel={args.travel}, "
            f"points={args.points}"
        )
    geom = load_geometry(args.geometry)
    if args.plot:  # before the sweep: a refused folder costs no work
        from suspenv.measurements.paths import check_output_dir

        check_output_dir(Path(args.out), args.overwrite)
    travel = 1e-3 * np.linspace(-args.travel, args.travel, args.points)
    results = []
    if args.solver in ("analytic", "both"):
        sweep = solve_sweep(geom, travel)
        if not bool(sweep.ok):
            raise LockupError(sweep.messages[0])
        results.append(("analytic", sweep, sweep_outputs(geom, sweep)))
    if args.solver in ("pymunk", "both"):
        from suspenv.models.planar.pymunk_model import simulate_sweep

        sweep = simulate_sweep(geom, travel)
        results.append(("pymunk", sweep, sweep_outputs(geom, sweep)))
    print(f"{geom.name} ({geom.kind}); frame: front view of the left wheel, y outboard, z up")
    for label, _, out in results:
        print(f"\n[{label}]")
        _print_table(out)
    if len(results) == 2:
        _print_agreement(results[0][2], results[1][2])
    if args.plot:
        from suspenv.measurements.paths import output_file, plain_file_name
        from suspenv.reports.planar import save_curves_figure, save_linkage_figure

        out_dir = Path(args.out)
        stem = plain_file_name(Path(args.geometry).stem, fallback="geometry")
        curves = [(label, out) for label, _, out in results]
        fig = save_linkage_figure(output_file(out_dir, f"{stem}.png"), geom, results[0][1], curves)
        curves_fig = save_curves_figure(output_file(out_dir, f"{stem}_curves.png"), curves)
        print(f"\nwrote {fig} and {curves_fig}")
    return 0


def _print_table(out) -> None:
    rows = out.as_rows()
    step = max(1, (len(rows) - 1) // 12)
    keep = rows[::step] if (len(rows) - 1) % step == 0 else rows[::step] + [rows[-1]]
    head = ("travel", "camber", "half-track", "roll centre", "motion", "wheel load", "wheel rate")
    units = ("mm", "deg", "mm", "mm", "ratio", "N", "N/mm")
    print("  ".join(f"{h:>11}" for h in head))
    print("  ".join(f"{u:>11}" for u in units))
    for r in keep:
        print("  ".join(f"{v:>11.4g}" for v in r.values()))
    print(f"camber gain at design: {float(out.camber_gain_deg_per_m):.4g} deg/m")


def _print_agreement(a, b) -> None:
    from suspenv.problems.planar import CURVE_UNITS

    print("\nanalytic vs pymunk, largest difference over the sweep:")
    for field, unit in CURVE_UNITS.items():
        diff = np.max(np.abs(getattr(a, field) - getattr(b, field)))
        print(f"  {field:<22} {diff:.3g} {unit}")
