"""The residual left by the final model, in the family's noise units.

The family gives the final model's residual divided by its noise level, one array per
(test, channel) (``family.noise_units(fit, setup)``; None: the family judges its residual
itself). A white residual at the noise has an RMS of 1 in these units. The residual
**remains** (physics outside what was named is left) when some channel's RMS exceeds
:data:`RESIDUAL_LIMIT` and its chi-square test against the noise rejects at the rule's
level, Bonferroni-corrected over the channels. The limit is a size, not only a test:
the noise levels are themselves estimates (the K&C family's from the roughness of the
residual, within about 20 % on a loop of 50 samples), and a test alone would read a
noise level estimated 20 % low as missing physics.

The finding says the size (RMS in noise units, largest channel), where it lives (the
test and channel holding the largest share of the excess energy) and its structure
(the lag-1 autocorrelation of that cell: near 0 for noise, near 1 for a smooth missing
force), and which candidates the search refitted without taking it up.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import stats

from suspenv.diagnosis.checks.finding import Context, Finding
from suspenv.diagnosis.fitting import lag1_autocorrelation

#: a channel whose residual RMS exceeds this many noise levels is a residual left
RESIDUAL_LIMIT = 3.0


def judge(cells: dict[tuple[str, str], np.ndarray], alpha: float) -> dict[str, Any]:
    """The numbers of the rule on ``cells`` ((test, channel) -> residual in noise units):
    per channel RMS and corrected p-value, the worst channel, where the excess lives."""
    by_channel: dict[str, list[np.ndarray]] = {}
    for (_, ch), r in cells.items():
        by_channel.setdefault(ch, []).append(np.asarray(r, float))
    rms, p = {}, {}
    for ch, parts in by_channel.items():
        r = np.concatenate(parts)
        rms[ch] = float(np.sqrt(np.mean(r**2)))
        # sum of squares of n unit-variance samples: chi-square with n degrees of freedom
        p[ch] = min(1.0, len(by_channel) * float(stats.chi2.sf(np.sum(r**2), r.size)))
    worst = max(rms, key=lambda c: rms[c])
    excess = {k: float(np.sum(np.asarray(r) ** 2) - r.size) for k, r in cells.items()}
    where = max(excess, key=lambda k: excess[k])
    total = sum(max(v, 0.0) for v in excess.values()) or 1.0
    return {
        "rms_noise_units": rms,
        "p_corrected": p,
        "worst_channel": worst,
        "worst_rms": rms[worst],
        "where": {"test": where[0], "channel": where[1]},
        "where_share": max(excess[where], 0.0) / total,
        "lag1": lag1_autocorrelation(cells[where]),
        "remains": bool(rms[worst] > RESIDUAL_LIMIT and p[worst] < alpha),
    }


def run(ctx: Context) -> Finding | None:
    """The residual-left finding of the final model (None: the family judges its own)."""
    ask = getattr(ctx.family, "noise_units", None)
    cells = ask(ctx.outcome.current, ctx.setup) if ask is not None else None
    if not cells:
        return None
    n = judge(cells, ctx.rule.alpha)
    if not n["remains"]:
        return Finding("residual_left", numbers=n)
    named = ctx.outcome.named
    tried = sorted({h.words for h in ctx.outcome.hypotheses if all(h is not w for w in named)})
    what = (
        f"the candidates refitted ({'; '.join(tried)}) could not take it up"
        if tried
        else "no candidate was refitted against it"
    )
    shape = "structured (smooth along the test), not noise" if n["lag1"] > 0.5 else "rough"
    sentence = (
        f"a residual of {n['worst_rms']:.3g} times the noise is left in {n['worst_channel']} "
        f"(limit {RESIDUAL_LIMIT:g}); {100 * n['where_share']:.0f} % of the excess lies in "
        f"the {n['where']['test']} test's {n['where']['channel']}, {shape} (lag-1 "
        f"correlation {n['lag1']:.2f}); {what}: physics outside the library remains"
    )
    return Finding("residual_left", True, False, sentence, True, n)
