"""A named sensor gain against a reading error that grows with the signal's size.

A transducer whose reading departs from the true value in proportion to its square
(``y_rec = y + q y |y| / Y``: a non-linear deflection transducer or load cell, not in
the library) reads, at one test amplitude, like a calibration error: the library's sensor
gain takes up its part along ``y``, and what it leaves, the signed square's remainder,
is often under the noise in RMS yet one shape over the whole record. Where a sensor gain
is named on a channel, the final model's residual there is regressed on the centred
prediction ``u`` (over its largest size on the fitted samples), on ``u |u|`` and a
constant, on the fitted samples. The signed square's coefficient is the reading's
relative error at full scale beyond the named gain; its standard error is widened by the
residual's lag-1 correlation (AR(1) effective sample size). It is physics left outside
the library when, as every probe beyond the library is judged
(:func:`~suspenv.diagnosis.component.residual_left.beyond_library`), its two-sided p
is under the rule's alpha, the held-out samples confirm it, and the part it takes is
material against what it leaves
(:data:`~suspenv.diagnosis.component.residual_left.MATERIAL_RATIO`). The held-out
samples judge the change the coefficients fitted make there, ``d``: the held-out
residual's coefficient on it, both about their held-out means (a sensor zero that
drifted past the fit samples is a level, not the shape), is 1 for a real error and 0
for one fitted to noise, and a
one-sided normal test at alpha (standard error widened as above) places it above 1/2
(confirmed) or below (refuted); where the held-out samples span too little of the signal
to place it, it is neither. Where the p holds and the held-out samples do not refute it,
the error may be real: the gain is named, not with confidence, as the library's nearest
element to such a transducer (a refit of a gain on a few held-out cycles of small
amplitude cannot tell, and a confident name would hide it).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from suspenv.diagnosis.component.residual_left import MATERIAL_RATIO
from suspenv.diagnosis.decision import DecisionRule
from suspenv.diagnosis.evidence import heldout_residuals
from suspenv.diagnosis.fitting import FitResult, ar1_effective_size, lag1_autocorrelation
from suspenv.diagnosis.protocols import RecordingLike
from suspenv.diagnosis.record import Record
from suspenv.diagnosis.split import Split


@dataclass
class CurvatureLeft(Record):
    """The signed square of a channel beside its named sensor gain (module docstring).

    Attributes:
        channel: the recorded channel the gain is named on.
        error_at_full_scale: the reading's relative error at the prediction's largest
            size beyond the named gain (signed: positive reads high at both ends) [-].
        z: that coefficient over its AR(1)-widened standard error.
        p_value: its two-sided p.
        heldout_reduction: relative drop of the held-out RMS error with it.
        heldout_coefficient: the held-out residual's coefficient on the change the
            coefficients make there (1: real, 0: fitted to noise), and its standard error.
        structured_ratio: RMS of the part it takes over RMS of what it leaves (fitted).
        confirmed: the held-out samples confirm it (coefficient above 1/2).
        significant: the p holds and the held-out samples do not refute it: the gain may
            change with the size.
        remains: the p holds, the held-out samples confirm it and the part is material:
            a reading error outside the library.
    """

    channel: str
    error_at_full_scale: float
    z: float
    p_value: float
    heldout_reduction: float
    heldout_coefficient: tuple[float, float]
    structured_ratio: float
    confirmed: bool
    significant: bool
    remains: bool

    def short(self) -> str:
        """A few words for the headline."""
        return (
            f"the {self.channel} reading {100 * abs(self.error_at_full_scale):.2g} % off at "
            "full scale beyond the gain, growing with its size"
        )

    def sentence(self) -> str:
        """One sentence for the verdict."""
        evidence = (
            f"{100 * self.error_at_full_scale:+.2g} % at full scale, z = {self.z:.3g}, "
            f"p = {self.p_value:.2g}, held-out error {-100 * self.heldout_reduction:+.1f} % "
            f"(coefficient there {self.heldout_coefficient[0]:.2f} +- "
            f"{self.heldout_coefficient[1]:.2g}, 1 for a real error), "
            f"{self.structured_ratio:.2g} x the residual it leaves"
        )
        test = "a calibration at two amplitudes would tell a gain from it"
        if self.remains:
            return (
                f"unexplained, not in the library: beyond the sensor gain named on "
                f"{self.channel}, its reading departs from the model's in proportion to the "
                f"square of its size (a non-linear transducer; {evidence}); {test}"
            )
        if self.significant:
            why = (
                f"under {MATERIAL_RATIO:.2g} x, not material beside the noise"
                if self.confirmed
                else "the held-out samples cannot confirm it"
            )
            return (
                f"the sensor gain named on {self.channel} may change with the signal's size "
                f"({evidence}; {why}): it may stand for a non-linear transducer, not in the "
                f"library; {test}"
            )
        return f"the {self.channel} gain does not change with the signal's size ({evidence})"


def _parts(
    fit: FitResult,
    recordings: Sequence[RecordingLike],
    masks: Sequence[np.ndarray | None] | None,
    channel: str,
) -> tuple[np.ndarray, np.ndarray]:
    """The residual and the prediction of ``channel`` on the samples of ``recordings``
    (those of each mask), stacked [channel unit]: the residual the fit remembers
    (:func:`~suspenv.diagnosis.evidence.heldout_residuals`), the prediction the recorded
    values less it."""
    r = heldout_residuals(fit, recordings, masks)[channel]
    recorded = [np.asarray(rec.outputs[channel], float) for rec in recordings]
    if masks is not None:
        recorded = [y if m is None else y[m] for y, m in zip(recorded, masks, strict=True)]
    return r, np.concatenate(recorded) - r


def curvature_left(final: FitResult, sp: Split, channel: str, rule: DecisionRule) -> CurvatureLeft:
    """The signed square of ``channel`` judged beside the final model's sensor gain
    there (module docstring)."""
    r, p = _parts(final, sp.fit_recordings, sp.fit_masks, channel)
    centre = float(np.median(p))
    scale = float(np.max(np.abs(p - centre))) or 1.0

    def design(q: np.ndarray) -> np.ndarray:
        u = (q - centre) / scale
        return np.column_stack([np.ones_like(u), u, u * np.abs(u)])

    x = design(p)
    full = np.linalg.lstsq(x, r, rcond=None)[0]
    part = np.linalg.lstsq(x[:, :2], r, rcond=None)[0]
    e, e0 = r - x @ full, r - x[:, :2] @ part
    n_eff = max(ar1_effective_size(e.size, lag1_autocorrelation(e)), 4.0)
    var = float(e @ e) / max(e.size - 3, 1) * e.size / n_eff
    se = float(np.sqrt(var * np.linalg.inv(x.T @ x)[2, 2]))
    z = float(full[2] / se) if se > 0 else 0.0
    p_value = float(2.0 * stats.norm.sf(abs(z)))
    ratio = float(np.sqrt(max(float(e0 @ e0) / float(e @ e) - 1.0, 0.0))) if e @ e > 0 else 0.0
    hr, hp = _parts(final, sp.heldout_recordings, sp.heldout_masks, channel)
    hx = design(hp)
    before, d = hr - hx[:, :2] @ part, hx @ full - hx[:, :2] @ part
    gain = 1.0 - float(np.sqrt(np.mean((before - d) ** 2) / max(np.mean(before**2), 1e-300)))
    beta, beta_se = _coefficient(before, d)
    z_crit = float(stats.norm.isf(rule.alpha))
    significant = bool(p_value < rule.alpha and (beta - 0.5) / beta_se > -z_crit)
    confirmed = bool((beta - 0.5) / beta_se > z_crit)
    remains = significant and confirmed and ratio > MATERIAL_RATIO
    error, coefficient = float(full[2]) / scale, (beta, beta_se)
    return CurvatureLeft(
        channel, error, z, p_value, gain, coefficient, ratio, confirmed, significant, remains
    )


def _coefficient(r: np.ndarray, d: np.ndarray) -> tuple[float, float]:
    """The coefficient of ``r`` on ``d``, both about their means, and its standard error,
    widened by the AR(1) effective sample size of what it leaves (inf where ``d`` is
    nil)."""
    r, d = r - np.mean(r), d - np.mean(d)
    dd = float(d @ d)
    if not dd > 1e-24 * max(float(r @ r), 1e-300):
        return 0.0, float("inf")
    beta = float(r @ d) / dd
    e = r - beta * d
    n_eff = max(ar1_effective_size(e.size, lag1_autocorrelation(e)), 2.0)
    return beta, float(np.sqrt(float(e @ e) / n_eff / dd))
