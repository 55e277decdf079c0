"""The end stop's tabulated non-Gaussian closure (:mod:`suspenv.models.minibus.stop_closure`):
its quadrature against adaptive quadrature, the table against that quadrature at points
between its nodes (tolerance: the bicubic splines' interpolation error bound from the
table's own fourth differences), its Gaussian limit against the closed forms, and the
Hermite remainder's series against its closed-form variance."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq
from scipy.special import ndtr

from suspenv.models.minibus import stop_closure as sc


def interpolation_bound(name: str) -> float:
    """Bound (-) of the interpolation error of the table's quantity ``name`` (mu, g, v)
    between its nodes: a cubic spline's ``(5/384) h^4 max|f''''|`` per axis (de Boor),
    ``h^4 f''''`` taken as the table's largest fourth difference along that axis, the
    two axes' bounds added; times 2 for the difference estimate."""
    table = sc.closure_table()
    x, a = np.meshgrid(sc._X_NODES, sc._A_NODES, indexing="ij")
    f = getattr(table, name).ev(x.ravel(), a.ravel()).reshape(x.shape)
    d4 = sum(np.abs(np.diff(f, 4, axis=k)).max() for k in (0, 1))
    return float(2 * 5 / 384 * d4)


@pytest.mark.parametrize("kappa, beta", [(0.5, 1.0), (8.0, 1.2), (18.0, -10.0), (60.0, -0.3)])
def test_closure_statistics_equal_adaptive_quadrature(kappa, beta):
    """The Gauss-Legendre sums of :func:`closure_statistics` (the kink at a node) against
    scipy's adaptive quadrature of the density's moments (rel 1e-9; measured 1e-13)."""

    def expect(fn) -> float:
        def dens(u: float) -> float:
            return fn(u) * np.exp(-0.5 * (u * u + kappa * max(u - beta, 0.0) ** 2))

        return quad(dens, -40, 40, points=[beta], limit=400, epsabs=0, epsrel=1e-12)[0]

    z = expect(lambda u: 1.0)
    mu = expect(lambda u: u) / z
    var = expect(lambda u: (u - mu) ** 2) / z
    force = expect(lambda u: max(u - beta, 0.0)) / z
    fy = expect(lambda u: max(u - beta, 0.0) * (u - mu)) / z
    var_f = expect(lambda u: (max(u - beta, 0.0) - force) ** 2) / z
    sd = np.sqrt(var)
    ref = ((beta - mu) / sd, force / sd, fy / var, (var_f - fy * fy / var) / var)
    got = sc.closure_statistics(np.array(kappa), np.array(beta))
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-15)


def test_table_equals_direct_quadrature_between_nodes():
    """:func:`closure_moments` at 400 random (kappa, beta) (kappa up to ``KAPPA_MAX``,
    a inside ``A_RANGE``, off the nodes) against :func:`closure_statistics` there,
    within each quantity's :func:`interpolation_bound` (measured: 0.2 of it); the
    derivative dmu/da against central differences of the direct quadrature."""
    rng = np.random.default_rng(11)
    kappa = np.expm1(rng.uniform(0.0, np.log1p(sc.KAPPA_MAX), 400))
    beta = rng.uniform(-3.0, 6.0, 400) * np.where(rng.random(400) < 0.5, np.sqrt(1 + kappa), 1)
    a, mu, g, v = sc.closure_statistics(kappa, beta)
    inside = (a > sc.A_RANGE[0]) & (a < sc.A_RANGE[1])
    assert inside.sum() > 200
    got = sc.closure_moments(kappa[inside], a[inside], "mu g v")
    for name, value, ref in zip(("mu", "g", "v"), got, (mu, g, v), strict=True):
        assert np.abs(value - ref[inside]).max() <= interpolation_bound(name), name
    h = 1e-4
    up, down = (sc.closure_statistics(kappa, beta + d) for d in (h, -h))
    dmu_ref = (up[1] - down[1]) / (up[0] - down[0])
    (dmu,) = sc.closure_moments(kappa[inside], a[inside], "dmu")
    # central differences: O(h^2) below 1e-6; the derivative of the spline: the bound
    # per unit of the a nodes' spacing
    step = sc._A_NODES[1] - sc._A_NODES[0]
    assert np.abs(dmu - dmu_ref[inside]).max() <= 10 * interpolation_bound("mu") / step


