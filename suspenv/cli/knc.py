"""``suspenv knc VEHICLE.toml --test parallel|opposite|single|lateral|longitudinal|all
[--plot] [--out DIR]``.

Runs the virtual K&C rig on a McPherson vehicle file (format: ``docs/knc.md``),
writes the loop curves as CSV (one row per rig step, both wheels, edge units: mm,
deg, N; ISO 8855 signs, lateral outboard positive) and, with ``--plot``, a PNG of the
usual curves against wheel travel (travel tests) or contact-point force (compliance
tests). Prints the travel test's objectives, the compliance test's slopes, and the
classic K&C numbers.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from suspenv.rigs.knc import ALL_TESTS, FORCE_TESTS, TESTS

#: CSV/plot channels: column stem -> (rig channel, scale to edge units, outboard-mirrored)
CHANNELS = {
    "wheel_travel_mm": ("wheel_centre_z", 1e3, False),
    "pad_mm": ("pad_z", 1e3, False),
    "toe_deg": ("toe", np.rad2deg(1.0), False),
    "camber_deg": ("camber", np.rad2deg(1.0), False),
    "caster_deg": ("caster", np.rad2deg(1.0), False),
    "kpi_deg": ("kpi", np.rad2deg(1.0), False),
    "hub_x_mm": ("wheel_centre_x", 1e3, False),
    "hub_y_out_mm": ("wheel_centre_y", 1e3, True),
    "contact_x_mm": ("contact_x", 1e3, False),
    "contact_y_out_mm": ("contact_y", 1e3, True),
    "tyre_fz_N": ("tyre_fz", 1.0, False),
    "spring_force_N": ("spring_force", 1.0, False),
    "scrub_radius_mm": ("scrub_radius", 1e3, False),
    "trail_mm": ("trail", 1e3, False),
}


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "knc",
        help="run a virtual K&C rig on a McPherson vehicle file",
        description="Parallel, opposite or single wheel travel (+-40 mm, 30 steps, loop "
        "design -> bump -> rebound -> design), or a lateral or longitudinal force at both "
        "contact points (+-2500 N, same loop), of a McPherson axle; writes CSV curves and "
        "optionally a plot.",
    )
    p.add_argument(
        "vehicle",
        help="vehicle TOML file (see docs/knc.md); 'reference' for the shipped reference vehicle",
    )
    p.add_argument("--test", choices=[*ALL_TESTS, "all"], default="parallel", help="rig test")
    p.add_argument("--plot", action="store_true", help="also write a PNG of the curves")
    p.add_argument("--out", default="knc_out", help="output folder (default: knc_out)")
    p.add_argument("--amplitude", type=float, default=40.0, help="stroke +- [mm]")
    p.add_argument("--force", type=float, default=2500.0, help="compliance tests' force +- [N]")
    p.add_argument("--steps", type=int, default=30, help="grid intervals (even)")
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    from suspenv.metrics.knc import OBJECTIVES, objectives, usual_outputs
    from suspenv.models.mcpherson.vehicle_file import REFERENCE_FILE, load_vehicle
    from suspenv.rigs.knc import run_tests

    path = REFERENCE_FILE if args.vehicle == "reference" else Path(args.vehicle)
    vehicle = load_vehicle(path)
    tests = ALL_TESTS if args.test == "all" else (args.test,)
    # the objectives and classic numbers need the three travel tests; they are cheap
    run = tuple(dict.fromkeys([*TESTS, *tests]))
    results = run_tests(
        vehicle.axle(),
        run,
        args.amplitude / 1e3,
        args.steps,
        vehicle.effects,
        force_amplitude=args.force,
    )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    failed = [f"{t}: {r.messages[0]}" for t, r in results.items() if not r.ok[0]]
    if failed:
        print("rig test failed: " + "; ".join(failed))
        return 1
    F = objectives(results)[0]
    for test in tests:
        csv_path = out / f"{vehicle.name}_{test}.csv"
        write_csv(results[test], csv_path)
        print(f"wrote {csv_path}")
        if args.plot:
            png = out / f"{vehicle.name}_{test}.png"
            what = "force at the contact points" if test in FORCE_TESTS else "wheel travel"
            plot_curves(results[test], png, f"{vehicle.name}: {test} {what}")
            print(f"wrote {png}")
        if test in FORCE_TESTS:
            print(f"\n{test} compliance (left wheel, slope through the static position):")
            for name, v in compliance_slopes(results[test]).items():
                print(f"  {name:26s} {v:12.5g}")
            continue
        print(f"\n{test} travel objectives:")
        for o, v in zip(OBJECTIVES, F, strict=True):
            if o.test == test:
                print(f"  {o.name:26s} {v:12.5g} {o.unit:10s} {o.label}")
    print("\nclassic K&C numbers (left wheel, static position):")
    for k, v in usual_outputs(results).items():
        print(f"  {k:20s} {v[0]:10.4g}")
    return 0


def curve_table(res) -> tuple[list[str], np.ndarray]:
    """Column names and rows (P, columns) of one design's loop (row 0 of the batch)."""
    from suspenv.models.mcpherson.params import SIDE_SIGN

    force = res.test in FORCE_TESTS
    cols = ["step", "force_N" if force else "stroke_mm", "direction"]
    data = [np.arange(res.path.size), res.grid[res.path] * (1.0 if force else 1e3)]
    d = np.sign(np.diff(res.grid[res.path], prepend=res.grid[res.path][0]))
    data.append(d)
    for stem, (ch, scale, mirrored) in CHANNELS.items():
        for w, side in enumerate(("left", "right")):
            v = res.channels[ch][0, :, w] * scale
            if ch in ("wheel_centre_z", "pad_z"):  # travel from the static position
                v = (res.channels[ch][0, :, w] - res.channels[ch][0, 0, w]) * scale
            if mirrored:
                v = v * SIDE_SIGN[w]
            cols.append(f"{stem}_{side}")
            data.append(v)
    return cols, np.column_stack(data)


