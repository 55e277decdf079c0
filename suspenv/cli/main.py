"""``suspenv`` console script. Each command lives in its own module in this package,
exposing ``register(subparsers)`` which adds its parser and sets ``func(args) -> int``."""

from __future__ import annotations

import argparse
import importlib
import sys

from suspenv.core.errors import SuspenvError

#: command modules, in the order they are listed by ``suspenv --help``
COMMAND_MODULES = (
    "run",
    "list_cmd",
    "show",
    "compare",
    "export",
    "suite",
    "knc",
    "planar",
    "diagnose",
    "identify",
)


def add_output_options(
    p: argparse.ArgumentParser, default: str | None, files: str, out_help: str = ""
) -> None:
    """``--out`` (``default``; None: named by the command from its input) and
    ``--overwrite``: the rule of :func:`suspenv.measurements.paths.check_output_dir`, whose
    message the help repeats with the command's ``files``."""
    p.add_argument("--out", default=default, help=out_help or f"output folder (default: {default})")
    p.add_argument(
        "--overwrite",
        action="store_true",
        help=f"write into an existing non-empty output folder: replace the {files} of the "
        "same names; other files are kept, nothing is deleted",
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="suspenv",
        description="Vehicle suspension problems as fast, honest black-box optimisation.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        module = importlib.import_module(f"suspenv.cli.{name}")
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except (SuspenvError, OSError) as exc:  # OSError: a missing, unreadable or unwritable file
        print(f"suspenv {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"suspenv {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