def test_zero_stiffness_ratio_and_outside_the_table_are_gaussian():
    """kappa = 0 leaves the density Gaussian: mu = T(a), dmu/da = -(1 - Phi(a)), g = 1 -
    Phi(a) (Stein) and v the Gaussian remainder variance (closed forms) within the
    interpolation bound, and outside ``A_RANGE`` exactly those closed forms."""
    a = np.linspace(-2.95, 5.95, 59)
    mu, dmu, g, v = sc.closure_moments(np.zeros_like(a), a)
    q = ndtr(-a)
    for value, ref, name in ((mu, sc.gaussian_excess(a), "mu"), (g, q, "g")):
        assert np.abs(value - ref).max() <= interpolation_bound(name)
    assert np.abs(v - sc.gaussian_remainder_variance(a)).max() <= interpolation_bound("v")
    assert np.abs(dmu + q).max() <= 10 * interpolation_bound("mu") / (a[1] - a[0])
    out = np.array([-5.0, 7.5])
    got = sc.closure_moments(np.array([3.0, 3.0]), out)
    ref = (sc.gaussian_excess(out), -ndtr(-out), ndtr(-out), sc.gaussian_remainder_variance(out))
    np.testing.assert_array_equal(got, ref)


@pytest.mark.parametrize("a", [-1.0, 0.5, 1.6, 3.0])
def test_hermite_series_carries_the_gaussian_remainder_variance(a):
    """Parseval: the squared coefficients of :func:`hermite_remainder` sum to the
    remainder's closed-form variance (:func:`gaussian_remainder_variance`) less the
    orders beyond ``ORDERS``, which for a <= 3 carry under 1 % (docstring) and whose
    terms fall off (the last order's term below 1e-3 of the sum)."""
    c = sc.hermite_remainder(np.array(a))
    total = float(sc.gaussian_remainder_variance(np.array(a)))
    assert total * 0.99 <= float(np.sum(c**2)) <= total * (1 + 1e-12)
    assert c[-1] ** 2 < 1e-3 * np.sum(c**2)


@pytest.mark.parametrize("gamma", [-0.6, -0.15, 0.2, 0.8])
@pytest.mark.parametrize("a", [-1.2, 0.4, 1.9, 3.4])
def test_skew_ratios_equal_quadrature_of_the_cornish_fisher_deflection(gamma, a):
    """:func:`skew_ratios` (truncated normal moments beyond the rising branch's root)
    against scipy's adaptive quadrature over the whole u line of ``F = max(y(u) - a,
    0)`` for the Cornish-Fisher deflection y (the falling branch beyond ``|u| =
    3/|gamma|`` included: its weight, below phi(5), lies far under the tolerance),
    divided by the same quadrature for gamma = 0 (the Gaussian): mean force, gain
    ``E[F y]`` and remainder variance ``Var F - E[F y]^2`` (rel 1e-8; 0 where y
    never reaches the gap), each ratio alone and all three together."""
    c = 1.0 / np.sqrt(1.0 + gamma * gamma / 18.0)

    def moments(g: float, cc: float) -> np.ndarray:
        def y(u: float) -> float:
            return cc * (u + g * (u * u - 1.0) / 6.0)

        # the kink where y(u) = a on y's rising branch (brentq; none where y stays below a)
        lo, hi = (-3.0 / g, 12.0) if g > 0 else (-12.0, -3.0 / g if g < 0 else 12.0)
        kink = [brentq(lambda u: y(u) - a, lo, hi, xtol=1e-15)] if y(hi) > a else []

        def expect(fn) -> float:
            def dens(u: float) -> float:
                return fn(u) * np.exp(-0.5 * u * u) / np.sqrt(2 * np.pi)

            # |u| <= 12 carries all but phi(12) ~ 1e-32 of the weight
            return quad(dens, -12, 12, points=kink, limit=400, epsabs=0, epsrel=1e-12)[0]

        mean = expect(lambda u: max(y(u) - a, 0.0))
        gain = expect(lambda u: max(y(u) - a, 0.0) * y(u))
        var = expect(lambda u: max(y(u) - a, 0.0) ** 2) - mean * mean - gain * gain
        return np.array([mean, gain, var])

    ref = moments(gamma, c) / moments(0.0, 1.0)
    got = sc.skew_ratios(np.array(gamma), np.array(a))
    np.testing.assert_allclose(got, ref, rtol=1e-8, atol=1e-12)
    for k, name in enumerate(("mu", "g", "v")):
        (alone,) = sc.skew_ratios(np.array(gamma), np.array(a), name)
        assert float(alone) == float(got[k])


def test_skew_ratios_are_one_without_skewness():
    """gamma = 0: the Cornish-Fisher deflection is the Gaussian itself (ratios 1 to
    round-off), and 1 where the Gaussian value underflows."""
    a = np.array([-2.0, 0.0, 1.5, 4.0, 60.0])
    for ratio in sc.skew_ratios(np.zeros_like(a), a):
        np.testing.assert_allclose(ratio, 1.0, rtol=1e-9)
