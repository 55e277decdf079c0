"""Limit behaviour of the minibus in the steady circle (docs/minibus_handling.md, "Limit
behaviour"): which axle saturates first, against an independent steady-state load
transfer written here, and the figures ``benchmarks.minibus_limit`` writes."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

from benchmarks import minibus_limit as ml
from suspenv.models.minibus.handling_model import handling_parameters
from suspenv.models.minibus.tyre import LIGHT_TRUCK_TYRE
from suspenv.models.minibus.vehicle import (
    BASELINE_DESIGN,
    LOAD_CASES,
    REFERENCE_MINIBUS,
    G,
    vehicle_parameters,
)

#: the circle search's grid step (m/s^2) plus the tabulated capacity's error (about
#: 2e-5 of 10 kN, over the ~1 kN per m/s^2 by which the axle's required force grows)
AY_TOL = 1.2e-3


def _tyre_force(alpha: np.ndarray | float, fz: float) -> np.ndarray:
    """Lateral force (N) of one tyre at slip ``alpha`` (rad) and load ``fz`` (N): the
    pure-slip Magic Formula (Pacejka, *Tyre and Vehicle Dynamics*, 3rd ed., 2012, ch. 4,
    MF 5.2 without shifts, camber and scaling) with the reference tyre's coefficients,
    written out here."""
    t = LIGHT_TRUCK_TYRE
    if fz <= 0:
        return np.zeros_like(alpha)
    dfz = (fz - t.fz0) / t.fz0
    d = t.pDy1 * (1 + t.pDy2 * dfz) * fz
    ky = t.pKy1 * t.fz0 * np.sin(2 * np.arctan(fz / (t.pKy2 * t.fz0)))
    b = ky / (t.pCy1 * d)
    e = t.pEy1 + t.pEy2 * dfz
    ba = b * alpha
    return d * np.sin(t.pCy1 * np.arctan(ba - e * (ba - np.arctan(ba))))


def _capacity(fz_in: float, fz_out: float) -> float:
    """Peak over slip angle of an axle's two tyres' force (N): a 0.05 deg scan, then
    bounded Brent around its best point."""
    grid = np.radians(np.arange(0.0, 20.0, 0.05))
    j = int(
        np.clip(np.argmax(_tyre_force(grid, fz_in) + _tyre_force(grid, fz_out)), 1, grid.size - 2)
    )
    res = minimize_scalar(
        lambda a: -float(_tyre_force(a, fz_in) + _tyre_force(a, fz_out)),
        bounds=(grid[j - 1], grid[j + 1]),
        method="bounded",
        options={"xatol": 1e-12},
    )
    return -float(res.fun)


def _axle_limits(x: np.ndarray, load_case: str) -> tuple[float, float, bool]:
    """(a_y at which the front axle saturates, the rear, whether an inner wheel lifts
    before the first) of design ``x`` in the steady circle, m/s^2, from the vehicle data
    alone: the textbook steady load transfer per axle (Milliken & Milliken, *Race Car
    Vehicle Dynamics*, 1995, ch. 18): elastic by the axle's roll stiffness (springs +
    bar in series with the tyres) times the body roll ``ms h' a_y / (K_f + K_r - ms h'
    g)``, geometric by the axle's sprung-mass share times its roll-centre height, and
    the unsprung mass at wheel-centre height; the axle forces the circle needs from the
    lateral and yaw balance (``m a_y b / L``, ``m a_y a / L``); an axle saturates where
    that force reaches the peak of its two tyres' force at their loads (brentq). None of
    the handling model's or the rigs' functions."""
    v, lc = REFERENCE_MINIBUS, REFERENCE_MINIBUS.load_case(load_case)
    vp = vehicle_parameters(x[None, :], load_case, v)
    L, ms = v.wheelbase, lc.sprung_mass
    muf, mur = 2 * v.unsprung_front, 2 * v.unsprung_rear
    m = ms + muf + mur
    a_s = float(np.broadcast_to(vp.a, (1,))[0])  # sprung CoM behind the front axle
    a = (ms * a_s + mur * L) / m
    h_rf = v.front_ic_height * (v.track_front / 2) / v.front_ic_inboard
    h_rr = v.rear_roll_centre_height
    h_prime = lc.cg_z - (h_rf + (h_rr - h_rf) * a_s / L)

    def series(k_susp: float, track: float) -> float:
        k_tyre = v.tyre_vertical_stiffness * track**2 / 2
        return k_susp * k_tyre / (k_susp + k_tyre)

    k_f = series(
        float(vp.design.front_wheel_rate[0]) * v.track_front**2 / 2
        + float(vp.design.front_roll_arb[0]),
        v.track_front,
    )
    k_r = series(
        float(vp.rear_static_rate[0]) * v.leaf_spacing**2 / 2 + float(vp.design.rear_roll_arb[0]),
        v.track_rear,
    )
    roll_per_ay = ms * h_prime / (k_f + k_r - ms * h_prime * G)
    axles = (
        (k_f, ms * (L - a_s) / L, h_rf, muf, v.track_front, v.unsprung_front, m * (L - a) / L),
        (k_r, ms * a_s / L, h_rr, mur, v.track_rear, v.unsprung_rear, m * a / L),
    )
    limits, lift = [], []
    for k, ms_i, h_rc, mu, track, mu_corner, share in axles:
        dfz = (k * roll_per_ay + ms_i * h_rc + mu * v.tyre_loaded_radius) / track  # N per m/s^2
        fz = ms_i * G / 2 + mu_corner * G
        ay = brentq(
            lambda ay, fz=fz, dfz=dfz, share=share: (
                _capacity(fz - dfz * ay, fz + dfz * ay) - share * ay
            ),
            1.0,
            12.0,
            xtol=1e-9,
        )
        limits.append(ay)
        lift.append(fz / dfz)
    return limits[0], limits[1], min(lift) < min(limits)


def _designs() -> np.ndarray:
    """The baseline, the bars at the box's opposite corners and three random designs."""
    X = np.vstack([BASELINE_DESIGN] * 3 + [ml.designs(3, seed=7)[2:]])
    lo, hi = 2e5, 9e5
    X[1, 4], X[1, 5] = hi, lo  # stiff front bar (T2), soft rear (T3)
    X[2, 4], X[2, 5] = lo, hi
    return X


