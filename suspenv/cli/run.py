"""``suspenv run CONFIG``: run an experiment config into a run directory (resumes)."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "run",
        help="run an experiment config (TOML)",
        description="Run an experiment config. Re-running the same config resumes a run that "
        "died, without re-evaluating what is archived.",
    )
    p.add_argument("config", help="path to an experiment TOML file (see experiments/)")
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a config value, e.g. --set strategy.options.popsize=42",
    )
    p.add_argument(
        "--allow-code",
        action="store_true",
        help="allow `module:attribute` problem or strategy names in the config (imports and "
        "runs that code; a config cannot allow it itself)",
    )
    p.add_argument("--workers", type=int, help="evaluate in a process pool of N workers")
    p.add_argument("--dask", metavar="ADDRESS", help="evaluate on a Dask cluster (scheduler)")
    p.add_argument("--output", help="parent folder of run directories (default: runs)")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="delete an existing run directory of a different experiment",
    )
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    overrides = list(args.overrides)
    if args.workers is not None:
        overrides.append(f"run.workers={args.workers}")
    if args.dask:
        overrides.append(f'run.dask_scheduler="{args.dask}"')
    if args.output:
        overrides.append(f'run.output="{args.output}"')
    if args.no_plots:
        overrides.append("run.plots=false")
    if args.quiet:
        overrides.append("run.progress=false")
    from suspenv.runs.config import load_config
    from suspenv.runs.runner import run_experiment

    config = load_config(args.config, overrides, allow_code=args.allow_code)
    run_dir, summary = run_experiment(config, overwrite=args.overwrite)
    from suspenv.cli.show import format_summary

    print(format_summary(summary))
    print(f"run directory: {run_dir}")
    return 0
