"""The shared residual-left rule (:mod:`suspenv.diagnosis.checks.residual_left`) on each
family's noise model: a structured residual above the family's limit is reported with
its size and place; noise alone is not.

References: Monte-Carlo draws of white Gaussian noise for the size limits' false-alarm
rates (the noise level estimated as each family estimates it); a residual built from a
known structure plus white Gaussian noise of known standard deviation (the size in
noise units is then sqrt(1 + (S/N)^2) in closed form); the chi-square distribution of
a sum of squares of unit normal samples (K&C cells).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from suspenv.diagnosis.checks.residual_left import (
    Left,
    from_cells,
    roughness_factor,
    run,
    size_limit,
)
from suspenv.diagnosis.decision import DecisionRule


def _finding(views: list[Left]):
    """The shared rule's finding on a family that supplies ``views``."""
    family = SimpleNamespace(residual_left=lambda outcome, setup, alpha: (views, None))
    outcome = SimpleNamespace(named=[], hypotheses=[])
    ctx = SimpleNamespace(family=family, setup=None, outcome=outcome, rule=DecisionRule())
    return run(ctx)  # type: ignore[arg-type]


def _guide(ripple_n: float, seed: int):
    """A friction guide of 20 kg and 50 N s/m with a position ripple of ``ripple_n`` N
    amplitude and white noise of 2 N, its plain model fitted."""
    from suspenv.diagnosis.fitting import fit
    from suspenv.diagnosis.split import Split
    from suspenv.measurements import Recording
    from suspenv.models.components import FrictionGuideModel

    t = np.arange(0.0, 40.0, 1.0 / 500.0)
    w = 2 * np.pi * 0.5
    x, v, a = 0.05 * np.sin(w * t), 0.05 * w * np.cos(w * t), -0.05 * w * w * np.sin(w * t)
    noise = np.random.default_rng(seed).normal(0.0, 2.0, t.size)
    force = 20.0 * a + 50.0 * v + ripple_n * np.sin(2 * np.pi * x / 0.03) + noise
    units = {"time": "s", "position": "m", "velocity": "m/s", "acceleration": "m/s^2", "force": "N"}
    inputs = {"position": x, "velocity": v, "acceleration": a}
    rec = Recording("sweep", "guide", t, inputs, {"force": force}, units, {})
    return fit(FrictionGuideModel(), [rec]), Split([rec], None, [], None, "all samples")


def test_component_structure_above_the_limit_is_reported_with_size_and_place():
    from suspenv.diagnosis.component.residual_left import LIMIT, MATERIAL_RATIO, residual_left

    res, split = _guide(4.0, seed=1)
    (left,) = residual_left(res, split)
    state = left.views()[0]
    # a ripple of 4 N amplitude (2.83 N RMS) over 2 N of noise: sqrt(1 + 1.41^2) = 1.73
    assert state.remains and state.rms == pytest.approx(np.hypot(1.0, 2.83 / 2.0), rel=0.1)
    found = _finding(left.views())
    assert found is not None and found.remains and not found.confident
    assert f"{state.rms:.3g} times the noise" in found.sentence
    assert "largest moving" in found.sentence and "cycle-to-cycle test" in found.sentence
    # the limit in noise units is the size rule S > MATERIAL_RATIO N: sqrt(1 + ratio^2)
    assert abs(LIMIT - np.sqrt(1 + MATERIAL_RATIO**2)) < 1e-12


def test_component_noise_alone_is_not_a_residual_left():
    from suspenv.diagnosis.component.residual_left import residual_left

    res, split = _guide(0.0, seed=2)
    (left,) = residual_left(res, split)
    assert not left.remains
    found = _finding(left.views())
    assert found is not None and not found.remains and found.sentence == ""


def test_knc_cells_structure_is_reported_with_size_and_place_noise_is_not():
    rng = np.random.default_rng(5)
    cells = {(t, c): rng.normal(size=50) for t in ("parallel", "opposite") for c in ("fz", "toe")}
    views, _ = from_cells(cells, 0.01)
    assert not views[0].remains and _finding(views).sentence == ""
    # a stop's force in the parallel test's fz: 12 noise levels over 40 % of the travel
    # (RMS over the channel's 100 samples sqrt((20 * 144 + 100) / 100) = 5.5)
    cells[("parallel", "fz")] = cells[("parallel", "fz")] + 12.0 * (np.arange(50) >= 30)
    views, numbers = from_cells(cells, 0.01)
    (left,) = views
    assert left.remains and left.channel == "fz" and left.rms > left.limit
    assert "parallel test's fz" in left.where and numbers["lag1"] > 0.5
    assert f"{left.rms:.3g} times the noise" in _finding(views).sentence


