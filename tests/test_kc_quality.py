"""KCIdentification's quality: RMS of the 40 mismatches in standard errors.

References: a hand computation of the definition; the least-squares slope's variance from
the normal equations (``sigma^2 (X^T X)^-1``, independent of the perturbation that
:func:`objective_noise` applies to the objectives' own code); a seeded Monte Carlo of the
rig's noise; and a change of unit (N -> kN) that a cross-unit sum does not survive.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.metrics.knc import FIT_HALF_WIDTH, OBJECTIVE_CHANNELS, OBJECTIVE_NAMES, objectives
from suspenv.problems.kc_identification import (
    KCIdentification,
    noise_scaled_rms,
    objective_noise,
)
from suspenv.rigs.knc import KCResult


@pytest.fixture(scope="module")
def problem() -> KCIdentification:
    return KCIdentification(truth_seed=1, concealed=["tolerance"])


def test_quality_of_the_truth_is_the_hand_computed_rms(problem):
    F = problem.evaluate(problem.truth_design()[None, :]).objectives
    s = problem.objective_scales
    hand = math.sqrt(sum((float(f) / float(v)) ** 2 for f, v in zip(F[0], s, strict=True)) / 40)
    assert problem.quality(F)[0] == pytest.approx(hand, rel=1e-12)
    assert problem.quality_name == "RMS mismatch in standard errors"


def test_ride_rate_standard_error_is_the_least_squares_slope_variance(problem):
    # sgl_ride_rate_pos: slope of tyre_fz [N] over pad travel [mm] on the moving wheel,
    # mean of the two branches' 7-point quadratic fits; tyre_fz noise 1 N per sample,
    # pad travel practically exact, so var = sigma^2 / 4 * sum_b [(X_b^T X_b)^-1]_11
    r = problem.measured["single"]
    st = r.static_index
    var = 0.0
    for b in ("down", "up"):
        pad = r.branch("pad_z", b)[0, :, 0] * 1e3
        x = pad[st - FIT_HALF_WIDTH : st + FIT_HALF_WIDTH + 1] - pad[st]
        X = np.stack([np.ones_like(x), x, x * x], axis=1)
        var += np.linalg.inv(X.T @ X)[1, 1]
    sigma = problem.measurement.noise["tyre_fz"]
    expected = sigma * math.sqrt(var) / 2
    j = OBJECTIVE_NAMES.index("sgl_ride_rate_pos")
    assert problem.objective_scales[j] == pytest.approx(expected, rel=1e-6)


def test_standard_errors_match_a_monte_carlo_of_the_rig_noise(problem):
    n = 400
    rng = np.random.default_rng(7)
    noisy = {}
    for t, r in problem.measured.items():
        ch = {}
        for c in OBJECTIVE_CHANNELS:
            base = np.repeat(r.channels[c][:1], n, axis=0)
            ch[c] = base + rng.normal(0.0, problem.measurement.noise.get(c, 0.0), base.shape)
        noisy[t] = KCResult(t, r.grid, r.path, ch, np.ones(n, bool), [""] * n)
    sd = objectives(noisy).std(axis=0, ddof=1)
    # a sample standard deviation's relative standard error is 1/sqrt(2(n-1)); 5 of them
    bound = 5.0 / math.sqrt(2 * (n - 1))
    np.testing.assert_array_less(np.abs(sd / problem.objective_scales - 1.0), bound)


def test_a_change_of_unit_changes_the_sums_ranking_but_not_the_qualitys(problem):
    rng = np.random.default_rng(3)
    U = rng.uniform(0.35, 0.65, size=(10, problem.space.dim))
    X = np.vstack([problem.truth_design(), problem.initial_design(), problem.space.to_physical(U)])
    b = problem.evaluate(X)
    F = b.objectives[b.ok]
    assert len(F) >= 4
    # tyre forces in kN instead of N, in the rig's recordings and their noise: every
    # objective read from them is 1000 times smaller, and so is its standard error
    kn = {
        t: KCResult(
            t, r.grid, r.path, {**r.channels, "tyre_fz": r.channels["tyre_fz"] * 1e-3}, r.ok, []
        )
        for t, r in problem.measured.items()
    }
    noise_kn = {**problem.measurement.noise, "tyre_fz": problem.measurement.noise["tyre_fz"] * 1e-3}
    force = np.array(["N" in u for u in problem.objective_units])
    factor = np.where(force, 1e-3, 1.0)
    np.testing.assert_allclose(objectives(kn)[0], problem.targets * factor, rtol=1e-9, atol=0)
    s_kn = objective_noise(kn, noise_kn)
    np.testing.assert_allclose(s_kn, problem.objective_scales * factor, rtol=1e-6)
    q, q_kn = problem.quality(F), noise_scaled_rms(F * factor, s_kn)
    np.testing.assert_allclose(q_kn, q, rtol=1e-6)
    assert list(np.argsort(q_kn)) == list(np.argsort(q))
    # the plain sum ranks the same designs differently in N and in kN
    assert list(np.argsort((F * factor).sum(axis=1))) != list(np.argsort(F.sum(axis=1)))


def test_a_measurement_without_noise_is_refused_by_name():
    p = KCIdentification(truth_seed=1, concealed=["tolerance"])
    p.measurement.noise = {c: 0.0 for c in p.measurement.noise}
    with pytest.raises(ValidationError, match=r"standard error must be > 0.*'par_toe'"):
        p.quality(np.zeros((1, 40)))
