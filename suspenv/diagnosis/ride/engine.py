"""Ride diagnosis: fit -> locate -> screen -> refit -> decide, on minibus ride recordings.

Reuses the generic engine's pieces (:func:`suspenv.diagnosis.fit.fit_model`,
:func:`suspenv.diagnosis.evidence.compare`, the decision rule and ranking of
:mod:`suspenv.diagnosis.name`, the :class:`~suspenv.diagnosis.engine.Diagnosis`
record) and replaces the parts that assume one component stroke ``x``:

* **locate** (:func:`locate_ride`): residual energy shares by channel, by test
  speed (also against each speed's share of the response energy: amplitude
  dependence, 20 vs 50 km/h), by time window relative to the
  impacts (before, after the front wheels hit, after the rear wheels hit, free
  decay) and by frequency band (body modes, mid, wheel hop, high);
* **screen** (:func:`screen_candidates`): each candidate element (kind + location)
  is added at a physical starting size; the change it makes to the prediction,
  projected off the baseline Jacobian (what a refit of the base parameters could
  absorb), is regressed on the residual. The share of residual energy it explains
  is its score (a Lagrange-multiplier statistic, like the generic signatures, but
  with the model's own response as the feature). The best ``screen`` candidates
  are refitted.

Decision rule: the generic one (corrected LR p-value below alpha / tests, BIC
falls, held-out RMS error falls by at least ``min_heldout_gain``).

What is left (:mod:`suspenv.diagnosis.ride.residual`): the held-out error of the
final model against the sensor-noise floor and the whiteness of that residual. A
named element that leaves a structured residual well above the noise is reported
as "not confident: physics outside the candidate list remains" (the candidate list
is finite; a real vehicle is not).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from suspenv.core.errors import EvaluationError
from suspenv.diagnosis.engine import Diagnosis, Split, main_channel
from suspenv.diagnosis.evidence import (
    baseline_summary,
    compare,
    fit_residual_series,
)
from suspenv.diagnosis.fit import FitResult, as_list, fit_model, residuals
from suspenv.diagnosis.locate import Location, Share
from suspenv.diagnosis.name import (
    Hypothesis,
    ambiguities,
    corrected_delta_bic,
    decide,
    family_of,
    rank,
)
from suspenv.diagnosis.ride.model import (
    RIDE_CANDIDATES,
    MinibusRideAdapter,
    effect_words,
    ride_effect,
)
from suspenv.diagnosis.ride.residual import ResidualCheck, residual_check
from suspenv.diagnosis.signatures import Signature, effective_n

#: frequency bands of the residual (Hz): body modes, mid, wheel hop, high
BANDS = (
    ("body 0.5-3 Hz", 0.5, 3.0),
    ("mid 3-8 Hz", 3.0, 8.0),
    ("wheel hop 8-16 Hz", 8.0, 16.0),
    ("high > 16 Hz", 16.0, np.inf),
)


@dataclass
class RideDiagnosis(Diagnosis):
    """A :class:`~suspenv.diagnosis.engine.Diagnosis` plus the residual left after it."""

    residual: ResidualCheck | None = None

    @property
    def confident(self) -> bool:
        """Something named, and it leaves only noise (see :class:`ResidualCheck`)."""
        return bool(self.residual is not None and self.residual.confident)

    def to_dict(self) -> dict[str, Any]:
        out = super().to_dict()
        out["residual"] = self.residual.to_dict() if self.residual else None
        out["confident"] = self.confident
        return out


def _windows(rec: Any) -> dict[str, np.ndarray]:
    t = rec.time
    if rec.test != "pulse":
        return {"random road": np.ones(t.size, bool)}
    t0 = float(rec.meta.get("bump_time_s", 0.3))
    lag = float(rec.meta.get("wheelbase_delay_s", 0.2))
    return {
        "before the bump": t < t0,
        "front impact (0.3 s)": (t >= t0) & (t < t0 + min(lag, 0.3)),
        "rear impact (0.3 s)": (t >= t0 + lag) & (t < t0 + lag + 0.3),
        "free decay": t >= t0 + lag + 0.3,
    }


def locate_ride(fit: FitResult, recordings: Sequence[Any]) -> Location:
    """Shares of the scaled residual energy by channel, test, time window, band."""
    parts = residuals(fit.model, fit.theta, recordings, fit.channels)
    loc = Location()
    acc: dict[tuple[str, str], list[float]] = {}
    total, n_total = 0.0, 0
    band_e: dict[str, float] = {}
    band_n: dict[str, float] = {}
    acc_signal: dict[str, list[float]] = {}
    for rec, part in zip(recordings, parts, strict=True):
        n = rec.n_samples
        n_total += n * len(fit.channels)
        speed = f"{rec.test} {rec.meta.get('speed_kmh', 0):.0f} km/h"
        f = np.fft.rfftfreq(n, rec.sample_interval)
        for c in fit.channels:
            r = part[c] / fit.scales[c]
            e = float(np.sum(r**2))
            total += e
            for key in (("channel", c), ("test", speed)):
                a = acc.setdefault(key, [0.0, 0.0])
                a[0] += e
                a[1] += n
            # amplitude dependence: residual share against the share of response energy
            y = np.asarray(rec.outputs[c], float) / fit.scales[c]
            a = acc_signal.setdefault(speed, [0.0, 0.0])
            a[0] += e
            a[1] += float(np.sum(y**2))
            for w, m in _windows(rec).items():
                a = acc.setdefault(("time window", w), [0.0, 0.0])
                a[0] += float(np.sum(r[m] ** 2))
                a[1] += int(m.sum())
            p = np.abs(np.fft.rfft(r)) ** 2
            for name, lo, hi in BANDS:
                sel = (f >= lo) & (f < hi)
                band_e[name] = band_e.get(name, 0.0) + float(p[sel].sum())
                band_n[name] = band_n.get(name, 0.0) + float(sel.sum()) / f.size
    for (dim, part_name), (e, n) in acc.items():
        loc.shares.append(Share(dim, part_name, e / total if total else 0.0, n / n_total))
    sig_total = sum(v[1] for v in acc_signal.values()) or 1.0
    if len(acc_signal) > 1:
        for speed, (e, y2) in acc_signal.items():
            loc.shares.append(
                Share("test vs response energy", speed, e / total if total else 0.0, y2 / sig_total)
            )
    spec_total = sum(band_e.values()) or 1.0
    n_sets = len(recordings) * len(fit.channels)
    for name, _, _ in BANDS:
        loc.shares.append(
            Share("frequency band", name, band_e[name] / spec_total, band_n[name] / n_sets)
        )
    return loc


def screen_candidates(
    fit: FitResult, recordings: Sequence[Any], candidates: Sequence[tuple[str, str]]
) -> list[Signature]:
    """Score each (kind, location): partial R^2 of the residual explained by the
    prediction change the element makes at its starting size, beyond the baseline
    Jacobian's span. Sorted best first."""
    r = fit_residual_series(fit, recordings)
    J = fit.extra.get("jacobian")
    basis = None
    if J is not None and J.shape[0] == r.size:
        U, s, _ = np.linalg.svd(J, full_matrices=False)
        basis = U[:, s > s[0] * 1e-8] if s.size else None
    base_pred = _stacked_prediction(fit.model, fit.theta, recordings, fit)
    out = []
    for kind, loc in candidates:
        eff = ride_effect(kind, loc)
        model = fit.model.with_effects((*fit.model.effects, eff))
        guess = model.initial_guess(recordings[0])
        th = np.concatenate([fit.theta, guess[fit.theta.size :]])
        try:
            pred = _stacked_prediction(model, th, recordings, fit)
        except EvaluationError:
            pred = base_pred
        feat = pred - base_pred
        if basis is not None:
            feat = feat - basis @ (basis.T @ feat)
        den = float(feat @ feat)
        r2 = float((feat @ r) ** 2 / (den * float(r @ r))) if den > 0 and r @ r > 0 else 0.0
        n_eff = effective_n(r - (feat * (feat @ r) / den if den > 0 else 0.0))
        p = float(stats.chi2.sf(n_eff * r2, 1))
        out.append(
            Signature(
                f"{kind}@{loc}",
                r2,
                p,
                f"{effect_words(eff)} at its starting size explains {100 * r2:.1f} % of the "
                "residual energy beyond the baseline parameters",
                {"partial_r2": r2},
            )
        )
    return sorted(out, key=lambda s: -s.score)


