"""The ride family: what the minibus ride model leaves out of ride recordings.

Its pieces of the one loop (:mod:`suspenv.diagnosis.engine`), where a component's
single stroke ``x`` does not exist:

* **locate** (:func:`locate_ride`): residual energy shares by channel, by test
  speed (also against each speed's share of the response energy: amplitude
  dependence, 20 vs 50 km/h), by time window relative to the
  impacts (before, after the front wheels hit, after the rear wheels hit, free
  decay) and by frequency band (body modes, mid, wheel hop, high);
* **screen** (:func:`screen_candidates`): each candidate element (kind + location) is
  added at a physical starting size; the change it makes to the prediction, projected
  off the baseline Jacobian (what a refit of the base parameters could absorb), is
  regressed on the residual. The share of residual energy it explains is its score (a
  Lagrange-multiplier statistic, like the generic signatures, but with the model's own
  response as the feature). The best ``screen`` candidates are refitted.

What is left: the ride family's noise model (:meth:`RideFamily.residual_left`) judged by
the shared rule (:mod:`suspenv.diagnosis.checks.residual_left`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.diagnosis.checks.finding import Check
from suspenv.diagnosis.checks.residual_left import Left
from suspenv.diagnosis.decision import DecisionRule
from suspenv.diagnosis.evidence import fit_residual_series
from suspenv.diagnosis.family import (
    Conclusion,
    OptionalSteps,
    Outcome,
    Screening,
    Setup,
    SignatureLike,
)
from suspenv.diagnosis.fitting import FitResult, fit, residuals
from suspenv.diagnosis.hypothesis import split_candidate
from suspenv.diagnosis.ride.model import MinibusRideAdapter, effect_words, ride_effect
from suspenv.diagnosis.ride.residual import ResidualCheck, residual_check
from suspenv.diagnosis.screening import (
    Location,
    Share,
    Signature,
    orthonormal_basis,
    partial_r2,
    score_p_value,
)
from suspenv.diagnosis.split import Holdout, Recordings, Split, as_recordings, heldout_recordings

#: the reported ride benchmark's decision rule
RIDE_RULE = DecisionRule(alpha=0.01, heldout_rule="fraction", min_heldout_gain=0.01)

#: frequency bands of the residual (Hz): body modes, mid, wheel hop, high
BANDS = (
    ("body 0.5-3 Hz", 0.5, 3.0),
    ("mid 3-8 Hz", 3.0, 8.0),
    ("wheel hop 8-16 Hz", 8.0, 16.0),
    ("high > 16 Hz", 16.0, np.inf),
)


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


def _add(sums: dict[Any, list[float]], key: Any, a: float, b: float) -> None:
    """Add ``a`` and ``b`` to the running sums of ``key``."""
    pair = sums.setdefault(key, [0.0, 0.0])
    pair[0] += a
    pair[1] += b


def locate_ride(fit: FitResult, recordings: Sequence[Any]) -> Location:
    """Shares of the scaled residual energy by channel, test, time window, band."""
    parts = residuals(fit.model, fit.theta, recordings, fit.channels)
    loc = Location()
    # per key: (residual energy, samples); per speed: (residual, response energy); per
    # band: (residual energy, fraction of the lines)
    acc: dict[tuple[str, str], list[float]] = {}
    acc_signal: dict[str, list[float]] = {}
    bands: dict[str, list[float]] = {}
    total, n_total = 0.0, 0
    for rec, part in zip(recordings, parts, strict=True):
        n = rec.n_samples
        n_total += n * len(fit.channels)
        speed = f"{rec.test} {rec.meta.get('speed_kmh', 0):.0f} km/h"
        f = np.fft.rfftfreq(n, rec.sample_interval)
        for c in fit.channels:
            r = part[c] / fit.scales[c]
            e = float(np.sum(r**2))
            total += e
            _add(acc, ("channel", c), e, n)
            _add(acc, ("test", speed), e, n)
            # amplitude dependence: residual share against the share of response energy
            y = np.asarray(rec.outputs[c], float) / fit.scales[c]
            _add(acc_signal, speed, e, float(np.sum(y**2)))
            for w, m in _windows(rec).items():
                _add(acc, ("time window", w), float(np.sum(r[m] ** 2)), int(m.sum()))
            p = np.abs(np.fft.rfft(r)) ** 2
            for name, lo, hi in BANDS:
                sel = (f >= lo) & (f < hi)
                _add(bands, name, float(p[sel].sum()), float(sel.sum()) / f.size)
    for (dim, part_name), (e, n) in acc.items():
        loc.shares.append(Share(dim, part_name, e / total if total else 0.0, n / n_total))
    sig_total = sum(v[1] for v in acc_signal.values()) or 1.0
    if len(acc_signal) > 1:
        for speed, (e, y2) in acc_signal.items():
            loc.shares.append(
                Share("test vs response energy", speed, e / total if total else 0.0, y2 / sig_total)
            )
    spec_total = sum(v[0] for v in bands.values()) or 1.0
    n_sets = len(recordings) * len(fit.channels)
    for name, (e, lines) in bands.items():
        loc.shares.append(Share("frequency band", name, e / spec_total, lines / n_sets))
    return loc


def screen_candidates(
    fit: FitResult, recordings: Sequence[Any], candidates: Sequence[str]
) -> list[Signature]:
    """Score each candidate ``kind@location`` (the screen of the module docstring), best
    first."""
    r = fit_residual_series(fit, recordings)
    J = fit.extra.get("jacobian")
    basis = orthonormal_basis(J) if J is not None and J.shape[0] == r.size else None
    base_pred = _stacked_prediction(fit.model, fit.theta, recordings, fit)
    out = []
    for cand in candidates:
        kind, loc = split_candidate(cand)
        eff = ride_effect(kind, loc)
        model = fit.model.with_effects((*fit.model.effects, eff))
        guess = model.initial_guess(recordings[0])
        th = np.concatenate([fit.theta, guess[fit.theta.size :]])
        try:
            pred = _stacked_prediction(model, th, recordings, fit)
        except EvaluationError:
            pred = base_pred
        r2, _, fitted = partial_r2(r, (pred - base_pred)[:, None], basis)
        p = score_p_value(r2, r - fitted)
        words = (
            f"{effect_words(eff)} at its starting size explains {100 * r2:.1f} % of the "
            "residual energy beyond the baseline parameters"
        )
        out.append(Signature(f"{kind}@{loc}", r2, p, words, {"partial_r2": r2}))
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


@dataclass
class RideFamily(OptionalSteps):
    """The ride family's steps of the diagnosis loop (see the module docstring).

    Args:
        model: the base model (default: :class:`MinibusRideAdapter` without effects).
        screen_count: refit this many best-screened candidates per round.
        max_effects: most elements added in turn.
        max_nfev: budget of each fit.
        rule: the decision rule (default :data:`RIDE_RULE`).
    """

    model: MinibusRideAdapter | None = None
    screen_count: int = 3
    max_effects: int = 1
    max_nfev: int = 30
    rule: DecisionRule = RIDE_RULE
    name: str = field(default="ride", init=False)

    def prepare(
        self, recordings: Recordings, holdout: Holdout, candidates: Sequence[str] | None
    ) -> Setup:
        """``holdout``: the recordings not used for fitting (repeat runs, a random-road run)."""
        recs = as_recordings(recordings)
        if holdout is None:
            fit_recs = [r for r in recs if r.name.endswith("run1")] or recs[:1]
            held = [r for r in recs if r not in fit_recs]
        else:
            fit_recs, held = recs, heldout_recordings(holdout)
        if not held:
            raise ValidationError(
                "a ride diagnosis needs held-out recordings (repeat runs or another test), "
                f"but got only {[r.name for r in fit_recs]}"
            )
        model = self.model or MinibusRideAdapter()
        cands = list(candidates if candidates is not None else model.candidate_effects)
        return Setup(Split.separate(fit_recs, held), model, cands)

    def fit_baseline(self, setup: Setup) -> FitResult:
        return fit(setup.model, setup.split.fit_recordings, max_nfev=self.max_nfev)

    def locate(self, base: FitResult, setup: Setup) -> tuple[Location, str]:
        return locate_ride(base, setup.split.fit_recordings), base.main_channel()

    def screen(
        self, current: FitResult, setup: Setup, open_candidates: Sequence[str], round_: int
    ) -> Screening:
        sigs = screen_candidates(current, setup.split.fit_recordings, open_candidates)
        return Screening(sigs, [(s.kind, s) for s in sigs[: self.screen_count]])

    def refit(
        self, current: FitResult, candidate: str, signature: SignatureLike | None, setup: Setup
    ) -> FitResult:
        """``current`` with one more element, refitted from its fitted values."""
        kind, loc = split_candidate(candidate)
        eff = ride_effect(kind, loc)
        model = current.model.with_effects((*current.model.effects, eff))
        theta0 = dict(zip(current.names, current.theta, strict=True))
        out = fit(model, setup.split.fit_recordings, theta0=theta0, max_nfev=self.max_nfev)
        out.extra["effect"] = eff.to_dict()
        return out

    def words(self, candidate: str, setup: Setup) -> str:
        return effect_words(ride_effect(*split_candidate(candidate)))

    def residual_left(
        self, outcome: Outcome, setup: Setup, alpha: float
    ) -> tuple[list[Left], ResidualCheck]:
        """The held-out residual against the sensor-noise floor and its whiteness at the
        rule's level (:func:`~suspenv.diagnosis.ride.residual.residual_check`)."""
        left = residual_check(
            outcome.base,
            outcome.current,
            setup.split.heldout_recordings,
            [h.words for h in outcome.named],
            alpha=alpha,
        )
        return [left.view()], left

    def checks(self) -> list[Check]:
        """The report's baseline holds no element (the ride model has none)."""
        return [lambda ctx: Conclusion(baseline={"effects": []})]
