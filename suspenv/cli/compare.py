"""``suspenv compare RUN...``: runs grouped by full configuration, compared per problem.

Prints per problem a table (group, configuration hash, runs, budget, quality at the common
budget: median and quartiles, ECDF area) with the flags and the rank-test verdicts;
writes ``compare.json``, ``compare.md`` and the figures into ``--out`` (see
``docs/analysis.md``)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from suspenv.core.markdown import fmt


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "compare",
        help="compare runs (strategies x seeds): tables, fixed-budget/target views, rank tests",
        description="Group runs by their full strategy configuration (hash shown), refuse "
        "to pool unlike runs, and report fixed-budget and fixed-target views (ERT, runtime "
        "ECDF, performance profile), hypervolume/IGD for multi-objective runs and rank "
        "tests. Definitions: docs/analysis.md.",
    )
    p.add_argument(
        "runs",
        nargs="+",
        help="run directories, or the output folder of `suspenv suite run` (its suite.json "
        "gives every instance's known optimum, target or reference front)",
    )
    p.add_argument("--out", default="compare", help="folder for compare.json, .md and figures")
    p.add_argument(
        "--suite",
        action="store_true",
        help="runs of several problem configurations: report each problem on its own and "
        "compare strategies across them by a performance profile (never pooled)",
    )
    p.add_argument(
        "--allow-unequal-budgets",
        action="store_true",
        help="pool runs of one group with different budgets (compared at the smallest)",
    )
    p.add_argument(
        "--measure",
        choices=("auto", "quality", "hypervolume"),
        default="auto",
        help="what is compared; auto: the run's quality, or the hypervolume deficit for "
        "multi-objective runs without a scalar quality",
    )
    p.add_argument(
        "--f-opt", type=float, default=None, help="known optimum of the quality (targets)"
    )
    p.add_argument("--n-targets", type=int, default=21, help="number of targets (default 21)")
    p.add_argument("--alpha", type=float, default=0.05, help="test level (default 0.05)")
    p.add_argument("--ioh", action="store_true", help="also write the IOHanalyzer export ioh/")
    p.add_argument("--no-plots", action="store_true", help="no figures")
    p.set_defaults(func=_compare)


def _g(v: Any) -> str:
    return "-" if v is None else fmt(v, missing="-")


def _compare(args: argparse.Namespace) -> int:
    from suspenv.analysis.compare import check_options, compare, compare_suite
    from suspenv.reports.analysis import write_compared
    from suspenv.suite.runner import SUITE_FILE

    check_options(args.f_opt, args.n_targets, args.alpha, args.measure)
    options: dict[str, Any] = {
        "allow_unequal_budgets": args.allow_unequal_budgets,
        "measure": args.measure,
        "n_targets": args.n_targets,
        "alpha": args.alpha,
    }
    if len(args.runs) == 1 and (Path(args.runs[0]) / SUITE_FILE).is_file():
        comparison = compare_suite(args.runs[0], **options)
    else:
        comparison = compare(args.runs, suite=args.suite, f_opt=args.f_opt, **options)
    result = write_compared(comparison, args.out, figures=not args.no_plots, ioh=args.ioh)
    for prob in result["problems"]:
        print(
            f"problem: {prob['problem']}[{prob['hash']}]   measure: {prob['measure']} "
            f"(lower is better) at {prob['common_budget']} evaluations"
        )
        hdr = (
            f"{'group':<22} {'hash':<8} {'runs':>4} {'budget':>8} {'median':>11} "
            f"{'q25':>11} {'q75':>11} {'ecdf':>6}  differs"
        )
        print(hdr)
        print("-" * len(hdr))
        for r in sorted(prob["table"], key=lambda r: (r["median"] is None, r["median"] or 0)):
            budget = "/".join(map(str, r["budgets"])) + ("*" if r["unequal_budget"] else "")
            differs = ", ".join(f"{k}={v}" for k, v in r["differs"].items())
            print(
                f"{r['group']:<22} {r['hash']:<8} {r['runs']:>4} {budget:>8} "
                f"{_g(r['median']):>11} {_g(r['q25']):>11} {_g(r['q75']):>11} "
                f"{_g(r['ecdf_area']):>6}  {differs}"
            )
        for flag in prob["flags"]:
            print(f"flag: {flag}")
        tests = prob["rank_tests"]
        fr = tests["friedman"]
        if fr and "p" in fr:
            print(f"Friedman over seeds {fr['seeds']}: p = {fr['p']:.3g}")
        for pair in tests["pairs"]:
            print(f"{pair['a']} vs {pair['b']}: {pair['verdict']}")
        print()
    if result["performance_profile"]:
        print(
            f"performance profile over {len(result['performance_profile']['instances'])} "
            "(problem, target) instances: profile.png"
        )
    print(f"wrote {', '.join(result.get('files', []))} into {Path(args.out)}")
    return 0
