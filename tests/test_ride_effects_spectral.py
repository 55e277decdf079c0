"""Effects in the spectral ride method (statistical linearisation): the Gaussian
expectations against closed forms (stops about a mean, Caughey's cubic spring, the
Coulomb limit) and numerical integration, the springs' mean-deflection balance, a
single-DOF Coulomb oscillator against its
closed-form linearisation and a Monte-Carlo run, the Dahl element against its complex
stiffness, the halves against the whole model, the fixed point, and the long-run check
against the nonlinear time-domain model (slow)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
import pytest
from scipy import integrate, optimize
from scipy.special import ndtr
from test_stop_closure import interpolation_bound

from suspenv.metrics.ride import (
    DOSE_KEYS,
    _output_matrix,
    corner_statistics,
    modal_form,
    modal_response,
    ride_spectral,
)
from suspenv.models.effects.effect import make_effect
from suspenv.models.minibus import STUDY_PICK, design_space, stop_closure
from suspenv.models.minibus.linearisation import (
    DAMPER,
    ElementLinearisation,
    _excess,
    _sign_series,
    coulomb_rate,
    dahl_incoherent_variance,
    dahl_loop,
    dahl_rates,
    deflection_compliances,
    stop_moments,
    tail_moment,
    temperature_ratio,
)
from suspenv.models.minibus.ride_model import RideModel
from suspenv.models.minibus.suspension import DamperCurve, damper_force
from suspenv.models.minibus.vehicle import (
    LOAD_CASES,
    REFERENCE_MINIBUS,
    stacked_vehicle_parameters,
)
from suspenv.models.road import RandomRoad
from suspenv.rigs.ride import random_road_run

LEAF_FRICTION = make_effect("dahl_hysteresis", location="rear_leaf", f_c=600.0, sigma=600 / 3.5e-3)
STOPS = [
    make_effect("bump_stop", location="front_suspension", gap=0.012, k_stop=3e5),
    make_effect("rebound_stop", location="rear_suspension", gap=0.015, k_stop=2e5, p=2.0),
]
#: the benchmark's stops (benchmarks/minibus_ride_effects.py)
STOPS_15MM = [
    make_effect("bump_stop", location="front_suspension", gap=0.015, k_stop=3e5),
    make_effect("bump_stop", location="rear_suspension", gap=0.015, k_stop=3e5),
]
DAMPER_FRICTION = make_effect("coulomb_friction", location="rear_damper", f_c=250.0, v_eps=0.03)


def _phi(t: float) -> float:
    return float(np.exp(-0.5 * t * t) / np.sqrt(2 * np.pi))


@pytest.mark.parametrize("digressive", [False, True])
def test_damper_rate_is_the_gaussian_equivalent_of_the_curve(digressive):
    """The damper's equivalent rate (``ElementLinearisation.rates``, the E[F'(v)] form)
    against ``E[F(v) v] / s^2`` of the curve itself (:func:`damper_force`, trapezoid
    over +-12 s) and, for a piecewise-linear asymmetric curve (no digression), against
    the closed form (c_b + c_r)/2 for any zero-mean Gaussian velocity; its mean force
    (``damper_mean_force``) against ``E[F(v)]`` by the same quadrature and, without
    digression, the closed form (c_b - c_r) s / sqrt(2 pi)."""
    curve = DamperCurve(1300.0, 520.0, 0.13, 3900.0, 1560.0, 0.13)
    if not digressive:
        curve = DamperCurve(1300.0, 1300.0, 0.13, 3900.0, 3900.0, 0.13)
    vehicle = dataclasses.replace(REFERENCE_MINIBUS, damper_front=curve, damper_rear=curve)
    X = np.vstack([STUDY_PICK, design_space().to_physical(np.full((1, 8), 0.3))])
    model = RideModel(stacked_vehicle_parameters(X, LOAD_CASES, vehicle))
    lz = ElementLinearisation(model)
    s = np.array([0.02, 0.1, 0.13, 0.3, 1.0])  # RMS velocities (m/s), across the knee
    sig = np.full((model.n, 6), 5e-3)  # leaf deflection RMS (m): any positive value
    scale = np.concatenate([p.design.front_damper_scale for p in model.params])
    for s_k in s:
        sig[:, :4] = s_k
        c_eq = lz.rates(sig, lz.initial(1.0))[:, DAMPER]
        v = np.linspace(-12 * s_k, 12 * s_k, 400_001)
        dens = np.exp(-0.5 * (v / s_k) ** 2) / (np.sqrt(2 * np.pi) * s_k)
        ref = np.trapezoid(damper_force(v, curve) * v * dens, v) / s_k**2
        # trapezoid error: O(h^2) at the curve's kinks, h = 6e-5 s, far below 1e-6
        np.testing.assert_allclose(c_eq[:, 0], scale * ref, rtol=1e-6)
        mean = lz.damper_mean_force(np.full((model.n, 4), s_k))[:, 0]
        ref_mean = np.trapezoid(damper_force(v, curve) * dens, v)
        np.testing.assert_allclose(mean, scale * ref_mean, rtol=1e-6)
        if not digressive:
            np.testing.assert_allclose(c_eq[:, 0], scale * (1300.0 + 3900.0) / 2, rtol=1e-12)
            closed = (1300.0 - 3900.0) * s_k / np.sqrt(2 * np.pi)
            np.testing.assert_allclose(mean, scale * closed, rtol=1e-12)


def test_compiled_damper_leaf_rates_equal_the_numpy_form():
    """The compiled damper and leaf rates (no rear stops:
    ``spectral_kernel.damper_leaf_rates``) against the numpy form
    (``ElementLinearisation.damper_leaf_rates``) on RMS values across the damper knees
    and the leaf's helper knee: the same laws and Newton steps in another operation
    order, equal to rounding (a 1e-12 relative bound leaves the few-ulp differences of
    erf/erfc and the order of the sums ample room)."""
    space = design_space()
    X = space.to_physical(np.random.default_rng(4).random((6, 8)))
    lz = ElementLinearisation(RideModel(stacked_vehicle_parameters(X, LOAD_CASES)))
    rng = np.random.default_rng(5)
    n = X.shape[0] * len(LOAD_CASES)
    for _ in range(5):
        sv = np.exp(rng.uniform(np.log(0.01), np.log(1.0), (n, 4)))  # m/s
        sd = np.exp(rng.uniform(np.log(1e-3), np.log(0.05), (n, 2)))  # m
        sig = np.asfortranarray(np.hstack([sv, sd]))  # the spectral passes' layout
        ref = np.empty((n, 6))
        lz.damper_leaf_rates(sv, sd, ref)
        np.testing.assert_allclose(lz.rates(sig, lz.initial(1.0)), ref, rtol=1e-12, atol=0)


def test_spring_mean_equals_the_nonlinear_model_s_mean_compression():
    """The springs' mean compression from rest that the asymmetric dampers' mean force
    (jacking) and the two-stage leaf give (``ElementLinearisation.spring_mean``), fed
    with the RMS values of a 60 s nonlinear time-domain run, against that run's own
    mean compression, front springs and rear leaves. The road record is one period of
    a zero-mean periodic profile, so the linear response averages to zero over it and
    the mean is the nonlinear rectification alone; the Gaussian assumption is what the
    tolerance (10 % + 0.05 mm) allows for (measured: within 0.08 mm of 0.6-2.5 mm).
    With bump stops in contact a few % of the time the time-domain deflection is skewed
    away from the stop (its upper tail cut), the stop's mean force is below the
    Gaussian one and the measured mean lies above the balance's (by up to 0.8 mm at
    the front of the all-low corner, 15 mm stops: docs/minibus.md), so stops are not
    part of this check; ``test_spring_mean_solves_the_force_balance`` checks the
    balance itself."""
    space = design_space()
    X = np.vstack([STUDY_PICK, space.to_physical(np.array([[0.0] * 8, [0.0, 1.0] * 4]))])
    road = RandomRoad(duration_s=60.0, seed=500)
    rec = random_road_run(X, LOAD_CASES, road, record_states=True)
    model = RideModel(stacked_vehicle_parameters(X, LOAD_CASES))
    nq, npos = model.nq, model.n_pos
    q, qd = rec.states[:, :nq], rec.states[:, nq : 2 * nq]
    lz = ElementLinearisation(model)
    for end in (0, 1):
        cols = slice(2 * end, 2 * end + 2)
        x = np.einsum("nqt,qe->net", q, model.E[:nq, cols])  # (n, L/R, time)
        v = np.einsum("nqt,qe->net", qd, model.E[nq:, npos + 2 * end : npos + 2 * end + 2])
        sd = np.sqrt(np.mean((x - x.mean(axis=2, keepdims=True)) ** 2, axis=2))
        m = lz.spring_mean(end, np.sqrt(np.mean(v**2, axis=2)), sd)
        measured = x.mean(axis=2)
        assert np.all(measured > 3e-4)  # rebound-heavy dampers pull the springs in
        np.testing.assert_allclose(m, measured, rtol=0.1, atol=5e-5)


def _closure_mean_force(kappa: float, a: float) -> float:
    """A p = 1 stop's mean force per unit k_stop s under the closure's density of
    normalised gap a, by root-finding beta on the direct quadrature
    (:func:`stop_closure.closure_statistics`, not its table)."""
    beta = optimize.brentq(
        lambda b: float(stop_closure.closure_statistics(np.array(kappa), np.array(b))[0]) - a,
        a - 40.0,
        a + 40.0,
        xtol=1e-13,
    )
    return float(stop_closure.closure_statistics(np.array(kappa), np.array(beta))[1])


@pytest.mark.parametrize("effects", [[], STOPS, STOPS_15MM])
def test_spring_mean_solves_the_force_balance(effects):
    """The fixed Newton steps of ``spring_mean`` solve its balance at both ends, with
    bump, rebound and p = 2 stops and deflection RMS values from far below the gaps to
    beyond them: the residual, with the p = 2 stop's Gaussian mean force by quadrature
    and the p = 1 stops' closure mean force by the closure's direct quadrature, stays
    below 1e-7 of the damper's mean force (measured 8e-9) plus the table's
    interpolation bound on the p = 1 stops' mean force."""
    X = design_space().to_physical(np.random.default_rng(8).random((3, 8)))
    model = RideModel(stacked_vehicle_parameters(X, LOAD_CASES), effects=effects)
    lz = ElementLinearisation(model)
    table_tol = interpolation_bound("mu")
    for sd in (1e-3, 6e-3, 0.02):
        sdv = np.full((model.n, 2), sd)
        sv = np.full((model.n, 2), 0.15)
        for end in (0, 1):
            m = lz.spring_mean(end, sv, sdv)
            k1, dk, thr = (lz.k1, lz.dk, lz.thr) if end else (lz.k_front, 0.0, 0.0)
            f_stop, tol = np.zeros_like(m), 0.0
            for (sign, gap, k_stop, p), kappa in zip(lz.stops[end], lz.kappa[end], strict=True):
                if kappa is not None:
                    a = (gap - sign * m) / sd
                    mu = np.vectorize(_closure_mean_force)(kappa, a)
                    f_stop += sign * k_stop * sd * mu
                    tol += k_stop * sd * table_tol
                    continue
                xs = np.linspace(-10 * sd, 10 * sd, 200_001)
                law = k_stop * np.maximum(sign * (m[..., None] + xs) - gap, 0.0) ** p
                dens = np.exp(-0.5 * (xs / sd) ** 2) / (np.sqrt(2 * np.pi) * sd)
                f_stop += sign * np.trapezoid(law * dens, xs, axis=-1)
            leaf = dk * (sdv * _excess((thr - m) / sdv) - np.maximum(-thr, 0.0))
            damper = lz.damper_mean_force(sv, slice(2 * end, 2 * end + 2))
            res = k1 * m + leaf + f_stop + damper
            # quadrature error of the p = 2 stop's mean force: O(h^2) at its kink, far below
            assert np.abs(res).max() <= 1e-7 * np.abs(damper).max() + tol


