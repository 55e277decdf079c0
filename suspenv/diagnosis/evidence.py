"""Evidence that an added effect is real: held-out error, information criteria,
likelihood-ratio test, residual whiteness, parameters with uncertainty.

Units: RMS errors are in each channel's unit; information criteria are
dimensionless (Gaussian log-likelihood with each channel's noise variance at its
maximum-likelihood value, or the family's own: ``FitResult.log_lik``). Where a family's
noise law is not Gaussian, its held-out "RMS" errors are root mean deviances under that
law (``FitResult.deviance``), so that the held-out leg judges what the likelihood does.

The likelihood-ratio statistic assumes independent samples; recordings are serially
correlated, so the statistic is also given scaled by ``n_eff / n`` of the *extended*
model's residual (an AR(1) effective sample size): when the added physics is right
that residual is close to white and the correction is small; when structure remains
the test becomes appropriately more cautious.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from suspenv.diagnosis.fitting import FitResult, ar1_effective_size, lag1_autocorrelation, residuals
from suspenv.diagnosis.split import Recordings, Split, as_recordings


def ljung_box(r: np.ndarray, lags: int = 20) -> tuple[float, float]:
    """Ljung-Box portmanteau statistic Q and its p-value (H0: the series is white).

    ``Q = n (n + 2) sum_{k=1..h} rho_k^2 / (n - k)`` ~ chi2(h) under H0
    (Ljung & Box, 1978).
    """
    r = np.asarray(r, float)
    r, n = r - np.mean(r), r.size
    h = int(min(lags, max(n // 4, 1)))
    den = float(np.dot(r, r))
    if n < 8 or den <= 0:
        return 0.0, 1.0
    rho = np.array([np.dot(r[k:], r[:-k]) / den for k in range(1, h + 1)])
    q = float(n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, h + 1))))
    return q, float(stats.chi2.sf(q, h))


def heldout_rms(
    fit: FitResult, recordings: Recordings, masks: Sequence[np.ndarray | None] | None = None
) -> dict[str, float]:
    """Per-channel RMS error of a fitted model on (held-out) samples (channel unit)."""
    return _channel_rms(heldout_residuals(fit, recordings, masks), fit.deviance)


def remembered_residuals(
    fit: FitResult, recordings: Recordings, masks: Sequence[np.ndarray | None] | None = None
) -> list[dict[str, np.ndarray]]:
    """:func:`~suspenv.diagnosis.fitting.residuals` of ``fit`` on ``recordings``,
    remembered on the fit (``extra["residuals"]``): a parent model is compared with each
    of its candidates on the same recordings and is simulated once. An entry is reused
    only for the same model object, the same parameter values and the very same
    recording and mask objects."""
    recs = as_recordings(recordings)
    memo: list[tuple[Any, ...]] = fit.extra.setdefault("residuals", [])
    for model, theta, seen, seen_masks, parts in memo:
        if (
            model is fit.model
            and np.array_equal(theta, fit.theta)
            and _same(seen, recs)
            and _same(seen_masks, masks)
        ):
            return parts
    parts = residuals(fit.model, fit.theta, recs, fit.channels, masks)
    memo.append((fit.model, np.array(fit.theta, float), list(recs), masks, parts))
    return parts


def _same(a: Sequence[Any] | None, b: Sequence[Any] | None) -> bool:
    """The same objects in the same order (or both None)."""
    if a is None or b is None:
        return a is b
    return len(a) == len(b) and all(x is y for x, y in zip(a, b, strict=True))


def heldout_residuals(
    fit: FitResult, recordings: Recordings, masks: Sequence[np.ndarray | None] | None = None
) -> dict[str, np.ndarray]:
    """Per-channel residual of a fitted model on (held-out) samples, recordings stacked."""
    parts = remembered_residuals(fit, recordings, masks)
    return {c: np.concatenate([p[c] for p in parts]) for c in fit.channels}


def _channel_rms(
    res: dict[str, np.ndarray], deviance: Callable[[np.ndarray], np.ndarray] | None = None
) -> dict[str, float]:
    """Per channel, the root mean square of the residuals (of their ``deviance`` where
    given: a noise law other than Gaussian)."""
    dev = deviance or np.square
    return {c: float(np.sqrt(np.mean(dev(r)))) if r.size else float("nan") for c, r in res.items()}


def heldout_noise_units(
    before: dict[str, np.ndarray], after: dict[str, np.ndarray], scales: dict[str, float]
) -> tuple[float, float]:
    """The held-out gain ``G`` and signal ``L`` of a model change, in noise units.

    With residuals ``r_b`` (before) and ``r_a`` (after) and each channel's noise scale
    ``s``: ``G = sum (r_b^2 - r_a^2) / s^2`` (the drop of the held-out chi-square) and
    ``L = sum (r_b - r_a)^2 / s^2`` (how far the change moved the held-out prediction).
    If the change captures a real effect, ``G ~ N(L, 4 L)``; if it only fitted noise,
    ``G ~ N(-L, 4 L)`` (white noise of scale ``s``). A change that hardly moves the
    held-out prediction (small ``L``) is then neither confirmed nor refuted by it,
    whatever its relative RMS change.
    """
    gain = signal = 0.0
    for c, rb in before.items():
        s2, ra = float(scales[c]) ** 2, after[c]
        gain += float(np.sum(rb**2 - ra**2)) / s2
        signal += float(np.sum((rb - ra) ** 2)) / s2
    return gain, signal


def heldout_confirmation_z(
    before: dict[str, np.ndarray], after: dict[str, np.ndarray], noise: dict[str, float], rho: float
) -> float:
    """How many standard deviations a model change's held-out chi-square drop lies above
    what a change that fitted only noise gives (0 when the change does not move the
    held-out prediction).

    ``G`` and ``L`` of :func:`heldout_noise_units` taken with each channel's noise scale
    ``noise`` (channel unit): a change that captures nothing the held-out samples hold
    gives ``G ~ N(-L, 4 L k)``, ``k = (1 + rho) / (1 - rho)`` for noise of lag-1
    autocorrelation ``rho >= 0`` (an AR(1) variance factor, the correction every
    likelihood ratio of the diagnosis takes), so ``z = (G + L) / (2 sqrt(L k))``. Unlike a
    relative drop of the held-out RMS error, it does not ask more of a change than the
    noise floor leaves: a model already close to the noise can be improved by little, but
    that little is confirmed or refuted on many held-out samples.
    """
    gain, signal = heldout_noise_units(before, after, noise)
    if signal <= 0.0:
        return 0.0
    r = min(max(float(rho), 0.0), 0.99)
    return float((gain + signal) / (2.0 * np.sqrt(signal * ((1.0 + r) / (1.0 - r)))))


def relative_drop(
    before: dict[str, np.ndarray],
    after: dict[str, np.ndarray],
    scales: dict[str, float],
    deviance: Callable[[np.ndarray], np.ndarray] | None = None,
) -> float:
    """Relative drop of the RMS error (root mean ``deviance``, where given) from
    residuals ``before`` to ``after`` (per channel, channel unit), channels combined by
    :func:`scaled_rms` with ``scales``; 0 when there was no error."""
    rms_before = scaled_rms(_channel_rms(before, deviance), scales)
    rms_after = scaled_rms(_channel_rms(after, deviance), scales)
    return float(1.0 - rms_after / rms_before) if rms_before > 0 else 0.0


def scaled_rms(rms: dict[str, float], scales: dict[str, float]) -> float:
    """One number across channels: RMS of the per-channel RMS divided by channel scale."""
    vals = [rms[c] / scales[c] for c in rms if np.isfinite(rms[c])]
    return float(np.sqrt(np.mean(np.square(vals)))) if vals else float("nan")


def baseline_summary(
    fit: FitResult,
    fit_recordings: Recordings,
    heldout_recordings: Recordings,
    fit_masks: Sequence[np.ndarray | None] | None = None,
    heldout_masks: Sequence[np.ndarray | None] | None = None,
) -> dict[str, Any]:
    """The numbers every diagnosis reports for its baseline fit: parameters, fit and
    held-out RMS per channel, AIC, BIC and the Ljung-Box whiteness test of the residual."""
    q, p = ljung_box(fit_residual_series(fit, fit_recordings, fit_masks))
    return {
        "params": fit.params(),
        "fit_rms": fit.rms(),
        "heldout_rms": heldout_rms(fit, heldout_recordings, heldout_masks),
        "aic": fit.aic(),
        "bic": fit.bic(),
        "ljung_box": {"Q": q, "p": p},
    }


def fit_residual_series(
    fit: FitResult, recordings: Recordings, masks: Sequence[np.ndarray | None] | None = None
) -> np.ndarray:
    """The fit's scaled residual, channels and recordings stacked (for whiteness tests)."""
    parts = remembered_residuals(fit, recordings, masks)
    return np.concatenate([p[c] / fit.scales[c] for p in parts for c in fit.channels])