def write_csv(res, path: Path) -> None:
    cols, rows = curve_table(res)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for row in rows:
            w.writerow([f"{v:.8g}" for v in row])


def compliance_slopes(res) -> dict[str, float]:
    """Left wheel's compliance of a force test: central difference of the loop's
    mid-line through the static position, per kN (deg/kN, mm/kN, N/kN)."""
    i = res.static_index
    df = (res.grid[i + 1] - res.grid[i - 1]) / 1e3  # kN
    out = {}
    for stem, ch, scale, unit in (
        ("toe", "toe", np.rad2deg(1.0), "deg"),
        ("camber", "camber", np.rad2deg(1.0), "deg"),
        ("contact_x", "contact_x", 1e3, "mm"),
        ("contact_y (outboard)", "contact_y", 1e3, "mm"),
        ("tyre_fz", "tyre_fz", 1.0, "N"),
    ):
        mid = res.mean_branch(ch)[0, :, 0] * scale
        out[f"d{stem} [{unit}/kN]"] = float((mid[i + 1] - mid[i - 1]) / df)
    return out


def plot_curves(res, path: Path, title: str) -> None:
    """Toe, camber, caster, tyre force, hub and contact-patch lateral against wheel travel
    (travel tests) or the contact-point force (compliance tests)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols, rows = curve_table(res)
    col = {c: i for i, c in enumerate(cols)}
    panels = [
        "toe_deg",
        "camber_deg",
        "caster_deg",
        "tyre_fz_N",
        "hub_y_out_mm",
        "contact_y_out_mm",
    ]
    force = res.test in FORCE_TESTS
    fig, axes = plt.subplots(2, 3, figsize=(12, 7), constrained_layout=True)
    for ax, stem in zip(axes.ravel(), panels, strict=True):
        for side, style in (("left", "-"), ("right", "--")):
            x = rows[:, col["force_N"]] if force else rows[:, col[f"wheel_travel_mm_{side}"]]
            ax.plot(x, rows[:, col[f"{stem}_{side}"]], style, lw=1.2, label=side)
        ax.set_xlabel(
            f"force at both contact points [N] (+{'y' if res.test == 'lateral' else 'x'})"
            if force
            else "wheel travel [mm] (bump +)"
        )
        ax.set_ylabel(stem.replace("_", " "))
        ax.grid(alpha=0.3)
    axes[0, 0].legend()
    fig.suptitle(title)
    fig.savefig(path, dpi=110)
    plt.close(fig)
