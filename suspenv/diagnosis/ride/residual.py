"""What is left after the diagnosis: held-out residual against the sensor-noise floor.

Units: accelerations m/s^2; "scaled" numbers divide each channel by the fit's
channel scale (its standard deviation) and pool channels as the RMS of the
per-channel values, exactly as the held-out errors of
:class:`~suspenv.diagnosis.evidence.Comparison` are pooled.

Definitions (all on the **held-out** recordings, final model = baseline plus the
named elements, or the baseline when nothing is named):

* **noise floor** (per channel): the white sensor-noise standard deviation
  estimated from the final model's residual above :data:`NOISE_BAND_HZ` (default
  50 Hz up to Nyquist), where the ride response (body 1-2 Hz, wheel hop 8-12 Hz)
  and any model-form error are negligible: ``sigma^2 = mean Hann-tapered
  periodogram level in the band / sum(w^2)`` (a flat spectrum has the same level
  everywhere). Channels are pooled like the held-out RMS.
* **excess ratio** = held-out scaled RMS after / noise floor (1 when only noise is
  left).
* **explained share** of the baseline's model error: ``(before^2 - after^2) /
  (before^2 - floor^2)``.
* **whiteness**: Ljung-Box test (20 lags) of the final held-out scaled residual,
  recordings and channels stacked.
* **residual remains** by the shared rule (:mod:`suspenv.diagnosis.checks.residual_left`):
  the excess ratio (the RMS in noise units) above its size limit *and* the Ljung-Box
  p-value below the rule's level. The limit is
  :func:`~suspenv.diagnosis.checks.residual_left.size_limit` of how well the floor is
  known: the mean of ``K`` Hann-tapered periodogram lines of white noise estimates
  ``sigma^2`` with relative variance ``c / K``, ``c = N sum(w^4) / sum(w^2)^2`` (35/18
  for the Hann taper: neighbouring lines are correlated), so ``sigma`` has ``c / (4 K)``;
  ``K`` counts the lines over the held-out recordings and channels, the RMS's ``n`` their
  samples (channels taken as equally weighted in the pooled ratio).
* **named with confidence**: something is named and no residual remains (a named
  element's parameter on its fit bound is the shared check's,
  :mod:`suspenv.diagnosis.checks.bounds`).

Limits: a recording low-pass filtered below the band (anti-aliasing) makes the
floor too low and the check too cautious (it reports a residual); model error with
content above the band (e.g. other tyres on a sharp bump) raises the floor and makes
the check less sensitive.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.checks.residual_left import Left, size_limit
from suspenv.diagnosis.evidence import ljung_box, scaled_rms
from suspenv.diagnosis.fitting import FitResult, residuals
from suspenv.diagnosis.record import Record

#: band (Hz) where the sensor-noise floor is measured
NOISE_BAND_HZ = 50.0
#: Ljung-Box p below which the held-out residual is not white
WHITENESS_ALPHA = 0.01


def white_noise_sd(r: np.ndarray, dt: float, f_min: float = NOISE_BAND_HZ) -> tuple[float, float]:
    """Standard deviation of the white part of ``r`` from its periodogram above ``f_min``
    (Hz), and the relative variance of ``sd^2`` for white noise (``c / K``, module
    docstring)."""
    r = np.asarray(r, float)
    r = r[np.isfinite(r)]
    n = r.size
    if n < 16:
        raise ValidationError(f"noise floor needs at least 16 samples, but got {n}")
    f = np.fft.rfftfreq(n, dt)
    if not f_min < f[-1]:
        raise ValidationError(
            f"`f_min < Nyquist` must hold, but got (f_min={f_min}, Nyquist={f[-1]})"
        )
    band = (f >= f_min) & (f < f[-1])  # the Nyquist line counts once: leave it out
    # Hann taper: the leakage of strong low-frequency motion into the band falls as
    # 1/f^3 (a plain periodogram's falls as 1/f and would swamp the noise)
    w = np.hanning(n)
    p = np.abs(np.fft.rfft((r - r.mean()) * w)[band]) ** 2
    taper = n * np.sum(w**4) / np.sum(w**2) ** 2
    return float(np.sqrt(np.mean(p) / np.sum(w**2))), float(taper / band.sum())


def noise_floor(
    fit: FitResult, recordings: Any, f_min: float = NOISE_BAND_HZ
) -> tuple[dict[str, float], float]:
    """Per-channel noise standard deviation (channel unit) over ``recordings`` (each
    recording weighted by its samples, as the held-out RMS pools them), and the
    relative variance of the pooled floor (module docstring)."""
    parts = residuals(fit.model, fit.theta, list(recordings), fit.channels)
    out, precision = {}, 0.0
    for c in fit.channels:
        num, den = 0.0, 0
        for rec, part in zip(recordings, parts, strict=True):
            sd, var2 = white_noise_sd(part[c], rec.sample_interval, f_min)
            precision += 1.0 / var2  # the lines behind this estimate, in white-noise units
            n = int(np.isfinite(part[c]).sum())
            num += sd**2 * n
            den += n
        out[c] = float(np.sqrt(num / den)) if den else float("nan")
    return out, 0.25 / precision if precision else float("inf")


@dataclass
class ResidualCheck(Record):
    """The held-out residual left after the diagnosis, against the noise floor: the ride
    family's noise model (:meth:`view` is its view for the shared rule)."""

    heldout_before: float  # scaled held-out RMS of the baseline
    heldout_after: float  # same, final model
    noise_floor: float  # scaled, pooled
    excess_ratio: float  # after / floor
    explained_share: float  # of the baseline's model-error energy
    ljung_box_q: float
    ljung_box_p: float
    excess_limit: float  # size limit of the excess ratio (module docstring)
    named: bool = False
    per_channel_floor: dict[str, float] = field(default_factory=dict)
    whiteness_alpha: float = WHITENESS_ALPHA
    derived = ("residual_remains", "confident")

    def view(self) -> Left:
        """The shared rule's view (:mod:`suspenv.diagnosis.checks.residual_left`): the
        excess ratio against :attr:`excess_limit`, structured where the residual is not
        white."""
        return Left(
            "the held-out channels (pooled)",
            self.excess_ratio,
            self.excess_limit,
            self.ljung_box_p < self.whiteness_alpha,
            f"Ljung-Box p = {self.ljung_box_p:.2g}",
            self.sentence(),
        )

    @property
    def residual_remains(self) -> bool:
        """A residual above the noise rule is left."""
        return self.view().remains

    @property
    def confident(self) -> bool:
        """A named element that leaves only noise."""
        return self.named and not self.residual_remains

    def sentence(self) -> str:
        """The numbers in words."""
        pct = 100 * self.heldout_after / self.heldout_before if self.heldout_before else np.nan
        said = (
            f"held-out error {pct:.0f} % of the baseline's, {self.excess_ratio:.2f} x the "
            "sensor-noise floor"
        )
        if not self.named:
            return said
        share = 100 * max(self.explained_share, 0.0)
        return f"{said}; the named effect explains {share:.0f} % of the baseline's model error"

    def to_dict(self) -> dict[str, Any]:
        return super().to_dict() | {"sentence": self.sentence()}


