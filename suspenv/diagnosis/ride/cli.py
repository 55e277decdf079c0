"""Routing of ``suspenv diagnose`` to the ride and road diagnosis.

:func:`route` takes the parsed ``diagnose`` arguments (``recording``, ``out``,
``holdout``, ``data_dir``) and handles, returning an exit code:

* ``road_profile`` / ``road_profile_1`` / ``road_profile_2``: the shared measured
  profiles (``<data-dir>/road_profiles`` or ``../shared/data/real/road_profiles``),
  fitted on one and validated on the other;
* a ``*.txt`` profile (two columns: distance [m], elevation [m]); ``--holdout``
  another profile (default: the second half of the same one);
* a ride recording (``.npz`` whose test is ``pulse`` or ``random_road``) with
  ``--holdout`` another one, or a folder of them (recordings named ``*run1`` are
  fitted, the others held out).

Anything else returns None (the component engine handles it).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from suspenv.core.errors import ValidationError

SHARED_ROADS = Path(__file__).resolve().parents[3].parent / "shared" / "data" / "real"
RIDE_TESTS = ("pulse", "random_road")


def _road(args: Any) -> int | None:
    from suspenv.diagnosis.ride.road import diagnose_road, load_profile_txt, write_road_report

    name = str(args.recording)
    if name.startswith("road_profile"):
        root = Path(args.data_dir) if getattr(args, "data_dir", None) else SHARED_ROADS
        root = root / "road_profiles" if (root / "road_profiles").is_dir() else root
        first = "profile_2.txt" if name.endswith("_2") else "profile_1.txt"
        second = "profile_1.txt" if first == "profile_2.txt" else "profile_2.txt"
        if not (root / first).is_file():
            raise ValidationError(f"road profiles not found in {str(root)!r} (need {first})")
        rec, held = load_profile_txt(root / first), load_profile_txt(root / second)
    elif name.endswith(".txt"):
        rec = load_profile_txt(name)
        hold = getattr(args, "holdout", None)
        held = load_profile_txt(hold) if hold and str(hold).endswith(".txt") else None
    else:
        return None
    diag = diagnose_road(rec, heldout=held)
    paths = write_road_report(diag, Path(args.out or f"diagnosis_{rec.name}"))
    print(diag.verdict)
    for p in paths:
        print(f"wrote {p}")
    return 0


def _ride_recordings(path: Path) -> list[Any] | None:
    from suspenv.recordings import load_recording

    files = sorted(path.glob("*.npz")) if path.is_dir() else [path]
    if not files or any(f.suffix != ".npz" for f in files):
        return None
    recs = [load_recording(f) for f in files]
    if not all(r.test in RIDE_TESTS for r in recs):
        return None
    return recs


def _ride(args: Any) -> int | None:
    from suspenv.diagnosis.ride.engine import diagnose_ride
    from suspenv.diagnosis.ride.report import write_ride_report

    path = Path(str(args.recording))
    if not path.exists():
        return None
    recs = _ride_recordings(path)
    if recs is None:
        return None
    hold = getattr(args, "holdout", None)
    if hold is not None and str(hold).endswith(".npz"):
        fit, held = recs, _ride_recordings(Path(hold)) or []
    else:
        fit = [r for r in recs if r.name.endswith("run1")] or recs[:1]
        held = [r for r in recs if r not in fit]
    if not held:
        raise ValidationError(
            "a ride diagnosis needs held-out recordings: pass --holdout other.npz or a folder "
            f"holding repeat runs, but got only {[r.name for r in fit]}"
        )
    diag = diagnose_ride(fit, held)
    paths = write_ride_report(diag, Path(args.out or f"diagnosis_{path.stem}"))
    print(diag.verdict)
    for p in paths:
        print(f"wrote {p}")
    return 0


def route(args: Any) -> int | None:
    """Run the ride/road diagnosis when ``args.recording`` is one; else None."""
    rc = _road(args)
    if rc is None:
        rc = _ride(args)
    return rc
