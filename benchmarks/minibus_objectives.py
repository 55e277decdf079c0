"""Minibus objectives over the design box: how much each one varies, both objective sets.

For ``--designs`` random designs of the 8-variable box (seeded, uniform) plus the study's
pick and the baseline, every objective of ``MinibusRideHandling`` is evaluated with the
default set (``handling="standard"``) and the study's (``handling="study"``, on a
subset: its time-domain slalom is slow), and so are the per-load-case measures behind
them. Spread = (max - min) / |median| over the designs, in %, and the robust spread
(95th - 5th percentile) / |median|, which corners of the box cannot inflate; the target:
every default objective's robust spread >= 3 %. Numerical noise: the largest relative
difference between the batch's value and the same designs evaluated one at a time
(every default path is deterministic, so this is round-off). The default objectives'
rank correlations with each other and with the understeer and roll gradients
(``summary.rank_correlations``) say how many independent numbers they carry.

The study's table side by side (``summary.paper_table``): the baseline, the study's
pick and the ride-focused pick of the last study run (read from
``docs/benchmarks/minibus_study.json``, so run ``minibus_study`` first): their designs,
both sets' objectives and the routine figures of the study's step 5 (natural
frequencies and their ratio, damping ratios, front share of the roll stiffness; no
load and full load, :func:`suspenv.reports.suspension.suspension_figures`).

Run: ``python -m benchmarks.minibus_objectives [--designs N]``; writes
``docs/benchmarks/minibus_objectives.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import spearmanr

from benchmarks.common import write_result
from suspenv.models.minibus import BASELINE_DESIGN, STUDY_PICK, design_space
from suspenv.problems.minibus import MinibusRideHandling
from suspenv.reports.suspension import suspension_figures

STUDY_JSON = Path(__file__).resolve().parents[1] / "docs" / "benchmarks" / "minibus_study.json"
#: routine figures of the study's step 5 in the side-by-side table
FIGURES = ("freq_front", "freq_rear", "freq_ratio", "zeta_front", "zeta_rear", "roll_share_front")

TARGET_SPREAD_PERCENT = 3.0
#: per-load-case measures reported besides the objectives
MEASURES = (
    "ay_max",
    "understeer",
    "understeer_03g",
    "yaw_overshoot",
    "yaw_bandwidth",
    "yaw_gain",
    "roll_gradient",
)


def _spread(v: np.ndarray) -> float:
    return float(100.0 * np.ptp(v) / abs(np.median(v)))


def _robust_spread(v: np.ndarray) -> float:
    lo, hi = np.percentile(v, [5.0, 95.0])
    return float(100.0 * (hi - lo) / abs(np.median(v)))


def _rows(label: str, p: MinibusRideHandling, X: np.ndarray, n_single: int) -> list[dict[str, Any]]:
    b = p.evaluate(X)
    ok = b.ok
    single = np.vstack([p.evaluate(X[i : i + 1]).objectives for i in range(n_single)])
    noise = np.max(np.abs(single - b.objectives[:n_single]) / np.abs(b.objectives[:n_single]), 0)
    rows = []
    for j, name in enumerate(p.objective_names):
        v = b.objectives[ok, j]
        rows.append(
            {
                "set": label,
                "quantity": name,
                "unit": p.objective_units[j],
                "baseline": float(b.objectives[1, j]),
                "min": float(v.min()),
                "max": float(v.max()),
                "spread_percent": _spread(v),
                "p5_p95_spread_percent": _robust_spread(v),
                "noise_percent": float(100.0 * noise[j]),
            }
        )
    if label == "default":
        for key in MEASURES:
            for lc in ("no_load", "full_load"):
                v = b.extras[f"{key}_{lc}"][ok]
                rows.append(
                    {
                        "set": "measure",
                        "quantity": f"{key}_{lc}",
                        "unit": "",
                        "baseline": float(b.extras[f"{key}_{lc}"][1]),
                        "min": float(v.min()),
                        "max": float(v.max()),
                        "spread_percent": _spread(v),
                        "p5_p95_spread_percent": _robust_spread(v),
                        "noise_percent": float("nan"),
                    }
                )
    return rows


#: the handling measures the default objectives' rank correlations are taken against
FOLLOWED = ("understeer_03g_no_load", "understeer_03g_full_load", "roll_gradient_no_load",
            "roll_gradient_full_load")  # fmt: skip


def rank_correlations(p: MinibusRideHandling, X: np.ndarray) -> dict[str, Any]:
    """Spearman rank correlations (-) over the designs ``X`` between the default set's
    objectives and the handling measures they may follow (:data:`FOLLOWED`): how many
    independent numbers the objectives carry over the box."""
    b = p.evaluate(X)
    names = [*p.objective_names, *FOLLOWED]
    cols = np.column_stack([b.objectives[b.ok], *(b.extras[k][b.ok] for k in FOLLOWED)])
    rho = spearmanr(cols).statistic
    return {"names": names, "spearman": np.round(rho, 4).tolist()}


def paper_table(study_json: Path = STUDY_JSON) -> dict[str, Any]:
    """Designs, both sets' objectives and the routine figures of the baseline, the
    study's pick and the last study run's ride-focused pick (module docstring)."""
    pick = json.loads(study_json.read_text())["summary"]["study"]["ride_focused_pick_x"]
    names = ("baseline", "study's pick", "ride-focused pick")
    X = np.vstack([BASELINE_DESIGN, STUDY_PICK, [pick[k] for k in design_space().names]])
    table: dict[str, Any] = {"designs": dict(zip(names, X.tolist(), strict=True))}
    for label, p in (
        ("default", MinibusRideHandling()),
        ("study", MinibusRideHandling(handling="study")),
    ):
        F = p.evaluate(X).objectives
        table[label] = {
            "names": list(p.objective_names),
            "units": list(p.objective_units or ()),
            "values": dict(zip(names, F.tolist(), strict=True)),
        }
    figs = suspension_figures(X)
    table["figures"] = {
        f"{key}_{lc}": figs[lc][key].tolist() for lc in ("no_load", "full_load") for key in FIGURES
    }
    return table


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=2000, help="random designs (default 2000)")
    ap.add_argument("--study-designs", type=int, default=300, help="of them for the study's set")
    ap.add_argument("--output-dir", default=None)
    args = ap.parse_args(argv if argv is not None else sys.argv[1:])
    rng = np.random.default_rng(2024)
    X = np.vstack(
        [STUDY_PICK, BASELINE_DESIGN, design_space().to_physical(rng.random((args.designs, 8)))]
    )
    rows = _rows("default", MinibusRideHandling(), X, 20)
    rows += _rows("study", MinibusRideHandling(handling="study"), X[: args.study_designs + 2], 3)
    default = [r for r in rows if r["set"] == "default"]
    summary = {
        "what": f"spread (max - min)/|median| over {args.designs} random designs + the "
        "study's pick + the baseline, each objective of both sets",
        "designs": args.designs,
        "study_designs": args.study_designs,
        "target_spread_percent": TARGET_SPREAD_PERCENT,
        "default_min_spread_percent": min(r["p5_p95_spread_percent"] for r in default),
        "default_max_noise_percent": max(r["noise_percent"] for r in default),
        "default_meets_target": all(
            r["p5_p95_spread_percent"] >= TARGET_SPREAD_PERCENT for r in default
        ),
        "paper_table": paper_table(),
        "rank_correlations": rank_correlations(MinibusRideHandling(), X),
        "below_target": [
            f"{r['set']}:{r['quantity']}"
            for r in rows
            if r["set"] != "measure" and r["p5_p95_spread_percent"] < TARGET_SPREAD_PERCENT
        ],
    }
    command = "python -m benchmarks.minibus_objectives"
    write_result("minibus_objectives", rows, summary, command, args.output_dir)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
