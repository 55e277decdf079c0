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

**The size limit** (:func:`size_limit`) follows from how well the noise level is known.
Under noise only the RMS in noise units is ``rms / sigma_hat``: the RMS of ``n``
unit-variance samples has relative variance ``1 / (2 n)``, the noise estimate
``sigma_hat`` its own relative variance ``v`` (the family's, from the number of samples
or spectral lines it is read from), so the ratio's standard error is
``se = sqrt(v + 1 / (2 n))`` and the ratio exceeds ``1 + z(alpha / m) se`` with
probability at most ``alpha / m`` (normal approximation, ``z`` the upper quantile);
with ``m`` channels tested (Bonferroni) the false-alarm rate of the size limit under
noise only is at most ``alpha``.

A family whose residual comes in noise units per (test, channel), the noise level read
from the roughness of the residual itself (the K&C family's), takes its view from
:func:`from_cells`.

The finding says the size, where it lives, the test, and which candidates the search
refitted without taking it up; it stands in for "no significant missing physics".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
from scipy import stats

from suspenv.diagnosis.checks.finding import Context, Finding
from suspenv.diagnosis.fitting import lag1_autocorrelation
from suspenv.diagnosis.record import Record


def size_limit(noise_variance: float, n: int, alpha: float, tests: int = 1) -> float:
    """The RMS in noise units above which a residual counts (module docstring):
    ``1 + z(alpha / tests) sqrt(noise_variance + 1 / (2 n))``.

    Args:
        noise_variance: relative variance of the noise level's estimate (dimensionless).
        n: samples behind the RMS.
        alpha: the rule's level; tests: the views tested (Bonferroni).
    """
    se = np.sqrt(noise_variance + 0.5 / n)
    return float(1.0 + stats.norm.isf(alpha / tests) * se)


@cache
def roughness_factor() -> float:
    """``n`` times the relative variance of the noise level read from ``n`` second
    differences ``d_i = r_i - (r_(i-1) + r_(i+1)) / 2`` of white Gaussian noise by their
    median absolute value (:func:`~suspenv.diagnosis.knc.locate.residual_map`).

    The sample median ``q`` of ``|d|`` has asymptotic variance ``sum_k g_k / (n f^2)``,
    ``f`` the density of ``|d|`` at its median and ``g_k`` the covariance of the
    indicators ``|d_i| <= q`` at lag ``k`` (the differences are correlated -2/3 at lag 1
    and 1/6 at lag 2, independent beyond). In units of the standard deviation of ``d``:
    ``q = z(1/4)``, ``f = 2 phi(q)``; the relative variance is that over ``q^2``
    (1.36 / n for independent samples, the median absolute deviation's)."""
    q = float(stats.norm.isf(0.25))
    g = 0.25  # lag 0: the indicator's variance p (1 - p), p = 1/2
    for rho in (-2.0 / 3.0, 1.0 / 6.0):
        mvn = stats.multivariate_normal(cov=[[1.0, rho], [rho, 1.0]])
        both = mvn.cdf([q, q]) - 2 * mvn.cdf([q, -q]) + mvn.cdf([-q, -q])
        g += 2 * (both - 0.25)
    return float(g / (2 * stats.norm.pdf(q) * q) ** 2)


@dataclass
class Left(Record):
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
    derived = ("remains",)

    @property
    def remains(self) -> bool:
        """The rule: above the limit and structured."""
        return bool(self.rms > self.limit and self.structured)


def from_cells(
    cells: dict[tuple[str, str], np.ndarray], alpha: float
) -> tuple[list[Left], dict[str, Any]]:
    """The view of a residual in noise units per (test, channel) (``cells``, the noise
    level read from the roughness of the same residual) and its numbers: per channel RMS,
    size limit (:func:`size_limit`, ``v`` from :func:`roughness_factor`) and chi-square
    p-value (Bonferroni over the channels), the worst channel, where the excess lives."""
    by_channel: dict[str, list[np.ndarray]] = {}
    for (_, ch), r in cells.items():
        by_channel.setdefault(ch, []).append(np.asarray(r, float))
    rms, p, limit = {}, {}, {}
    for ch, parts in by_channel.items():
        r = np.concatenate(parts)
        rms[ch] = float(np.sqrt(np.mean(r**2)))
        # the noise level is read from the second differences within each part
        rough = roughness_factor() / max(sum(x.size - 2 for x in parts), 1)
        limit[ch] = size_limit(rough, r.size, alpha, len(by_channel))
        # sum of squares of n unit-variance samples: chi-square with n degrees of freedom
        p[ch] = min(1.0, len(by_channel) * float(stats.chi2.sf(np.sum(r**2), r.size)))
    worst = max(rms, key=lambda c: rms[c] / limit[c])
    excess = {k: float(np.sum(np.asarray(r) ** 2) - r.size) for k, r in cells.items()}
    where = max(excess, key=lambda k: excess[k])
    share = max(excess[where], 0.0) / (sum(max(v, 0.0) for v in excess.values()) or 1.0)
    lag1 = lag1_autocorrelation(cells[where])
    shape = "structured (smooth along the test)" if lag1 > 0.5 else "rough"
    left = Left(
        worst,
        rms[worst],
        limit[worst],
        p[worst] < alpha,
        f"chi-square test against the noise p = {p[worst]:.2g}",
        f"{100 * share:.0f} % of the excess in the {where[0]} test's {where[1]}, {shape}, "
        f"lag-1 correlation {lag1:.2f}",
    )
    return [left], {
        "rms_noise_units": rms,
        "p_corrected": p,
        "worst_channel": worst,
        "worst_rms": rms[worst],
        "limit": limit,
        "where": {"test": where[0], "channel": where[1]},
        "where_share": share,
        "lag1": lag1,
        "remains": left.remains,
    }


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
    if (ask := getattr(ctx.family, "residual_left", None)) is None:
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
