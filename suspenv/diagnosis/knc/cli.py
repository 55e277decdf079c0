"""Command-line entry of the K&C diagnosis (called by ``suspenv diagnose``).

Targets:

* ``knc-blind:SEED``: a blind K&C case made from the seed (its truth is not shown);
* a folder of K&C recordings (``*.npz`` with ``meta["rig"] == "knc"``), or one such
  file (the other K&C recordings of its folder are taken with it).

Held out: ``--holdout`` names rig test(s) (default ``single``) or another ``.npz``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from suspenv.core.errors import ValidationError

BLIND_PREFIX = "knc-blind:"


def is_knc_target(target: str) -> bool:
    """True when ``target`` is a blind K&C case, a folder or a file of K&C recordings."""
    if target.startswith(BLIND_PREFIX):
        return True
    p = Path(target)
    files = sorted(p.glob("*.npz")) if p.is_dir() else [p] if p.suffix == ".npz" else []
    if not files or not files[0].exists():
        return False
    from suspenv.diagnosis.knc.recording import is_knc
    from suspenv.recordings import load_recording

    return is_knc(load_recording(files[0]))


def load_target(target: str) -> tuple[dict[str, Any], str]:
    """({test: Recording}, stem) of a K&C target."""
    from suspenv.diagnosis.knc.recording import blind_case, is_knc, rig_test
    from suspenv.recordings import load_recording

    if target.startswith(BLIND_PREFIX):
        text = target[len(BLIND_PREFIX) :]
        if not text.isdigit():
            raise ValidationError(f"`knc-blind:SEED` needs an integer seed, but got {text!r}")
        case, _ = blind_case(int(text))
        return case["recordings"], f"knc_blind_{text}"
    p = Path(target)
    folder = p if p.is_dir() else p.parent
    recs = [load_recording(f) for f in sorted(folder.glob("*.npz"))]
    recs = [r for r in recs if is_knc(r)]
    if not recs:
        raise ValidationError(f"no K&C recordings (meta rig = 'knc') found in {str(folder)!r}")
    return {rig_test(r): r for r in recs}, folder.name or "knc"


def run(args: argparse.Namespace) -> int:
    """Diagnose ``args.recording`` (a K&C target) and write the report to ``args.out``."""
    from suspenv.diagnosis.knc.diagnose import diagnose_knc
    from suspenv.recordings import load_recording

    recs, stem = load_target(args.recording)
    holdout: Any = getattr(args, "holdout", None) or "single"
    if str(holdout).endswith(".npz"):
        holdout = [load_recording(Path(holdout))]
    elif isinstance(holdout, str):
        holdout = [h.strip() for h in holdout.split(",") if h.strip()]
    out = Path(getattr(args, "out", None) or f"diagnosis_{stem}")
    diag = diagnose_knc(recs, holdout=holdout, report_dir=out, progress=True)
    print(diag.verdict)
    print(f"report: {out / 'report.md'}")
    return 0
