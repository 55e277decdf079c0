"""Minibus limit behaviour in the steady circle: which axle saturates first, over the box.

For the study's pick, the baseline and ``--designs`` random designs of the 8-variable box
(uniform, seed :data:`SEED`: the designs of ``benchmarks.minibus_objectives``), both load
cases, the steady circle (:func:`suspenv.rigs.handling.steady_circle`, 15 m) names the
condition that bounds the maximum quasi-steady lateral acceleration: front axle (limit
understeer), rear axle (limit oversteer) or rollover. Reported:

- ``limit``: the counts per load case and the range of ``ay_max`` [m/s^2];
- ``bars``: the empty van's rear-limited share with the front bar stiffer than the rear
  (T2 > T3) and the other way, and per band of the front share of the axle roll
  stiffness (springs + bar in series with the tyres);
- ``reserve``: at the limit, the other axle's capacity over the force the circle needs
  of it, minus 1 (grid-search capacity, :func:`suspenv.rigs.handling.axle_capacity`):
  how far the balance sits from the edge;
- ``load_transfer``: the baseline's steady lateral load transfer per wheel per m/s^2,
  empty, split into elastic (roll-stiffness share), geometric (roll centre) and
  unsprung parts, against the static wheel load;
- ``variants``: the same over the vehicle data that decide it (rear roll-centre height,
  steering compliance): the linear understeer gradient and its steering-compliance and
  bicycle-model terms and the roll gradient at the pick [deg/g], the loaded secant
  understeer ``(steer - L/R) / a_y`` at 3 and 4 m/s^2 (box minimum) [deg/g], the
  rear/front ratio of the baseline's geometric load transfer and the rear-limited
  counts.

Every figure is a model quantity of the stated vehicle data (no timing, no noise: the
search is deterministic). Run: ``python -m benchmarks.minibus_limit [--designs N]``;
writes ``docs/benchmarks/minibus_limit.json`` (about 2 s).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from typing import Any

import numpy as np

from benchmarks.common import write_result
from benchmarks.minibus_speed import steady_loads
from suspenv.models.minibus import BASELINE_DESIGN, STUDY_PICK, design_space
from suspenv.models.minibus.handling_model import (
    DEFAULT_LEAF_GEOMETRY,
    HandlingParams,
    LeafAxleGeometry,
    handling_parameters,
)
from suspenv.models.minibus.vehicle import LOAD_CASES, REFERENCE_MINIBUS, G, Minibus
from suspenv.rigs.handling import (
    SteadyCircleConfig,
    axle_capacity,
    steady_circle,
    steady_state_sweep,
)

#: the random designs' seed (that of ``benchmarks.minibus_objectives``)
SEED = 2024
#: deg/g per rad/(m/s^2)
DEG_PER_G = float(np.degrees(1.0) * G)
#: bands of the front share of the axle roll stiffness
SHARE_EDGES = (0.5, 0.55, 0.6)
#: the vehicle data that decide the balance (docs/minibus_handling.md, "Handling
#: balance"): (rear roll-centre height m, steering trail m, steering stiffness N m/rad)
VARIANTS: dict[str, tuple[float, float, float]] = {
    "before": (0.45, 0.030, 3.0e4),
    "rear roll centre 0.30 m only": (0.30, 0.030, 3.0e4),
    "steering compliance only": (0.45, 0.050, 2.0e4),
    "now": (0.30, 0.050, 2.0e4),
    "now, rear roll centre 0.20 m": (0.20, 0.050, 2.0e4),
    "now, rear roll centre 0.10 m": (0.10, 0.050, 2.0e4),
}


def designs(n: int, seed: int = SEED) -> np.ndarray:
    """The study's pick, the baseline and ``n`` uniform random designs (n + 2, 8)."""
    unit = np.random.default_rng(seed).random((n, 8))
    return np.vstack([STUDY_PICK, BASELINE_DESIGN, design_space().to_physical(unit)])