@dataclass
class LikelihoodRatio:
    statistic: float
    dof: int
    p_value: float
    statistic_corrected: float
    p_value_corrected: float


def likelihood_ratio(base: FitResult, ext: FitResult, ext_residual: np.ndarray) -> LikelihoodRatio:
    """LR test of nested fits ``base`` (fewer parameters) vs ``ext``."""
    stat = max(2.0 * (ext.log_likelihood() - base.log_likelihood()), 0.0)
    dof = max(ext.n_params - base.n_params, 1)
    stat_c = stat * ar1_effective_size(1.0, lag1_autocorrelation(ext_residual))
    return LikelihoodRatio(
        statistic=stat,
        dof=dof,
        p_value=float(stats.chi2.sf(stat, dof)),
        statistic_corrected=stat_c,
        p_value_corrected=float(stats.chi2.sf(stat_c, dof)),
    )


@dataclass
class Comparison:
    """Baseline vs extended model on the same data (JSON-friendly via :meth:`to_dict`)."""

    heldout_rms_before: dict[str, float]
    heldout_rms_after: dict[str, float]
    fit_rms_before: dict[str, float]
    fit_rms_after: dict[str, float]
    heldout_reduction: float  # 1 - after/before on the scaled, channel-averaged RMS
    aic_before: float
    aic_after: float
    bic_before: float
    bic_after: float
    lr: LikelihoodRatio
    ljung_box_before: tuple[float, float]
    ljung_box_after: tuple[float, float]
    params_after: dict[str, dict[str, float]] = field(default_factory=dict)
    #: held-out chi-square drop and prediction change in noise units
    #: (:func:`heldout_noise_units`; NaN when :func:`compare` had no noise levels)
    heldout_gain: float = float("nan")
    heldout_signal: float = float("nan")

    @property
    def heldout_z(self) -> float:
        """How many standard deviations the held-out gain lies below what a real effect
        of this size would give (``(G - L) / (2 sqrt L)``; negative: short of it); 0 when
        the change does not move the held-out prediction, NaN when not computed."""
        if not np.isfinite(self.heldout_signal):
            return float("nan")
        if self.heldout_signal <= 0.0:
            return 0.0
        return float(
            (self.heldout_gain - self.heldout_signal) / (2.0 * np.sqrt(self.heldout_signal))
        )

    @property
    def delta_bic(self) -> float:
        return self.bic_after - self.bic_before

    def to_dict(self) -> dict[str, Any]:
        out = dict(vars(self), delta_bic=self.delta_bic, heldout_z=self.heldout_z)
        out["likelihood_ratio"] = vars(out.pop("lr"))
        for k in ("ljung_box_before", "ljung_box_after"):
            out[k] = dict(zip(("Q", "p"), out[k], strict=True))
        return out


