"""``suspenv diagnose TARGET [--model NAME] [--holdout H] [--out DIR]``: locate, name, model,
refit, show.

TARGET is a recording file (``.npz``, see ``docs/recordings.md``, or a real-data file
``.mat``/``.dat``/``.csv``), the name of a shared real recording (``emps``,
``mr_damper``, ``damper_dyno``, ``road_profile``; read from ``$SUSPENV_DATA`` or
``../shared/data``), K&C rig recordings of the McPherson axle (a ``.npz`` file or folder
of them, or ``knc-blind:SEED`` for a generated blind case), minibus ride recordings, or a
road profile (``.txt``); see :mod:`suspenv.cli.targets`. Writes ``report.md`` (with
PNG figures) and ``diagnosis.json`` into ``--out`` (default ``diagnosis_<name>``, the name
made a plain file name).

An existing non-empty output folder is refused unless ``--overwrite`` is given; then the
files of the same names are replaced and every other file in the folder is kept (nothing
is deleted). Data the diagnosis cannot judge (too few samples or motion cycles for the
model, non-finite values, units it does not read, implausible magnitudes) are refused
before any fitting, with what is missing (:mod:`suspenv.diagnosis.sufficiency`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from suspenv.cli.main import add_output_options


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "diagnose",
        help="find, name and model the physics a model leaves out of recordings",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "recording",
        help=".npz recording (or folder), emps | mr_damper | damper_dyno | road_profile, "
        "a road profile .txt, or knc-blind:SEED",
    )
    p.add_argument(
        "--model",
        default=None,
        help="component model: damper, mr_damper, friction_guide, quarter_car_rig with "
        "the family's standard baseline (damper: gas force; every family: a zero offset "
        "and a linear zero drift); FAMILY+KIND adds an element to the baseline, FAMILY-KIND "
        "removes one (damper-gas_spring-zero_drift: F = c v alone); or a model file "
        "(.toml: family, baseline, known rig parameters, signs). Default: from the "
        "data (meta['rig'])",
    )
    add_output_options(
        p, None, "files (report, JSON, figures)", "output folder (default: diagnosis_<name>)"
    )
    p.add_argument(
        "--holdout",
        default=None,
        help="held-out data: components: 'cycles' / 'cycles:N' (one motion cycle in N, "
        "interleaved; default one in 4, or the last 30 %% when a recording has fewer than 8 "
        "cycles), a fraction (the last part of each recording) or another recording; "
        "K&C: rig test name(s) (default single) or another .npz; ride: another .npz; "
        "road: another profile",
    )
    p.add_argument("--data-dir", default=None, help="folder of the real recordings")
    p.set_defaults(func=_diagnose)


def _diagnose(args: argparse.Namespace) -> int:
    from suspenv.cli.targets import resolve_target
    from suspenv.measurements.paths import check_output_dir, plain_file_name

    target = resolve_target(args.recording, args.holdout, args.model, args.data_dir)
    out = Path(args.out) if args.out else Path(f"diagnosis_{plain_file_name(target.stem)}")
    check_output_dir(out, args.overwrite)
    if target.family == "road":
        from suspenv.diagnosis.road import diagnose_road
        from suspenv.reports.diagnosis.road import write_road_report

        road = diagnose_road(target.recordings, heldout=target.holdout)
        paths = write_road_report(road, target.recordings, out)
        print(road.verdict)
    else:
        from suspenv.diagnosis.engine import diagnose
        from suspenv.reports.diagnosis import write_diagnosis_report

        diag = diagnose(
            target.recordings, target.family, target.holdout, progress=target.family == "knc"
        )
        paths = write_diagnosis_report(diag, out)
        print(diag.headline)
        # what was read or changed about the rig and its channels, then the evidence
        for line in [*diag.baseline.get("rig_notes", []), *diag.evidence]:
            print(f"  - {line}")
    for p in paths:
        print(f"wrote {p}")
    return 0
