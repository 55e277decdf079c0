"""``suspenv knc VEHICLE.toml --test parallel|opposite|single|lateral|longitudinal|all
[--plot] [--out DIR]``.

Runs the virtual K&C rig on a McPherson vehicle file (format: ``docs/knc.md``),
writes the loop curves as CSV (one row per rig step, both wheels, edge units: mm,
deg, N; ISO 8855 signs, lateral outboard positive) and, with ``--plot``, a PNG of the
usual curves against wheel travel (travel tests) or contact-point force (compliance
tests). Prints the travel test's objectives, the compliance test's slopes, and the
classic K&C numbers.

Files are named ``<vehicle name>_<test>.csv`` / ``.png`` with the vehicle's ``name`` made a
plain file name (``../x`` -> ``_x``), so nothing is written outside ``--out``. An existing
non-empty output folder is refused unless ``--overwrite`` is given; then the files of the
same names are replaced and every other file is kept (nothing is deleted).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from suspenv.rigs.knc import KCResult

#: the rig tests (``suspenv.rigs.knc.ALL_TESTS``, pinned by a test; the CLI does not
#: import the solver before a command needs it)
TEST_CHOICES = ("parallel", "opposite", "single", "lateral", "longitudinal")


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
    p.add_argument("--test", choices=[*TEST_CHOICES, "all"], default="parallel", help="rig test")
    p.add_argument("--plot", action="store_true", help="also write a PNG of the curves")
    p.add_argument("--out", default="knc_out", help="output folder (default: knc_out)")
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="write into an existing non-empty output folder: replace the files of the same "
        "names (<vehicle>_<test>.csv/.png); other files are kept, nothing is deleted",
    )
    p.add_argument("--amplitude", type=float, default=40.0, help="stroke +- [mm]")
    p.add_argument("--force", type=float, default=2500.0, help="compliance tests' force +- [N]")
    p.add_argument("--steps", type=int, default=30, help="grid intervals (even)")
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    from suspenv.measurements.paths import check_output_dir, output_file, plain_file_name
    from suspenv.metrics.knc import OBJECTIVES, objectives, usual_outputs
    from suspenv.models.mcpherson.vehicle_file import REFERENCE_FILE, load_vehicle
    from suspenv.reports.knc_rig import plot_rig_curves, write_csv
    from suspenv.rigs.knc import ALL_TESTS, FORCE_TESTS, TESTS, run_tests

    path = REFERENCE_FILE if args.vehicle == "reference" else Path(args.vehicle)
    vehicle = load_vehicle(path)
    out = check_output_dir(Path(args.out), args.overwrite)
    stem = plain_file_name(vehicle.name, fallback="vehicle")
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
    out.mkdir(parents=True, exist_ok=True)
    failed = [f"{t}: {r.messages[0]}" for t, r in results.items() if not r.ok[0]]
    if failed:
        print("rig test failed: " + "; ".join(failed))
        return 1
    F = objectives(results)[0]
    for test in tests:
        csv_path = output_file(out, f"{stem}_{test}.csv")
        write_csv(results[test], csv_path)
        print(f"wrote {csv_path}")
        if args.plot:
            png = output_file(out, f"{stem}_{test}.png")
            what = "force at the contact points" if test in FORCE_TESTS else "wheel travel"
            plot_rig_curves(results[test], png, f"{vehicle.name}: {test} {what}")
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
    for k, values in usual_outputs(results).items():
        print(f"  {k:20s} {values[0]:10.4g}")
    return 0


def compliance_slopes(res: KCResult) -> dict[str, float]:
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
