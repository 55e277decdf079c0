"""``suspenv compare RUN...``: several strategies/seeds side by side (table + spread plot)."""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from suspenv.cli.show import load_summary
from suspenv.core.errors import ValidationError
from suspenv.experiments.plots import plot_compare


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compare", help="compare runs (strategies x seeds): table and plot")
    p.add_argument("runs", nargs="+", help="run directories")
    p.add_argument("--out", default="compare", help="folder for compare.png / compare.json")
    p.set_defaults(func=_compare)


def compare_runs(runs: list[str | Path], out: str | Path) -> dict:
    summaries = [load_summary(r) for r in runs]
    problems = {s["problem"] for s in summaries}
    if len(problems) > 1:
        raise ValidationError(f"compare needs runs of one problem, but got {sorted(problems)}")
    groups: dict[str, list[dict]] = defaultdict(list)
    for s in summaries:
        groups[s["strategy"]].append(s)
    table = []
    curves = {}
    for strat, ss in groups.items():
        best = np.array(
            [s["best_quality"] if s["best_quality"] is not None else np.nan for s in ss]
        )
        evals = [s["n_evaluations"] for s in ss]
        table.append(
            {
                "strategy": strat,
                "runs": len(ss),
                "seeds": sorted(s["seed"] for s in ss),
                "evaluations": int(np.median(evals)),
                "best_median": float(np.nanmedian(best)),
                "best_min": float(np.nanmin(best)),
                "best_max": float(np.nanmax(best)),
                "wall_time_median_s": float(np.median([s["wall_time_s"] for s in ss])),
            }
        )
        curves[strat] = [
            np.array([np.inf if v is None else v for v in s["quality_curve"]]) for s in ss
        ]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    ylabel = f"best {summaries[0].get('quality_name', 'quality')}"
    plot_compare(curves, ylabel, out / "compare.png")
    result = {
        "problem": problems.pop(),
        "quality_name": summaries[0].get("quality_name"),
        "table": table,
    }
    (out / "compare.json").write_text(json.dumps(result, indent=2) + "\n")
    return result


def _compare(args: argparse.Namespace) -> int:
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