@pytest.mark.parametrize("load_case", LOAD_CASES)
def test_limit_axle_is_the_one_that_saturates_first_in_a_textbook_load_transfer(load_case):
    # the steady circle's limit and its name (benchmarks.minibus_limit.limits, which
    # the JSON's counts tally) against the independent calculation above
    X = _designs()
    _, ay_max, names = ml.limits(X, load_case)
    ref = np.array([_axle_limits(x, load_case) for x in X])
    front, rear, lifted = ref.T
    assert not lifted.any()  # below rollover: the limit is an axle's
    np.testing.assert_allclose(ay_max, np.minimum(front, rear), atol=AY_TOL)
    clear = np.abs(front - rear) > AY_TOL  # rows whose axle order the search can resolve
    assert clear.sum() >= 4
    expected = np.where(front < rear, "front", "rear")
    np.testing.assert_array_equal(names[clear], expected[clear])
    if load_case == "no_load":  # the bar split decides it empty
        assert (names[1], names[2]) == ("front", "rear")
    else:  # 56 % of the load on the rear axle: rear-limited whatever the bars
        assert set(names) == {"rear"}


def test_load_transfer_table_balances_the_overturning_moment():
    # the JSON's per-m/s^2 load transfer of the baseline, empty: its parts add up, and
    # the two axles' transfers times their tracks balance the overturning moment at
    # a_y = 1 m/s^2 (Gillespie, *Fundamentals of Vehicle Dynamics*, 1992, ch. 8): the
    # sprung mass at its CoM height, its lateral shift by the body roll, and the
    # unsprung masses at wheel-centre height
    P = handling_parameters(BASELINE_DESIGN[None, :], "no_load")
    rows = ml.load_transfer(P)
    for r in rows:
        parts = r["elastic_N"] + r["geometric_N"] + r["unsprung_N"]
        assert parts == pytest.approx(r["total_N"], rel=1e-12)
        assert r["of_static"] == pytest.approx(r["total_N"] / r["static_N"], rel=1e-12)
    v, lc = REFERENCE_MINIBUS, REFERENCE_MINIBUS.load_case("no_load")
    moment = rows[0]["total_N"] * v.track_front + rows[1]["total_N"] * v.track_rear
    roll = float(P.roll_gradient()[0])  # rad at 1 m/s^2
    sprung = lc.sprung_mass * (lc.cg_z + G * float(P.h_prime[0]) * roll)
    unsprung = 2 * (v.unsprung_front + v.unsprung_rear) * v.tyre_loaded_radius
    assert moment == pytest.approx(sprung + unsprung, rel=1e-9)


def test_counts_and_bar_split_tally_the_names():
    X = ml.designs(40)
    P, _, names = ml.limits(X, "no_load")
    c = ml.counts(names)
    assert sum(c.values()) == X.shape[0]
    split = ml.bars(X, P, names)
    assert split["T2_gt_T3"]["rear_limited"] + split["T2_lt_T3"]["rear_limited"] == c["rear"]
    assert sum(b["designs"] for b in split["front_roll_stiffness_share"]) == X.shape[0]
