"""The held-out test in noise units (``heldout_noise_units``) and the decision rule
that uses it (``DecisionRule(heldout_rule="noise")``).

References: the sums are checked against their definition written out by hand; the
distribution of the gain against the Gaussian algebra it rests on (a real effect ``d``
under white noise ``e`` of scale ``s``: ``G = sum(2 e d + d^2) / s^2`` has mean ``L``
and variance ``4 L``; a change that only fitted noise has mean ``-L``).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.decision import DecisionRule, decide
from suspenv.diagnosis.evidence import heldout_confirmation_z, heldout_noise_units
from suspenv.diagnosis.hypothesis import Hypothesis


def test_noise_units_match_their_definition():
    rng = np.random.default_rng(3)
    before = {"f": rng.normal(size=40), "x": rng.normal(size=40)}
    after = {"f": rng.normal(size=40), "x": rng.normal(size=40)}
    scales = {"f": 2.0, "x": 0.5}
    gain, signal = heldout_noise_units(before, after, scales)
    g = sum(np.sum(before[c] ** 2 - after[c] ** 2) / scales[c] ** 2 for c in before)
    s = sum(np.sum((before[c] - after[c]) ** 2) / scales[c] ** 2 for c in before)
    assert gain == pytest.approx(g, rel=1e-12)
    assert signal == pytest.approx(s, rel=1e-12)


@pytest.mark.parametrize("real", [True, False])
def test_gain_distribution_follows_gaussian_algebra(real):
    """Mean L (real effect) or -L (fitted noise), variance 4 L, over 4000 noise draws."""
    rng = np.random.default_rng(11)
    sigma, n = 0.7, 200
    d = 0.1 * np.sin(np.linspace(0.0, 6.0, n))  # the refit's change of prediction
    lam = float(np.sum(d**2) / sigma**2)
    gains = []
    for _ in range(4000):
        e = rng.normal(0.0, sigma, n)
        before = e + d if real else e  # real: the truth contains the effect d
        gain, signal = heldout_noise_units({"c": before}, {"c": before - d}, {"c": sigma})
        assert signal == pytest.approx(lam, rel=1e-12)
        gains.append(gain)
    gains = np.array(gains)
    expected = lam if real else -lam
    se_mean = np.sqrt(4 * lam / gains.size)
    assert abs(gains.mean() - expected) < 4 * se_mean
    assert gains.var() == pytest.approx(4 * lam, rel=0.1)


def _ar1(rng: np.random.Generator, n: int, rho: float, sigma: float) -> np.ndarray:
    """AR(1) noise of lag-1 autocorrelation ``rho`` and marginal scale ``sigma``."""
    e = rng.normal(0.0, sigma * np.sqrt(1.0 - rho**2), n)
    out = np.empty(n)
    out[0] = rng.normal(0.0, sigma)
    for i in range(1, n):
        out[i] = rho * out[i - 1] + e[i]
    return out


@pytest.mark.parametrize("rho", [0.0, 0.6])
def test_confirmation_z_is_standard_normal_for_a_change_that_fitted_noise(rho):
    """A change ``d`` the held-out samples do not hold: ``z = (G + L) / (2 sqrt(L k))``
    with ``k = (1 + rho) / (1 - rho)``, the AR(1) variance factor of a slowly varying
    ``d`` against noise of lag-1 autocorrelation ``rho``: mean 0, variance 1 over noise
    draws (without ``k`` the variance would be ``k`` = 4 at rho = 0.6)."""
    rng = np.random.default_rng(5)
    sigma, n = 0.5, 2000
    d = 0.02 * np.sin(np.linspace(0.0, 9.0, n))
    zs = np.array(
        [
            heldout_confirmation_z({"c": e}, {"c": e - d}, {"c": sigma}, rho)
            for e in (_ar1(rng, n, rho, sigma) for _ in range(1500))
        ]
    )
    assert abs(zs.mean()) < 4.0 / np.sqrt(zs.size)
    assert zs.var() == pytest.approx(1.0, rel=0.15)


def test_confirmation_z_grows_with_a_real_effect_and_is_zero_without_change():
    """A real effect: ``G`` about ``L``, so ``z`` about ``sqrt(L)`` (white noise); a
    change too small for a relative drop of 1 % of the held-out error is still
    confirmed on many samples; no change of prediction gives 0."""
    rng = np.random.default_rng(8)
    sigma, n = 1.0, 20000
    d = 0.12 * np.sin(np.linspace(0.0, 60.0, n))
    e = rng.normal(0.0, sigma, n)
    lam = float(np.sum(d**2) / sigma**2)
    z = heldout_confirmation_z({"c": e + d}, {"c": e}, {"c": sigma}, 0.0)
    assert z == pytest.approx(np.sqrt(lam), abs=3.0)
    relative_drop = 1.0 - np.sqrt(np.mean(e**2)) / np.sqrt(np.mean((e + d) ** 2))
    assert relative_drop < 0.01 and z > 8.0
    assert heldout_confirmation_z({"c": e}, {"c": e}, {"c": sigma}, 0.0) == 0.0


def _hyp(p: float, reduction: float, z: float) -> Hypothesis:
    h = Hypothesis(
        kind="cubic_stiffness",
        location="",
        family="progressive",
        words="progressive stiffness",
        round=1,
        signature_score=5.0,
        signature_evidence="",
        lr_statistic=60.0,
        lr_statistic_corrected=60.0,
        lr_dof=1,
        p_value_corrected=p,
        delta_bic_corrected=-40.0,
        heldout_reduction=reduction,
    )
    h.comparison = SimpleNamespace(heldout_z=z, delta_bic=-40.0)
    return h


def test_noise_rule_keeps_what_the_heldout_test_cannot_see_and_vetoes_what_it_refutes():
    unseen = _hyp(1e-10, reduction=-0.005, z=-0.3)  # tiny held-out change, as expected
    refuted = _hyp(1e-10, reduction=0.02, z=-3.0)  # moved the held-out a lot, gained little
    unfit = _hyp(0.5, reduction=0.05, z=0.5)  # fitted data do not support it
    hyps = [unseen, refuted, unfit]
    decide(hyps, 3, DecisionRule(alpha=0.01, min_heldout_gain=0.01))
    assert [h.significant for h in hyps] == [False, True, False]
    decide(hyps, 3, DecisionRule(alpha=0.01, min_heldout_gain=0.01, heldout_rule="noise"))
    assert [h.significant for h in hyps] == [True, False, False]


def test_unknown_heldout_rule_is_named():
    with pytest.raises(ValidationError, match="heldout_rule.*'chi2'"):
        DecisionRule(alpha=0.01, min_heldout_gain=0.01, heldout_rule="chi2")