def test_ride_view_needs_size_and_structure():
    from suspenv.diagnosis.ride.residual import ResidualCheck

    limit = 1.05

    def check(excess: float, p: float) -> ResidualCheck:
        return ResidualCheck(1.0, excess * 0.1, 0.1, excess, 0.5, 50.0, p, limit, named=True)

    assert check(1.8, 1e-6).view().remains  # large and not white
    assert not check(1.8, 0.5).view().remains  # large but white: noise of another level
    assert not check(0.5 * (1 + limit), 1e-6).view().remains  # below the limit
    found = _finding([check(1.8, 1e-6).view()])
    assert "1.8 times the noise" in found.sentence and "Ljung-Box p = 1e-06" in found.sentence
    assert "sensor-noise floor" in found.sentence  # where: the held-out error in words


def _rate_within(alarms: int, rounds: int, alpha: float) -> None:
    """The false-alarm rate is at most ``alpha`` within 4 binomial standard errors, and
    the limit is not needlessly wide (the rate is above a tenth of ``alpha``)."""
    rate, se = alarms / rounds, np.sqrt(alpha * (1 - alpha) / rounds)
    assert alpha / 10 < rate <= alpha + 4 * se, (rate, se)


def test_roughness_factor_matches_a_monte_carlo_of_the_noise_estimate():
    # reference: the variance of the K&C noise estimate (median absolute second
    # difference, suspenv.diagnosis.knc.locate.residual_map) over 4000 draws of 400
    # white samples; 1.36 would be the median absolute deviation of independent samples
    r = np.random.default_rng(11).normal(size=(4000, 400))
    d = r[:, 1:-1] - 0.5 * (r[:, :-2] + r[:, 2:])
    sigma = 1.4826 * np.median(np.abs(d), axis=1) / np.sqrt(1.5)
    # relative standard error of a variance estimate from 4000 draws: sqrt(2 / 4000)
    assert np.var(sigma) * d.shape[1] == pytest.approx(roughness_factor(), rel=0.1)


@pytest.mark.parametrize("alpha", [0.01, 0.05])
def test_knc_size_limit_false_alarm_rate_under_noise_is_at_most_alpha(alpha):
    # 6 channels x 3 tests of 50 samples of white noise in unknown units, each channel's
    # noise read from its roughness; the size limit alone (no chi-square test)
    rng = np.random.default_rng(12)
    rounds, alarms = 4000, 0
    for _ in range(rounds):
        r = rng.normal(size=(6, 3, 50))
        d = r[:, :, 1:-1] - 0.5 * (r[:, :, :-2] + r[:, :, 2:])
        sigma = 1.4826 * np.median(np.abs(d).reshape(6, -1), axis=1) / np.sqrt(1.5)
        cells = {(t, f"c{c}"): r[c, t] / sigma[c] for c in range(6) for t in range(3)}
        views, numbers = from_cells(cells, alpha)
        limit = size_limit(roughness_factor() / (3 * 48), 150, alpha, 6)
        assert numbers["limit"]["c0"] == pytest.approx(limit, rel=1e-12)
        alarms += max(numbers["rms_noise_units"].values()) > limit
    _rate_within(alarms, rounds, alpha)


@pytest.mark.parametrize("alpha", [0.01, 0.05])
def test_ride_size_limit_false_alarm_rate_under_noise_is_at_most_alpha(alpha):
    # 2 recordings of 1024 white samples at 200 Hz, noise read from the Hann periodogram
    # above 50 Hz (suspenv.diagnosis.ride.residual.white_noise_sd), pooled as the floor
    from suspenv.diagnosis.ride.residual import white_noise_sd

    rng = np.random.default_rng(13)
    rounds, alarms = 3000, 0
    for _ in range(rounds):
        r = rng.normal(size=(2, 1024))
        sd, var2 = zip(*(white_noise_sd(x, 0.005) for x in r), strict=True)
        floor = np.sqrt(np.mean(np.square(sd)))
        limit = size_limit(0.25 / sum(1 / v for v in var2), r.size, alpha)
        alarms += np.sqrt(np.mean(r**2)) / floor > limit
    _rate_within(alarms, rounds, alpha)
