"""Named elements whose evidence rests on a residual an unrecorded input drives.

When the missing-input finding (:mod:`.missing_input`) calls the residual driven by an
input the recording does not carry, an element named before may have taken up part of
that switching residual on average (a switched damping fitted as a viscoelastic
element). For each named element, its improvement ``d`` (the refit's prediction less
its parent's: the model it extends) is set against the parent's residual ``r`` block by
block (the finding's block length): the gain ``<r, d> / |d|`` of a time-invariant
element keeps no memory from block to block beyond the noise; one that **switches**
(the lag-1 autocorrelation of those gains above what independent gains give: exact
one-sided p-value, :func:`~.missing_input.lag1_p`, Bonferroni over the recordings and
channels, below the rule's ``alpha``) fits a residual whose level an unrecorded input
sets. Such an element may not be named with confidence: the verdict says, per element,
"an unrecorded input may drive what it fits", with the test's numbers. Whether the
element is there beside the switching cannot be told from these recordings (a lag or a
stop the switched force projects on switches too), so it is not withdrawn. Nor does a
refit on the blocks where the input sits at its base level tell it: with the true
off-blocks it withdraws a spurious element (corrected p = 0.79), but the levels read
off the residual (two-means of the block gains) leave a few switched blocks in the
base, enough to keep a spurious element significant (p = 2e-17), while a true stop
the base blocks hardly reach loses its significance there.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from suspenv.diagnosis.checks.finding import Context
from suspenv.diagnosis.checks.missing_input import block_gains, lag1_p
from suspenv.diagnosis.family import Conclusion
from suspenv.diagnosis.fitting import FitResult, residuals


def gain_lag1(r: np.ndarray, d: np.ndarray, length: int) -> tuple[float, float]:
    """(p, rho): the lag-1 autocorrelation ``rho`` of the gains ``<r, d> / |d|`` of
    ``r`` on ``d`` in blocks of ``length`` (:func:`~.missing_input.block_gains`) and its
    exact one-sided p-value for independent gains (:func:`~.missing_input.lag1_p`)."""
    g = block_gains(r, d, length)
    if g.size < 3 or not np.ptp(g) > 0:
        return 1.0, 0.0
    rho, p = lag1_p(g, np.ones((g.size, 1)))
    return p, rho


def gain_switching(
    ctx: Context, parent: FitResult, refit: FitResult, length: int
) -> dict[str, float]:
    """The switching test of the element's improvement (``refit`` less ``parent``) on
    the parent's residual (:func:`gain_lag1`) over the recordings and channels: the
    smallest p-value, Bonferroni-corrected, and its lag-1 correlation."""
    tried = []
    for rec in ctx.setup.split.recordings():
        (res,) = residuals(parent.model, parent.theta, [rec], refit.channels)
        new, old = refit.model.simulate(refit.theta, rec), parent.model.simulate(parent.theta, rec)
        tried += [gain_lag1(res[ch], new[ch] - old[ch], length) for ch in refit.channels]
    p, rho = min(tried, default=(1.0, 0.0))
    return {"p_switching": min(1.0, p * max(len(tried), 1)), "gain_lag1": rho}


def run(ctx: Context) -> Conclusion | None:
    """The named elements whose gain switches beside the missing-input finding, not
    confident (None without the finding or such an element)."""
    f = ctx.found.findings.get("missing_input")
    if f is None or not f.remains or f.numbers.get("cause") != "unrecorded":
        return None
    length = int(f.numbers["judged_blocks"])
    named = list(ctx.outcome.named)
    parents = [ctx.outcome.base, *(h.fit for h in named)][: len(named)]
    out: list[dict[str, Any]] = []
    sentences = []
    for h, parent in zip(named, parents, strict=True):
        if h.fit is None or parent is None:
            continue
        n = gain_switching(ctx, parent, h.fit, length)
        if n["p_switching"] >= ctx.rule.alpha:
            continue
        out.append({"candidate": h.candidate, **n})
        sentences.append(
            f"{h.words} is not named with confidence: an unrecorded input may drive what it "
            f"fits (its gain on the residual switches and persists over blocks of {length} "
            f"samples: lag-1 correlation {n['gain_lag1']:.2f}, p = {n['p_switching']:.2g})"
        )
    if not out:
        return None
    return Conclusion(sentences=sentences, confident=False, findings={"switched_elements": out})