@pytest.mark.parametrize("m", [0.0, 0.5, 1.0, 1.5, 2.0])
@pytest.mark.parametrize("a", [-1.5, 0.0, 0.7, 3.0])
def test_tail_moment_equals_numerical_integral(a, m):
    """E[max(t - a, 0)^m] against scipy's adaptive quadrature (rel 1e-8)."""
    ref = integrate.quad(lambda t: (t - a) ** m * _phi(t), a, np.inf, epsabs=0, epsrel=1e-11)[0]
    assert float(tail_moment(np.array([a]), m)[0]) == pytest.approx(ref, rel=1e-8, abs=1e-14)


@pytest.mark.parametrize("shift", [0.0, 0.006, -0.004])
def test_stop_moments_against_closed_forms_and_quadrature(shift):
    """A stop's mean force and equivalent stiffness for a Gaussian deflection of mean
    ``shift`` towards it: p = 1 against the closed forms ``k_stop P(contact)`` and
    ``k_stop (sigma phi(a) - (gap - shift)(1 - Phi(a)))``, a = (gap - shift)/sigma; any
    p against quadrature of ``E[F(m + x)]``, ``E[F'(m + x)]`` and Booton's / Caughey's
    ``E[x F(m + x)] / sigma^2`` (equal to the latter for a Gaussian x: Stein)."""
    s = np.array([0.004, 0.01, 0.03])
    a = (0.015 - shift) / s
    mean, rate = stop_moments(0.015, 3e5, 1.0, s, shift)
    assert rate == pytest.approx(3e5 * ndtr(-a), rel=1e-12)
    phi = np.exp(-0.5 * a * a) / np.sqrt(2 * np.pi)
    assert mean == pytest.approx(3e5 * (s * phi - (0.015 - shift) * ndtr(-a)), rel=1e-12)
    for p in (1.0, 1.7, 2.0):
        for sig in s:

            def expect(g: Callable[[float], float], sig: float = sig) -> float:
                """E[g(x)] over the contact range x > gap - shift, x ~ N(0, sig^2)."""
                lo = 0.015 - shift
                return integrate.quad(
                    lambda x: g(x) * _phi(x / sig) / sig, lo, lo + 12 * sig, epsabs=0, epsrel=1e-11
                )[0]

            def law(x: float, p: float = p) -> float:
                return 3e5 * (x + shift - 0.015) ** p

            def slope(x: float, p: float = p) -> float:
                return p * 3e5 * (x + shift - 0.015) ** (p - 1)

            m_k, k_k = stop_moments(0.015, 3e5, p, np.array([sig]), shift)
            assert float(m_k[0]) == pytest.approx(expect(law), rel=1e-7)
            assert float(k_k[0]) == pytest.approx(expect(slope), rel=1e-7)
            booton = expect(lambda x, law=law: x * law(x)) / sig**2
            assert float(k_k[0]) == pytest.approx(booton, rel=1e-7)


