"""Signature detectors on planted cases.

Reference: each planted residual is made by the effect library's own element
functions (suspenv.models.effects), an implementation independent of the
detectors' feature builders; the baseline is a linear spring-damper fitted by
ordinary least squares, so the planted part the baseline cannot absorb is what
the detectors see.
"""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.diagnosis.component.signatures import (
    SignalSet,
    first_order_lowpass,
    score_signatures,
    unit_dahl,
)
from suspenv.diagnosis.screening import effective_n, partial_r2
from suspenv.models.effects import damper_curves, friction, hysteresis, sensor, stiffness
from suspenv.models.effects.viscoelastic import maxwell_series

T = np.arange(0.0, 8.0, 0.004)
# sine with a slowly growing amplitude (amplitudes differ, reversals at many strokes)
X = 0.02 * (0.4 + 0.6 * T / T[-1]) * np.sin(2 * np.pi * 1.5 * T)
V = np.gradient(X, T)
BASE = 20000.0 * X + 1500.0 * V
NOISE = np.random.default_rng(7).normal(0.0, 3.0, T.size)


def _signals(measured: np.ndarray, fit_baseline: bool = True) -> SignalSet:
    """Residual of an OLS spring-damper fit (or of the exact baseline) as a SignalSet."""
    J = np.c_[X, V]
    if fit_baseline:
        coef, *_ = np.linalg.lstsq(J, measured, rcond=None)
        pred = J @ coef
    else:
        pred = BASE
    scale = float(np.std(measured))
    return SignalSet(
        T,
        X,
        V,
        (measured - pred) / scale,
        pred / scale,
        J / scale if fit_baseline else None,
        scale=scale,
        unit="N",
    )


PLANTED = {
    "friction": lambda: friction.coulomb_smooth(V, 60.0, 1e-3),
    "hysteresis": lambda: hysteresis.dahl_path(X, 80.0 / 0.003, 80.0),
    "progressive": lambda: stiffness.cubic_stiffness(X, 4e6),
    "end_stop": lambda: stiffness.bump_stop(X, 0.012, 3e5),
    "damper_asymmetry": lambda: damper_curves.extra_rebound_damping(V, 600.0),
    "digressive": lambda: damper_curves.damper_digressive(V, 3000.0, 0.03),
    "sensor_offset": lambda: np.full(T.size, 40.0),
}


@pytest.mark.parametrize("kind", sorted(PLANTED))
def test_planted_effect_ranks_first(kind: str) -> None:
    sigs = score_signatures(_signals(BASE + PLANTED[kind]() + NOISE))
    assert sigs[0].kind == kind, [(s.kind, round(s.score, 3)) for s in sigs[:3]]
    assert sigs[0].score > 0.5
    assert sigs[0].p_value < 1e-6
    assert sigs[0].evidence


def test_end_stop_signature_tells_one_side_from_both() -> None:
    # X reaches +-20 mm; a bump stop at 12 mm and a rebound stop at 10 mm (library elements)
    one = score_signatures(_signals(BASE + PLANTED["end_stop"]() + NOISE), ["end_stop"])[0]
    assert one.numbers["sides"] == 1.0
    # thresholds are quantiles of x (a coarse grid): on the right side, near the contact
    assert one.numbers["threshold_bump_m"] == pytest.approx(0.012, abs=0.004)
    assert "threshold_rebound_m" not in one.numbers
    pair = stiffness.bump_and_rebound_stops(X, 0.012, 3e5, 0.010, 2e5)
    both = score_signatures(_signals(BASE + pair + NOISE), ["end_stop"])[0]
    assert both.numbers["sides"] == 2.0
    assert both.numbers["threshold_bump_m"] == pytest.approx(0.012, abs=0.004)
    assert both.numbers["threshold_rebound_m"] == pytest.approx(-0.010, abs=0.004)
    assert "compression" in both.evidence and "extension" in both.evidence
    assert both.score > 0.9


