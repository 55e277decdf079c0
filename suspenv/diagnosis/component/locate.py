"""Locate a mismatch: where does the residual energy live?

Every partition of the samples reports, per part, the share of residual energy, the
fraction of samples and their ratio, the enrichment (:class:`~suspenv.diagnosis.screening.Share`).

Partitions (those that apply to the data at hand):
    channel, test (recording), branch (sign of velocity: bump = compression v > 0,
    rebound v < 0), reversal neighbourhood (displacement travelled since the last
    velocity reversal below 10 % of the stroke), amplitude bins (|x - centre| in
    quarters of the half-stroke), frequency band (multiples of the dominant excitation
    frequency), time window after impacts (large input accelerations).

Units: ``x`` deflection [m] (positive = compression / bump), ``v`` [m/s], ``t`` [s];
residual channels in their own units.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from suspenv.diagnosis.screening import Location, Share


@dataclass
class Segment:
    """Samples of one recording prepared for locating (one fit or held-out span)."""

    test: str
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    residual: dict[str, np.ndarray]  # channel -> scaled residual (dimensionless)


def reversal_indices(v: np.ndarray) -> np.ndarray:
    """Indices where the velocity changes sign (first sample of the new direction)."""
    s = np.sign(v)
    # carry the last non-zero sign over exact zeros
    if not s.any():
        return np.zeros(0, int)
    idx = np.maximum.accumulate(np.where(s != 0, np.arange(s.size), 0))
    s = s[idx]
    return np.flatnonzero(np.diff(s) != 0) + 1


def travel_since_reversal(x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """|x - x at the last velocity reversal| per sample [m] (from the start before any)."""
    marks = np.zeros(x.size, int)
    rev = reversal_indices(v)
    marks[rev] = rev
    return np.abs(x - x[np.maximum.accumulate(marks)])


def dominant_frequency(t: np.ndarray, x: np.ndarray) -> float:
    """Frequency [Hz] of the largest non-DC spectral line of ``x``."""
    if x.size < 8:
        return float("nan")
    dt = float(np.median(np.diff(t)))
    spec = np.abs(np.fft.rfft(x - np.mean(x)))
    freqs = np.fft.rfftfreq(x.size, dt)
    spec[0] = 0.0
    return float(freqs[int(np.argmax(spec))])


def _energy(residual: dict[str, np.ndarray], mask: np.ndarray | None = None) -> float:
    return float(sum(np.sum((r if mask is None else r[mask]) ** 2) for r in residual.values()))


def _partition(
    dimension: str, segments: Sequence[Segment], labeller, total: float, n_total: int
) -> list[Share]:
    """Shares of ``total`` energy for the parts a ``labeller(segment) -> {part: mask}`` gives."""
    acc: dict[str, list[float]] = {}
    for seg in segments:
        for part, mask in labeller(seg).items():
            e, n = acc.setdefault(part, [0.0, 0.0])
            acc[part] = [e + _energy(seg.residual, mask), n + int(np.count_nonzero(mask))]
    return [
        Share(dimension, part, e / total if total > 0 else 0.0, n / n_total if n_total else 0.0)
        for part, (e, n) in acc.items()
    ]


#: half-width [samples] of the velocity difference an impact is read from
IMPACT_HALF_WINDOW = 5


def windowed_acceleration(t: np.ndarray, v: np.ndarray, w: int = IMPACT_HALF_WINDOW) -> np.ndarray:
    """Acceleration [m/s^2] read as the velocity change over ``2 w`` samples: an impact
    (a velocity jump) keeps its size, while the sample-to-sample noise of a recorded or
    differentiated velocity, which a plain gradient turns into spikes on a pure sine,
    falls by about ``w``. The ends repeat the nearest value."""
    n = t.size
    if n <= 2 * w:
        return np.gradient(v, t)
    a = (v[2 * w :] - v[: -2 * w]) / (t[2 * w :] - t[: -2 * w])
    return np.concatenate([np.full(w, a[0]), a, np.full(w, a[-1])])


#: share of a record that follows an impact, and the block length (share of the record)
#: whose acceleration level an impact stands out of
IMPACT_WINDOW = 0.05
#: an impact's acceleration exceeds this multiple of the level around it
IMPACT_RATIO = 8.0


def impact_samples(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Samples of an impact: an acceleration (:func:`windowed_acceleration`) above
    :data:`IMPACT_RATIO` times the level around it, the largest 90th percentile of
    ``|a|`` over its block of :data:`IMPACT_WINDOW` of the record and the two
    neighbouring blocks. A sine's ``|a|`` stays within 1.5 times its 90th percentile,
    and a programme that steps from slow to fast sines raises the level with the
    speed, so neither holds an impact; a velocity jump stands out of its surroundings."""
    a = np.abs(windowed_acceleration(t, v))
    w = max(16, int(IMPACT_WINDOW * a.size))
    p = np.array([np.percentile(a[i : i + w], 90) for i in range(0, a.size, w)])
    level = np.maximum.reduce([p, np.r_[p[:1], p[:-1]], np.r_[p[1:], p[-1:]]])
    return a > IMPACT_RATIO * np.repeat(level, w)[: a.size] + 1e-12