def _stacked_prediction(
    model: Any, theta: np.ndarray, recordings: Sequence[Any], fit: FitResult
) -> np.ndarray:
    """Scaled predictions of the fitted channels, recordings stacked (non-finite -> 0)."""
    cols = []
    for rec in recordings:
        pred = model.simulate(theta, rec)
        cols += [np.asarray(pred[c], float) / fit.scales[c] for c in fit.channels]
    v = np.concatenate(cols)
    return np.where(np.isfinite(v), v, 0.0)


def _refit(
    current: FitResult, kind: str, loc: str, recs: Sequence[Any], max_nfev: int
) -> tuple[FitResult, Any]:
    """Refit ``current`` with one more element, starting from its fitted values."""
    eff = ride_effect(kind, loc)
    model = current.model.with_effects((*current.model.effects, eff))
    theta0 = dict(zip(current.names, current.theta, strict=True))
    fit = fit_model(model, recs, theta0=theta0, max_nfev=max_nfev)
    fit.extra["effect"] = eff.to_dict()
    return fit, eff


def diagnose_ride(
    recordings: Any,
    heldout: Any,
    model: MinibusRideAdapter | None = None,
    candidates: Sequence[tuple[str, str]] = RIDE_CANDIDATES,
    screen: int = 3,
    max_effects: int = 1,
    alpha: float = 0.01,
    min_heldout_gain: float = 0.01,
    max_nfev: int = 30,
) -> RideDiagnosis:
    """Diagnose what the minibus ride model leaves out of ride recordings.

    Args:
        recordings: fit recordings (e.g. the first pulse runs at 20 and 50 km/h).
        heldout: recordings not used for fitting (repeat runs, a random-road run).
        model: the base model (default: :class:`MinibusRideAdapter` without effects).
        candidates: (kind, location) pairs to consider.
        screen: refit this many best-screened candidates per round.
        max_effects: most effects added in turn.
    """
    t0 = time.perf_counter()
    model = model or MinibusRideAdapter()
    recs, held = as_list(recordings), as_list(heldout)
    sp = Split(
        fit_recordings=recs,
        fit_masks=None,
        heldout_recordings=held,
        heldout_masks=None,
        description="separate recording(s): " + ", ".join(r.name for r in held),
    )
    base = fit_model(model, recs, max_nfev=max_nfev)
    location = locate_ride(base, recs)
    current = base
    named: list[Hypothesis] = []
    all_hyps: list[Hypothesis] = []
    first_sigs: list[Signature] = []
    amb = []
    remaining = list(candidates)
    for rnd in range(1, max_effects + 1):
        sigs = screen_candidates(current, recs, remaining)
        if rnd == 1:
            first_sigs = sigs
        hyps = []
        for sig in sigs[:screen]:
            kind, loc = sig.kind.split("@")
            try:
                ext, eff = _refit(current, kind, loc, recs, max_nfev)
            except EvaluationError as exc:  # the element at its start made the model diverge
                eff = ride_effect(kind, loc)
                all_hyps.append(
                    Hypothesis(
                        f"{kind}@{loc}",
                        family_of(kind),
                        effect_words(eff),
                        rnd,
                        sig.score,
                        f"refit failed: {exc}",
                        0.0,
                        0.0,
                        0,
                        1.0,
                        np.inf,
                        0.0,
                    )
                )
                continue
            comp = compare(current, ext, recs, None, held, None)
            own = {k: v for k, v in ext.params().items() if k.startswith(eff.name + ".")}
            hyps.append(
                Hypothesis(
                    kind=f"{kind}@{loc}",
                    family=family_of(kind),
                    words=effect_words(eff),
                    round=rnd,
                    signature_score=sig.score,
                    signature_evidence=sig.evidence,
                    lr_statistic=comp.lr.statistic,
                    lr_statistic_corrected=comp.lr.statistic_corrected,
                    lr_dof=comp.lr.dof,
                    p_value_corrected=comp.lr.p_value_corrected,
                    delta_bic_corrected=corrected_delta_bic(
                        comp.lr.statistic_corrected, comp.lr.dof, current.n_samples
                    ),
                    heldout_reduction=comp.heldout_reduction,
                    params=own,
                    fit=ext,
                    comparison=comp,
                )
            )
        decide(hyps, len(candidates), alpha, min_heldout_gain)
        ranked = rank(hyps)
        all_hyps += ranked
        amb += ambiguities(ranked)
        if not ranked or not ranked[0].significant:
            break
        named.append(ranked[0])
        remaining = [c for c in remaining if f"{c[0]}@{c[1]}" != ranked[0].kind]
        current = ranked[0].fit

    comparison = compare(base, current, recs, None, held, None) if named else None
    if named:
        verdict = "missing physics: " + "; then ".join(h.words for h in named)
        if amb:
            verdict += ". " + " ".join(a.sentence() for a in amb)
    else:
        best = min(all_hyps, key=lambda h: h.p_value_corrected, default=None)
        verdict = "no significant missing physics"
        if best is not None:
            verdict += (
                f" (strongest candidate, {best.words}: corrected p = "
                f"{best.p_value_corrected:.2g}, held-out error change "
                f"{-100 * best.heldout_reduction:+.1f} %)"
            )
    residual = residual_check(base, current, held, [h.fit.extra["effect"]["name"] for h in named])
    if named and not residual.confident:
        verdict = verdict.replace("missing physics:", "missing physics (not confident):", 1)
    verdict = verdict.rstrip(". ") + ". " + residual.sentence()
    baseline = baseline_summary(base, recs, held)
    baseline["effects"] = []
    channel = main_channel(base)
    return RideDiagnosis(
        recording=", ".join(r.name for r in recs),
        family=model.family,
        holdout=sp.description,
        channel=channel,
        baseline=baseline,
        location=location,
        signatures=first_sigs,
        hypotheses=all_hyps,
        named=named,
        ambiguities=amb,
        verdict=verdict,
        comparison=comparison,
        final_params=current.params(),
        seconds=time.perf_counter() - t0,
        base_fit=base,
        final_fit=current,
        split=sp,
        residual=residual,
    )