@pytest.mark.parametrize("m", [0.0, 0.004, -0.007])
def test_cubic_spring_from_two_stops_is_caughey_s_closed_form(m):
    """A bump and a rebound stop without a gap, p = 3, on the front springs make the
    cubic spring F = k d^3 (Duffing). About a mean deflection m, for a Gaussian x of
    RMS sigma: the equivalent stiffness ``E[F'(m + x)] = 3 k (m^2 + sigma^2)`` (Caughey:
    ``E[x F]/E[x^2] = 3 k sigma^2`` at m = 0, E[x^4] = 3 sigma^4) and the mean force
    ``k (m^3 + 3 m sigma^2)`` (the stops' sum, ``ElementLinearisation._stop_terms`` and
    ``_stop_rate``: p != 1, so Gaussian)."""
    cubic = [
        make_effect("bump_stop", location="front_suspension", gap=0.0, k_stop=2e7, p=3.0),
        make_effect("rebound_stop", location="front_suspension", gap=0.0, k_stop=2e7, p=3.0),
    ]
    X = STUDY_PICK[None, :]
    lz = ElementLinearisation(RideModel(stacked_vehicle_parameters(X, LOAD_CASES), cubic))
    sd = np.array([[0.001, 0.02], [0.005, 0.5]])
    force, slope = lz._stop_terms(0, np.full_like(sd, m), sd)
    rate = lz._stop_rate(0, np.full_like(sd, m), sd)
    assert slope == pytest.approx(rate, rel=1e-12)  # Gaussian: d E[F]/dm = E[F']
    assert rate == pytest.approx(3 * 2e7 * (m * m + sd**2), rel=1e-12)
    assert force == pytest.approx(2e7 * (m**3 + 3 * m * sd**2), rel=1e-12, abs=1e-9)


