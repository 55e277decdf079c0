"""ISO 2631-1 frequency weightings Wk (vertical) and Wd (horizontal), weighted RMS, comfort scale.

Units: acceleration in m/s^2, frequency in Hz, time in s. Weightings follow the
ISO 2631-1 / ISO 8041 parameterisation ``W = Hh * Hl * Ht * Hs`` with p = j*omega:

- band limiting: high-pass Hh = 1/(1 + sqrt(2) w1/p + (w1/p)^2),
  low-pass Hl = 1/(1 + sqrt(2) p/w2 + (p/w2)^2);
- a-v transition Ht = (1 + p/w3)/(1 + p/(Q4 w4) + (p/w4)^2);
- upward step Hs = (1 + p/(Q5 w5) + (p/w5)^2)/(1 + p/(Q6 w6) + (p/w6)^2) * (w5/w6)^2.

Two evaluations that must agree (tests check both against the standard's table):

- frequency domain: :func:`weighting_response` (exact analogue response), used by
  :func:`weighted_rms_fft` which weights the FFT of a record (Parseval);
- time domain: :func:`weighting_sos` (bilinear transform with pre-warping of every
  corner, second-order sections) used by :func:`weighted_signal`; it needs a sample
  rate well above 200 Hz because the band-limiting low-pass sits at 100 Hz.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from suspenv.core.errors import ValidationError


@dataclass(frozen=True)
class Weighting:
    """Corner frequencies (Hz) and quality factors of one ISO 2631-1 weighting."""

    name: str
    f1: float
    f2: float
    f3: float
    f4: float
    q4: float
    f5: float = np.inf
    q5: float = 1.0
    f6: float = np.inf
    q6: float = 1.0


#: ISO 2631-1 Table (ISO 8041 parameterisation)
WEIGHTINGS: dict[str, Weighting] = {
    "Wk": Weighting("Wk", 0.4, 100.0, 12.5, 12.5, 0.63, 2.37, 0.91, 3.35, 0.91),
    "Wd": Weighting("Wd", 0.4, 100.0, 2.0, 2.0, 0.63),
}

#: comfort reactions to weighted RMS acceleration (ISO 2631-1 Annex C), upper edges m/s^2
COMFORT_SCALE: tuple[tuple[float, str], ...] = (
    (0.315, "not uncomfortable"),
    (0.63, "a little uncomfortable"),
    (1.0, "fairly uncomfortable"),
    (1.6, "uncomfortable"),
    (2.5, "very uncomfortable"),
    (np.inf, "extremely uncomfortable"),
)


def get_weighting(name: str | Weighting) -> Weighting:
    """The weighting named "Wk" or "Wd" (or a :class:`Weighting` passed through)."""
    if isinstance(name, Weighting):
        return name
    if name not in WEIGHTINGS:
        raise ValidationError(f"weighting must be one of {sorted(WEIGHTINGS)}, but got {name!r}")
    return WEIGHTINGS[name]


def weighting_response(f: np.ndarray, name: str | Weighting = "Wk") -> np.ndarray:
    """Complex analogue weighting W(j 2 pi f) at frequencies f (Hz); W(0) = 0."""
    w = get_weighting(name)
    f = np.asarray(f, dtype=float)
    p = 2j * np.pi * f
    w1, w2, w3, w4 = (2 * np.pi * x for x in (w.f1, w.f2, w.f3, w.f4))
    with np.errstate(divide="ignore", invalid="ignore"):
        hh = 1.0 / (1.0 + np.sqrt(2.0) * w1 / p + (w1 / p) ** 2)
    hh = np.where(f == 0, 0.0, hh)
    hl = 1.0 / (1.0 + np.sqrt(2.0) * p / w2 + (p / w2) ** 2)
    ht = (1.0 + p / w3) / (1.0 + p / (w.q4 * w4) + (p / w4) ** 2)
    hs: np.ndarray | float  # the optional upward step; 1.0 when the weighting has none
    if np.isfinite(w.f5):
        w5, w6 = 2 * np.pi * w.f5, 2 * np.pi * w.f6
        hs = (1.0 + p / (w.q5 * w5) + (p / w5) ** 2) / (1.0 + p / (w.q6 * w6) + (p / w6) ** 2)
        hs = hs * (w5 / w6) ** 2
    else:
        hs = 1.0
    return hh * hl * ht * hs


def weighting_magnitude(f: np.ndarray, name: str | Weighting = "Wk") -> np.ndarray:
    """|W(f)| (-) at frequencies f (Hz)."""
    return np.abs(weighting_response(f, name))


# ------------------------------------------------------------------ time domain
def _bilinear_section(
    num: tuple[float, float, float], den: tuple[float, float, float], fc: float, fs: float
) -> np.ndarray:
    """One analogue biquad in s/wc (coefficients of 1, s/wc, (s/wc)^2) -> digital SOS row.

    The substitution s/wc -> (1/tan(pi fc/fs)) (1 - z^-1)/(1 + z^-1) pre-warps the
    corner fc so that it lands exactly where the analogue one is.
    """
    if not fc < fs / 2:
        raise ValidationError(
            f"`corner < fs/2` must hold for the bilinear weighting filter, but got "
            f"(corner={fc} Hz, fs={fs} Hz)"
        )
    k = 1.0 / np.tan(np.pi * fc / fs)

    # (1 - z^-1)/(1 + z^-1) = u; polynomial in u of degree 2 times (1 + z^-1)^2
    def expand(c: tuple[float, float, float]) -> np.ndarray:
        c0, c1, c2 = c[0], c[1] * k, c[2] * k * k
        # c0 (1+z)^2 + c1 (1-z)(1+z) + c2 (1-z)^2 in powers of z^-1
        return np.array([c0 + c1 + c2, 2 * c0 - 2 * c2, c0 - c1 + c2])

    b, a = expand(num), expand(den)
    return np.concatenate([b / a[0], a / a[0]])


def weighting_sos(fs: float, name: str | Weighting = "Wk") -> np.ndarray:
    """Second-order sections (scipy ``sos``) of the weighting at sample rate fs (Hz)."""
    w = get_weighting(name)
    sos = [
        # high-pass: 1/(1 + sqrt2 w1/s + (w1/s)^2) = (s/w1)^2/((s/w1)^2 + sqrt2 s/w1 + 1)
        _bilinear_section((0.0, 0.0, 1.0), (1.0, np.sqrt(2.0), 1.0), w.f1, fs),
        _bilinear_section((1.0, 0.0, 0.0), (1.0, np.sqrt(2.0), 1.0), w.f2, fs),
    ]
    # transition: numerator corner w3 differs from denominator corner w4; express both
    # in s/w4 so one pre-warp frequency serves the section (exact when f3 == f4).
    r = w.f4 / w.f3
    sos.append(_bilinear_section((1.0, r, 0.0), (1.0, 1.0 / w.q4, 1.0), w.f4, fs))
    if np.isfinite(w.f5):
        g = (w.f5 / w.f6) ** 2
        r56 = w.f6 / w.f5
        row = _bilinear_section((1.0, r56 / w.q5, r56**2), (1.0, 1.0 / w.q6, 1.0), w.f6, fs)
        row[:3] *= g
        sos.append(row)
    return np.vstack(sos)


def weighted_signal(
    a: np.ndarray, fs: float, name: str | Weighting = "Wk", axis: int = -1
) -> np.ndarray:
    """Frequency-weighted acceleration time history (time-domain biquads, causal)."""
    return signal.sosfilt(weighting_sos(fs, name), np.asarray(a, dtype=float), axis=axis)


# ------------------------------------------------------------------ RMS values
def rms(a: np.ndarray, axis: int = -1) -> np.ndarray:
    """Root mean square along ``axis``."""
    a = np.asarray(a, dtype=float)
    return np.sqrt(np.mean(a * a, axis=axis))


def weighted_rms(
    a: np.ndarray, fs: float, name: str | Weighting = "Wk", axis: int = -1
) -> np.ndarray:
    """Weighted RMS a_w (m/s^2) of a time history by the time-domain filters."""
    return rms(weighted_signal(a, fs, name, axis=axis), axis=axis)


def weighted_rms_fft(
    a: np.ndarray,
    fs: float,
    name: str | Weighting = "Wk",
    band: tuple[float, float] = (0.5, 80.0),
    axis: int = -1,
) -> np.ndarray:
    """Weighted RMS a_w (m/s^2) by weighting the record's FFT (Parseval), over ``band`` Hz.

    The record is treated as one period; lines outside the evaluation band (default
    ISO 2631-1's 0.5-80 Hz) are dropped. Fast and exact for the weighting's magnitude,
    independent of the sample rate (no bilinear warping).
    """
    a = np.moveaxis(np.asarray(a, dtype=float), axis, -1)
    n = a.shape[-1]
    spec = np.fft.rfft(a, axis=-1)
    f = np.fft.rfftfreq(n, 1.0 / fs)
    gain2 = weighting_magnitude(f, name) ** 2
    gain2 = np.where((f >= band[0]) & (f <= band[1]), gain2, 0.0)
    # one-sided power: double every line except DC and (even n) Nyquist
    dbl = np.full(f.shape, 2.0)
    dbl[0] = 1.0
    if n % 2 == 0:
        dbl[-1] = 1.0
    power = (spec.real**2 + spec.imag**2) @ (gain2 * dbl) / n**2
    return np.sqrt(power)


def weighted_signal_fft(
    a: np.ndarray,
    fs: float,
    name: str | Weighting = "Wk",
    band: tuple[float, float] = (0.5, 80.0),
) -> np.ndarray:
    """Frequency-weighted time history (m/s^2) of records ``a`` (time on the last axis)
    by weighting their FFT with the complex response (magnitude and phase) over ``band``
    Hz; the record is treated as one period. Any sample rate (the time-domain biquads of
    :func:`weighted_signal` need fs well above 200 Hz); its RMS is
    :func:`weighted_rms_fft`'s. For the peak and fourth-power measures (crest factor,
    VDV) of ISO 2631-1."""
    a = np.asarray(a, dtype=float)
    n = a.shape[-1]
    f = np.fft.rfftfreq(n, 1.0 / fs)
    w = np.where((f >= band[0]) & (f <= band[1]), weighting_response(f, name), 0.0)
    return np.fft.irfft(np.fft.rfft(a, axis=-1) * w, n=n, axis=-1)


def comfort_reaction(a_w: float) -> str:
    """ISO 2631-1 Annex C wording for a weighted RMS acceleration (m/s^2).

    The Annex's bands overlap (e.g. 0.315-0.63 and 0.5-1.0); each band's upper edge
    is used as the boundary here, so inside an overlap the milder wording is given.
    """
    if not a_w >= 0:
        raise ValidationError(f"`a_w >= 0` must hold, but got a_w={a_w}")
    for edge, text in COMFORT_SCALE:
        if a_w < edge:
            return text
    return COMFORT_SCALE[-1][1]
