"""Measurement noise and the derivative a user computes from a measured position.

Noise kinds (added to an output channel, rms in the channel's SI unit):

* ``white`` -- independent Gaussian samples;
* ``coloured`` -- a first-order autoregressive sequence ``n[k+1] = phi n[k] + e[k]``
  with ``phi = exp(-1 / n_c)``, correlation time ``n_c >= 5`` samples, scaled to the rms;
* ``drift`` -- white noise plus a slow zero drift of the load cell (or of the deflection
  transducer): a slow sine of period at least 1.5 recording lengths, or a random walk
  smoothed by a moving average of a quarter of the record, with amplitude 1-5 % of the
  channel's range (max - min).

:func:`sg_derivative` is the Savitzky-Golay differentiator (Savitzky and Golay 1964): a
local cubic least-squares fit over a centred window, differentiated analytically.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.signal import lfilter, savgol_filter

NOISE_KINDS = ("white", "coloured", "drift")


def white(rng: np.random.Generator, n: int, rms: float) -> np.ndarray:
    """Gaussian white noise of standard deviation ``rms``."""
    return rms * rng.standard_normal(n)


def coloured(rng: np.random.Generator, n: int, rms: float, n_corr: float) -> np.ndarray:
    """AR(1) noise of stationary standard deviation ``rms``, correlation ``n_corr`` samples."""
    phi = math.exp(-1.0 / n_corr)
    e = rng.standard_normal(n) * math.sqrt(1.0 - phi * phi)
    x0 = rng.standard_normal()
    out, _ = lfilter([1.0], [1.0, -phi], e, zi=np.array([phi * x0]))
    return rms * np.asarray(out)


def drift(
    rng: np.random.Generator, t: np.ndarray, amplitude: float
) -> tuple[np.ndarray, dict[str, Any]]:
    """A slow zero drift of peak amplitude ``amplitude`` and its description."""
    length = float(t[-1] - t[0])
    if rng.random() < 0.5:
        period = length * rng.uniform(1.5, 4.0)
        phase = rng.uniform(0.0, 2.0 * math.pi)
        d = amplitude * np.sin(2.0 * math.pi * (t - t[0]) / period + phase)
        d -= d[0]
        return d, {"drift": "slow sine", "period_s": period, "phase_rad": phase}
    steps = rng.standard_normal(t.size)
    walk = np.cumsum(steps)
    win = max(t.size // 4, 3)
    kernel = np.ones(win) / win
    smooth = np.convolve(np.pad(walk, (win, win), mode="edge"), kernel, mode="same")[win:-win]
    smooth -= smooth[0]
    peak = float(np.max(np.abs(smooth))) or 1.0
    return amplitude * smooth / peak, {
        "drift": "smoothed random walk",
        "window_s": win * float(t[1] - t[0]),
    }


def add_noise(
    rng: np.random.Generator,
    t: np.ndarray,
    channels: dict[str, np.ndarray],
    kind: str,
    drift_channel: str,
) -> tuple[dict[str, np.ndarray], dict[str, float], dict[str, Any]]:
    """Noisy copies of ``channels``: per-channel rms 1-4 % of the channel's std.

    Returns the noisy channels, the rms per channel [SI] and the details of the draw.
    """
    out: dict[str, np.ndarray] = {}
    rms: dict[str, float] = {}
    details: dict[str, Any] = {"level_of_std": {}}
    n_corr = float(rng.uniform(5.0, 30.0))
    for name, clean in channels.items():
        level = float(rng.uniform(0.01, 0.04))
        sd = float(np.std(clean))
        r = level * sd
        noise = coloured(rng, t.size, r, n_corr) if kind == "coloured" else white(rng, t.size, r)
        rms[name] = r
        details["level_of_std"][name] = level
        out[name] = clean + noise
    if kind == "coloured":
        details["ar1_correlation_samples"] = n_corr
    if kind == "drift":
        clean = channels[drift_channel]
        frac = float(rng.uniform(0.01, 0.05))
        amp = frac * float(np.ptp(clean))
        d, info = drift(rng, t, amp)
        out[drift_channel] = out[drift_channel] + d
        details.update(info)
        details.update(
            {
                "drift_channel": drift_channel,
                "drift_fraction_of_range": frac,
                "drift_amplitude": amp,
            }
        )
    return out, rms, details


def sg_derivative(x: np.ndarray, dt: float, window_s: float, deriv: int) -> np.ndarray:
    """Savitzky-Golay derivative ``deriv`` (1 or 2) of ``x`` sampled every ``dt`` [s]
    (cubic fit, odd window of about ``window_s`` [s])."""
    n = int(round(window_s / dt)) | 1
    n = max(n, 5)
    return np.asarray(savgol_filter(x, n, 3, deriv=deriv, delta=dt))