def test_coulomb_rate_against_quadrature_and_the_sign_limit():
    """E[d/dv f_c tanh(v/v_eps)] by quadrature; v_eps/sigma -> 0 gives the ideal Coulomb
    law's f_c sqrt(2/pi)/sigma (Roberts & Spanos)."""
    for v_eps, sig in ((0.03, 0.05), (0.001, 0.2), (0.05, 0.01)):
        ref = integrate.quad(
            lambda v, e=v_eps, s=sig: (
                200.0 / e / np.cosh(min(abs(v / e), 300.0)) ** 2 * _phi(v / s) / s
            ),
            -np.inf,
            np.inf,
            epsabs=0,
            epsrel=1e-11,
        )[0]
        assert float(coulomb_rate(200.0, v_eps, np.array([sig]))[0]) == pytest.approx(ref, 1e-8)
    sig = np.array([0.05, 0.1])
    lim = coulomb_rate(200.0, 1e-7, sig)
    assert lim == pytest.approx(200.0 * np.sqrt(2 / np.pi) / sig, rel=1e-6)


def _sdof_el_sigma_v(m: float, c: float, k: float, f_c: float, s0: float) -> float:
    """Statistical linearisation of m x'' + c x' + f_c sign(x') + k x = w (two-sided
    force PSD s0): var(x') = pi s0 / (m c_tot), c_tot = c + f_c sqrt(2/pi)/sigma_v
    (Roberts & Spanos), a quadratic in sigma_v."""
    b = f_c * np.sqrt(2 / np.pi)
    return float((-b + np.sqrt(b * b + 4 * c * np.pi * s0 / m)) / (2 * c))


def test_sdof_coulomb_fixed_point_and_monte_carlo():
    """A 1-DOF oscillator (1 Hz, damping ratio 0.1) with Coulomb friction under white
    force noise. (1) The fixed point of coulomb_rate (v_eps -> 0) with the linear
    oscillator's variance pi s0/(m c) equals the quadratic's root. (2) Monte Carlo: 600
    paths, 12 s after 6 s of settling, semi-implicit Euler at 1 ms (its own bias at
    f_c = 0 is below 0.5 %); the linearised RMS velocity lies within 3 standard errors
    (between paths) + 2 % of the simulated one (Gaussian linearisation's own error for
    this friction level: measured -1.5 % with 4000 paths x 30 s)."""
    m, k, c, f_c, s0 = 1.0, (2 * np.pi) ** 2, 0.4 * np.pi, 0.2, 0.01
    sv = np.sqrt(np.pi * s0 / (m * c))
    for _ in range(60):
        c_eq = c + float(coulomb_rate(f_c, 1e-7, np.array([sv]))[0])
        sv = np.sqrt(np.pi * s0 / (m * c_eq))
    sv_el = _sdof_el_sigma_v(m, c, k, f_c, s0)
    assert sv == pytest.approx(sv_el, rel=1e-9)
    rng = np.random.default_rng(3)
    n, dt = 600, 1e-3
    x, v = np.zeros(n), np.zeros(n)
    sd = np.sqrt(2 * np.pi * s0 / dt)  # white force of two-sided PSD s0, sampled at dt
    acc, cnt = np.zeros(n), 0
    for i in range(18000):
        a = (sd * rng.standard_normal(n) - c * v - k * x - f_c * np.tanh(v / 1e-3)) / m
        v += a * dt
        x += v * dt
        if i >= 6000:
            acc += v * v
            cnt += 1
    per_path = acc / cnt
    ms, se = per_path.mean(), per_path.std(ddof=1) / np.sqrt(n)
    assert sv_el**2 == pytest.approx(ms, abs=3 * se + 0.04 * ms)
    # the friction matters here: the linear oscillator's RMS is 1.5x the simulated one
    assert np.sqrt(np.pi * s0 / (m * c)) > 1.3 * np.sqrt(ms)


def test_dahl_rates_limits():
    """Wen's linearised Dahl element: with no force yet (s_z = 0) c_z is the pre-sliding
    stiffness sigma; k_z = sigma/f_c sqrt(2/pi) s_v, so at high velocity the element is a
    dashpot c_z/k_z; and the stationarity identity E[v z] = k_z s_z^2/c_z enters c_z."""
    sig, fc = 2e5, 600.0
    c, k = dahl_rates(sig, fc, np.array([0.05]), np.array([0.0]), np.array([sig]), np.array([1.0]))
    assert c[0] == pytest.approx(sig) and k[0] == pytest.approx(
        sig / fc * np.sqrt(2 / np.pi) * 0.05
    )
    c2, _ = dahl_rates(
        sig, fc, np.array([0.05]), np.array([300.0]), np.array([1e5]), np.array([20.0])
    )
    evz = 20.0 * 300.0**2 / 1e5
    assert c2[0] == pytest.approx(sig * (1 - np.sqrt(2 / np.pi) * evz / (fc * 0.05)))