def _channel_shares(segments: Sequence[Segment], total: float) -> list[Share]:
    """Residual energy by output channel (fraction 1 / number of channels: each has
    every sample); none for one channel."""
    channels = list(dict.fromkeys(c for s in segments for c in s.residual))
    if len(channels) < 2:
        return []

    def energy(c: str) -> float:
        return sum(float(np.sum(s.residual[c] ** 2)) for s in segments if c in s.residual)

    return [
        Share("channel", c, energy(c) / total if total else 0.0, 1.0 / len(channels))
        for c in channels
    ]


def _amplitude(s: Segment) -> dict[str, np.ndarray]:
    centre = 0.5 * (np.max(s.x) + np.min(s.x))
    half = 0.5 * float(np.ptp(s.x)) or 1.0
    a = np.abs(s.x - centre) / half
    edges = [0.0, 0.25, 0.5, 0.75, 1.0 + 1e-12]
    return {
        f"{int(lo * 100)}-{int(min(hi, 1.0) * 100)} % of half-stroke": (a >= lo) & (a < hi)
        for lo, hi in zip(edges[:-1], edges[1:], strict=True)
    }


def _travel_side(s: Segment) -> dict[str, np.ndarray]:
    centre = 0.5 * (np.max(s.x) + np.min(s.x))
    return {"compression half (x > centre)": s.x > centre, "extension half": s.x <= centre}


def _impacts(s: Segment) -> dict[str, np.ndarray]:
    if s.t.size < 16:
        return {}
    hits = np.flatnonzero(impact_samples(s.t, s.v))
    if hits.size == 0:
        return {}
    window = IMPACT_WINDOW * float(s.t[-1] - s.t[0])
    after = np.zeros(s.t.size, bool)
    for h in hits:
        after |= (s.t >= s.t[h]) & (s.t <= s.t[h] + window)
    return {"after impacts": after, "elsewhere": ~after}


#: frequency bands relative to the dominant excitation frequency f0: names and edges
BAND_NAMES = ("drift (< 0.5 f0)", "f0 (0.5-1.5 f0)", "2 f0", "3 f0", "high (> 3.5 f0)")
BAND_EDGES = (0.0, 0.5, 1.5, 2.5, 3.5, np.inf)


def _band_shares(segments: Sequence[Segment]) -> list[Share]:
    """Residual energy by frequency band relative to the dominant excitation frequency
    (Parseval shares); a band's "fraction" is its share of the spectral lines (white
    residual = fair)."""
    bands = list(zip(BAND_NAMES, BAND_EDGES[:-1], BAND_EDGES[1:], strict=True))
    band_e: dict[str, float] = {}
    spec_total = 0.0
    for s in segments:
        f0 = dominant_frequency(s.t, s.x)
        if not np.isfinite(f0) or f0 <= 0:
            continue
        dt = float(np.median(np.diff(s.t)))
        freqs = np.fft.rfftfreq(s.t.size, dt) / f0
        for r in s.residual.values():
            p = np.abs(np.fft.rfft(r)) ** 2
            spec_total += float(np.sum(p))
            for name, lo, hi in bands:
                band_e[name] = band_e.get(name, 0.0) + float(
                    np.sum(p[(freqs >= lo) & (freqs < hi)])
                )
    if not spec_total > 0:
        return []
    seg0 = segments[0]
    f0 = dominant_frequency(seg0.t, seg0.x)
    dt = float(np.median(np.diff(seg0.t)))
    freqs = np.fft.rfftfreq(seg0.t.size, dt) / f0
    return [
        Share(
            "frequency band",
            name,
            band_e[name] / spec_total,
            float(np.mean((freqs >= lo) & (freqs < hi))),
        )
        for name, lo, hi in bands
    ]


def locate(segments: Sequence[Segment], reversal_fraction: float = 0.1) -> Location:
    """Partition the residual energy of ``segments`` along every applicable dimension."""
    total = sum(_energy(s.residual) for s in segments)
    n_samples = sum(s.t.size for s in segments)
    loc = Location()
    loc.shares += _channel_shares(segments, total)
    if len({s.test for s in segments}) > 1:
        loc.shares += _partition(
            "test", segments, lambda s: {s.test: np.ones(s.t.size, bool)}, total, n_samples
        )

    def branch(s: Segment) -> dict[str, np.ndarray]:
        return {"bump (v > 0)": s.v > 0, "rebound (v < 0)": s.v < 0}

    def near_reversal(s: Segment) -> dict[str, np.ndarray]:
        stroke = float(np.ptp(s.x)) or 1.0
        near = travel_since_reversal(s.x, s.v) < reversal_fraction * stroke
        return {"near reversal": near, "away from reversal": ~near}

    for dim, part in (
        ("branch", branch),
        ("reversal", near_reversal),
        ("amplitude", _amplitude),
        ("travel side", _travel_side),
        ("after impacts", _impacts),
    ):
        loc.shares += _partition(dim, segments, part, total, n_samples)
    loc.shares += _band_shares(segments)
    return loc
