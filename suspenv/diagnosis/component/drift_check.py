"""Named elements judged again beside a zero drift of more shape than the baseline's.

The baseline's zero drift (``zero_drift``: a rate and the Legendre polynomials P2, P3 of
time over the record) follows a slow, smooth trend of a sensor's zero. A zero that
wanders more (a random walk smoothed over a few seconds, as a strain gauge's or a charge
amplifier's does) outruns it and leaves a slow residual. An element whose mean force
differs between the motion's blocks can take that up: a bump/rebound asymmetry (its mean
over a cycle is proportional to the cycle's speed), a hysteresis loop. Its refit then
passes the test on a recording that holds no such element.

After the search each named element is therefore judged again beside a drift of more
shape: the Legendre polynomials P4 ... P\\ :data:`DRIFT_ORDER` of time over each
recording added on every channel the model drifts, with and without the element. The
drift's terms enter the prediction linearly, so each model is fitted with them by
backfitting (:func:`fit_beside_drift`): the model fitted, the terms fitted to its
residual on the fit samples by least squares and taken off the recording, the model
fitted again, :data:`BACKFIT_ROUNDS` times. The elements are judged in the order the
search named them, each in the model it was named in (the baseline with the elements
named before it, less any withdrawn), with and without it, both beside the drift of more
shape: their likelihood ratio, corrected for serial correlation as every refit's, at
the decision rule's ``alpha``, and the corrected BIC (one test per element: the benefit
of the doubt goes to the element named). An element is withdrawn when it passes that
test beside the baseline's drift while beside the drift of more shape its likelihood
ratio is no longer significant: the drift, not a held-out gain or the test's context,
is what takes its support (a BIC that rises while the ratio stays significant does not
withdraw an element already named). The final model is then refitted without it (with
the baseline's drift). The held-out samples are not read here: the drift's terms are
fitted on the fit samples of each model apart.

A real element keeps a shape within each motion cycle that no slow drift has (an
asymmetry's half-wave with its even harmonics; a friction step at each reversal; a loop's
width), so it stays. ``DRIFT_ORDER = 8`` gives features of about a sixth of the record
(2-3 s on the dyno's 15-20 s records): slower than a motion cycle (0.3-1.2 s) by a
factor of two or more.

Units: time [s]; residuals and drift in each channel's unit.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from suspenv.diagnosis.component.rig import DRIFT
from suspenv.diagnosis.component.withdrawal import element_name, reduced, without_element
from suspenv.diagnosis.decision import DecisionRule
from suspenv.diagnosis.evidence import fit_residual_series, likelihood_ratio
from suspenv.diagnosis.fitting import DRIFT_ORDER, FitResult, drift_basis, fit, residuals
from suspenv.diagnosis.hypothesis import Hypothesis, Withdrawal, corrected_delta_bic
from suspenv.diagnosis.split import Split

#: rounds of backfitting (model, then the drift's terms on its residual)
BACKFIT_ROUNDS = 3


def drifting_channels(model: Any) -> list[str]:
    """The channels the model's baseline gives a zero drift (its elements' locations)."""
    return [str(e.location) for e in model.effects if e.kind == DRIFT]


def fit_beside_drift(
    model: Any,
    theta0: dict[str, float],
    sp: Split,
    scales: dict[str, float],
    channels: Sequence[str],
    budget: int,
    rounds: int = BACKFIT_ROUNDS,
) -> FitResult:
    """``model`` fitted on the fit samples beside the drift's extra terms on
    ``channels`` (module docstring): the fit of the last of ``rounds`` backfitting rounds
    (1: the plain fit beside the baseline's drift), on the recordings with the drift it
    found taken off (``extra["drift_corrected"]``)."""
    masks = sp.fit_masks
    # the component rigs' recordings (:class:`~suspenv.measurements.Recording`)
    corrected: list[Any] = list(sp.fit_recordings)
    bases = [drift_basis(np.asarray(rec.time, float)) for rec in corrected]
    res = fit(model, corrected, masks, theta0=theta0, scales=scales, max_nfev=budget)
    for _ in range(rounds - 1):
        parts = residuals(res.model, res.theta, corrected, res.channels)
        new: list[Any] = []
        selections = sp.fit_selections()
        for rec, part, basis, m in zip(corrected, parts, bases, selections, strict=True):
            outputs = {}
            for c in channels:
                if c not in part:
                    continue
                r = np.asarray(part[c], float)
                ok = m & np.isfinite(r)
                coef, *_ = np.linalg.lstsq(basis[ok], r[ok], rcond=None)
                outputs[c] = np.asarray(rec.outputs[c], float) - basis @ coef
            new.append(rec.with_outputs({**rec.outputs, **outputs}) if outputs else rec)
        corrected, start = new, dict(zip(res.names, res.theta, strict=True))
        res = fit(model, corrected, masks, theta0=start, scales=scales, max_nfev=budget)
    res.extra["drift_corrected"] = corrected
    return res


def judge_beside_drift(
    final: FitResult, named: Sequence[Hypothesis], sp: Split, budget: int, rule: DecisionRule
) -> tuple[FitResult, list[Withdrawal]]:
    """The elements ``named`` (each in ``final``'s model) judged again beside a zero
    drift of more shape (module docstring). Returns (the final model, refitted without
    the withdrawn elements; the withdrawals in order); without a drifting channel,
    (``final``, [])."""
    channels = drifting_channels(final.model)
    present = {e.name for e in final.model.effects}
    order = sorted((h for h in named if element_name(h) in present), key=lambda h: h.round)
    if not channels or not order:
        return final, []
    beside = (
        f"a zero drift of more shape (Legendre terms to order {DRIFT_ORDER} over the "
        f"record on {', '.join(channels)})"
    )
    named_names = {str(element_name(h)) for h in order}

    fits: dict[tuple[tuple[str, ...], bool], FitResult] = {}

    def with_elements(kept: Sequence[str], drift: bool) -> FitResult:
        """The baseline with the named elements ``kept`` only (started from the final
        fit's values), beside the drift of more shape or (``drift=False``) the
        baseline's; each fitted once, when first asked for."""
        key = (tuple(kept), drift)
        if key not in fits:
            model, theta0 = reduced(final, named_names - set(kept))
            rounds = BACKFIT_ROUNDS if drift else 1  # one round: the plain fit
            fits[key] = fit_beside_drift(model, theta0, sp, final.scales, channels, budget, rounds)
        return fits[key]

    def test(kept: Sequence[str], name: str, drift: bool) -> tuple[float, float]:
        """(corrected p-value, corrected BIC change) of the element ``name`` added to
        the baseline with ``kept`` (the likelihood ratio of every refit)."""
        with_it, without = with_elements([*kept, name], drift), with_elements(kept, drift)
        recordings = with_it.extra["drift_corrected"]
        lr = likelihood_ratio(
            without, with_it, fit_residual_series(with_it, recordings, sp.fit_masks)
        )
        bic = corrected_delta_bic(lr.statistic_corrected, lr.dof, with_it.n_samples)
        return lr.p_value_corrected, bic

    context: list[str] = []
    withdrawals: list[Withdrawal] = []
    for h in order:
        name = str(element_name(h))
        p_c, bic_c = test(context, name, drift=True)
        if p_c >= rule.alpha:
            # the drift must be what takes its support (module docstring): an element
            # that fails the test beside the baseline's drift too (named by the held-out
            # data, or by a model that held other elements) is not this check's to withdraw
            p_plain, bic_plain = test(context, name, drift=False)
            if p_plain < rule.alpha and bic_plain < 0.0:
                withdrawals.append(Withdrawal(h, beside, p_c, bic_c))
                continue
        context.append(name)
    for w in withdrawals:
        final = without_element(final, str(element_name(w.hypothesis)), sp, budget)
    return final, withdrawals