@pytest.mark.parametrize("a", [0.2, 0.7, 2.0, 6.0])
def test_dahl_loop_against_the_integrated_law(a):
    """``dahl_loop``'s closed forms against the Dahl law integrated over a sinusoidal
    deflection ``x = a cos t`` (``delta = f_c = 1``; ``dz/dt = dx/dt (1 - z sgn
    dx/dt)``, scipy's DOP853 at rtol 1e-11 from z = 0 over enough cycles for the start
    to fade below e^-20, each cycle's travel 4 a taking e^-4a of it; the last cycle
    averaged by the trapezoid rule on 4096 points): mean square and the fundamental in
    phase with x and with its rate, within 1e-6."""

    def law(t, z):
        v = -a * np.sin(t)
        return v * (1.0 - z * np.sign(v))

    cycles = 2 + int(np.ceil(5.0 / a))
    t = np.linspace(2 * np.pi * (cycles - 1), 2 * np.pi * cycles, 4097)
    sol = integrate.solve_ivp(
        law, (0, t[-1]), [0.0], method="DOP853", rtol=1e-11, atol=1e-13, t_eval=t
    )
    z = sol.y[0]
    ms, a1, b1 = dahl_loop(np.array(a))
    assert ms == pytest.approx(integrate.trapezoid(z * z, t) / (2 * np.pi), abs=1e-6)
    assert a1 == pytest.approx(integrate.trapezoid(z * np.cos(t), t) / np.pi, abs=1e-6)
    assert b1 == pytest.approx(-integrate.trapezoid(z * np.sin(t), t) / np.pi, abs=1e-6)


def _rayleigh_average(k: int, sx: float, delta: float) -> float:
    """Adaptive quadrature over Rayleigh amplitudes A (RMS deflection ``sx``) of the
    Dahl loop's mean square (k = 0) or A times its fundamental's part k (1, 2)."""

    def integrand(A: float) -> float:
        q = float(dahl_loop(np.array(A / delta))[k]) * (A if k else 1.0)
        return q * A / sx**2 * np.exp(-0.5 * (A / sx) ** 2)

    return integrate.quad(integrand, 0, 12 * sx, limit=200, epsabs=0, epsrel=1e-12)[0]


def test_dahl_incoherent_variance_limits_and_rayleigh_average():
    """The Dahl force's variance beside a linear map of the deflection: its Rayleigh
    average against adaptive quadrature of the same loop (rel 1e-5: the method's
    48-point rule, measured under 4e-6 over 0.05-50 travels); nothing in the
    stick (under 1e-4 f_c^2 at s_x = 0.05 delta, falling as s_x^4: a quarter power of
    ten per halving); the Gaussian sign law's remainder ``f_c^2 (1 - 2/pi)`` in the
    Coulomb limit (the variance of ``f_c sgn v`` less its Gaussian gain's share
    ``2/pi``; within 2e-4 at s_x = 1e7 delta, the loop's rounded corners fading as
    1/sqrt(s_x))."""
    fc, sig = 600.0, 600.0 / 3.5e-3
    delta = fc / sig
    for s in (0.6, 1.3, 4.0):
        sx = s * delta
        ms, pa, pb = (_rayleigh_average(fn, sx, delta) for fn in range(3))
        ref = fc**2 * (ms - (pa**2 + pb**2) / (2 * 2 * sx**2))
        assert dahl_incoherent_variance(fc, sig, np.array([sx]))[0] == pytest.approx(ref, rel=1e-5)
    small = dahl_incoherent_variance(1.0, 1.0, np.array([0.05, 0.025]))
    assert small[0] < 1e-4 and small[1] / small[0] == pytest.approx(1 / 16, rel=0.05)
    big = dahl_incoherent_variance(1.0, 1.0, np.array([1e7]))[0]
    assert big == pytest.approx(1 - 2 / np.pi, abs=2e-4)


def test_sign_series_is_the_sign_laws_hermite_expansion():
    """``_sign_series``: ``sqrt(n!) b_n`` of ``sgn u = sum b_n He_n(u)`` beyond its
    linear term, ``b_n = 2 He_(n-1)(0) phi(0)/n!`` (numpy's HermiteE at 0, not the
    stop's recursion it is built from), scaled to unit variance; even orders vanish."""
    n = np.arange(2, stop_closure.ORDERS + 1)
    he = np.array([np.polynomial.hermite_e.hermeval(0.0, [0] * (k - 1) + [1]) for k in n])
    fact = np.array([float(np.prod(np.arange(1.0, k + 1.0))) for k in n])
    ref = 2 * he * _phi(0.0) / fact * np.sqrt(fact)
    ref[-1] = 0.0  # the series stops at ORDERS - 1 (odd)
    ref /= np.sqrt(np.sum(ref * ref))
    assert _sign_series() == pytest.approx(ref, rel=1e-12, abs=1e-15)
    assert np.all(_sign_series()[::2] == 0.0) and np.sum(_sign_series() ** 2) == pytest.approx(1.0)


def test_modal_form_with_dahl_states_equals_complex_stiffness_solve():
    """The first-order Dahl element dz/dt = c_z e' - k_z z is a Maxwell element of
    complex stiffness c_z i w / (i w + k_z) on the leaf deflection: the modal form with
    its states equals ``Co (K + Pz^T D(w) Pz - w^2 M + i w C)^-1 (Kin + i w Cin)`` solved
    per frequency (rel 1e-8), and its force output equals D(w) Pz q."""
    X = design_space().to_physical(np.random.default_rng(2).random((3, 8)))
    lin = RideModel(stacked_vehicle_parameters(X, LOAD_CASES), linear=True)
    M, C, K, Kin, Cin = lin.linear_system()
    Co = _output_matrix(lin)
    Pz = lin.E[: lin.nq, 2:4].T
    cz = np.array([[1.5e5, 1.5e5], [9e4, 9e4], [2e5, 2e5]] * 2)
    kz = np.array([[30.0, 30.0], [80.0, 80.0], [5.0, 5.0]] * 2)
    f = np.geomspace(0.3, 40.0, 37)
    lam, P = modal_form(M, C, K, Kin, Cin, Co, (Pz, cz, kz))
    H = modal_response(lam, P, f)
    for i, fi in enumerate(f):
        w = 2 * np.pi * fi
        D = cz * 1j * w / (1j * w + kz)  # (n, 2)
        Z = K + np.einsum("ai,na,aj->nij", Pz, D, Pz) - w * w * M + 1j * w * C
        q = np.linalg.solve(Z, Kin + 1j * w * Cin)
        ref = np.concatenate([Co @ q, D[:, :, None] * (Pz @ q)], axis=1)
        assert H[:, i] == pytest.approx(ref, rel=1e-8, abs=1e-12 * np.abs(ref).max())


