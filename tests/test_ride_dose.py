"""Crest factor and vibration dose value (ISO 2631-1, 6.3): the Gaussian closed forms of
:func:`suspenv.metrics.ride.gaussian_dose` against records drawn from a known spectrum,
the spectral ride method's values against the time-domain method's records, and the
time method's keys against closed forms of a sine."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.metrics.iso2631 import weighting_response
from suspenv.metrics.ride import (
    CREST_LIMIT,
    DOSE_KEYS,
    gaussian_dose,
    gaussian_peak_factor,
    peak,
    record_objectives,
    vibration_dose_value,
)
from suspenv.models.minibus.ride_model import RideRecord
from suspenv.models.minibus.vehicle import BASELINE_DESIGN, LOAD_CASES, STUDY_PICK
from suspenv.models.road import RandomRoad
from suspenv.problems.minibus import MinibusRideHandling
from suspenv.problems.minibus_ride import ride_objectives_all

#: synthetic records: sample rate (Hz), length (s), band (Hz) and the mode's frequency
#: (about 80 zero crossings per record, as the minibus's weighted accelerations have
#: 100-150 in 10 s)
FS, T, BAND, F0 = 400.0, 10.0, (0.5, 40.0), 4.0


def _gaussian_records(
    zeta: float, n: int, seed: int
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Largest |x| and dose ``int x^4 dt`` (n,) of ``n`` records of a stationary zero-mean
    Gaussian process, periodic over T, sampled at FS, with the one-sided spectrum of a
    mode (F0, damping ratio ``zeta``) on the lines of ``BAND``: each line's complex
    amplitude circular normal (so the sum is exactly Gaussian); and the process's
    spectral moments m0, m2 from those lines."""
    m = int(FS * T)
    f = np.fft.rfftfreq(m, 1.0 / FS)
    df = 1.0 / T
    mode = 1.0 / ((F0**2 - f**2) ** 2 + (2 * zeta * F0 * f) ** 2)
    s = np.where((f >= BAND[0]) & (f <= BAND[1]), mode, 0.0)
    rng = np.random.default_rng(seed)
    peaks, doses = [], []
    for _ in range(n // 500):
        c = rng.standard_normal((500, f.size)) + 1j * rng.standard_normal((500, f.size))
        # x = sum_k 2 Re(c_k e^{i w_k t}) sqrt(s_k df / 4), E|c_k|^2 = 2: variance
        # sum_k s_k df
        x = np.fft.irfft(c * np.sqrt(s * df / 4.0), m, axis=-1) * m
        peaks.append(peak(x))
        doses.append(vibration_dose_value(x, FS) ** 4)
    m0 = float(np.sum(s) * df)
    m2 = float(np.sum((2 * np.pi * f) ** 2 * s) * df)
    return np.concatenate(peaks), np.concatenate(doses), m0, m2


def test_peak_factor_tends_to_davenport():
    # Davenport (1964): the expected largest value over N crossings is L + 0.5772/L,
    # L = sqrt(2 ln N), to O(L^-3): the difference must shrink towards it
    n = np.array([1e2, 1e4, 1e8, 1e16])
    lead = np.sqrt(2 * np.log(n))
    diff = np.abs((lead + np.euler_gamma / lead) / gaussian_peak_factor(n) - 1.0)
    assert np.all(np.diff(diff) < 0) and diff[-1] < 2e-4
    # the quadrature against a 400,001-point trapezoid of the same integral
    n = np.array([0.3, 5.0, 80.0, 1e8])
    u = np.linspace(0.0, 40.0, 400_001)
    ref = np.trapezoid(-np.expm1(-n[:, None] * np.exp(-0.5 * u * u)), u, axis=1)
    np.testing.assert_allclose(gaussian_peak_factor(n), ref, rtol=1e-7)
    # N -> 0: |x| is never crossed, P(max > u) = N exp(-u^2/2), E = N sqrt(pi/2)
    assert gaussian_peak_factor(1e-6) == pytest.approx(1e-6 * np.sqrt(np.pi / 2), rel=1e-5)


def test_crest_and_vdv_against_gaussian_records():
    """Broad band (damping ratio 0.5): over 2000 records the mean largest |x| / sigma and
    the mean dose int x^4 dt / sigma^4 equal the closed forms within 4 standard errors of
    the records' means (the sampling statistics; the 400 Hz samples of a 40 Hz band lose
    under 0.1 % of the peak)."""
    pk, dose, m0, m2 = _gaussian_records(0.5, 2000, seed=1)
    sigma = np.sqrt(m0)
    crest, vdv = gaussian_dose(np.array(m0), np.array(m2), T)
    pk = pk / sigma
    assert abs(pk.mean() - crest) < 4 * pk.std(ddof=1) / np.sqrt(pk.size)
    # E[int x^4 dt] = 3 sigma^4 T exactly for each record
    assert abs(dose.mean() - vdv**4) < 4 * dose.std(ddof=1) / np.sqrt(dose.size)
    assert vdv == pytest.approx(sigma * (3 * T) ** 0.25, rel=1e-12)
    # nu0 = sqrt(m2/m0)/(2 pi) (here about F0), 2 nu0 T crossings of |x|'s zero level:
    # half as many (one direction only) gives a peak factor outside the records' mean
    half = gaussian_peak_factor(np.sqrt(m2 / m0) / (2 * np.pi) * T)
    assert abs(pk.mean() - half) > 10 * pk.std(ddof=1) / np.sqrt(pk.size)


def test_narrow_band_peaks_lie_below_the_poisson_count():
    # the limitation gaussian_peak_factor states: a lightly damped mode's exceedances
    # come in clumps, so its records' peaks lie 2-5 % below the closed form
    pk, _, m0, m2 = _gaussian_records(0.1, 1000, seed=2)
    crest, _ = gaussian_dose(np.array(m0), np.array(m2), T)
    assert 0.95 < (pk / np.sqrt(m0)).mean() / crest < 0.98


def test_spectral_dose_within_the_time_methods_seed_scatter():
    """The spectral method's VDV and crest factor (equivalent-linear, Gaussian) against
    the time method's 10 s records (nonlinear model) over 20 road seeds, study pick and
    baseline, both load cases, front and rear: VDV within one standard deviation of a
    single record (the records' own scatter; the time mean's standard error is that /
    sqrt(20), and the short records' known low bias of the lightly damped full-load
    rear, docs/minibus.md, lies inside it), the crest factor within 3 standard errors of
    the records' mean crest factor."""
    X = np.vstack([STUDY_PICK, BASELINE_DESIGN])
    spec = ride_objectives_all(X, road=RandomRoad(), method="spectral")
    runs = [
        ride_objectives_all(X, road=RandomRoad(seed=s), method="time", dtype=np.float64)
        for s in range(1, 21)
    ]
    for lc in LOAD_CASES:
        for end in ("front", "rear"):
            vdv = np.array([r[lc][f"vdv_{end}"] for r in runs])
            assert np.all(np.abs(spec[lc][f"vdv_{end}"] - vdv.mean(0)) < vdv.std(0, ddof=1))
            crest = np.array([r[lc][f"crest_{end}"] for r in runs])
            se = crest.std(0, ddof=1) / np.sqrt(len(runs))
            assert np.all(np.abs(spec[lc][f"crest_{end}"] - crest.mean(0)) < 3 * se)


def test_time_method_dose_keys_on_a_sine():
    # a sine on an FFT line: the weighted record is |W| A sin(.), so crest sqrt(2) and
    # VDV = |W| A (3 T / 8)^(1/4) (closed forms), at both ends and for every row
    fs, dur, f0, amp = 100.0, 10.0, 4.0, 1.3
    t = np.arange(int(fs * dur)) / fs
    a = amp * np.sin(2 * np.pi * f0 * t)
    rows = np.vstack([a, 2 * a])
    rec = RideRecord(1 / fs, np.zeros((2, 3, t.size)), rows, rows[::-1].copy())
    out = record_objectives(rec, fs, ("no_load", "full_load"))
    w = abs(weighting_response(np.array([f0]), "Wk")[0])
    for lc, scale in (("no_load", 1.0), ("full_load", 2.0)):
        assert set(DOSE_KEYS) <= set(out[lc])
        assert out[lc]["crest_front"][0] == pytest.approx(np.sqrt(2), rel=1e-3)
        assert out[lc]["crest_rear"][0] == pytest.approx(np.sqrt(2), rel=1e-3)
        vdv = w * amp * (3 * dur / 8) ** 0.25
        assert out[lc]["vdv_front"][0] == pytest.approx(scale * vdv, rel=1e-9)
        assert out[lc]["vdv_rear"][0] == pytest.approx((3 - scale) * vdv, rel=1e-9)


@pytest.mark.parametrize("method", ["spectral", "time"])
def test_problem_archives_dose_measures(method):
    # same keys for both methods; the exposure is ride_duration_s (VDV ~ T^(1/4) for
    # the spectral method); vdv_applies is the crest factor over ISO 2631-1's 9
    X = np.atleast_2d(STUDY_PICK)
    m = MinibusRideHandling(ride_method=method).evaluate(X).extras
    for lc in LOAD_CASES:
        for key in DOSE_KEYS:
            assert np.isfinite(m[f"{key}_{lc}"]).all()
        crest = max(m[f"crest_front_{lc}"][0], m[f"crest_rear_{lc}"][0])
        assert m[f"vdv_applies_{lc}"][0] == float(crest > CREST_LIMIT) == 0.0
    if method == "spectral":
        long = MinibusRideHandling(ride_duration_s=160.0).measures(X)
        assert long["vdv_rear_no_load"][0] == pytest.approx(2 * m["vdv_rear_no_load"][0])
        assert long["crest_rear_no_load"][0] > m["crest_rear_no_load"][0]
        assert long["aw_rear_no_load"][0] == m["aw_rear_no_load"][0]


def test_spectral_paths_agree_on_the_dose():
    # the symmetric split (compiled sums), the whole model's modal sums and, with leaf
    # friction, the halves' complex modal sums against the whole model's: the same
    # integrals, so the same crest factors and VDVs to round-off
    from suspenv.metrics.ride import ride_spectral
    from suspenv.problems.minibus import ride_effect_list

    X = np.vstack([STUDY_PICK, BASELINE_DESIGN])
    split, whole = ride_spectral(X), ride_spectral(X, split=False)
    leaf = [{"kind": "dahl_hysteresis", "location": "rear_leaf", "params": {"f_c": 600.0}}]
    eff = ride_effect_list("test", leaf)
    halves, whole_eff = ride_spectral(X, effects=eff), ride_spectral(X, effects=eff, split=False)
    for key in DOSE_KEYS:
        np.testing.assert_allclose(split[key], whole[key], rtol=1e-9)
        np.testing.assert_allclose(halves[key], whole_eff[key], rtol=1e-9)
        assert np.isfinite(halves[key]).all()
