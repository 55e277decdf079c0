"""``suspenv compare RUN...``: several strategies/seeds side by side (table + spread plot)."""

from __future__ import annotations

import argparse
from pathlib import Path


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compare", help="compare runs (strategies x seeds): table and plot")
    p.add_argument("runs", nargs="+", help="run directories")
    p.add_argument("--out", default="compare", help="folder for compare.png / compare.json")
    p.set_defaults(func=_compare)


def _compare(args: argparse.Namespace) -> int:
    from suspenv.runs.compare import compare_runs

    result = compare_runs(args.runs, args.out)
    print(f"problem: {result['problem']}   quality: {result['quality_name']} (lower is better)")
    hdr = f"{'strategy':<10} {'runs':>4} {'evals':>6} {'median':>12} {'min':>12} {'max':>12}"
    print(hdr)
    print("-" * len(hdr))
    for r in sorted(result["table"], key=lambda r: r["best_median"]):
        print(
            f"{r['strategy']:<10} {r['runs']:>4} {r['evaluations']:>6} "
            f"{r['best_median']:>12.6g} {r['best_min']:>12.6g} {r['best_max']:>12.6g}"
        )
    print(f"wrote {Path(args.out) / 'compare.png'} and compare.json")
    return 0