@pytest.mark.parametrize(
    "effects", [[LEAF_FRICTION], STOPS, [DAMPER_FRICTION, LEAF_FRICTION] + STOPS]
)
def test_halves_equal_the_whole_model_with_effects(effects):
    """The split halves (one Dahl state each; compiled eigen-decomposition and modal
    sums) equal the whole 16-state model (numpy's complex modal forms; rel 1e-10),
    rates and the Gaussian doses (from the weighted acceleration's rate) included."""
    X = design_space().to_physical(np.random.default_rng(5).random((6, 8)))
    a = ride_spectral(X, effects=effects)
    b = ride_spectral(X, effects=effects, split=False)
    keys = ("aw_front", "aw_rear", "rms_front", "rms_rear", "damper_c", "leaf_k", *DOSE_KEYS)
    for key in keys:
        assert a[key] == pytest.approx(b[key], rel=1e-10), key


def test_effects_that_never_act_change_nothing():
    """Stops far beyond the travel and zero friction give the plain spectral values
    (the whole-model path, rel 1e-9)."""
    X = design_space().to_physical(np.random.default_rng(6).random((4, 8)))
    none = [
        make_effect("bump_stop", location="front_suspension", gap=0.3, k_stop=1e6),
        make_effect("rebound_stop", location="rear_suspension", gap=0.3, k_stop=1e6),
        make_effect("coulomb_friction", location="front_damper", f_c=0.0),
    ]
    a = ride_spectral(X, effects=none)
    b = ride_spectral(X, split=False, iterations=8)
    for key in ("aw_front", "aw_rear"):
        assert a[key] == pytest.approx(b[key], rel=1e-9)


@pytest.mark.parametrize(
    "effects, rel",
    [([LEAF_FRICTION], 1e-3), (STOPS, 5e-3), ([DAMPER_FRICTION], 5e-3)],
)
def test_default_passes_reach_the_fixed_point(effects, rel):
    """The default passes lie near the fixed point (tol 1e-10) over random designs of
    the box, both load cases: leaf friction alone (4 passes) within 0.1 % (measured
    1.2e-4 at 900 N), stops and damper friction (8 passes), whose rates fall as their
    RMS rises and converge linearly, within 0.5 % (measured up to 0.34 % for a front
    stop 8 mm away)."""
    X = design_space().to_physical(np.random.default_rng(7).random((12, 8)))
    a = ride_spectral(X, effects=effects)
    b = ride_spectral(X, effects=effects, iterations=200, tol=1e-10)
    assert int(b["iterations"]) < 200
    for key in ("aw_front", "aw_rear"):
        assert a[key] == pytest.approx(b[key], rel=rel)


@pytest.mark.slow
def test_leaf_friction_against_long_time_domain_runs():
    """The study's pick with rear interleaf friction: the spectral values lie within 2 %
    + 2 standard errors of the nonlinear time-domain model's mean square over 4
    antithetic pairs of 120 s records (``benchmarks.minibus_ride_effects.long_runs``,
    RK4 at 200 Hz; the benchmark measures the box). Measured: -0.2 to -0.6 % (-0.4 to
    -1.6 % without the Dahl force's incoherent part), standard errors 0.02-0.13 %.
    Ignoring the friction errs by more than 15 % at the rear, no load (measured: 0.52
    of the mean square)."""
    from benchmarks.minibus_ride_effects import long_runs

    X = STUDY_PICK[None, :]
    td, se, _ = long_runs(X, [LEAF_FRICTION], 4)  # (end, load case): m/s^2, %
    sp = ride_spectral(X, effects=[LEAF_FRICTION])
    for j, key in enumerate(("aw_front", "aw_rear")):
        err = 100 * (sp[key] / td[j] - 1)
        assert np.all(np.abs(err) <= 2.0 + 2 * se[j]), (key, err, se[j])
    assert ride_spectral(X)["aw_rear"][0] ** 2 < 0.7 * td[1, 0] ** 2


def test_problem_option_passes_the_effects_to_the_ride():
    """MinibusRideHandling(ride_effects=...) gives the spectral values with the effects
    (same numbers as ride_spectral), its config holds them as plain data that rebuilds
    the same problem, and bad entries are refused naming the rule."""
    from suspenv.core.errors import ValidationError
    from suspenv.problems.minibus import MinibusRideHandling

    spec = {"kind": "dahl_hysteresis", "location": "rear_leaf", "params": {"f_c": 600.0}}
    spec["params"]["sigma"] = 600 / 3.5e-3
    p = MinibusRideHandling(ride_effects=[spec])
    m = p.measures(STUDY_PICK[None, :])
    ref = ride_spectral(STUDY_PICK[None, :], effects=[LEAF_FRICTION])
    assert m["aw_rear_no_load"][0] == pytest.approx(ref["aw_rear"][0], rel=1e-12)
    again = MinibusRideHandling(**p.config())
    assert again.measures(STUDY_PICK[None, :])["aw_rear_no_load"][0] == m["aw_rear_no_load"][0]
    for bad in (
        [{"kind": "dahl_hysteresis", "location": "front_damper"}],
        [{"kind": "bump_stop", "location": "rear_suspension", "params": {"gap": -0.01}}],
        [{"kind": "bump_stop", "location": "rear_suspension", "code": "x"}],
        "dahl_hysteresis",
    ):
        with pytest.raises(ValidationError, match="ride_effects|ride effect"):
            MinibusRideHandling(ride_effects=bad)