def test_viscoelastic_lag_found_under_a_two_tone_input() -> None:
    # two tones: a Maxwell element's lag differs per frequency, so a single spring and
    # damper cannot absorb it (at one frequency it could)
    x = 0.01 * np.sin(2 * np.pi * 0.5 * T) + 0.004 * np.sin(2 * np.pi * 6.0 * T)
    v = np.gradient(x, T)
    measured = 20000.0 * x + 1500.0 * v + maxwell_series(x, T, 4e3, 400.0) + NOISE
    J = np.c_[x, v]
    coef, *_ = np.linalg.lstsq(J, measured, rcond=None)
    pred = J @ coef
    s = float(np.std(measured))
    sigs = score_signatures(SignalSet(T, x, v, (measured - pred) / s, pred / s, J / s, scale=s))
    assert sigs[0].kind == "viscoelastic", [(g.kind, round(g.score, 3)) for g in sigs[:3]]


def test_sensor_gain_and_lag_against_a_fixed_baseline() -> None:
    # with the baseline parameters held (no Jacobian), a gain error is proportional to
    # the signal and a first-order sensor lag to its rate of change
    gain = _signals(sensor.sensor_offset_gain(BASE, 0.0, 1.05) + NOISE, fit_baseline=False)
    assert score_signatures(gain)[0].kind == "sensor_gain"
    lag = _signals(sensor.sensor_lag(BASE, T, 0.004) + NOISE, fit_baseline=False)
    top = score_signatures(lag)[0]
    assert top.kind == "sensor_lag"
    # first-order lag tau appears, to first order, as a pure delay of tau (4 ms)
    assert top.numbers["lag_s"] == pytest.approx(0.004, rel=0.1)


def test_no_effect_scores_are_negligible() -> None:
    sigs = score_signatures(_signals(BASE + NOISE))
    assert max(s.score for s in sigs) < 0.01
    # Bonferroni over the 11 detectors at 1 %: no false claim on white noise
    assert min(s.p_value for s in sigs) > 0.01 / len(sigs)


def test_friction_step_size_matches_the_planted_friction() -> None:
    top = score_signatures(_signals(BASE + PLANTED["friction"]() + NOISE), ["friction"])[0]
    # a Coulomb force of 60 N steps by 2 * 60 N at each reversal
    assert top.numbers["step"] == pytest.approx(120.0, rel=0.1)


def test_partial_r2_closed_forms() -> None:
    rng = np.random.default_rng(0)
    f = rng.normal(size=500)
    # a residual equal to a feature is fully explained
    assert partial_r2(3.0 * f, f[:, None], None)[0] == pytest.approx(1.0)
    # a feature inside the baseline span explains nothing once projected out
    basis = (f / np.linalg.norm(f))[:, None]
    assert partial_r2(rng.normal(size=500), f[:, None], basis)[0] == pytest.approx(0.0, abs=1e-12)


def test_effective_n_of_ar1_series() -> None:
    # AR(1) with rho = 0.8: n_eff = n (1 - rho) / (1 + rho) = n / 9
    rng = np.random.default_rng(1)
    e = rng.normal(size=20000)
    r = np.zeros_like(e)
    for k in range(1, e.size):
        r[k] = 0.8 * r[k - 1] + e[k]
    assert effective_n(r) == pytest.approx(e.size / 9.0, rel=0.1)


def test_feature_builders_against_closed_forms() -> None:
    # Dahl state after a long monotone stretch saturates at +-1 (exact solution)
    x = np.linspace(0.0, 0.1, 200)
    assert unit_dahl(x, 0.002)[-1] == pytest.approx(1.0, abs=1e-9)
    # first-order low-pass of a step: 1 - exp(-t / tau)
    t = np.linspace(0.0, 1.0, 1001)
    u = np.ones_like(t)
    u[0] = 0.0
    y = first_order_lowpass(u, t, 0.1)
    assert y[-1] == pytest.approx(1.0 - np.exp(-10.0), rel=1e-3)
