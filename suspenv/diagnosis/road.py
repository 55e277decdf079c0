"""Diagnosis of a measured road profile against the ISO 8608 model, in the one loop.

Frame and units: distance x along the road (m, + in the direction of travel),
elevation z (m, + up), spatial frequency n (cycle/m); PSDs are one-sided (m^3).
ISO 8608: Gd(n) = Gd(n0) (n / n0)^-w, n0 = 0.1 cycle/m, standard waviness w = 2.

The road family (:class:`RoadFamily`) runs in :func:`~suspenv.diagnosis.engine.diagnose`
like every other family, so the shared checks (:mod:`suspenv.diagnosis.checks`) judge
its verdict:

* data: the periodogram lines inside ``band`` of the first-differenced profile (the
  slope of a w = 2 road is nearly white, so no leakage from the strong long waves),
  each ``4 sin^2(pi n dx) Gd(n)`` times an Exp(1) variable (:func:`spectrum_recording`,
  :class:`RoadSpectrum`);
* fits: Whittle's likelihood (:func:`whittle_fit`), so the loop's likelihood-ratio test
  and BIC leg are the Whittle ones (least squares on the log lines, of known variance
  pi^2/6, would keep only 6 / pi^2 = 61 % of the information);
* baseline: the standard's form (Gd(n0) fitted, w = 2); the one candidate sets w free,
  named by :data:`ROAD_RULE`; held out: the second half of a single profile (the first
  is fitted), or another profile;
* what is left: :meth:`RoadFamily.residual_left`; the fits' numbers, the ISO 8608 class
  (whose range, half to double its mean, holds Gd(n0)), the held-out likelihoods and
  the octaves: the finding ``spectrum`` (:meth:`RoadFamily.spectrum_check`); the ride
  consequence (finding ``ride``): :func:`diagnose_road`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from scipy import optimize, stats

from suspenv.core.errors import ValidationError
from suspenv.diagnosis import engine
from suspenv.diagnosis.checks.finding import Check, Context, Finding
from suspenv.diagnosis.checks.residual_left import Left, size_limit
from suspenv.diagnosis.decision import DecisionRule
from suspenv.diagnosis.engine import Diagnosis
from suspenv.diagnosis.evidence import ljung_box
from suspenv.diagnosis.family import OptionalSteps, Outcome, Screening, Setup
from suspenv.diagnosis.fitting import FitResult, evaluate, residuals
from suspenv.diagnosis.hypothesis import Hypothesis
from suspenv.diagnosis.protocols import DiagnosableModel, RecordingLike
from suspenv.diagnosis.record import Record
from suspenv.diagnosis.split import Holdout, Recordings, Split, as_recordings, heldout_recordings
from suspenv.measurements import Recording
from suspenv.measurements.sources.road_profile import load_profile_txt
from suspenv.metrics.ride import road_ride_consequence
from suspenv.models.road import N0, gd0_class

#: default fitted band (cycle/m): long waves of a ~500 m profile up to 1 cycle/m (below
#: the 2 cycle/m Nyquist line of a 0.25 m grid, where interpolation and profiler
#: filtering bend the spectrum)
DEFAULT_BAND = (0.02, 1.0)
STANDARD_WAVINESS = 2.0


def profile_grid(rec: Recording) -> tuple[np.ndarray, float]:
    """(elevation (m), grid spacing (m)) of a profile recording."""
    rec.require(outputs=("elevation",), units={"elevation": "m"})
    z = rec.outputs["elevation"]
    dx = float(rec.meta.get("dx") or np.median(np.diff(rec.inputs.get("distance", rec.time))))
    return z, dx


# ------------------------------------------------------------------ spectra
def slope_periodogram(z: np.ndarray, dx: float) -> tuple[np.ndarray, np.ndarray]:
    """(n, I): one-sided periodogram of the first difference of z (m^3), lines 1..N/2-1."""
    d = np.diff(np.asarray(z, float))
    d = d - d.mean()
    N = d.size
    n = np.fft.rfftfreq(N, dx)
    I_ = 2.0 * dx / N * np.abs(np.fft.rfft(d)) ** 2
    keep = slice(1, N // 2 if N % 2 == 0 else None)
    return n[keep], I_[keep]


def difference_gain(n: np.ndarray, dx: float) -> np.ndarray:
    """|1 - exp(-2 pi i n dx)|^2 = 4 sin^2(pi n dx): PSD gain of first differencing."""
    return 4.0 * np.sin(np.pi * n * dx) ** 2


# ------------------------------------------------------------------ the spectral model
def spectrum_recording(rec: Recording, band: tuple[float, float] = DEFAULT_BAND) -> Recording:
    """The lines of ``rec``'s pre-whitened periodogram inside ``band`` as a recording the
    loop reads: input ``log_frequency`` = ln(n / n0), output ``log_periodogram`` =
    ln(I / (4 sin^2(pi n dx) x 1 m^3)) (both dimensionless), one sample per line (the
    sample axis ``time`` counts the lines)."""
    z, dx = profile_grid(rec)
    n, i_ = slope_periodogram(z, dx)
    lo, hi = band
    if not 0 < lo < hi:
        raise ValidationError(f"`0 < low < high` must hold for the band, but got ({lo}, {hi})")
    sel = (n >= lo) & (n <= hi)
    if sel.sum() < 8:
        raise ValidationError(
            f"the band {band} cycle/m must hold >= 8 Fourier lines of the profile, but holds "
            f"{int(sel.sum())} (length {len(z) * dx:.1f} m, dx {dx} m)"
        )
    return Recording(
        name=f"{rec.name}:spectrum",
        test="road_spectrum",
        time=np.arange(int(sel.sum()), dtype=float),
        inputs={"log_frequency": np.log(n[sel] / N0)},
        outputs={"log_periodogram": np.log(i_[sel] / difference_gain(n[sel], dx))},
        units={"log_frequency": "1", "log_periodogram": "1"},
        meta={"profile": rec.name, "dx": dx, "band": [float(lo), float(hi)]},
    )


@dataclass(frozen=True)
class Waviness:
    """The element the road search adds: the waviness ``w`` set free (ISO 8608's form
    fixes it at 2); an :class:`~suspenv.diagnosis.protocols.EffectLike`."""

    w: float = STANDARD_WAVINESS
    kind: str = "waviness"
    name: str = "waviness"
    location: str = ""

    @property
    def params(self) -> dict[str, float]:
        return {"w": self.w}

    def with_params(self, values: Mapping[str, Any]) -> Waviness:
        return Waviness(float(np.ravel(values.get("w", self.w))[0]))

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "name": self.name, "location": "", "params": self.params}


class RoadSpectrum:
    """ISO 8608's displacement PSD, Gd(n) = Gd(n0) (n / n0)^-w, as a model of the
    expected log periodogram lines (:func:`spectrum_recording`): ``ln Gd(n0) - w ln(n/n0)
    - gamma`` (gamma: Euler's constant, the mean of the log of an Exp(1) line), so the
    residual is ``ln(I / S) + gamma``, of mean 0 and variance pi^2 / 6 (model family
    ``road_profile``; parameters ``log_gd0`` [ln m^3], ``waviness.w`` [-])."""

    family = "road_profile"
    location = ""
    output_channels = ("log_periodogram",)
    input_channels = ("log_frequency",)
    channel_units: ClassVar[dict[str, str]] = {"log_frequency": "1", "log_periodogram": "1"}
    effect_defaults: ClassVar[dict[str, dict[str, float]]] = {}
    candidate_effects = ("waviness",)
    base_names = ("log_gd0",)

    def __init__(self, effects: Sequence[Waviness] = ()):
        self.effects = tuple(effects)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return self.base_names + tuple(f"{e.name}.w" for e in self.effects)

    @property
    def parameter_units(self) -> tuple[str, ...]:
        return ("ln m^3",) + ("-",) * len(self.effects)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        k = len(self.effects)
        return np.array([np.log(1e-10)] + [0.2] * k), np.array([np.log(1e-2)] + [6.0] * k)

    def initial_guess(self, rec: Recording) -> np.ndarray:
        x, y = rec.inputs["log_frequency"], rec.outputs["log_periodogram"]
        a = np.log(np.mean(np.exp(y + STANDARD_WAVINESS * x)))
        return np.array([a] + [STANDARD_WAVINESS] * len(self.effects))

    def simulate(self, theta: np.ndarray, rec: Recording) -> dict[str, np.ndarray]:
        th = np.asarray(theta, float)
        a, w = th[..., :1], th[..., 1:2] if self.effects else STANDARD_WAVINESS
        return {"log_periodogram": a - w * rec.inputs["log_frequency"] - np.euler_gamma}

    def unpack(self, theta: np.ndarray) -> tuple[dict[str, np.ndarray], list[Waviness]]:
        th = np.asarray(theta, float)
        return {"log_gd0": th[..., 0]}, [e.with_params({"w": th[..., 1]}) for e in self.effects]

    def with_effects(self, effects: Sequence[Waviness]) -> RoadSpectrum:
        return RoadSpectrum(effects)

    def difference_step(self, theta: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        return 1e-6 * (1.0 + np.abs(np.asarray(theta, float)))

    def refine_start(self, theta0: np.ndarray, recordings: Any, masks: Any) -> None:
        return None

    def jacobian_model(self) -> RoadSpectrum:
        return self

    def force_view(self, theta: np.ndarray, rec: Recording) -> None:
        return None


#: variance of the log of an Exp(1) periodogram line (the residual's, known exactly)
LOG_LINE_VARIANCE = float(np.pi**2 / 6.0)
#: its fourth moment over the variance squared (3 + the Gumbel law's excess kurtosis 12/5)
LOG_LINE_KURTOSIS = 5.4


def whittle_fit(model: DiagnosableModel, recs: Sequence[RecordingLike]) -> FitResult:
    """Whittle maximum-likelihood fit of ``model`` to spectrum recordings (module
    docstring): Gd(n0) in closed form for a given w (the mean of I / (gain (n/n0)^-w)),
    w (when free) by a bounded 1-D search; the result carries the Whittle log-likelihood
    ``-sum(ln S + I / S)`` (:attr:`FitResult.log_lik`)."""
    x = np.concatenate([r.inputs["log_frequency"] for r in recs])
    y = np.concatenate([r.outputs["log_periodogram"] for r in recs])

    def log_gd0(w: float) -> float:
        return float(np.log(np.mean(np.exp(y + w * x))))

    def nll(w: float) -> float:
        a = log_gd0(w)
        return float(np.sum(a - w * x + np.exp(y - a + w * x)))

    if model.effects:
        lo, hi = model.bounds()
        w = float(optimize.minimize_scalar(nll, bounds=(lo[1], hi[1]), method="bounded").x)
    else:
        w = STANDARD_WAVINESS
    theta = np.array([log_gd0(w)] + [w] * len(model.effects))
    # the scaled residual has unit variance: J = X gives cov = (X^T X)^-1, Whittle's
    X = np.column_stack([np.ones_like(x), -x])[:, : theta.size]
    out = evaluate(model, theta, recs, {"log_periodogram": np.sqrt(LOG_LINE_VARIANCE)}, None, X)
    out.log_lik = whittle_loglik(out, recs)
    out.deviance = whittle_deviance
    return out


def whittle_deviance(r: np.ndarray) -> np.ndarray:
    """Per line, the Whittle deviance ``2 (I/S - 1 - ln(I/S))`` of the log-line residual
    ``r = ln(I/S) + gamma`` (about ``r^2`` near the mode): the held-out comparison's
    error, so that it judges what the Whittle likelihood does."""
    u = np.asarray(r, float) - np.euler_gamma
    return 2.0 * (np.expm1(u) - u)


@dataclass
class PsdFit(Record):
    """A Whittle fit of Gd(n) = gd0 (n/n0)^-w over ``band`` (SI: m^3, cycle/m)."""

    gd0: float
    gd0_ci95: tuple[float, float]
    waviness: float
    waviness_se: float
    loglik: float
    n_lines: int
    band: tuple[float, float]
    fixed_waviness: bool
    derived = ("road_class",)

    @classmethod
    def of(cls, fit: FitResult, band: tuple[float, float]) -> PsdFit:
        """The numbers of a :func:`whittle_fit`."""
        a, se_a = float(fit.theta[0]), float(fit.stderr[0])
        free = fit.theta.size > 1
        return cls(
            gd0=float(np.exp(a)),
            gd0_ci95=(float(np.exp(a - 1.96 * se_a)), float(np.exp(a + 1.96 * se_a))),
            waviness=float(fit.theta[1]) if free else STANDARD_WAVINESS,
            waviness_se=float(fit.stderr[1]) if free else 0.0,
            loglik=fit.log_likelihood(),
            n_lines=fit.n_samples,
            band=(float(band[0]), float(band[1])),
            fixed_waviness=not free,
        )

    @property
    def road_class(self) -> str:
        return gd0_class(self.gd0)


# ------------------------------------------------------------------ the family
#: the road family's decision rule: the loop's, the held-out log-line error asked not
#: to grow
ROAD_RULE = DecisionRule(alpha=0.01, heldout_rule="fraction", min_heldout_gain=0.0)


@dataclass
class Octaves:
    """Mean measured line over the model's, per octave band (1: the model holds)."""

    rows: list[dict[str, float]]

    def to_dict(self) -> dict[str, Any]:
        return {"octaves": self.rows}


def octaves(fit: FitResult, recs: Sequence[RecordingLike]) -> Octaves:
    """:class:`Octaves` of ``fit`` over ``recs``: per octave (``n_low``, ``n_high``
    cycle/m) the lines, the mean measured line over the model's (``ratio``) and the mean
    log-line residual in its noise units (``z``: standard normal under the model, its
    noise variance pi^2/6 over the lines being known)."""
    x = np.concatenate([r.inputs["log_frequency"] for r in recs])
    r = log_residual(fit, recs)
    rows, lo = [], N0 * float(np.exp(x.min()))
    while lo < N0 * np.exp(x.max()):
        sel = (x >= np.log(lo / N0)) & (x < np.log(2 * lo / N0))
        m = int(sel.sum())
        if m >= 2:
            rows.append(
                {
                    "n_low": lo,
                    "n_high": 2 * lo,
                    "lines": m,
                    "ratio": float(np.mean(np.exp(r[sel] - np.euler_gamma))),
                    "z": float(np.mean(r[sel]) * np.sqrt(m / LOG_LINE_VARIANCE)),
                }
            )
        lo *= 2
    return Octaves(rows)


def log_residual(fit: FitResult, recs: Sequence[RecordingLike]) -> np.ndarray:
    """The log-line residual of ``fit`` on ``recs`` (``ln(I / S) + gamma``), stacked."""
    return np.concatenate(
        [p["log_periodogram"] for p in residuals(fit.model, fit.theta, recs, fit.channels)]
    )


def whittle_loglik(fit: FitResult, recs: Sequence[RecordingLike]) -> float:
    """Whittle log-likelihood ``-sum(ln S + I / S)`` of ``recs``' lines under ``fit``
    (I over the differencing gain, whose log is a constant of the data)."""
    r = log_residual(fit, recs) - np.euler_gamma
    y = np.concatenate([q.outputs["log_periodogram"] for q in recs])
    return float(np.sum(r - np.exp(r) - y))


@dataclass
class RoadFamily(OptionalSteps):
    """A measured road profile against ISO 8608, in the one loop (the module docstring:
    baseline, candidate, held-out data and what is left)."""

    band: tuple[float, float] = DEFAULT_BAND
    rule: DecisionRule = ROAD_RULE
    name: str = field(default="road", init=False)
    max_effects: int = 1
    #: the log lines' known noise variance, for the share of variance explained
    noise_variance: dict[str, float] = field(
        default_factory=lambda: {"log_periodogram": LOG_LINE_VARIANCE}, init=False
    )

    def prepare(self, recordings: Recordings, holdout: Holdout, candidates: Any) -> Setup:
        profiles = [_as_profile(r) for r in as_recordings(recordings)]
        if holdout is None and len(profiles) == 1:
            one, k = profiles[0], profiles[0].n_samples // 2
            fit = [one.select(slice(0, k), f"{one.name}:first_half")]
            held = [one.select(slice(k, None), f"{one.name}:second_half")]
            words = f"fit on the first half of {one.name}, held out its second half"
        else:
            fit, held = profiles, [_as_profile(r) for r in heldout_recordings(holdout)]
            words = ""
        sp = Split.separate(
            [spectrum_recording(r, self.band) for r in fit],
            [spectrum_recording(r, self.band) for r in held],
            words,
        )
        return Setup(sp, RoadSpectrum(), list(candidates or RoadSpectrum.candidate_effects))

    def fit_baseline(self, setup: Setup) -> FitResult:
        return whittle_fit(setup.model, setup.split.fit_recordings)

    def locate(self, base: FitResult, setup: Setup) -> tuple[Octaves, str]:
        return octaves(base, setup.split.fit_recordings), "log_periodogram"

    def screen(
        self, current: FitResult, setup: Setup, open_candidates: Any, round_: int
    ) -> Screening:
        return Screening([], [(c, None) for c in open_candidates])

    def refit(self, current: FitResult, candidate: str, signature: Any, setup: Setup) -> FitResult:
        out = whittle_fit(current.model.with_effects([Waviness()]), setup.split.fit_recordings)
        out.extra["effect"] = Waviness().to_dict()
        return out

    def words(self, candidate: str, setup: Setup) -> str:
        """The free waviness's way and value (the fit :meth:`refit` makes)."""
        free = PsdFit.of(
            whittle_fit(RoadSpectrum((Waviness(),)), setup.split.fit_recordings), self.band
        )
        way = "steeper" if free.waviness > STANDARD_WAVINESS else "shallower"
        return (
            f"waviness {way} than ISO 8608's 2 (w = {free.waviness:.2f} +- {free.waviness_se:.2f})"
        )

    def checks(self) -> tuple[Check, ...]:
        return (self.spectrum_check,)

    def spectrum_check(self, ctx: Context) -> Finding | None:
        """The road family's check after the search (finding ``spectrum``): both fits'
        numbers (``free_fit``, ``standard_fit``: :class:`PsdFit`), the held-out likelihoods
        (``heldout``), measured over model per octave for both (``octave_bands``), and the
        sentence of the ISO 8608 class with the waviness test's numbers."""
        hyp, base = ctx.outcome.hypotheses[0], ctx.outcome.base  # the one candidate's refit
        if hyp.fit is None:
            return None
        free, std = PsdFit.of(hyp.fit, self.band), PsdFit.of(base, self.band)
        recs = ctx.setup.split.fit_recordings
        bands = [
            {
                **{k: a[k] for k in ("n_low", "n_high", "lines")},
                "measured_over_free": a["ratio"],
                "measured_over_standard": b["ratio"],
            }
            for a, b in zip(octaves(hyp.fit, recs).rows, octaves(base, recs).rows, strict=True)
        ]
        fit = free if ctx.outcome.named else std
        test = (
            f"LR = {hyp.lr_statistic_corrected:.1f}, p = {hyp.p_value_corrected:.2g}, "
            f"dBIC = {hyp.delta_bic_corrected:.1f}"
        )
        return Finding(
            "spectrum",
            sentence=f"class {fit.road_class} by Gd(n0) = {fit.gd0 * 1e6:.1f}e-6 m^3 ({test})",
            numbers={
                "free_fit": free.to_dict(),
                "standard_fit": std.to_dict(),
                "heldout": _heldout_numbers(ctx.setup.split, base, hyp),
                "octave_bands": bands,
            },
        )

    def assumptions(self, setup: Setup) -> list[str]:
        """What the spectral test takes for granted."""
        return [
            "the profile's slope is a stationary Gaussian process (periodogram lines "
            "independent, Exp(1) about the spectrum: the Whittle likelihood)",
            f"the spectrum is judged in {self.band[0]:g}-{self.band[1]:g} cycle/m",
        ]

    def residual_left(
        self, outcome: Outcome, setup: Setup, alpha: float
    ) -> tuple[list[Left], dict[str, Any]]:
        """The final model's log lines over every profile (fit and held out), refitted to
        all of them (a half fitted alone carries its estimation error into the other
        half, which is no error of the model's form), in noise units (the noise level is
        known, not estimated), three views (Bonferroni over them):

        * octaves: the RMS over the octaves of each octave's mean residual in its noise
          units (:func:`octaves`; shape errors: a knee, a hump), limit
          :func:`size_limit` over the octaves, structured by the chi-square test of those
          means;
        * lines: the lines' RMS over sqrt(pi^2/6) (the limit's variance 1/(2n) grows to
          (kurtosis - 1)/(4n) for the log-Exp law), structured where the lines are
          correlated along the frequency (Ljung-Box) or one line stands out beyond what n
          Exp(1) lines give (a periodic component);
        * curvature: a look-alike of more shape than the free waviness
          (:func:`curvature_view`: a knee or a bend of the log spectrum)."""
        recs = setup.split.recordings()
        final = whittle_fit(outcome.current.model, recs)
        r = log_residual(final, recs)
        n = r.size
        _, p_lb = ljung_box(r)
        top = int(np.argmax(r))
        p_peak = float(-np.expm1(n * np.log1p(-np.exp(-np.exp(r[top] - np.euler_gamma)))))
        x = np.concatenate([q.inputs["log_frequency"] for q in recs])
        table = octaves(final, recs).rows
        z = np.array([row["z"] for row in table])
        worst = table[int(np.argmax(np.abs(z)))]
        p_bands = float(stats.chi2.sf(np.sum(z**2), z.size))
        extra = (LOG_LINE_KURTOSIS - 1.0) / 4.0 - 0.5
        views = [
            Left(
                "the octave means of the log periodogram",
                float(np.sqrt(np.mean(z**2))),
                size_limit(0.0, z.size, alpha, 3),
                p_bands < alpha,
                f"chi-square of the octave means p = {p_bands:.2g}",
                f"measured / model {worst['ratio']:.2f} in {worst['n_low']:.3g}-"
                f"{worst['n_high']:.3g} cycle/m",
            ),
            Left(
                "the log periodogram lines",
                float(np.sqrt(np.mean(r**2) / LOG_LINE_VARIANCE)),
                size_limit(extra / n, n, alpha, 3),
                min(p_lb, p_peak) < alpha / 2,
                f"Ljung-Box along the frequency p = {p_lb:.2g}, largest line p = {p_peak:.2g}",
                f"largest line {np.exp(r[top] - np.euler_gamma):.0f} x the model at "
                f"{N0 * np.exp(x[top]):.3g} cycle/m",
            ),
            curvature_view(recs, alpha / 3),
        ]
        return views, {"octaves": table, "ljung_box_p": p_lb, "peak_p": p_peak}


def curvature_view(recs: Sequence[RecordingLike], alpha: float) -> Left:
    """Whether the log spectrum of ``recs`` bends: the Whittle score test of a term
    ``c (ln(n/n0))^2`` added to ln S at the free-waviness fit of every line. With ``q``
    that term's regressor made orthogonal to ``[1, ln(n/n0)]`` (the parameters fitted),
    the score ``U = sum q (I / S - 1)`` has variance ``sum q^2`` under the model (the
    Whittle Fisher information), so ``z = U / sqrt(sum q^2)`` is standard normal. Its
    size is ``|z|`` against the two-sided quantile of ``alpha``; the sign says which way
    the spectrum bends (a knee to a steeper slope bends it down)."""
    free = whittle_fit(RoadSpectrum((Waviness(),)), recs)
    x = np.concatenate([q.inputs["log_frequency"] for q in recs])
    basis = np.column_stack([np.ones_like(x), x])
    q = x**2 - basis @ np.linalg.lstsq(basis, x**2, rcond=None)[0]
    z = float(q @ np.expm1(log_residual(free, recs) - np.euler_gamma) / np.sqrt(q @ q))
    limit = float(stats.norm.isf(alpha / 2))
    return Left(
        "the curvature of the log spectrum",
        abs(z),
        limit,
        abs(z) > limit,
        f"Whittle score test of a bend, z = {z:+.2f}",
        f"the spectrum bends {'down' if z < 0 else 'up'} across the band against one slope",
    )


def _as_profile(rec: RecordingLike) -> Recording:
    if not isinstance(rec, Recording):
        raise ValidationError(f"a road profile must be a Recording, but got {type(rec).__name__}")
    return rec


# ------------------------------------------------------------------ diagnosis
def _heldout_numbers(split: Split, base: FitResult, hyp: Hypothesis) -> dict[str, Any]:
    """The held-out check in numbers: both models' Whittle log-likelihood per held-out
    line, and the waviness fitted to the held-out profile(s) on their own."""
    held, free = split.heldout_recordings, hyp.fit
    assert free is not None  # the candidate's refit (checked by the caller)
    own = whittle_fit(RoadSpectrum((Waviness(),)), held)

    def per_line(fit: FitResult) -> float:
        return whittle_loglik(fit, held) / own.n_samples

    w, se = float(free.theta[1]), float(free.stderr[1])
    return {
        "description": split.description,
        "fit_waviness": w,
        "fit_waviness_se": se,
        "heldout_waviness": float(own.theta[1]),
        "heldout_waviness_se": float(own.stderr[1]),
        "waviness_agreement_z": float((own.theta[1] - w) / np.hypot(own.stderr[1], se)),
        "heldout_loglik_per_line_free": per_line(free),
        "heldout_loglik_per_line_standard": per_line(base),
        "heldout_loglik_gain_per_line": per_line(free) - per_line(base),
        "heldout_lines": own.n_samples,
        "heldout_reduction": float(hyp.heldout_reduction),
    }


def diagnose_road(
    recording: Recording | str | Path,
    heldout: Recording | str | Path | None = None,
    band: tuple[float, float] = DEFAULT_BAND,
    alpha: float = 0.01,
    ride: bool = True,
    ride_speed_kmh: float = 80.0,
    ride_seeds: tuple[int, ...] = (0, 1, 2),
) -> Diagnosis:
    """Diagnose a measured road profile against ISO 8608 in the one loop, with its ride
    consequence said last (see the module docstring).

    Args:
        recording: a profile Recording (or a ``profile_*.txt`` path).
        heldout: another profile held out (default: the second half of ``recording``;
            the fit then uses the first half).
        band: fitted spatial-frequency band (cycle/m).
        alpha: the decision rule's level.
        ride: also compute the ride consequence (a few short ride-model runs,
            :func:`suspenv.metrics.ride.road_ride_consequence`).
    """
    rec = recording if isinstance(recording, Recording) else load_profile_txt(recording)
    held = (
        heldout if heldout is None or isinstance(heldout, Recording) else load_profile_txt(heldout)
    )
    family = RoadFamily(band=band, rule=replace(ROAD_RULE, alpha=alpha))
    diag = engine.diagnose(rec, family, holdout=held)
    spectrum = diag.findings.get("spectrum")
    if ride and spectrum is not None:
        free, std = spectrum.numbers["free_fit"], spectrum.numbers["standard_fit"]
        numbers = road_ride_consequence(
            (free["gd0"], free["waviness"]),
            std["gd0"],
            profile_grid(rec),
            ride_speed_kmh,
            ride_seeds,
        )
        said = (
            f"ride: Wk-weighted RMS at {ride_speed_kmh:g} km/h front "
            f"{numbers['aw_front_measured_spectrum']:.3f} vs {numbers['aw_front_standard']:.3f} "
            f"m/s^2 on the w = 2 fit ({100 * (numbers['ratio_front'] - 1):+.0f} %)"
        )
        diag.findings["ride"] = Finding("ride", sentence=said, numbers=numbers)
        diag.evidence.append(said)
        diag.verdict += ". R" + said[1:]
    return diag