def test_remainder_coefficients_of_a_bump_and_a_rebound_stop():
    """``remainder_coefficients`` of a bump and a rebound stop on the same front spring
    (p = 1, k_stop far below the wheel rate so the closure is the Gaussian density):
    by Parseval the squared sums of the two stops' Hermite terms are the variance of
    their summed remainder ``max(u - a_b, 0) - T(a_b) - (1 - Phi(a_b)) u - max(-u - a_r,
    0) + T(a_r) - (1 - Phi(a_r)) u`` (per unit k_stop s, u standard normal), against
    quadrature: within the orders' truncation (1 % for gaps within 3 RMS; measured
    0.5 %). A rebound term of the wrong sign parity gives 0.08 or 3 times it."""
    k_stop = 1e-3  # N/m: kappa ~ 2e-8
    stops = [
        make_effect("bump_stop", location="front_suspension", gap=0.012, k_stop=k_stop),
        make_effect("rebound_stop", location="front_suspension", gap=0.006, k_stop=k_stop),
    ]
    lz = ElementLinearisation(
        RideModel(stacked_vehicle_parameters(STUDY_PICK[None], LOAD_CASES), stops)
    )
    s, m = 0.008, 0.002
    coef = lz.remainder_coefficients(np.full((2, 4), m), np.full((2, 4), s))
    a_b, a_r = (0.012 - m) / s, (0.006 + m) / s

    def rem(u: float) -> float:
        bump = max(u - a_b, 0.0) - float(_excess(np.array(a_b))) - ndtr(-a_b) * u
        rebound = -max(-u - a_r, 0.0) + float(_excess(np.array(a_r))) - ndtr(-a_r) * u
        return bump + rebound

    var = integrate.quad(
        lambda u: rem(u) ** 2 * _phi(u), -12, 12, points=[a_b, -a_r], epsabs=0, epsrel=1e-12
    )[0]
    series = np.sum((coef[:, :, :2] / (k_stop * s)) ** 2, axis=0)  # (load cases, FL FR)
    assert np.all(series <= var * (1 + 1e-9)) and np.all(series >= 0.99 * var)
    assert np.all(coef[:, :, 2:] == 0.0)  # no rear stops


#: p = 1 stops at both ends, bump and rebound: the rear bump stop meets the leaf's
#: composite rate where the helper knee lies below 8 mm (loaded), else its primary one
P1_STOPS = [
    make_effect("bump_stop", location="front_suspension", gap=0.015, k_stop=3e5),
    make_effect("bump_stop", location="rear_suspension", gap=0.008, k_stop=3e5),
    make_effect("rebound_stop", location="rear_suspension", gap=0.02, k_stop=2e5),
]


def test_stop_law_at_equal_temperatures_is_k_stop_times_the_static_compliance():
    """At r = 1 (``set_corners(None)``) the whole-vehicle law ``(A0 + C0)/(A1 + C1) - 1``
    is, by Sherman-Morrison, ``k_stop e^T K^-1 e``: against a direct
    ``numpy.linalg.solve`` of the linear model's own stiffness (``RideModel.
    linear_system``, the rear leaf at its rate at the contact point) (rel 1e-9: the
    stiffness' condition number times round-off); and ``A + C`` of
    :func:`deflection_compliances` is that compliance, ``C`` the wheels' block alone."""
    X = design_space().to_physical(np.random.default_rng(12).random((3, 8)))
    params = stacked_vehicle_parameters(X, LOAD_CASES)
    lin = RideModel(params, linear=True)
    lz = ElementLinearisation(RideModel(params, effects=P1_STOPS))
    lz.set_corners(None)
    nq = lin.nq
    for end in (0, 1):
        for (sign, gap, k_stop, _), kappa in zip(lz.stops[end], lz.kappa[end], strict=True):
            _, _, K, _, _ = lin.linear_system(leaf_k=lz.k1 + lz.dk * (lz.thr < sign * gap))
            e = lin.E[:nq, 2 * end]
            compliance = e @ np.linalg.solve(K, np.broadcast_to(e, (K.shape[0], nq))[..., None])
            np.testing.assert_allclose(kappa[:, 0], k_stop * compliance[:, 0], rtol=1e-9)
            np.testing.assert_array_equal(kappa[:, 0], kappa[:, 1])
            a, c = deflection_compliances(K, e)
            np.testing.assert_allclose(a + c, compliance[:, 0], rtol=1e-9)
            wheels = K[:, 3:7, 3:7]
            ew = np.broadcast_to(e[3:7], (K.shape[0], 4))[..., None]
            np.testing.assert_allclose(c, (ew * np.linalg.solve(wheels, ew)).sum((1, 2)))


