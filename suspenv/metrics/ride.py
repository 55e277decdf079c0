"""Ride metrics of acceleration records: PSD, peak, crest factor, vibration dose value.

Units: acceleration in m/s^2, time in s, frequency in Hz; PSDs are one-sided
((m/s^2)^2/Hz). Records carry time on the last axis; leading axes are a batch.
Weighted values use the ISO 2631-1 weightings of :mod:`suspenv.metrics.iso2631`.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from suspenv.core.errors import ValidationError
from suspenv.metrics.iso2631 import weighted_signal


def _record(a: np.ndarray, fs: float) -> np.ndarray:
    arr = np.asarray(a, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] < 2:
        raise ValidationError(
            f"an acceleration record needs >= 2 samples on its last axis, but got {arr.shape}"
        )
    if not fs > 0:
        raise ValidationError(f"`fs > 0` must hold, but got fs={fs}")
    return arr


def acceleration_psd(
    a: np.ndarray, fs: float, segment_s: float = 4.0
) -> tuple[np.ndarray, np.ndarray]:
    """One-sided Welch PSD (Hann, 50 % overlap) of a record: (f (Hz), PSD ((m/s^2)^2/Hz))."""
    a = _record(a, fs)
    nper = min(int(round(segment_s * fs)), a.shape[-1])
    return signal.welch(a, fs=fs, nperseg=nper, axis=-1)


def peak(a: np.ndarray) -> np.ndarray:
    """Largest absolute value along the last axis (m/s^2)."""
    return np.max(np.abs(np.asarray(a, dtype=float)), axis=-1)


def crest_factor(a: np.ndarray) -> np.ndarray:
    """Peak / RMS (-). ISO 2631-1 asks for VDV besides RMS when it exceeds 9."""
    a = np.asarray(a, dtype=float)
    return peak(a) / np.sqrt(np.mean(a * a, axis=-1))


def vibration_dose_value(a: np.ndarray, fs: float) -> np.ndarray:
    """VDV = (integral of a^4 dt)^(1/4) (m/s^1.75) of an (already weighted) record."""
    a = _record(a, fs)
    return (np.sum(a**4, axis=-1) / fs) ** 0.25


def weighted_vdv(a: np.ndarray, fs: float, name: str = "Wk") -> np.ndarray:
    """VDV of the record after ISO 2631-1 weighting (time-domain filters; fs > 200 Hz)."""
    return vibration_dose_value(weighted_signal(_record(a, fs), fs, name), fs)


def band_rms(f: np.ndarray, psd: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    """RMS (m/s^2) in a frequency band from a one-sided PSD (trapezoid integration)."""
    lo, hi = band
    if not lo < hi:
        raise ValidationError(f"`low < high` must hold, but got (low={lo}, high={hi})")
    sel = (f >= lo) & (f <= hi)
    return np.sqrt(np.trapezoid(np.asarray(psd)[..., sel], f[sel], axis=-1))