def compare(
    base: FitResult, ext: FitResult, sp: Split, noise: Mapping[str, float] | None = None
) -> Comparison:
    """Everything that shows whether ``ext`` is better than ``base`` on the split ``sp``
    (the fit samples for the likelihood ratio, the held-out ones for the error).

    ``noise``: each channel's noise level (channel unit), for the held-out gain and
    signal in noise units (:func:`heldout_noise_units`; ``Comparison.heldout_gain``,
    ``heldout_signal``, ``heldout_z``); None leaves them NaN: with fits weighted by
    anything else (a channel's spread) they would be in no unit their names state.
    """
    r_base = fit_residual_series(base, sp.fit_recordings, sp.fit_masks)
    r_ext = fit_residual_series(ext, sp.fit_recordings, sp.fit_masks)
    res_before = heldout_residuals(base, sp.heldout_recordings, sp.heldout_masks)
    res_after = heldout_residuals(ext, sp.heldout_recordings, sp.heldout_masks)
    gain = signal = float("nan")
    if noise is not None:
        gain, signal = heldout_noise_units(res_before, res_after, dict(noise))
    return Comparison(
        heldout_rms_before=_channel_rms(res_before, base.deviance),
        heldout_rms_after=_channel_rms(res_after, ext.deviance),
        fit_rms_before=base.rms(),
        fit_rms_after=ext.rms(),
        heldout_reduction=relative_drop(res_before, res_after, base.scales, base.deviance),
        aic_before=base.aic(),
        aic_after=ext.aic(),
        bic_before=base.bic(),
        bic_after=ext.bic(),
        lr=likelihood_ratio(base, ext, r_ext),
        ljung_box_before=ljung_box(r_base),
        ljung_box_after=ljung_box(r_ext),
        params_after=ext.params(),
        heldout_gain=gain,
        heldout_signal=signal,
    )
