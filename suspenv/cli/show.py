"""``suspenv show RUN``: the summary table of a run directory."""

from __future__ import annotations

import argparse
from typing import Any

from suspenv.runs.quality import scalar_recorded


def format_summary(s: dict[str, Any]) -> str:
    """The summary table of an optimisation run; other pipelines show their scalar items."""
    if "n_evaluations" not in s:
        rows = [
            (k, _fmt(v))
            for k, v in s.items()
            if isinstance(v, (str, int, float, bool)) and v is not None
        ]
        w = max((len(k) for k, _ in rows), default=0)
        return "\n".join(f"{k:<{w}}  {v}" for k, v in rows)
    rows = [
        ("run", s.get("name")),
        ("seed", s.get("seed")),
        ("problem", s.get("problem")),
        ("strategy", s.get("strategy")),
        ("budget", s.get("budget")),
        ("evaluations", s.get("n_evaluations")),
        ("resumed from archive", s.get("n_resumed")),
        ("ok / feasible", f"{s.get('n_ok')} / {s.get('n_feasible')}"),
        ("stop reason", s.get("stop_reason")),
        ("wall time [s]", _fmt(s.get("wall_time_s"))),
        *_best(s),
    ]
    w = max(len(str(k)) for k, _ in rows)
    return "\n".join(f"{k:<{w}}  {v}" for k, v in rows if v is not None)


def _best(s: dict[str, Any]) -> list[tuple[str, Any]]:
    """The run's best quality (:mod:`suspenv.runs.quality`); for several objectives
    without one (or a recorded plain sum of them), the size of its feasible front."""
    name = s.get("quality_name", "quality")
    names = s.get("objective_names") or []
    if scalar_recorded(name, len(names)):
        best = zip(names, s.get("best_objectives") or [], strict=False)
        return [(f"best {name}", _fmt(s.get("best_quality")))] + [
            (f"  best row: {n}", _fmt(v)) for n, v in best
        ]
    return [("feasible front [designs]", s.get("front_size"))]


def _fmt(v: Any) -> Any:
    return f"{v:.6g}" if isinstance(v, float) else v


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("show", help="summary table of a run directory")
    p.add_argument("run", help="run directory (contains summary.json)")
    p.set_defaults(func=_show)


def _show(args: argparse.Namespace) -> int:
    from suspenv.runs.run_dir import load_summary

    print(format_summary(load_summary(args.run)))
    return 0
