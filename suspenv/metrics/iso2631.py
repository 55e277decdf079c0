"""ISO 2631-1 frequency weightings Wk (vertical) and Wd (horizontal), weighted RMS, comfort scale.

Units: acceleration in m/s^2, frequency in Hz, time in s. Weightings follow the
ISO 2631-1 / ISO 8041 parameterisation ``W = Hh * Hl * Ht * Hs`` with p = j*omega:

- band limiting: high-pass Hh = 1/(1 + sqrt(2) w1/p + (w1/p)^2),
  low-pass Hl = 1/(1 + sqrt(2) p/w2 + (p/w2)^2);
- a-v transition Ht = (1 + p/w3)/(1 + p/(Q4 w4) + (p/w4)^2);
- upward step Hs = (1 + p/(Q5 w5) + (p/w5)^2)/(1 + p/(Q6 w6) + (p/w6)^2) * (w5/w6)^2.

The weighting is applied in the frequency domain: :func:`weighting_response` (the exact
analogue response, checked against the standard's table) weights the FFT of a record
(:func:`weighted_rms_fft` by Parseval, :func:`weighted_signal_fft` for the time history).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import choice


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
    return WEIGHTINGS[choice("ISO 2631-1", "weighting", name, sorted(WEIGHTINGS))]


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


# ------------------------------------------------------------------ RMS values
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
    Hz; the record is treated as one period, at any sample rate; its RMS is
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
