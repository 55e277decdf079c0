"""The Formula Student toe-compliance data as measured-K&C data
(suspenv/measurements/sources/fsae_knc.py) and the compliance analysis
(suspenv.measurements.knc_compliance.compliance_analysis).

The analysis is first checked on closed-form curves (exact slopes, asymmetry and
saturation); the real file's tests skip where the shared data is absent."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.cli.main import main
from suspenv.core.errors import ValidationError
from suspenv.measurements import RecordingError
from suspenv.measurements.knc_compliance import compliance_analysis
from suspenv.measurements.knc_file import (
    KncMeasurement,
    MeasuredTest,
    load_measurement,
    write_measurement,
)
from suspenv.measurements.sources.fsae_knc import (
    FOLDER,
    MZ_FILE,
    README_FRONT_COMPLIANCE,
    fsae_aligning,
    read_mz_csv,
)
from suspenv.rigs.knc_measured import on_grid

DEG = np.pi / 180


def one_wheel(x: np.ndarray, toe_deg: np.ndarray, wheel: str = "left") -> KncMeasurement:
    toe = np.full((x.size, 2), np.nan)
    toe[:, 0 if wheel == "left" else 1] = toe_deg * DEG
    test = MeasuredTest("aligning", x, np.where(x < 0, 2, 0), {"toe": toe}, (wheel,))
    return KncMeasurement("synthetic", {"aligning": test}, {"toe": 1e-6}, {"toe": "declared"})


# ------------------------------------------------------------------ closed forms
def test_analysis_of_a_line_with_different_slopes_each_side():
    """toe = kp M (M >= 0), kn M (M < 0) on M = -100..100 step 10: each side's line is
    exactly its slope; asymmetry (kp - kn) / ((kp + kn) / 2); the small-moment line
    through the symmetric points -20..20 has slope sum(M toe) / sum(M^2) = (kp + kn) / 2,
    and the large-moment ends kp and kn, mean (kp + kn) / 2: no saturation."""
    kp, kn = 0.02, 0.01  # deg per N*m
    x = np.arange(-100.0, 101.0, 10.0)
    a = compliance_analysis(one_wheel(x, np.where(x >= 0, kp, kn) * x))
    assert a.slope_positive == pytest.approx(kp * DEG, rel=1e-12)
    assert a.slope_negative == pytest.approx(kn * DEG, rel=1e-12)
    assert a.asymmetry == pytest.approx((kp - kn) / (0.5 * (kp + kn)), rel=1e-12)
    assert a.slope_small == pytest.approx(0.5 * (kp + kn) * DEG, rel=1e-12)
    assert a.saturation == pytest.approx(1.0, rel=1e-12)
    # a line through all 21 points (closed form: sum(M toe) / sum(M^2) about the mean)
    xm = x - x.mean()
    y = np.where(x >= 0, kp, kn) * x
    assert a.slope == pytest.approx(np.sum(xm * y) / np.sum(xm * xm) * DEG, rel=1e-12)


def test_analysis_of_a_saturating_odd_curve():
    """toe = s1 M for |M| <= 50, s1 50 + s2 (|M| - 50) beyond (odd, continuous): the
    small-moment slope is s1, the large-moment ends' s2, saturation s2 / s1, no
    asymmetry; the right wheel is read when it is the measured one."""
    s1, s2 = 0.04, 0.01
    x = np.arange(-100.0, 101.0, 10.0)
    y = np.sign(x) * np.where(np.abs(x) <= 50, s1 * np.abs(x), s1 * 50 + s2 * (np.abs(x) - 50))
    a = compliance_analysis(one_wheel(x, y, "right"))
    assert a.wheel == "right"
    assert a.slope_small == pytest.approx(s1 * DEG, rel=1e-12)
    assert a.slope_large == pytest.approx(s2 * DEG, rel=1e-12)
    assert a.saturation == pytest.approx(s2 / s1, rel=1e-12)
    assert a.asymmetry == pytest.approx(0.0, abs=1e-12)
    assert a.rms_cubic < a.rms_linear


def test_asymmetry_interval_matches_the_spread_of_noise_alone():
    """Reference: Monte Carlo. A symmetric compliance (0.01 deg per N m both ways) with
    white noise of 0.005 deg on a loop of 41 samples, 400 noise draws: the asymmetry
    noise alone gives is spread as the interval says (its mean half-width / 1.96 within
    10 % of the draws' standard deviation: the spread's own sampling error with 400
    draws is 3.5 %, the residual scatter's about 2 %), and the 95 % interval holds zero
    in 92-98 % of the draws (binomial sampling error 1.1 %)."""
    x = np.r_[np.arange(0.0, 101.0, 10.0), np.arange(90.0, -101.0, -10.0), np.arange(-90, 1, 10)]
    rng = np.random.default_rng(3)
    asym, half = [], []
    for _ in range(400):
        a = compliance_analysis(one_wheel(x, 0.01 * x + rng.normal(0.0, 0.005, x.size)))
        asym.append(a.asymmetry)
        half.append(a.asymmetry_ci95)
    asym, half = np.array(asym), np.array(half)
    assert np.mean(half) / 1.96 == pytest.approx(np.std(asym, ddof=1), rel=0.10)
    assert 0.92 <= np.mean(np.abs(asym) <= half) <= 0.98
    noiseless = compliance_analysis(one_wheel(x, 0.01 * x))
    assert noiseless.asymmetry_ci95 == pytest.approx(0.0, abs=1e-9)
    assert "+- " in "\n".join(noiseless.lines())


def test_analysis_refuses_a_travel_test_and_a_missing_wheel():
    x = np.arange(-100.0, 101.0, 10.0)
    m = one_wheel(x, 0.01 * x)
    with pytest.raises(ValidationError, match="wheel must be one of the measured"):
        compliance_analysis(m, wheel="right")
    with pytest.raises(ValidationError, match="needs a test of"):
        compliance_analysis(m, test="parallel")


# ------------------------------------------------------------------ the real file
@pytest.fixture
def mz_file(shared_data):
    path = shared_data / FOLDER / MZ_FILE
    if not path.is_file():
        pytest.skip(f"FSAE compliance data not available at {path}")
    return path


@pytest.mark.realdata
def test_import_keeps_the_files_numbers_on_the_right_wheel(mz_file):
    mz, toe = read_mz_csv(mz_file)
    assert mz.size == 21 and mz[0] == pytest.approx(-99.51456311) and mz[-1] == 100.0
    m = fsae_aligning(mz_file)
    t = m.tests["aligning"]
    assert m.wheels == ("right",) and t.wheels == ("right",)
    np.testing.assert_array_equal(t.drive, mz)  # N*m about +z, as in the file
    np.testing.assert_allclose(t.channels["toe"][:, 1], toe * DEG, rtol=1e-15)
    assert np.isnan(t.channels["toe"][:, 0]).all()
    # one ascending sweep: branch 2 below zero moment, 0 above
    np.testing.assert_array_equal(t.branch, np.where(mz < 0, 2, 0))
    assert m.noise_source == {"toe": "estimated"}


@pytest.mark.realdata
def test_import_round_trips_and_is_refused_for_identification(mz_file, tmp_path):
    m = fsae_aligning(mz_file)
    write_measurement(m, tmp_path)
    with pytest.raises(RecordingError, match=r"needs both wheels, but wheels = \['right'\]"):
        load_measurement(tmp_path)
    back = load_measurement(tmp_path, both_wheels=False)
    t, u = back.tests["aligning"], m.tests["aligning"]
    np.testing.assert_allclose(t.drive, u.drive, rtol=1e-14)
    np.testing.assert_allclose(t.channels["toe"][:, 1], u.channels["toe"][:, 1], rtol=1e-14)
    assert back.noise["toe"] == pytest.approx(m.noise["toe"], rel=1e-9)
    # the one-way sweep on a grid: the missing descending branch equals the ascending
    kc = on_grid(t, 10)
    np.testing.assert_allclose(kc.branch("toe", "down"), kc.branch("toe", "up"))


@pytest.mark.realdata
def test_compliance_of_the_fsae_moment_file(mz_file):
    """Linear compliance, asymmetry and saturation of the real file, checked against
    quantities read off the data independently: the end-to-end secant and the central
    difference through zero moment bracket the fitted line; the data README says
    'slightly non-linear (saturating) and different for positive and negative
    moments'."""
    mz, toe = read_mz_csv(mz_file)
    a = compliance_analysis(fsae_aligning(mz_file))
    per100 = a.slope / DEG * 100  # deg per 100 N*m
    secant = (toe[-1] - toe[0]) / (mz[-1] - mz[0]) * 100
    i = int(np.argmin(np.abs(mz)))
    centre = (toe[i + 1] - toe[i - 1]) / (mz[i + 1] - mz[i - 1]) * 100
    assert secant < per100 < centre
    assert per100 == pytest.approx(2.33, abs=0.01)
    # another team's car: about 4.7 times the README's front compliance of the ZR25
    assert per100 / README_FRONT_COMPLIANCE == pytest.approx(4.66, abs=0.05)
    assert a.saturation == pytest.approx(0.313, abs=0.005)  # saturating: stiffer at large Mz
    assert a.asymmetry == pytest.approx(-0.108, abs=0.005)  # positive Mz 11 % stiffer
    assert a.slope_positive < a.slope_negative
    # what the line leaves is far above the digitising noise: the nonlinearity is real
    assert a.rms_linear > 10 * a.noise
    assert a.noise / DEG == pytest.approx(0.0083, abs=0.001)


@pytest.mark.realdata
def test_cli_imports_and_analyses(mz_file, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SUSPENV_DATA", str(mz_file.parents[2]))
    out = tmp_path / "fsae"
    assert main(["knc", "fsae", "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["aligning.csv", "knc.toml"]
    text = capsys.readouterr().out
    assert "linear compliance        2.329 deg per 100 N*m" in text
    assert "saturation               0.313" in text
    assert main(["knc", str(out)]) == 0  # a measured folder: checked and analysed again
    assert "asymmetry                -10.8 %" in capsys.readouterr().out