def vehicle_data(name: str) -> tuple[Minibus, LeafAxleGeometry]:
    """The reference minibus and leaf geometry with the data of variant ``name``."""
    h_rr, trail, k_steer = VARIANTS[name]
    vehicle = dataclasses.replace(REFERENCE_MINIBUS, rear_roll_centre_height=h_rr)
    leaf = dataclasses.replace(
        DEFAULT_LEAF_GEOMETRY, steering_trail=trail, steering_stiffness=k_steer
    )
    return vehicle, leaf


def limits(
    X: np.ndarray,
    load_case: str,
    vehicle: Minibus = REFERENCE_MINIBUS,
    leaf: LeafAxleGeometry = DEFAULT_LEAF_GEOMETRY,
) -> tuple[HandlingParams, np.ndarray, np.ndarray]:
    """(handling parameters, ``ay_max`` m/s^2, the limit's name per design) of designs
    ``X`` in ``load_case`` on the 15 m circle."""
    P = handling_parameters(X, load_case, vehicle=vehicle, leaf=leaf)
    res = steady_circle(P)
    return P, res.ay_max, res.limit


def counts(names: np.ndarray) -> dict[str, int]:
    """How many designs each condition bounds."""
    return {k: int(np.sum(names == k)) for k in ("front", "rear", "rollover")}


def front_share(P: HandlingParams) -> np.ndarray:
    """Front share of the axle roll stiffness (springs + bar in series with the tyres)."""
    return P.kphi_front / P.kphi


def reserve(P: HandlingParams, ay_max: np.ndarray) -> np.ndarray:
    """At ``ay_max``: the larger of the axles' capacity / required force ratios over the
    smaller, minus 1 (the non-limiting axle's reserve)."""
    _, fl, fr, rl, rr = steady_loads(P, ay_max)
    cfg = SteadyCircleConfig()
    need = P.m * ay_max / P.wheelbase
    front = axle_capacity(P.tyre, fl, fr, cfg)[0] / (need * P.b)
    rear = axle_capacity(P.tyre, rl, rr, cfg)[0] / (need * P.a)
    return np.maximum(front, rear) / np.minimum(front, rear) - 1.0


def load_transfer(P: HandlingParams, i: int = 0) -> list[dict[str, Any]]:
    """Row ``i``'s steady lateral load transfer per wheel per m/s^2 [N], by part."""
    phi = P.roll_gradient()[i]
    rows = []
    for axle, k, ms, h, mu, t, fz in (
        ("front", P.kphi_front, P.ms_front, P.h_rc_front, P.mu_front, P.track_front, P.fz_front),
        ("rear", P.kphi_rear, P.ms_rear, P.h_rc_rear, P.mu_rear, P.track_rear, P.fz_rear),
    ):
        parts = {
            "elastic": k[i] * phi / t[i],
            "geometric": ms[i] * h[i] / t[i],
            "unsprung": mu[i] * P.wheel_radius[i] / t[i],
        }
        total = sum(parts.values())
        rows.append(
            {
                "axle": axle,
                "static_N": float(fz[i]),
                **{f"{k}_N": float(v) for k, v in parts.items()},
                "total_N": float(total),
                "of_static": float(total / fz[i]),
            }
        )
    return rows


def understeer_terms(P: HandlingParams, i: int = 0) -> dict[str, float]:
    """Row ``i``'s linear understeer gradient and two of its terms, deg/g: the bicycle
    model's ``m/L (b/Cf - a/Cr)`` and the steering compliance's ``-c_Ff b m/L``."""
    m_l = P.m[i] / P.wheelbase[i]
    return {
        "total": float(P.understeer_gradient()[i] * DEG_PER_G),
        "bicycle": float(
            m_l * (P.b[i] / P.cornering_front[i] - P.a[i] / P.cornering_rear[i]) * DEG_PER_G
        ),
        "steering_compliance": float(-P.force_steer_front[i] * P.b[i] * m_l * DEG_PER_G),
    }