def residual_check(
    base: FitResult,
    final: FitResult,
    heldout: Any,
    named_elements: list[str],
    alpha: float = WHITENESS_ALPHA,
) -> ResidualCheck:
    """The :class:`ResidualCheck` of a diagnosis (``final`` is ``base`` when nothing
    was named; ``named_elements``: names of the added elements)."""
    if not (held := list(heldout)):
        raise ValidationError("residual check needs at least one held-out recording, got 0")
    scales = base.scales
    parts_f = residuals(final.model, final.theta, held, final.channels)

    def rms(parts: list[dict[str, np.ndarray]]) -> dict[str, float]:
        return {
            c: float(np.sqrt(np.nanmean(np.concatenate([p[c] for p in parts]) ** 2)))
            for c in base.channels
        }

    before = scaled_rms(rms(residuals(base.model, base.theta, held, base.channels)), scales)
    after = scaled_rms(rms(parts_f), scales)
    floor_c, floor_variance = noise_floor(final, held)
    floor = scaled_rms(floor_c, scales)
    series = np.concatenate([p[c] / scales[c] for p in parts_f for c in final.channels])
    n = int(np.isfinite(series).sum())
    q, p = ljung_box(series[np.isfinite(series)])
    excess = after / floor if floor > 0 else float("inf")
    den = before**2 - floor**2
    explained = (before**2 - after**2) / den if den > 0 else 0.0
    return ResidualCheck(
        heldout_before=before,
        heldout_after=after,
        noise_floor=floor,
        excess_ratio=float(excess),
        explained_share=float(explained),
        ljung_box_q=q,
        ljung_box_p=p,
        excess_limit=size_limit(floor_variance, n, alpha),
        named=bool(named_elements),
        per_channel_floor=floor_c,
        whiteness_alpha=alpha,
    )
