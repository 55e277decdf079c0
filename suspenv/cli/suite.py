"""``suspenv suite``: list the benchmark suite's instances, run strategies over them, and
recompute a reference front.

    suspenv suite                                  # the instances (dimension, budget, optimum)
    suspenv suite run --strategies cmaes random --seeds 1 2 3 4 5 --out runs/suite
    suspenv suite front minibus --budget 15000     # recompute a shipped reference front
"""

from __future__ import annotations

import argparse
import json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "suite",
        help="the benchmark suite: instances, runs, reference fronts",
        description="List the suite's instances (default), run strategies over them, or "
        "recompute a reference front.",
    )
    p.add_argument("--json", action="store_true", help="print the instance cards as JSON")
    p.set_defaults(func=_list)
    actions = p.add_subparsers(dest="action", metavar="ACTION")

    run = actions.add_parser("run", help="run strategies x seeds over the suite's instances")
    run.add_argument(
        "--strategies",
        nargs="+",
        required=True,
        help="registered strategies (`suspenv list`) or plug-ins strategies/FILE.py:CLASS",
    )
    run.add_argument(
        "--seeds",
        nargs="+",
        type=int,
        help="distinct seeds (default: 1..n, n the larger of 5 and the fewest that let "
        "the rank tests tell the strategies apart at --alpha after Holm's correction)",
    )
    run.add_argument(
        "--alpha", type=float, default=0.05, help="level of the rank tests (default 0.05)"
    )
    run.add_argument(
        "--functions", nargs="+", help="suite functions or NAME/iN instances (default: all)"
    )
    run.add_argument("--out", default="runs/suite", help="output folder (default runs/suite)")
    run.add_argument(
        "--budget-scale", type=float, default=1.0, help="multiply every budget (quick looks)"
    )
    run.add_argument("--workers", type=int, default=1, help="process pool per run")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.set_defaults(func=_run)

    front = actions.add_parser("front", help="recompute a reference front (NSGA-II)")
    front.add_argument("name", help="a multi-objective suite function, e.g. minibus")
    front.add_argument("--budget", type=int, default=15000, help="evaluations per seed")
    front.add_argument("--seeds", nargs="+", type=int, default=[1, 2])
    front.add_argument("--population", type=int, default=200)
    front.set_defaults(func=_front)


def _list(args: argparse.Namespace) -> int:
    from suspenv.suite.instances import FUNCTIONS, SUITE_VERSION, build

    cards = [build(name, f.instances[0]).describe() for name, f in FUNCTIONS.items()]
    if args.json:
        print(json.dumps(cards, indent=2))
        return 0
    print(f"suite {SUITE_VERSION}")
    hdr = f"{'function':<14} {'inst':>5} {'d':>3} {'m':>3} {'k':>3} {'budget':>6}  known"
    print(hdr)
    print("-" * len(hdr))
    for card, f in zip(cards, FUNCTIONS.values(), strict=True):
        k = card["known"]
        known = f"front {k['front']}" if k["kind"] == "front" else f"{k['kind']} {k['f']:.4g}"
        inst = f"{len(f.instances)}" if len(f.instances) > 1 else "1"
        noisy = " (noisy)" if card["noisy"] else ""
        print(
            f"{card['function']:<14} {inst:>5} {card['dimension']:>3} {card['objectives']:>3} "
            f"{card['constraints']:>3} {card['budget']:>6}  {known}{noisy}"
        )
    return 0


def _run(args: argparse.Namespace) -> int:
    from suspenv.analysis.stats import seed_plan
    from suspenv.suite.runner import run_suite

    seeds, note = seed_plan(len(args.strategies), args.seeds, args.alpha)
    print(note + (f" (seeds {seeds[0]}..{seeds[-1]} chosen)" if args.seeds is None else ""))
    result = run_suite(
        args.strategies,
        seeds,
        args.out,
        functions=args.functions,
        budget_scale=args.budget_scale,
        workers=args.workers,
        progress=not args.quiet,
    )
    print(f"{len(result['runs'])} runs in {args.out} (suite.json lists them)")
    return 0


def _front(args: argparse.Namespace) -> int:
    from suspenv.suite.fronts import compute_front

    front = compute_front(args.name, args.budget, tuple(args.seeds), args.population)
    print(f"{front.name}: {len(front.points)} points ({front.provenance['command']})")
    return 0
