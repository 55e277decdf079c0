"""``suspenv export optuna RUN_DIR --storage URL [--study NAME] [--replace]``: a run
directory's evaluations as an optuna study (named parameters and objectives) that
optuna-dashboard reads: ``optuna-dashboard sqlite:///runs.db``. Rules:
:mod:`suspenv.runs.export`."""

from __future__ import annotations

import argparse
from typing import Any


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "export",
        help="export a run directory to another tool's format (optuna storage)",
        description="Export a run directory. `optuna`: every archived evaluation as a trial "
        "of a new optuna study, with the physical parameter values under their names, the "
        "design-space bounds, named objectives, constraints and run attributes.",
    )
    formats = p.add_subparsers(dest="format", metavar="FORMAT", required=True)
    o = formats.add_parser(
        "optuna",
        help="an optuna study (optuna-dashboard reads it)",
        description="Write RUN_DIR's evaluations to an optuna storage as one study; view it "
        "with `optuna-dashboard <storage URL>`.",
    )
    o.add_argument("run_dir", metavar="RUN_DIR", help="run directory (holds archive.sqlite)")
    o.add_argument(
        "--storage",
        required=True,
        help="optuna storage URL, e.g. sqlite:///runs.db (a plain file path means SQLite)",
    )
    o.add_argument("--study", default=None, help="study name (default: the run directory's name)")
    o.add_argument(
        "--replace", action="store_true", help="replace a study of that name in the storage"
    )
    o.set_defaults(func=_export_optuna)


def _export_optuna(args: argparse.Namespace) -> int:
    import sys

    from tqdm.auto import tqdm

    from suspenv.runs.export import export_optuna

    bar: Any = None

    def progress(done: int, total: int) -> None:
        nonlocal bar
        if bar is None:
            bar = tqdm(total=total, unit="trial", desc="optuna export", file=sys.stderr)
        bar.update(done - bar.n)

    try:
        r = export_optuna(
            args.run_dir, args.storage, args.study, replace=args.replace, progress=progress
        )
    finally:
        if bar is not None:
            bar.close()
    print(
        f"wrote study {r.study_name!r} to {r.storage}: {r.n_trials} trials "
        f"({r.n_complete} complete, {r.n_failed} failed; bounds from the {r.bounds})"
    )
    print(f"view it: optuna-dashboard {r.storage}")
    return 0
