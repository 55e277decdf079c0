"""The stop-gain criteria of ``benchmarks.minibus_stop_criteria`` (docs/minibus.md, "What
stays outside 2 %") against their definitions, by adaptive quadrature over a Gaussian
deflection y of RMS s about the spring's mean m, and against the limits that have
closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from benchmarks import minibus_stop_criteria as sc

GAP, KS = sc.GAP, sc.K_STOP
#: (m, s) in m: the gap 1.6 RMS away (frequent contact), 2.2 away, the mean beyond it
CASES = [(0.001, 0.009), (0.004, 0.005), (0.018, 0.006)]


def _expect(fn, m: float, s: float) -> float:
    """``E[fn(y)]`` for y ~ N(0, s^2), with the stop's kink as a breakpoint."""

    def integrand(y: float) -> float:
        return fn(y) * np.exp(-0.5 * (y / s) ** 2) / (np.sqrt(2 * np.pi) * s)

    return quad(integrand, -12 * s, 12 * s, points=[GAP - m], epsabs=0, epsrel=1e-12, limit=200)[0]


def _potential(m: float, s: float):
    """The stop's potential about the mean, ``U(y) = G(m + y) - G(m) - E[F] y`` (J),
    ``G(x) = k_stop max(x - gap, 0)^2 / 2``: U' is the force's fluctuation."""
    mean_force = _expect(lambda y: KS * max(m + y - GAP, 0.0), m, s)
    g_m = 0.5 * KS * max(m - GAP, 0.0) ** 2
    return lambda y: 0.5 * KS * max(m + y - GAP, 0.0) ** 2 - g_m - mean_force * y


@pytest.mark.parametrize("m, s", CASES)
def test_energy_criteria_equal_their_definitions(m, s):
    """``potential_energy`` is ``2 E[U]/s^2`` and ``energy_mean_square`` the least
    mean-square fit of the potentials, ``2 E[U y^2]/E[y^4]`` (E[y^4] = 3 s^4): their
    closed forms (tail moments; Stein's lemma twice) against quadrature."""
    u = _potential(m, s)
    pe = 2 * _expect(u, m, s) / s**2
    ems = 2 * _expect(lambda y: u(y) * y * y, m, s) / (3 * s**4)
    args = (np.array(1e5), np.array(m), np.array(s))
    np.testing.assert_allclose(sc._potential_energy(*args), pe, rtol=1e-8)
    np.testing.assert_allclose(sc._energy_mean_square(*args), ems, rtol=1e-8)


@pytest.mark.parametrize("m, s", CASES)
def test_kazakov_variance_equals_its_definition(m, s):
    """Kazakov's equal-variance gain ``sqrt(Var F)/s`` of a Gaussian deflection (tail
    moments) against quadrature."""
    mean = _expect(lambda y: KS * max(m + y - GAP, 0.0), m, s)
    var = _expect(lambda y: (KS * max(m + y - GAP, 0.0) - mean) ** 2, m, s)
    gain = sc._kazakov_variance(np.array(1e5), np.array(m), np.array(s))
    np.testing.assert_allclose(gain, np.sqrt(var) / s, rtol=1e-8)


@pytest.mark.parametrize("m, s", CASES)
def test_potential_closure_limits(m, s):
    """The closure's density is Gaussian for a spring far stiffer than the stop, so its
    gain is then Stein's ``E[F']`` (the ``gaussian`` criterion; the grid's sum carries
    the kink's O(h^2) error, h = s/100: measured 5e-5) and its equal-variance gain the
    Gaussian one; a stop in contact over the whole density is a linear spring, gain
    ``k_stop`` exactly by both."""
    mm, ss = np.array(m), np.array(s)
    gauss = sc._gaussian(np.array(1e5), mm, ss)
    np.testing.assert_allclose(sc._potential_closure(np.array(1e14), mm, ss), gauss, rtol=1e-3)
    var = sc._kazakov_variance(np.array(1e5), mm, ss)
    np.testing.assert_allclose(sc._kazakov_variance_closure(np.array(1e14), mm, ss), var, rtol=1e-3)
    for gain in (sc._potential_closure, sc._kazakov_variance_closure):
        np.testing.assert_allclose(gain(np.array(5e4), np.array(GAP + 9 * s), ss), KS, rtol=1e-9)
