"""Named elements that rest on a residual an unrecorded input drives, withdrawn.

When the missing-input finding (:mod:`.missing_input`) calls the residual driven by an
input the recording does not carry, an element named before may only have taken up
that switching on average (a switched damping fitted as a viscoelastic element). Where
the input stays at one level, nothing switches: an element the data carry keeps its
strength there, one that only absorbed the switching has nothing left to fit.

So the blocks of the finding (its block length) in the fit samples of every recording
are sorted by the level the input sets, read off the final model's residual ``r``: its
gains ``<r, s> / <s, s>`` on a recorded input or the prediction ``s`` split into two
clusters at the cut that leaves the least weighted variance within them
(:func:`two_means`, exact in one dimension; each gain weighted by its precision
``<s, s>``), on the signal where that split explains most of the gains' variance. The
**base level** is the cluster where ``r``'s gain on the model's own prediction is
lower: the input adds least force there, whatever the sign convention; a block beside
one of the other level holds a switch and is left out (:func:`block_levels`).

Each named element is then judged again on the fit samples of the base blocks alone:
the final model with and without the element, both refitted there (same channel
scales, started from the final values); the element's likelihood-ratio test
(serial-correlation corrected, :func:`~suspenv.diagnosis.evidence.likelihood_ratio`)
must stay below the rule's ``alpha``. An element that does not is **withdrawn**, with
the numbers, and the final model refitted without it; the finding already says that an
unrecorded input may drive the residual. With fewer base blocks than
:data:`~.missing_input.MIN_BLOCKS` (the fewest the switching test judges on) nothing
is judged. A wrong level split errs towards keeping a name: blocks where the input is
on leave the switching for a spurious element to fit. The rule reads no element names.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from suspenv.diagnosis.checks.finding import Context
from suspenv.diagnosis.checks.missing_input import MIN_BLOCKS
from suspenv.diagnosis.component.withdrawal import element_name, without_element
from suspenv.diagnosis.evidence import fit_residual_series, likelihood_ratio
from suspenv.diagnosis.family import Conclusion
from suspenv.diagnosis.fitting import FitResult, fit
from suspenv.diagnosis.hypothesis import Hypothesis, Withdrawal, corrected_delta_bic
from suspenv.diagnosis.split import Split

#: evaluation budget of each refit where the family states none (``family.budget``)
MAX_NFEV = 200


def two_means(g: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, float]:
    """The split of ``g`` (weights ``w``) into two clusters at the cut between sorted
    values that leaves the least weighted sum of squares within them, i.e. of largest
    between-cluster sum ``W1 W2 / W (m1 - m2)^2`` (weighted sizes ``W1``, ``W2``, means
    ``m1``, ``m2``): (True for the upper cluster, the share of the weighted sum of
    squares about the mean that the split explains)."""
    order = np.argsort(g)
    s, ws = g[order], np.asarray(w, float)[order]
    cw, cs = np.cumsum(ws)[:-1], np.cumsum(ws * s)[:-1]
    total, tsum = float(np.sum(ws)), float(np.sum(ws * s))
    w2 = np.maximum(total - cw, 1e-300)
    between = cw * w2 / total * (cs / np.maximum(cw, 1e-300) - (tsum - cs) / w2) ** 2
    k = int(np.argmax(between))
    spread = float(np.sum(ws * (s - tsum / total) ** 2))
    return g > s[k], float(between[k]) / max(spread, 1e-300)


def block_gains(r: np.ndarray, s: np.ndarray, length: int) -> tuple[np.ndarray, np.ndarray]:
    """The least-squares gains ``<r, s> / <s, s>`` of ``r`` on ``s`` in whole blocks of
    ``length`` and their precisions under white noise, ``<s, s>`` (a block where ``s``
    hardly moves tells little)."""
    blocks = r.size // length
    rb, sb = (a[: blocks * length].reshape(blocks, length) for a in (r, s))
    w = np.sum(sb * sb, axis=1)
    return np.sum(rb * sb, axis=1) / np.maximum(w, 1e-300), w


def block_levels(
    r: np.ndarray, pred: np.ndarray, signals: Sequence[np.ndarray], length: int
) -> np.ndarray:
    """Per block of ``length``, True at the base level (module docstring): the residual
    ``r``'s gains (:func:`block_gains`) split into two levels (:func:`two_means`) on the
    signal of ``signals`` where the split explains most; the base the level where
    ``r``'s mean gain on the model's prediction ``pred`` is lower (the output falls
    short of the model along its own force: the input adds least there, whatever the
    sign convention), less the blocks beside one of the other level (a block beside a
    switch holds both levels). Samples set to zero weigh nothing."""
    upper = max((two_means(*block_gains(r, s, length)) for s in signals), key=lambda u: u[1])[0]
    along, w = block_gains(r, pred, length)
    w = w + 1e-300
    lower = np.average(along[upper], weights=w[upper]) < np.average(
        along[~upper], weights=w[~upper]
    )
    base = upper if lower else ~upper
    beside = np.r_[True, base, True]
    return base & beside[:-2] & beside[2:]


def base_split(ctx: Context, final: FitResult, channel: str, length: int) -> tuple[Split, int]:
    """The split of the run with its fit samples restricted to the base blocks
    (:func:`block_levels`, from the fit samples) of every fitted recording, and how
    many base blocks there are."""
    sp = ctx.setup.split
    masks, blocks = [], 0
    for rec, use in zip(sp.fit_recordings, sp.fit_selections(), strict=True):
        pred = np.asarray(final.model.simulate(final.theta, rec)[channel], float)
        signals = [np.asarray(x, float) * use for x in [*rec.inputs.values(), pred]]
        r = (np.asarray(rec.outputs[channel], float) - pred) * use
        levels = block_levels(r, pred * use, [x for x in signals if np.ptp(x) > 0], length)
        masks.append(use & np.r_[np.repeat(levels, length), np.zeros(r.size % length, bool)])
        blocks += int(levels.sum())
    return replace(sp, fit_masks=masks, description=f"{sp.description}, base blocks"), blocks


def judged_on_base(final: FitResult, h: Hypothesis, sp: Split, budget: int) -> tuple[float, float]:
    """(corrected p-value, corrected BIC change) of ``h``'s element beside the other
    elements of ``final``, both refitted on the fit samples of ``sp``."""
    name = str(element_name(h))
    with_it = fit(
        final.model,
        sp.fit_recordings,
        sp.fit_masks,
        theta0=final.theta,
        scales=final.scales,
        max_nfev=budget,
    )
    without = without_element(final, name, sp, budget)
    lr = likelihood_ratio(
        without, with_it, fit_residual_series(with_it, sp.fit_recordings, sp.fit_masks)
    )
    bic = corrected_delta_bic(lr.statistic_corrected, lr.dof, with_it.n_samples)
    return lr.p_value_corrected, bic


def run(ctx: Context) -> Conclusion | None:
    """The named elements withdrawn beside the missing-input finding (None without the
    finding or such an element)."""
    f = ctx.found.findings.get("missing_input")
    if f is None or not f.remains or f.numbers.get("cause") != "unrecorded":
        return None
    final = ctx.outcome.current
    present = {e.name for e in final.model.effects}
    named = [h for h in ctx.outcome.named if element_name(h) in present]
    if not named or "channel" not in f.numbers:
        return None
    n = f.numbers
    length = int(n["judged_blocks"])
    sp, blocks = base_split(ctx, final, str(n["channel"]), length)
    if blocks < MIN_BLOCKS:  # too few to judge on: the names stay
        return None
    share = (
        np.concatenate(sp.fit_selections()).sum()
        / np.concatenate(ctx.setup.split.fit_selections()).sum()
    )
    beside = (
        f"the other elements, on the blocks of {length} samples where the unrecorded input "
        f"is at its base level ({100 * share:.0f} % of the fit samples)"
    )
    budget = int(getattr(ctx.family, "budget", MAX_NFEV))
    gone = []
    for h in named:
        p, bic = judged_on_base(final, h, sp, budget)
        if p >= ctx.rule.alpha:
            gone.append(Withdrawal(h, beside, p, bic))
    if not gone:
        return None
    for w in gone:
        final = without_element(final, str(element_name(w.hypothesis)), ctx.setup.split, budget)
    return Conclusion(
        withdrawn=gone,
        final_fit=final,
        sentences=[w.sentence() for w in gone],
        confident=False,
    )
