"""``suspenv diagnose RECORDING [--model NAME] [--out DIR]``: locate, name, model, refit, show.

RECORDING is a recording file (``.npz``, see ``docs/recordings.md``) or the name of a
real-data converter (``emps``, ``mr_damper``, ``damper_dyno``, ``road_profile``; read from
``../shared/data/real``). K&C rig recordings of the McPherson axle (a ``.npz`` file or
folder of them, or ``knc-blind:SEED`` for a generated blind case) go to the K&C
diagnosis; minibus ride recordings and road profiles (``.txt``) to the ride diagnosis.
Writes ``report.md`` (with PNG figures) and ``diagnosis.json`` into ``--out``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from suspenv.core.errors import ValidationError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "diagnose",
        help="find, name and model the physics a component model leaves out of a recording",
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
        help="component family: damper, mr_damper, friction_guide (default: from the data)",
    )
    p.add_argument("--out", default=None, help="output folder (default: diagnosis_<name>)")
    p.add_argument(
        "--holdout",
        default=None,
        help="held-out data: a fraction (default 0.3), 'cycles' / 'cycles:N' (one motion "
        "cycle in N, interleaved) or another .npz recording",
    )
    p.add_argument("--data-dir", default=None, help="folder of the real recordings")
    p.set_defaults(func=_diagnose)


def _guess_family(rec) -> str:
    names = set(rec.inputs)
    if "acceleration" in names and "position" in names:
        return "friction_guide"
    raise ValidationError(
        f"cannot tell the component family of recording {rec.name!r} (inputs {sorted(names)}); "
        "pass --model damper | mr_damper | friction_guide"
    )


def _diagnose(args: argparse.Namespace) -> int:
    from suspenv.diagnosis.knc.cli import is_knc_target
    from suspenv.diagnosis.knc.cli import run as run_knc
    from suspenv.diagnosis.ride.cli import route as route_ride

    if is_knc_target(args.recording):
        return run_knc(args)
    if (code := route_ride(args)) is not None:
        return code
    return _diagnose_component(args)


def _diagnose_component(args: argparse.Namespace) -> int:
    from suspenv.diagnosis.benchmark import REAL_CASES, SHARED_REAL
    from suspenv.diagnosis.engine import diagnose
    from suspenv.diagnosis.report import write_report
    from suspenv.recordings import load_recording

    name = args.recording
    if name in REAL_CASES:
        root = Path(args.data_dir) if args.data_dir else SHARED_REAL
        if not root.is_dir():
            raise ValidationError(f"real recordings folder {str(root)!r} does not exist")
        rec, holdout, family, _ = REAL_CASES[name](root)
        stem = name
    else:
        path = Path(name)
        if path.suffix != ".npz":
            raise ValidationError(
                f"RECORDING must be a .npz file or one of {sorted(REAL_CASES)}, but got {name!r}"
            )
        rec = load_recording(path)
        holdout, family, stem = 0.3, None, path.stem
    if args.holdout is not None:
        try:
            holdout = float(args.holdout)
        except ValueError:
            if args.holdout.startswith("cycles"):
                holdout = args.holdout
            else:
                holdout = load_recording(Path(args.holdout))
    family = args.model or family or _guess_family(rec)
    diag = diagnose(rec, family, holdout=holdout)
    out = Path(args.out or f"diagnosis_{stem}")
    paths = write_report(diag, out)
    print(diag.verdict)
    for p in paths:
        print(f"wrote {p}")
    return 0
