"""Compliance analysis of a measured K&C test: a channel against the test's load on one
wheel, its straight line (the linear compliance) and what the line leaves (asymmetry
of positive against negative load with its 95 % interval, saturation of large against
small load). Works on any compliance test of a
:class:`~suspenv.measurements.knc_file.KncMeasurement`, a one-wheel bench measurement
included. SI inside (raw ISO 8855, the format's signs); :meth:`ComplianceAnalysis.lines`
prints edge units (deg per kN, deg per 100 N*m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.measurements.knc import LOADED_TESTS
from suspenv.measurements.knc_file import CHANNELS, DRIVE_COLUMN, SIDES, KncMeasurement, edge_unit

#: drive quantity -> (per-unit of the reported slopes, its size in SI)
_PER = {"force": ("kN", 1e3), "moment": ("100 N*m", 100.0), "length": ("mm", 1e-3)}
#: |drive| below this fraction of the largest is "small" for the saturation slope
SMALL_FRACTION = 0.25
#: |drive| above this fraction of the largest is "large"
LARGE_FRACTION = 0.6


@dataclass
class ComplianceAnalysis:
    """A compliance test's channel against its drive on one wheel, linear and beyond.

    All slopes are in SI (channel unit per drive unit: rad per N*m for toe against an
    aligning moment); :meth:`lines` prints them in edge units (deg per 100 N*m).

    Attributes:
        test, channel, wheel: what was analysed.
        slope: least-squares straight line through every sample (the linear
            compliance); ``intercept`` its value at zero drive.
        rms_linear: RMS residual of that line; ``rms_cubic`` of the cubic
            ``a + b x + c x^2 + d x^3`` (what is left after the asymmetry and
            saturation), ``noise`` the channel's noise (declared or estimated).
        slope_positive / slope_negative: lines through the samples with drive >= 0 /
            <= 0; ``asymmetry`` = (positive - negative) / their mean, ``asymmetry_ci95``
            its 95 % half-width (:func:`_asymmetry_ci95`: noise alone gives a symmetric
            axle an asymmetry of that size).
        slope_small / slope_large: lines through the samples with |drive| <=
            :data:`SMALL_FRACTION` x max and through each end's samples with |drive| >=
            :data:`LARGE_FRACTION` x max (mean of the two ends' slopes);
            ``saturation`` = large / small (< 1: the compliance stiffens, saturates).
        drive_range: (min, max) of the drive [SI]; ``samples`` the count.
    """

    test: str
    channel: str
    wheel: str
    slope: float
    intercept: float
    rms_linear: float
    rms_cubic: float
    noise: float
    slope_positive: float
    slope_negative: float
    asymmetry: float
    asymmetry_ci95: float
    slope_small: float
    slope_large: float
    saturation: float
    drive_range: tuple[float, float]
    samples: int

    def lines(self) -> list[str]:
        """The analysis as text in edge units."""
        col, quantity = DRIVE_COLUMN[self.test]
        per, per_si = _PER[quantity]
        unit, u = edge_unit(CHANNELS[self.channel])
        k = per_si / u  # SI slope -> unit per `per`
        lo, hi = self.drive_range
        dq, du = edge_unit(quantity)
        rows = [
            (
                "linear compliance",
                f"{self.slope * k:.4g} {unit} per {per} (least squares through all "
                f"samples; {self.channel} at zero {col} {self.intercept / u:+.3g} {unit})",
            ),
            (
                "residual of the line",
                f"{self.rms_linear / u:.3g} {unit} RMS (noise {self.noise / u:.3g} {unit}; "
                f"a cubic leaves {self.rms_cubic / u:.3g})",
            ),
            (f"positive {col} slope", f"{self.slope_positive * k:.4g} {unit} per {per}"),
            (f"negative {col} slope", f"{self.slope_negative * k:.4g} {unit} per {per}"),
            (
                "asymmetry",
                f"{100 * self.asymmetry:+.1f} % +- {100 * self.asymmetry_ci95:.1f} % (positive "
                "- negative, of their mean; 95 % interval from the lines' scatter)",
            ),
            (
                f"small {col} slope",
                f"{self.slope_small * k:.4g} {unit} per {per} (|{col}| <= "
                f"{SMALL_FRACTION:g} x max)",
            ),
            (
                f"large {col} slope",
                f"{self.slope_large * k:.4g} {unit} per {per} (|{col}| >= "
                f"{LARGE_FRACTION:g} x max, both ends)",
            ),
            ("saturation", f"{self.saturation:.3g} (large / small slope; < 1: stiffens with load)"),
        ]
        head = (
            f"{self.test} test, {self.channel} of the {self.wheel} wheel against {col} "
            f"({self.samples} samples, {lo / du:g} to {hi / du:g} {dq}):"
        )
        return [head, *(f"  {label:24s} {text}" for label, text in rows)]


def _line(x: np.ndarray, y: np.ndarray, what: str) -> tuple[float, float]:
    """(slope, intercept) of the least-squares line; fewer than 2 distinct x refused."""
    if np.unique(x).size < 2:
        raise ValidationError(
            f"compliance analysis: the {what} samples need 2 distinct drive values for a "
            f"slope, but got {x.size} sample(s)"
        )
    b, a = np.polyfit(x, y, 1)
    return float(b), float(a)


def _asymmetry_ci95(x: np.ndarray, y: np.ndarray) -> float:
    """95 % half-width of the asymmetry ``2 (p - n) / (p + n)`` of the lines through the
    samples with drive ``x >= 0`` (slope p) and ``x <= 0`` (slope n), by the delta
    method for white noise: each slope is linear in the samples (weights ``w``, a sample
    at zero drive in both), so the asymmetry's gradient is ``g = dA/dp w_p + dA/dn
    w_n`` and its standard error ``s |g|``, ``s`` the two lines' pooled residual
    scatter (a loop's hysteresis and any curvature count as scatter: conservative).
    NaN with fewer than 5 samples or a zero mean slope."""
    fits = []
    for sel in (x >= 0, x <= 0):
        xc = x[sel] - x[sel].mean()
        w = np.zeros_like(x)
        w[sel] = xc / (xc @ xc) if np.any(xc) else np.nan
        b = float(w @ y)
        fits.append((b, w, y[sel] - y[sel].mean() - b * xc))
    (p, wp, rp), (n, wn, rn) = fits
    dof = rp.size + rn.size - 4
    if dof < 1 or p + n == 0:
        return float("nan")
    s = math.sqrt(float(rp @ rp + rn @ rn) / dof)
    g = 4.0 * (n * wp - p * wn) / (p + n) ** 2
    return NormalDist().inv_cdf(0.975) * s * float(np.linalg.norm(g))


def compliance_analysis(
    m: KncMeasurement, test: str = "aligning", channel: str = "toe", wheel: str | None = None
) -> ComplianceAnalysis:
    """Linear compliance of ``channel`` against the drive of a compliance test of
    ``m``, and what the line leaves: asymmetry (positive against negative drive) and
    saturation (slope at small against large drive). ``wheel`` defaults to the first
    measured wheel. Every sample of every branch enters (a loop's two branches average
    out its hysteresis in the fitted line)."""
    if test not in LOADED_TESTS:
        raise ValidationError(
            f"compliance analysis needs a test of {LOADED_TESTS}, but got {test!r}"
        )
    if test not in m.tests:
        raise ValidationError(f"the measurement holds no {test!r} test; it holds {list(m.tests)}")
    mt = m.tests[test]
    if channel not in mt.channels:
        raise ValidationError(
            f"the {test} test holds no channel {channel!r}; it holds {sorted(mt.channels)}"
        )
    side = wheel or mt.wheels[0]
    if side not in mt.wheels:
        raise ValidationError(f"wheel must be one of the measured {mt.wheels}, but got {side!r}")
    x = mt.drive
    y = mt.channels[channel][:, SIDES.index(side)]
    slope, intercept = _line(x, y, "")
    rms_lin = float(np.sqrt(np.mean((y - (intercept + slope * x)) ** 2)))
    cubic = np.polyfit(x, y, 3) if np.unique(x).size >= 4 else np.polyfit(x, y, 1)
    rms_cub = float(np.sqrt(np.mean((y - np.polyval(cubic, x)) ** 2)))
    pos, _ = _line(x[x >= 0], y[x >= 0], "positive-drive")
    neg, _ = _line(x[x <= 0], y[x <= 0], "negative-drive")
    amax = float(np.max(np.abs(x)))
    small = np.abs(x) <= SMALL_FRACTION * amax
    s_small, _ = _line(x[small], y[small], "small-drive")
    ends = [x >= LARGE_FRACTION * amax, x <= -LARGE_FRACTION * amax]
    large = [_line(x[e], y[e], "large-drive")[0] for e in ends if np.unique(x[e]).size >= 2]
    if not large:
        raise ValidationError(
            f"compliance analysis: no end of the drive has 2 samples with |drive| >= "
            f"{LARGE_FRACTION} x {amax:g}"
        )
    s_large = float(np.mean(large))
    mean = 0.5 * (pos + neg)
    return ComplianceAnalysis(
        test,
        channel,
        side,
        slope,
        intercept,
        rms_lin,
        rms_cub,
        float(m.noise.get(channel, float("nan"))),
        pos,
        neg,
        (pos - neg) / mean if mean else float("nan"),
        _asymmetry_ci95(x, y),
        s_small,
        s_large,
        s_large / s_small if s_small else float("nan"),
        (float(x.min()), float(x.max())),
        int(x.size),
    )
