"""ISO 8608 road profiles: PSD per octave band, RMS height, track coherency, delays."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import csd

from suspenv.core.errors import ValidationError
from suspenv.models.road import (
    CLASS_BAND,
    N0,
    ROAD_CLASS_GD0,
    class_gd0,
    contact_length_filter,
    displacement_psd,
    generate_profile,
    temporal_psd,
    track_coherence,
    triangular_bump,
    welch_psd,
)


def rms_height(road_class: str = "B", band: tuple[float, float] = CLASS_BAND) -> float:
    """RMS elevation (m) of a w = 2 road over a spatial band, the integral of the class
    formula: Gd(n0) n0^2 (1/n1 - 1/n2) (the reference of the generated profiles)."""
    n1, n2 = band
    return float(np.sqrt(class_gd0(road_class) * N0**2 * (1.0 / n1 - 1.0 / n2)))


def octave_band_check(
    n: np.ndarray,
    psd: np.ndarray,
    road_class: str | float = "B",
    band: tuple[float, float] = (0.05, 2.0),
) -> list[tuple[float, float, float]]:
    """Per octave band in ``band``: (lower edge, mean measured PSD / mean Gd, n_lines)."""
    rows = []
    lo = band[0]
    while lo * 2 <= band[1] * (1 + 1e-9):
        sel = (n >= lo) & (n < 2 * lo)
        if sel.any():
            ratio = float(np.mean(psd[sel]) / np.mean(displacement_psd(n[sel], road_class)))
            rows.append((lo, ratio, float(sel.sum())))
        lo *= 2
    return rows


def test_class_means_not_upper_limits():
    # ISO 8608 class means of Gd(n0) in 1e-6 m^3 (the standard's table)
    assert ROAD_CLASS_GD0["A"] == pytest.approx(16e-6)
    assert ROAD_CLASS_GD0["B"] == pytest.approx(64e-6)
    assert ROAD_CLASS_GD0["H"] == pytest.approx(262144e-6)
    assert displacement_psd(0.1, "C") == pytest.approx(256e-6)
    with pytest.raises(ValidationError, match="road class"):
        class_gd0("Z")


def test_class_b_rms_formula():
    # ride_standards spec: class B over 0.011-2.83 cycle/m is about 7.6 mm
    assert rms_height("B") == pytest.approx(7.6e-3, rel=0.01)


@pytest.mark.parametrize("road_class", ["B", "D"])
def test_generated_psd_within_10_percent_per_octave(road_class):
    dx = 0.05
    prof = generate_profile(8000.0, dx, road_class, seed=3, track=1.465)
    for track in (prof.left, prof.right):
        n, p = welch_psd(track, dx, segment_length=200.0)
        # reference: the class formula Gd(n); octave bands 0.05-1.6 cycle/m (the
        # band a vehicle at 20-110 km/h turns into 0.3-50 Hz)
        rows = octave_band_check(n, p, road_class, band=(0.05, 1.6))
        assert len(rows) == 5
        for lo, ratio, _ in rows:
            assert abs(ratio - 1.0) < 0.10, (lo, ratio)


def test_rms_height_matches_class_formula():
    prof = generate_profile(6000.0, 0.05, "B", seed=1)
    # the line amplitudes are exact, so the variance equals sum(Gd dn) up to the grid's
    # quadrature of the integral (class formula, reference)
    assert np.std(prof.left) == pytest.approx(rms_height("B"), rel=0.03)
    assert np.std(prof.right) == pytest.approx(rms_height("B"), rel=0.03)


def test_left_right_coherency_matches_isotropic_formula():
    track = 1.465
    dx = 0.05
    prof = generate_profile(20000.0, dx, "B", seed=7, track=track)
    f, pxy = csd(prof.left, prof.right, fs=1 / dx, nperseg=8000)
    _, pxx = welch_psd(prof.left, dx, 400.0)
    _, pyy = welch_psd(prof.right, dx, 400.0)
    rho_est = pxy.real / np.sqrt(pxx * pyy)
    # reference: rho(n) = 2 pi n B K1(2 pi n B) (isotropic w = 2 road)
    for n0 in (0.05, 0.1, 0.2):
        sel = np.abs(f - n0) < 0.01
        assert np.mean(rho_est[sel]) == pytest.approx(float(track_coherence(n0, track)), abs=0.05)
    assert track_coherence(0.0, track) == 1.0
    # independent tracks when no track width is given
    indep = generate_profile(20000.0, dx, "B", seed=7, track=None)
    f, pxy = csd(indep.left, indep.right, fs=1 / dx, nperseg=8000)
    assert abs(np.mean(pxy.real[(f > 0.05) & (f < 0.5)])) < 0.1 * np.mean(
        pxx[(f > 0.05) & (f < 0.5)]
    )


def test_delay_is_exact_shift_and_slope_is_derivative():
    dx = 0.1
    prof = generate_profile(500.0, dx, "C", seed=2)
    left, _ = prof.shifted(2.5)  # 25 samples
    np.testing.assert_allclose(left, np.roll(prof.left, 25), atol=1e-12)
    fine = generate_profile(200.0, 0.005, "C", seed=2)
    slope, _ = fine.slopes()
    # reference: central finite differences of the profile on a grid fine enough that
    # the difference quotient's gain at the band's top (2.83 cycle/m) is > 0.99
    fd = (np.roll(fine.left, -1) - np.roll(fine.left, 1)) / (2 * fine.dx)
    np.testing.assert_allclose(slope, fd, atol=0.01 * np.max(np.abs(slope)))


def test_temporal_psd_scaling():
    # Gq(f) = Gd(f/v)/v (ISO 8608)
    v = 20.0
    assert temporal_psd(2.0, v, "B") == pytest.approx(displacement_psd(0.1, "B") / v)


def test_bump_and_contact_filter_keep_area():
    dx = 0.001
    x = np.arange(0, 2.0, dx)
    bump = triangular_bump(x, 0.5, 0.4, 0.06)
    assert bump.max() == pytest.approx(0.06, rel=1e-3)
    # area of a triangle: base * height / 2; a moving average preserves the area
    assert bump.sum() * dx == pytest.approx(0.4 * 0.06 / 2, rel=1e-3)
    smooth = contact_length_filter(bump, dx, 0.16)
    assert smooth.sum() * dx == pytest.approx(0.4 * 0.06 / 2, rel=1e-3)
    assert smooth.max() < bump.max()
    with pytest.raises(ValidationError, match="base > 0"):
        triangular_bump(x, 0.5, -1.0)


def test_enveloped_profile_is_the_moving_mean_over_the_contact_length():
    # reference: a circular moving average of the sampled profile over the footprint
    dx, length = 0.005, 0.155  # 31 samples, centred
    prof = generate_profile(100.0, dx, "C", seed=4)
    env = prof.enveloped(length)
    k = int(round(length / dx))
    padded = np.concatenate([prof.left[-(k // 2) :], prof.left, prof.left[: k // 2]])
    moving = np.convolve(padded, np.ones(k) / k, mode="valid")
    np.testing.assert_allclose(env.left, moving, atol=0.01 * np.std(prof.left))
    assert np.std(env.left) < np.std(prof.left)
