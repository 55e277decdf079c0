"""Minibus suspension elements and vehicle data: two-stage leaf, damper scaling,
hysteretic energy per cycle, unit conversions, validation."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.models.effects.effect import make_effect
from suspenv.models.minibus import (
    REFERENCE_MINIBUS,
    STUDY_PICK,
    design_space,
    design_to_si,
    vehicle_parameters,
)
from suspenv.models.minibus.ride_model import RideModel
from suspenv.models.minibus.suspension import (
    damper_force,
    leaf_force,
    leaf_static_deflection,
    torsion_bar_wheel_rate,
)
from suspenv.models.minibus.vehicle import G


def test_two_stage_leaf_force_deflection():
    k1, k2, dh = 73.5e3, 151.5e3, 0.07
    d = np.array([0.0, 0.03, 0.07, 0.09])
    # hand calculation: k1 d up to the helper contact, then k1 dh + k2 (d - dh)
    expected = [0.0, k1 * 0.03, k1 * 0.07, k1 * 0.07 + k2 * 0.02]
    np.testing.assert_allclose(leaf_force(d, k1, k2, dh), expected)
    # inverse: static deflection returns the deflection that carries the load
    loads = np.array([2000.0, 5145.0, 8000.0])
    defl, on = leaf_static_deflection(loads, np.full(3, k1), np.full(3, k2), dh)
    np.testing.assert_allclose(leaf_force(defl, k1, k2, dh), loads, rtol=1e-12)
    assert on.tolist() == [False, False, True]
    # local slope by finite differences: k1 below, k2 above the knee
    eps = 1e-6
    for x, k in ((0.05, k1), (0.08, k2)):
        slope = (leaf_force(x + eps, k1, k2, dh) - leaf_force(x - eps, k1, k2, dh)) / (2 * eps)
        assert slope == pytest.approx(k, rel=1e-6)


def test_damper_curve_scaling_asymmetry_and_digression():
    curve = REFERENCE_MINIBUS.damper_front
    v = np.linspace(-1.0, 1.0, 41)
    f1 = damper_force(v, curve)
    for c in (0.6, 1.12, 1.8):
        # the study's C scales the force at every velocity
        np.testing.assert_allclose(damper_force(v, curve, c), c * f1)
    # dissipative everywhere: F v >= 0
    assert np.all(f1 * v >= 0)
    # rebound stronger than bump at the same speed (3:1 at low speed by construction)
    assert damper_force(-0.1, curve) == pytest.approx(-3 * damper_force(0.1, curve))
    # digressive: slope above the knee is below the slope under it (finite differences)
    lo = (damper_force(0.05, curve) - damper_force(0.04, curve)) / 0.01
    hi = (damper_force(0.6, curve) - damper_force(0.5, curve)) / 0.1
    assert hi == pytest.approx(curve.bump_high)
    assert lo == pytest.approx(curve.bump_low)


def test_design_unit_conversions():
    si = design_to_si(STUDY_PICK)
    # hand conversions (ride_standards "Conversions"): 1 N*mm/deg = 1e-3 * 180/pi N*m/rad
    assert si.front_torsion_bar[0] == pytest.approx(8.8e4 * 1e-3 * 180 / np.pi)
    assert si.front_wheel_rate[0] == pytest.approx(8.8e4 * 1e-3 * 180 / np.pi / 0.33**2)
    assert si.rear_primary_rate[0] == pytest.approx(73.5e3)
    assert si.front_roll_arb[0] == pytest.approx(6.8e5 * 1e-3 * 180 / np.pi)
    # spec: 7e4..1.5e5 N*mm/deg -> 4.0..8.6 kN*m/rad and 37..79 kN/m at l = 0.33 m
    lo, hi = design_to_si(design_space().lower), design_to_si(design_space().upper)
    assert lo.front_torsion_bar[0] == pytest.approx(4.0e3, rel=0.01)
    assert hi.front_torsion_bar[0] == pytest.approx(8.6e3, rel=0.01)
    assert lo.front_wheel_rate[0] == pytest.approx(37e3, rel=0.01)
    assert hi.front_wheel_rate[0] == pytest.approx(79e3, rel=0.01)
    assert torsion_bar_wheel_rate(1.0, 0.5) == pytest.approx(4.0)


def test_static_loads_balance_the_weight():
    X = np.vstack([STUDY_PICK, design_space().lower])
    for lc in ("no_load", "full_load"):
        p = vehicle_parameters(X, lc)
        # force balance: 2 front + 2 rear spring loads carry the sprung weight
        total = 2 * p.front_static_load + 2 * p.rear_static_load
        assert total == pytest.approx(p.load.sprung_mass * G)
        # moment balance about the CoM
        assert p.front_static_load * p.a == pytest.approx(p.rear_static_load * p.b)
    # the documented intent: empty rides on the primary leaf, full load on the helper
    assert not vehicle_parameters(design_space().lower, "no_load").rear_on_helper.any()
    assert vehicle_parameters(design_space().upper, "full_load").rear_on_helper.all()


def test_bad_designs_and_load_cases_are_rejected():
    with pytest.raises(ValidationError, match=r"shape \(n, 8\)"):
        design_to_si(np.ones((2, 7)))
    with pytest.raises(ValidationError, match="finite and > 0"):
        design_to_si(np.r_[STUDY_PICK[:-1], -1.0])
    bad = STUDY_PICK.copy()
    bad[1] = 50.0
    with pytest.raises(ValidationError, match="K2 >= K1"):
        design_to_si(bad)
    with pytest.raises(ValidationError, match="load case"):
        vehicle_parameters(STUDY_PICK, "half_load")


def test_hysteretic_leaf_energy_per_cycle_matches_dahl_closed_form():
    """Interleaf friction (Dahl) in the ride model: loop area vs the closed form.

    Reference: on a monotone stroke the Dahl force is z = s f_c + (z0 - s f_c)
    exp(-sigma |dx| / f_c); for a symmetric cycle of amplitude A the steady loop has
    z_A = f_c (1 - e)/(1 + e), e = exp(-2 sigma A / f_c), and the energy per cycle is
    2 (2 A f_c - (z_A + f_c) (f_c / sigma) (1 - e)).
    """
    f_c, sigma = 400.0, 1e5
    leaf = make_effect("dahl_hysteresis", location="rear_leaf", f_c=f_c, sigma=sigma)
    p = vehicle_parameters(STUDY_PICK, "no_load")
    model = RideModel(p, effects=[leaf])
    dt, n = 0.002, 4000  # 8 s at 0.5 Hz: quasi-static strokes of the rear axle
    t = dt / 2 * np.arange(2 * n + 1)
    z = np.zeros((t.size, 4))
    z[:, 2:4] = 0.02 * np.sin(2 * np.pi * 0.5 * t)[:, None]
    zd = np.gradient(z, dt / 2, axis=0)
    rec = model.simulate(z, zd, dt, record_states=True)
    nq = model.nq
    states = rec.states[0]  # (S, N)
    defl = model.Et[2, :nq] @ states[:nq]  # left leaf deflection from static (m)
    force = states[2 * nq]  # left leaf hysteretic force (N)
    last = slice(n - 1000, n)  # the last full 2 s cycle
    x, fz = defl[last], force[last]
    energy = np.sum(0.5 * (fz[1:] + fz[:-1]) * np.diff(x))  # closed-path integral of F dx
    amp = 0.5 * (x.max() - x.min())
    e = np.exp(-2 * sigma * amp / f_c)
    z_a = f_c * (1 - e) / (1 + e)
    expected = 2 * (2 * amp * f_c - (z_a + f_c) * (f_c / sigma) * (1 - e))
    assert energy == pytest.approx(expected, rel=0.03)
    assert energy > 0