@pytest.mark.parametrize("r", [0.3, 1.0, 2.5])
def test_temperature_ratio_recovers_a_two_temperature_corner(r):
    """A quarter car (body b on spring k, wheel w on tyre k_t, road at rest): the body
    at temperature T, the wheel about its static position given the body at r T, i.e.
    ``b`` and ``w' = w - k b/(k + k_t)`` independent with variances ``T/K_c`` (``K_c =
    k k_t/(k + k_t)``) and ``r T/(k + k_t)``; the tyre's compression ``-w`` and the
    spring's ``w - b`` (z up) from that covariance matrix by matrix algebra give back r
    (rel 1e-12); at r = 1 the covariance is also Boltzmann's ``T K^-1``."""
    k, k_t, T = 9.0e4, 4.0e5, 3.0
    L = np.array([[1.0, 0.0], [k / (k + k_t), 1.0]])  # (b, w) from (b, w')
    cov = L @ np.diag([T * (k + k_t) / (k * k_t), r * T / (k + k_t)]) @ L.T
    if r == 1.0:
        np.testing.assert_allclose(cov, T * np.linalg.inv([[k, -k], [-k, k + k_t]]))
    tyre, spring = np.array([0.0, -1.0]), np.array([-1.0, 1.0])
    got = temperature_ratio(
        np.array([tyre @ cov @ tyre]), np.array([spring @ cov @ tyre]), np.array([k]), k_t
    )
    assert float(got[0]) == pytest.approx(r, rel=1e-12)


def test_corner_statistics_through_the_halves_equal_the_whole_model():
    """:func:`corner_statistics` of the two halves (symmetric and antisymmetric, the
    road's coherency split between them) against the whole 7-DOF model: tyre
    deflection variances, covariances and skewness (rel 1e-10; measured 1e-13), the
    skewness of the benchmark's order (0.01-0.3) and the variances positive."""
    X = design_space().to_physical(np.random.default_rng(4).random((4, 8)))
    params = stacked_vehicle_parameters(X, LOAD_CASES)
    lin = RideModel(params, linear=True)
    lz = ElementLinearisation(RideModel(params, effects=P1_STOPS))
    args = (lin, lz, RandomRoad(), REFERENCE_MINIBUS, 150)
    halves, whole = corner_statistics(*args, True), corner_statistics(*args, False)
    np.testing.assert_allclose(halves, whole, rtol=1e-10)
    assert np.all(whole[:, :2] > 0) and np.all(np.abs(whole[:, 4:]) < 0.3)


def test_even_coefficients_equal_quadrature_of_the_laws():
    """``c_2 = E[F He_2(u)]/2`` of :meth:`ElementLinearisation.even_coefficients`
    (Stein's lemma, closed form in the laws' slope jumps) against the trapezoid rule
    over +-12 s of the damper curve itself (:func:`damper_force`, digressive) and of
    the leaf's second stage ``dk max(m + s u - e_k, 0)`` about the stop-free mean m
    (rel 1e-6; the rule's error at the kinks is O(h^2), h = 6e-5 s)."""
    curve = DamperCurve(1300.0, 520.0, 0.13, 3900.0, 1560.0, 0.13)
    vehicle = dataclasses.replace(REFERENCE_MINIBUS, damper_front=curve, damper_rear=curve)
    X = np.vstack([STUDY_PICK, design_space().to_physical(np.full((1, 8), 0.3))])
    model = RideModel(stacked_vehicle_parameters(X, LOAD_CASES, vehicle), effects=P1_STOPS)
    lz = ElementLinearisation(model)
    scale = np.concatenate([p.design.front_damper_scale for p in model.params])
    u = np.linspace(-12.0, 12.0, 400_001)
    he2 = (u * u - 1.0) * np.exp(-0.5 * u * u) / np.sqrt(2 * np.pi)
    for s_v, s_d in ((0.05, 0.004), (0.3, 0.012), (1.0, 0.03)):
        sv, sd = np.full((model.n, 4), s_v), np.full((model.n, 2), s_d)
        c2 = lz.even_coefficients(sv, sd)
        ref = 0.5 * np.trapezoid(damper_force(s_v * u, curve) * he2, u)
        np.testing.assert_allclose(c2[:, 0], scale * ref, rtol=1e-6)
        m = lz.spring_mean(1, sv[:, 2:4], sd, stops=False)
        leaf = lz.dk[..., None] * np.maximum(m[..., None] + s_d * u - lz.thr[..., None], 0.0)
        ref_leaf = 0.5 * np.trapezoid(leaf * he2, u, axis=-1)
        np.testing.assert_allclose(
            c2[:, 4:6], ref_leaf, rtol=1e-6, atol=1e-9 * np.abs(ref_leaf).max()
        )


def test_default_path_equals_the_values_before_the_stop_closure():
    """Golden: without effects the spectral values at the study's pick and the box's
    corners, both load cases, are those of main 5614d8b, before the stops' corner
    statistics (rel 1e-12: round-off of a different BLAS, far below any change of
    method)."""
    X = np.vstack([STUDY_PICK, design_space().lower, design_space().upper])
    sp = ride_spectral(X)
    golden = {
        "aw_front": [0.5364729335336114, 0.4419360324507848, 0.6986073644774247,
                     0.41257389731537747, 0.359867320647902, 0.5243151159538507],
        "aw_rear": [0.8249415770852035, 0.8256539101605416, 0.9444525844947621,
                    0.783569299767315, 0.8041302844500912, 0.7121277611713862],
        "rms_front": [0.7159986089704349, 0.6801817972487094, 0.9155225812713457,
                      0.5934921629939556, 0.5931850171120542, 0.7365220611279116],
        "rms_rear": [1.1865118648059974, 1.2823600881251813, 1.1935958759931813,
                     1.4228611907272084, 1.5016682151236553, 1.208413004489558],
    }  # fmt: skip
    for key, values in golden.items():
        np.testing.assert_allclose(sp[key], values, rtol=1e-12)
