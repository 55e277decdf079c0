"""Fit, evidence and locate against closed forms."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from suspenv.diagnosis.component.locate import (
    Segment,
    locate,
    reversal_indices,
    travel_since_reversal,
)
from suspenv.diagnosis.evidence import ljung_box
from suspenv.diagnosis.fitting import fit, parameter_covariance


class LinearDamper:
    """F = k x + c v (a model linear in its parameters, so OLS is the exact reference)."""

    family = "linear_damper"
    location = "damper"
    parameter_names = ("k", "c")
    output_channels = ("force",)
    effects = ()
    effect_defaults: dict = {}

    def bounds(self):
        return np.array([-1e7, -1e7]), np.array([1e7, 1e7])

    def initial_guess(self, rec):
        return np.array([1.0, 1.0])

    def simulate(self, theta, rec):
        return {
            "force": theta[..., 0, None] * rec.inputs["x"] + theta[..., 1, None] * rec.inputs["v"]
        }

    def with_effects(self, effects):
        return self

    def difference_step(self, theta, lo, hi):
        return 1e-6 * np.maximum(np.abs(theta), 1.0)

    def refine_start(self, theta0, recordings, masks):
        return None

    def jacobian_model(self):
        return self

    def force_view(self, theta, rec):
        return None


def _rec(noise: float, seed: int = 0):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 4.0, 0.005)
    x = 0.02 * np.sin(2 * np.pi * 1.3 * t) + 0.005 * np.sin(2 * np.pi * 4.1 * t)
    v = np.gradient(x, t)
    f = 15000.0 * x + 900.0 * v + rng.normal(0.0, noise, t.size)
    return SimpleNamespace(
        name="r", test="sine", time=t, inputs={"x": x, "v": v}, outputs={"force": f}, units={}
    )


def test_fit_matches_ordinary_least_squares_and_its_standard_errors() -> None:
    rec = _rec(noise=10.0)
    res = fit(LinearDamper(), rec)
    # reference: OLS normal equations, se = sqrt(diag(s^2 (X^T X)^-1)), s^2 = SSR / (n - p)
    X = np.c_[rec.inputs["x"], rec.inputs["v"]]
    beta, *_ = np.linalg.lstsq(X, rec.outputs["force"], rcond=None)
    r = rec.outputs["force"] - X @ beta
    s2 = r @ r / (X.shape[0] - 2)
    se = np.sqrt(np.diag(s2 * np.linalg.inv(X.T @ X)))
    np.testing.assert_allclose(res.theta, beta, rtol=1e-6)
    np.testing.assert_allclose(res.stderr, se, rtol=1e-3)
    assert res.rms()["force"] == pytest.approx(np.sqrt(np.mean(r**2)), rel=1e-6)


def test_standard_errors_of_parameters_in_units_decades_apart() -> None:
    # reference: the OLS covariance s^2 (X^T X)^-1 of well-scaled regressors X, carried to
    # parameters whose regressors are X's columns times 1e-7 ... 1e7 (theta_j = beta_j /
    # scale_j, so cov_theta = D^-1 cov_beta D^-1); a pseudo-inverse of J^T J drops the
    # small singular values of such a J and gives errors thousands of times too small
    rng = np.random.default_rng(0)
    X = rng.standard_normal((2000, 5))
    scale = np.array([1e-7, 1e-3, 1.0, 1e3, 1e7])
    exact = np.linalg.inv(X.T @ X) / np.outer(scale, scale) * 0.3
    cov = parameter_covariance(X * scale, 0.3)
    # tolerance: X^T X of 2000 normal rows has a condition number near 1, and the column
    # scales are exact powers of ten to one rounding each, so both sides are round-off
    # (~1e-14) apart whatever the BLAS kernel; rtol 1e-9 leaves a margin of 1e5 and still
    # fails the pseudo-inverse, which is off by factors of thousands
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), np.sqrt(np.diag(exact)), rtol=1e-9)
    np.testing.assert_allclose(cov, exact, rtol=1e-9, atol=0.0)
    # a parameter the residual does not depend on gets zero variance, the others theirs
    with_dead = parameter_covariance(np.c_[X * scale, np.zeros(2000)], 0.3)
    assert with_dead[-1, -1] == 0.0
    np.testing.assert_allclose(np.diag(with_dead)[:-1], np.diag(exact), rtol=1e-9)


def test_information_criteria_closed_form() -> None:
    res = fit(LinearDamper(), _rec(noise=5.0))
    n, ssr = res.n["force"], res.ssr["force"]
    # Gaussian log-likelihood at the variance MLE: -n/2 (ln(2 pi SSR/n) + 1)
    ll = -0.5 * n * (np.log(2 * np.pi * ssr / n) + 1)
    assert res.log_likelihood() == pytest.approx(ll)
    assert res.bic() == pytest.approx(2 * np.log(n) - 2 * ll)
    assert res.aic() == pytest.approx(4 - 2 * ll)


def test_fit_on_a_mask_uses_only_those_samples() -> None:
    rec = _rec(noise=1.0)
    mask = np.arange(rec.time.size) < 300
    res = fit(LinearDamper(), rec, masks=[mask])
    assert res.n["force"] == 300


def test_ljung_box_white_vs_correlated() -> None:
    rng = np.random.default_rng(3)
    e = rng.normal(size=4000)
    assert ljung_box(e)[1] > 0.01  # white noise: H0 kept
    ar = np.convolve(e, [1.0, 0.9, 0.8], mode="same")  # MA(2): clearly correlated
    assert ljung_box(ar)[1] < 1e-10


def test_reversals_and_travel_since_reversal() -> None:
    t = np.linspace(0.0, 2.0, 2001)
    x = np.sin(2 * np.pi * t)  # reversals at t = 0.25, 0.75, 1.25, 1.75
    v = np.gradient(x, t)
    rev = reversal_indices(v)
    np.testing.assert_allclose(t[rev], [0.25, 0.75, 1.25, 1.75], atol=2e-3)
    d = travel_since_reversal(x, v)
    # halfway between reversals (x = 0) the travel is one amplitude
    assert d[1000] == pytest.approx(1.0, abs=1e-2)


def test_locate_branch_reversal_and_band_shares() -> None:
    t = np.arange(0.0, 10.0, 0.01)
    x = 0.02 * np.sin(2 * np.pi * 1.0 * t)
    v = np.gradient(x, t)
    # residual only while compressing: the bump branch holds all of it, twice its share
    seg = Segment("sine", t, x, v, {"force": np.where(v > 0, 1.0, 0.0)})
    branch = {s.part: s for s in locate([seg]).by_dimension("branch")}
    assert branch["bump (v > 0)"].share == pytest.approx(1.0)
    assert branch["bump (v > 0)"].enrichment == pytest.approx(2.0, rel=0.02)
    # a pure third harmonic lives in the 3 f0 band (Parseval)
    seg = Segment("sine", t, x, v, {"force": np.sin(2 * np.pi * 3.0 * t)})
    band = {s.part: s.share for s in locate([seg]).by_dimension("frequency band")}
    assert band["3 f0"] == pytest.approx(1.0, abs=1e-6)
    # a residual confined to a narrow window after each reversal is enriched there
    near = travel_since_reversal(x, v) < 0.1 * np.ptp(x)
    seg = Segment("sine", t, x, v, {"force": near * np.sign(v)})
    loc = locate([seg])
    rev = {s.part: s for s in loc.by_dimension("reversal")}
    assert rev["near reversal"].share == pytest.approx(1.0)
    assert loc.hotspots()[0].part == "near reversal"


def test_locate_channels_and_tests() -> None:
    t = np.arange(0.0, 2.0, 0.01)
    x = np.sin(2 * np.pi * t)
    v = np.gradient(x, t)
    res = {"body_acceleration": np.ones_like(t), "suspension_deflection": np.zeros_like(t)}
    a, b = Segment("run A", t, x, v, res), Segment("run B", t, x, v, res)
    loc = locate([a, b])
    channel = {s.part: s.share for s in loc.by_dimension("channel")}
    assert channel == {"body_acceleration": 1.0, "suspension_deflection": 0.0}
    tests = {s.part: s.share for s in loc.by_dimension("test")}
    assert tests == {"run A": 0.5, "run B": 0.5}
