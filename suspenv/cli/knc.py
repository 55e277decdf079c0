"""``suspenv knc VEHICLE.toml --test TEST|all [--plot] [--out DIR]``.

Runs the virtual K&C rig on a McPherson vehicle file (format: ``docs/knc.md``),
writes the loop curves in the measured-K&C format (``docs/knc.md`` "Measured K&C
format": ``knc.toml`` and one CSV per test, one row per rig step, both wheels, units in
the column names: mm, deg, N, N*m; raw ISO 8855 signs), which
:func:`suspenv.measurements.knc_file.load_measurement` reads back, and, with ``--plot``,
a PNG of the usual curves against wheel travel (travel tests), the load (compliance
tests, in phase or opposed: :data:`TEST_CHOICES`, docs/knc.md) or the rack travel
(steering). Prints the travel test's objectives, the compliance test's slopes, and the
classic K&C numbers.

Files are ``knc.toml`` and ``<vehicle name>_<test>.csv`` / ``.png`` with the vehicle's
``name`` made a plain file name (``../x`` -> ``_x``), so nothing is written outside
``--out`` (``--overwrite``: :func:`suspenv.cli.main.add_output_options`).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from suspenv.cli.main import add_output_options

if TYPE_CHECKING:
    from suspenv.rigs.knc import KCResult

#: the rig tests (``suspenv.measurements.knc.RIG_TESTS``, pinned by a test; the CLI
#: does not import the solver before a command needs it)
TEST_CHOICES = (
    "parallel",
    "opposite",
    "single",
    "lateral",
    "longitudinal",
    "traction",
    "aligning",
    "steering",
    "lateral_opposed",
    "aligning_opposed",
)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "knc",
        help="run a virtual K&C rig on a McPherson vehicle file",
        description="Parallel, opposite or single wheel travel (+-40 mm, 30 steps, loop "
        "design -> bump -> rebound -> design), a compliance test (+-2500 N or +-250 N*m at "
        "both wheels, in phase or opposed, same loop) or rack travel, of a McPherson axle; "
        "writes CSV curves and optionally a plot.",
    )
    p.add_argument(
        "vehicle",
        help="vehicle TOML file (see docs/knc.md); 'reference' for the shipped reference "
        "vehicle; or a measured-K&C folder (holding knc.toml) to check it and print its "
        "compliance analysis; 'fsae' to import the shared Formula Student toe-compliance "
        "data into --out in that format and analyse it",
    )
    p.add_argument("--test", choices=[*TEST_CHOICES, "all"], default="parallel", help="rig test")
    p.add_argument("--plot", action="store_true", help="also write a PNG of the curves")
    add_output_options(p, "knc_out", "files (knc.toml, <vehicle>_<test>.csv/.png)")
    p.add_argument(
        "--amplitude",
        type=float,
        default=40.0,
        help="travel tests' pad stroke +- [mm]: the rig drives the pads; the report's curves "
        "and numbers are against wheel-centre travel, which is smaller by the tyre's deflection",
    )
    p.add_argument("--force", type=float, default=2500.0, help="compliance tests' force +- [N]")
    p.add_argument("--steps", type=int, default=30, help="grid intervals (even)")
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    from suspenv.measurements.knc import RIG_TESTS, TESTS
    from suspenv.measurements.knc_file import from_results, write_measurement
    from suspenv.measurements.paths import check_output_dir, output_file, plain_file_name
    from suspenv.metrics.knc import OBJECTIVES, objectives
    from suspenv.models.mcpherson.vehicle_file import REFERENCE_FILE, load_vehicle
    from suspenv.reports.knc_rig import plot_rig_curves
    from suspenv.rigs.knc import run_tests

    if args.vehicle == "fsae" or is_measurement(args.vehicle):
        return run_measured(args)
    path = REFERENCE_FILE if args.vehicle == "reference" else Path(args.vehicle)
    vehicle = load_vehicle(path)
    out = check_output_dir(Path(args.out), args.overwrite)
    stem = plain_file_name(vehicle.name, fallback="vehicle")
    tests = RIG_TESTS if args.test == "all" else (args.test,)
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
    # the measured-K&C format (docs/knc.md): knc.toml + <vehicle>_<test>.csv per test
    measurement = from_results(
        {t: results[t] for t in tests}, vehicle.name, source=f"suspenv knc {args.vehicle}"
    )
    names = {t: output_file(out, f"{stem}_{t}.csv").name for t in tests}
    for written in write_measurement(measurement, out, names):
        print(f"wrote {written}")
    for test in tests:
        if args.plot:
            png = output_file(out, f"{stem}_{test}.png")
            plot_rig_curves(results[test], png, f"{vehicle.name}: {test} test")
            print(f"wrote {png}")
        if test not in TESTS:
            print(f"\n{test} (left wheel, own sense, slope through the static position):")
            for name, v in compliance_slopes(results[test]).items():
                print(f"  {name:30s} {v:12.5g}")
            continue
        print(
            f"\n{test} travel: the paper's objectives (Tey et al. 2014; 'susp' ones against "
            "wheel-centre travel, the others against pad travel):"
        )
        for o, v in zip(OBJECTIVES, F, strict=True):
            if o.test == test:
                print(f"  {o.name:26s} {v:12.5g} {o.unit:10s} {o.label}")
    print_report(results, vehicle.constants)
    return 0


def print_report(results: dict[str, KCResult], constants) -> None:
    """Print the K&C report (:mod:`suspenv.metrics.knc_report`, docs/knc.md "K&C report:
    definitions and signs"): the wheel-centre travel the pad stroke gave, then every
    report number of the design in row 0, left and right wheel, unit and sign."""
    from suspenv.metrics.knc_report import ALL_ITEMS, knc_report

    par = results["parallel"]
    zw = (par.channels["wheel_centre_z"][0] - par.channels["wheel_centre_z"][0, 0]) * 1e3
    stroke = par.grid[-1] * 1e3
    print(
        f"\nK&C report (ADAMS/Car conventions, docs/knc.md), against wheel-centre travel: "
        f"pad stroke +-{stroke:g} mm gave wheel-centre travel {zw.min():+.1f} .. "
        f"{zw.max():+.1f} mm in parallel travel"
    )
    print_sheet(knc_report(results, constants), ALL_ITEMS)


def print_sheet(
    values: dict[str, np.ndarray], items: dict[str, Any], needs: dict[str, str] | None = None
) -> None:
    """The K&C sheet's rows (docs/knc.md): each item of ``values`` (name -> (n, 2) left
    and right wheel, the design in row 0) with a finite value, the right column "(axle)"
    for an axle number (``items[name].per_wheel`` False), unit and sign; then each item
    of ``needs`` (name -> what it needs) in place of its value."""
    needs = needs or {}
    w = max(30, *map(len, items))
    print(f"  {'':{w}s} {'left':>10s} {'right':>10s}  {'unit':8s} sign")
    for name, v in values.items():
        if name in needs or not np.all(np.isfinite(v[0])):
            continue
        it = items[name]
        right = f"{v[0, 1]:10.4g}" if it.per_wheel else f"{'(axle)':>10s}"
        print(f"  {name:{w}s} {v[0, 0]:10.4g} {right}  {it.unit:8s} {it.sign}")
    for name, why in needs.items():
        print(f"  {name:{w}s} {why}")


def compliance_slopes(res: KCResult) -> dict[str, float]:
    """Left wheel's response to a compliance or steering test: central difference of the
    loop's mid-line through the static position, per kN of force (deg/kN, mm/kN, N/kN),
    per kN*m of moment (``aligning``) or per mm of rack travel (``steering``). The left
    wheel's own sense is the test's positive sense: +y outboard (``lateral``,
    ``lateral_opposed``), +x forward (``longitudinal`` at the contact point, ``traction``
    at the wheel centre), +z a toe-out moment (``aligning``, ``aligning_opposed``), +y
    rack travel towards the left (``steering``)."""
    from suspenv.measurements.knc import DISPLAY

    i = res.static_index
    per, scale_in = {"N": ("kN", 1e3), "N*m": ("kN*m", 1e3), "m": ("mm", 1e-3)}[res.unit]
    df = (res.grid[i + 1] - res.grid[i - 1]) / scale_in
    out = {}
    for stem, ch in (
        ("toe", "toe"),
        ("camber", "camber"),
        ("contact_x", "contact_x"),
        ("contact_y (outboard)", "contact_y"),
        ("tyre_fz", "tyre_fz"),
    ):
        mid = res.mean_branch(ch)[0, :, 0] * DISPLAY[ch].scale
        out[f"d{stem} [{DISPLAY[ch].unit}/{per}]"] = float((mid[i + 1] - mid[i - 1]) / df)
    return out


def print_measured_sheet(m: Any) -> None:
    """The K&C sheet's numbers the measured loops of both wheels allow (docs/knc.md), and
    for each other number the test or channel it needs."""
    from suspenv.metrics.knc_report import (
        ALL_ITEMS,
        COMPLIANCE_ITEMS,
        compliance_report,
        knc_report,
        report_needs,
    )
    from suspenv.rigs.knc_measured import measured_results

    if len(m.wheels) < 2:
        print("\nK&C sheet: needs both wheels (this measurement holds one)")
        return
    results = measured_results(m)
    values = {**knc_report(results), **compliance_report(results)}
    print("\nK&C sheet of the measured loops (docs/knc.md):")
    print_sheet(values, {**ALL_ITEMS, **COMPLIANCE_ITEMS}, report_needs(results))


# ------------------------------------------------------------------ measured data
def is_measurement(source: str) -> bool:
    """True when ``source`` is a measured-K&C folder (holding ``knc.toml``) or that file."""
    from suspenv.measurements.knc_file import MANIFEST

    p = Path(source)
    return (p.is_dir() and (p / MANIFEST).is_file()) or p.name == MANIFEST


def run_measured(args: argparse.Namespace) -> int:
    """``suspenv knc DIR``: load a measured-K&C folder (every refusal rule of
    :func:`~suspenv.measurements.knc_file.load_measurement`; one-wheel data allowed),
    print its tests and noise and the compliance analysis of each compliance test's toe.
    ``suspenv knc fsae``: first write the shared FSAE moment file in the format into
    ``--out`` (:func:`~suspenv.measurements.sources.fsae_knc.fsae_aligning`)."""
    from suspenv.core.errors import ValidationError
    from suspenv.measurements.knc import LOADED_TESTS
    from suspenv.measurements.knc_compliance import compliance_analysis
    from suspenv.measurements.knc_file import (
        CHANNELS,
        DRIVE_COLUMN,
        edge_unit,
        load_measurement,
        write_measurement,
    )
    from suspenv.measurements.paths import check_output_dir

    folder = Path(args.vehicle)
    if args.vehicle == "fsae":
        from suspenv.measurements.sources.fsae_knc import (
            MZ_FILE,
            README_FRONT_COMPLIANCE,
            fsae_aligning,
            fsae_folder,
        )

        folder = check_output_dir(Path(args.out), args.overwrite)
        src = fsae_folder() / MZ_FILE
        for written in write_measurement(fsae_aligning(src), folder):
            print(f"wrote {written}")
        print(f"(imported {src})")
    m = load_measurement(folder, both_wheels=False)
    print(f"\nmeasured K&C data {m.name!r}: {m.meta.get('source', '')}")
    print(f"  wheels {list(m.wheels)}, channels {m.meta['channels']}")
    for test, mt in m.tests.items():
        col, quantity = DRIVE_COLUMN[test]
        unit, size = edge_unit(quantity)
        lo, hi = mt.drive.min() / size, mt.drive.max() / size
        branches = sorted({int(b) for b in mt.branch})
        print(
            f"  {test:16s} {mt.samples:4d} samples, {col} {lo:g} to {hi:g} {unit}, "
            f"branches {branches}"
        )
    print("  noise (one standard deviation):")
    for ch, sigma in m.noise.items():
        unit, size = edge_unit(CHANNELS[ch])
        print(f"    {ch:16s} {sigma / size:10.3g} {unit}  ({m.noise_source[ch]})")
    print_measured_sheet(m)
    for test in m.tests:
        if test not in LOADED_TESTS or "toe" not in m.tests[test].channels:
            continue
        for wheel in m.tests[test].wheels:
            print()
            try:
                print("\n".join(compliance_analysis(m, test, "toe", wheel).lines()))
            except ValidationError as exc:  # a loop too coarse for a slope: said, not fatal
                print(f"{test} test, toe of the {wheel} wheel: no compliance analysis: {exc}")
    if args.vehicle == "fsae":
        print(
            f"  (the data README's front compliance of the team's own car: about "
            f"{README_FRONT_COMPLIANCE:g} deg per 100 N*m; this moment file is another team's)"
        )
    return 0
