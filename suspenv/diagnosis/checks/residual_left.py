"""The residual left by the final model, judged by one rule for every family.

A family supplies its noise model through ``family.residual_left(outcome, setup,
alpha)``: one or more :class:`Left` views of the final model's residual, each with

* ``rms``: the residual's RMS in the family's noise units (1: noise only);
* ``limit``: the size above which a residual counts, in the same units, derived by the
  family from how well its noise level is known;
* ``structured``: the family's test, at the rule's level ``alpha``, that the residual is
  not noise (a chi-square against a known noise level, a cycle-to-cycle test, a
  whiteness test, a count of samples Gaussian noise does not give);
* words for the test and for where the excess lives;

and its own record of the numbers (for the report). The rule is the same everywhere:
**a residual remains** when some view is above its limit *and* structured. The limit
is a size, not only a test: noise levels are themselves estimates, and a test alone
would read a noise level estimated a little low as missing physics.

For a family whose residual comes in noise units per (test, channel) with the noise
level known (the K&C family's, from the roughness of the residual along each loop),
:func:`from_cells` is its view: a chi-square test per channel (Bonferroni over the
channels) and :data:`RESIDUAL_LIMIT`.

The finding says the size, where it lives, the test, and which candidates the search
refitted without taking it up; it stands in for "no significant missing physics".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from suspenv.diagnosis.checks.finding import Context, Finding
from suspenv.diagnosis.fitting import lag1_autocorrelation

#: a channel whose residual RMS exceeds this many noise levels is a residual left, where
#: the noise level is read from the residual's roughness along a loop of about 50
#: samples (within about 20 %, so a limit close to 1 would read an estimate 20 % low as
#: physics; 3 noise levels is more than ten standard errors of such an estimate)
RESIDUAL_LIMIT = 3.0


@dataclass
class Left:
    """One view of the residual left, in the family's noise units (module docstring).

    Attributes:
        channel: the output channel (or the channels pooled, in words).
        rms: residual RMS over the noise RMS (1: noise only).
        limit: the family's size limit in the same units.
        structured: the family's test says the residual is not noise (at the rule's
            level).
        test: that test in words, with its value.
        where: where the excess lives, in words.
    """

    channel: str
    rms: float
    limit: float
    structured: bool
    test: str
    where: str = ""

    @property
    def remains(self) -> bool:
        """The rule: above the limit and structured."""
        return bool(self.rms > self.limit and self.structured)

    def to_dict(self) -> dict[str, Any]:
        return {**self.__dict__, "remains": self.remains}


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


def from_cells(
    cells: dict[tuple[str, str], np.ndarray], alpha: float
) -> tuple[list[Left], dict[str, Any]]:
    """The view of a residual in known noise units per (test, channel) (:func:`judge`)
    and its numbers."""
    n = judge(cells, alpha)
    ch = n["worst_channel"]
    shape = "structured (smooth along the test)" if n["lag1"] > 0.5 else "rough"
    left = Left(
        ch,
        n["rms_noise_units"][ch],
        RESIDUAL_LIMIT,
        n["p_corrected"][ch] < alpha,
        f"chi-square test against the noise p = {n['p_corrected'][ch]:.2g}",
        f"{100 * n['where_share']:.0f} % of the excess in the {n['where']['test']} test's "
        f"{n['where']['channel']}, {shape}, lag-1 correlation {n['lag1']:.2f}",
    )
    return [left], n


def _tried(ctx: Context) -> str:
    """What the candidates could not do, in words."""
    named = ctx.outcome.named
    tried = sorted({h.words for h in ctx.outcome.hypotheses if all(h is not w for w in named)})
    if not tried:
        return "no candidate was refitted against it"
    return f"the candidates refitted ({'; '.join(tried)}) could not take it up"


def run(ctx: Context) -> Finding | None:
    """The residual-left finding of the final model (None: the family has no noise
    model)."""
    ask = getattr(ctx.family, "residual_left", None)
    if ask is None:
        return None
    views, record = ask(ctx.outcome, ctx.setup, ctx.rule.alpha)
    if not views:
        return None
    worst = max(views, key=lambda v: v.rms / v.limit)
    left: Sequence[Left] = [v for v in views if v.remains]
    numbers = {
        "worst_rms": worst.rms,
        "worst_channel": worst.channel,
        "limit": worst.limit,
        "views": [v.to_dict() for v in views],
    }
    if not left:
        return Finding("residual_left", numbers=numbers, record=record)
    top = max(left, key=lambda v: v.rms / v.limit)
    numbers.update(worst_rms=top.rms, worst_channel=top.channel, limit=top.limit)
    sentence = (
        f"unexplained residual above noise, not in the library: in {top.channel} the "
        f"residual is {top.rms:.3g} times the noise (limit {top.limit:.3g}; {top.test})"
        + (f", largest {top.where}" if top.where else "")
        + f"; {_tried(ctx)}"
    )
    return Finding("residual_left", True, False, sentence, True, numbers, record)
