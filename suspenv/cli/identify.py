"""``suspenv identify MEASUREMENTS --vehicle VEHICLE.toml [--out DIR]``: a McPherson axle's
parameters from measured K&C curves.

MEASUREMENTS is a measured-K&C folder (or its ``knc.toml``; format: ``docs/knc.md``
"Measured K&C format"), or ``test-car`` for the built-in test car (the reference vehicle
with concealed effects, ``--concealed``, ``--truth-seed``), measured through the same
path. Writes ``identified.toml`` (a vehicle file), ``report.md`` with figures and
``identify.json`` into ``--out`` (default ``identify_<name>``); progress on stderr.
An existing non-empty output folder is refused unless ``--overwrite`` is given; then the
files of the same names are replaced and nothing else is deleted. ``--method tey2014``
runs the paper's pipeline on the measured targets instead. See ``docs/identify.md``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from suspenv.cli.main import add_output_options

#: the test car's effects (suspenv.methods.curves.identify.CONCEALED, pinned by a test)
CONCEALED = ("hysteresis", "tolerance", "noise")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "identify",
        help="identify a McPherson axle's parameters from measured K&C curves",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("measurements", help="measured-K&C folder or knc.toml, or 'test-car'")
    p.add_argument(
        "--vehicle",
        default="reference",
        help="vehicle TOML file: start design, [bounds], constants (default: the reference)",
    )
    add_output_options(p, None, "files", "output folder (default: identify_<name>)")
    p.add_argument("--method", choices=("curves", "tey2014"), default="curves")
    p.add_argument(
        "--concealed",
        default=",".join(CONCEALED),
        help="test car only: comma-separated effects among hysteresis, tolerance, noise "
        "('' for none; default all three)",
    )
    p.add_argument("--truth-seed", type=int, default=0, help="test car only: its seed")
    p.add_argument(
        "--free",
        default="",
        help="comma-separated parameters to fit (default: all 49; the others stay at the start)",
    )
    p.add_argument(
        "--sides",
        choices=("symmetric", "both"),
        default="symmetric",
        help="symmetric: one design for both sides (default); both: left and right apart",
    )
    p.add_argument(
        "--global-evaluations", type=int, default=None, help="CMA-ES budget (0: polish only)"
    )
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        help="processes (default 2: the polish from the start runs beside the global stage; "
        "1: one after the other, the same numbers)",
    )
    p.add_argument(
        "--held-out",
        default="",
        help="a rig test kept out of the fit and predicted (a test of the measurement, or "
        "any rig test on the test car; 'auto': the one the others determine best)",
    )
    p.add_argument(
        "--no-loop",
        action="store_true",
        help="stop after the residual screen (do not add what it names and refit)",
    )
    p.add_argument("--seed", type=int, default=1, help="seed of the global stage")
    p.add_argument("--no-figures", action="store_true", help="write no PNG figures")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=_identify)


def _identify(args: argparse.Namespace) -> int:
    from suspenv.measurements.paths import check_output_dir, plain_file_name
    from suspenv.methods.curves.identify import (
        measure_test_car,
        resolve_vehicle,
        run_identify,
        write_outputs,
    )

    options: dict = {
        "figures": not args.no_figures,
        "sides": args.sides,
        "held_out": args.held_out,
        "loop": not args.no_loop,
    }
    if args.free:
        options["free"] = [n.strip() for n in args.free.split(",") if n.strip()]
    if args.global_evaluations is not None:
        options["global_evaluations"] = args.global_evaluations
    if args.workers is not None:
        options["workers"] = args.workers
    truth = None
    concealed = [c.strip() for c in args.concealed.split(",") if c.strip()]
    if args.measurements == "test-car":
        name = f"test_car_{args.truth_seed}"
    else:  # the folder's name (also when the manifest itself is given)
        path = Path(args.measurements)
        name = (path.parent if path.suffix == ".toml" else path).resolve().name
    out = Path(args.out) if args.out else Path(f"identify_{plain_file_name(name)}")
    check_output_dir(out, args.overwrite)
    if args.method == "tey2014":
        return _tey2014(args, out, concealed)
    vehicle = resolve_vehicle(args.vehicle)
    if args.measurements == "test-car":
        measurement, truth = measure_test_car(args.truth_seed, concealed)
    else:
        from suspenv.measurements.knc_file import load_measurement

        measurement = load_measurement(Path(args.measurements))
    result = run_identify(
        measurement, vehicle, options, truth=truth, progress=not args.quiet, seed=args.seed
    )
    for p in write_outputs(result, out, figures=not args.no_figures):
        print(f"wrote {p}")
    return 0


def _tey2014(args: argparse.Namespace, out: Path, concealed: list[str]) -> int:
    """The paper's pipeline on the same targets (``KCIdentification`` with the data)."""
    from suspenv.methods.tey2014.pipeline import check_tey2014_config, run_tey2014_pipeline

    options: dict = {}
    if args.measurements == "test-car":
        options.update(truth_seed=args.truth_seed, concealed=concealed)
    else:
        options["measurements"] = args.measurements
    if args.vehicle != "reference":
        options["vehicle"] = args.vehicle
    config = check_tey2014_config(
        {
            "name": out.name,
            "seed": args.seed,
            "pipeline": "tey2014",
            "problem": {"name": "KCIdentification", "options": options},
            "run": {"progress": not args.quiet, "plots": not args.no_figures},
        }
    )
    summary = run_tey2014_pipeline(config, out)
    print(f"wrote {out / 'report.md'} ({summary.get('wall_time_s', 0):.0f} s)")
    return 0