def variant(name: str, X: np.ndarray) -> dict[str, Any]:
    """The figures of variant ``name`` over designs ``X`` (row 0 the pick, 1 the
    baseline; module docstring)."""
    vehicle, leaf = vehicle_data(name)
    out: dict[str, Any] = {
        "rear_roll_centre_m": vehicle.rear_roll_centre_height,
        "steering_trail_m": leaf.steering_trail,
        "steering_stiffness_Nm_per_rad": leaf.steering_stiffness,
    }
    for lc in LOAD_CASES:
        P, _, names = limits(X, lc, vehicle, leaf)
        out[f"rear_limited_{lc}"] = int(np.sum(names == "rear"))
        out[f"understeer_pick_{lc}"] = understeer_terms(P)
        out[f"roll_gradient_pick_{lc}"] = float(P.roll_gradient()[0] * DEG_PER_G)
        if lc == "full_load":
            ay = np.array([3.0, 4.0])
            sw = steady_state_sweep(P, ay)
            secant = (sw.steer - P.wheelbase / 15.0) / ay[:, None] * DEG_PER_G
            out["secant_min_full_load_3_4"] = np.min(secant, axis=1).tolist()
    geo = load_transfer(handling_parameters(X[1:2], "no_load", vehicle=vehicle, leaf=leaf))
    out["geometric_rear_over_front"] = geo[1]["geometric_N"] / geo[0]["geometric_N"]
    return out


def bars(X: np.ndarray, P: HandlingParams, names: np.ndarray) -> dict[str, Any]:
    """The empty van's rear-limited share split by the bars and by the front share of
    the axle roll stiffness."""
    rear = names == "rear"
    t2_stiffer = X[:, 4] > X[:, 5]
    share = front_share(P)
    band = np.digitize(share, SHARE_EDGES)
    edges = (None, *SHARE_EDGES, None)  # open ends (JSON null)
    return {
        "T2_gt_T3": {"designs": int(t2_stiffer.sum()), "rear_limited": int(rear[t2_stiffer].sum())},
        "T2_lt_T3": {
            "designs": int((~t2_stiffer).sum()),
            "rear_limited": int(rear[~t2_stiffer].sum()),
        },
        "front_roll_stiffness_share": [
            {
                "from": edges[j],
                "to": edges[j + 1],
                "designs": int(np.sum(band == j)),
                "rear_limited": int(rear[band == j].sum()),
            }
            for j in range(len(edges) - 1)
        ],
        "front_share_baseline": float(share[1]),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=2000, help="random designs (default 2000)")
    ap.add_argument("--output-dir", default=None)
    args = ap.parse_args(argv if argv is not None else sys.argv[1:])
    X = designs(args.designs)
    rows = []
    summary: dict[str, Any] = {
        "what": f"steady-circle limit over the study's pick, the baseline and "
        f"{args.designs} random designs (seed {SEED}), both load cases",
        "designs": int(X.shape[0]),
        "seed": SEED,
    }
    for lc in LOAD_CASES:
        P, ay_max, names = limits(X, lc)
        r = reserve(P, ay_max)
        rows.append(
            {
                "load_case": lc,
                **counts(names),
                "ay_max_min": float(ay_max.min()),
                "ay_max_median": float(np.median(ay_max)),
                "ay_max_max": float(ay_max.max()),
                "reserve_median": float(np.median(r)),
                "reserve_p90": float(np.percentile(r, 90)),
            }
        )
        if lc == "no_load":
            summary["bars"] = bars(X, P, names)
            summary["load_transfer_baseline_no_load"] = load_transfer(P, 1)
    summary["limit"] = rows
    summary["variants"] = {name: variant(name, X) for name in VARIANTS}
    write_result(
        "minibus_limit", rows, summary, "python -m benchmarks.minibus_limit", args.output_dir
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
