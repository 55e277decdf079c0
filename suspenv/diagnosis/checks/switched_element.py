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
"an unrecorded input may drive what it fits", with the test's numbers.

A switching gain alone does not tell a spurious element from a real one (a lag or a
stop the switched force projects on switches too). What does is the element's own
shape **beyond a gain the input sets block by block** (:func:`beyond_switching`): a
real element's shape is in the residual at its fitted size (coefficient 1), one that
only fitted the switched force's average leaves nothing there (coefficient 0); a
one-sided normal test at ``alpha`` over the elements judged places it beside 1/2: one
shown below is **withdrawn**, one it cannot place (a smooth element, e.g. a cubic
spring, is locally a level and a ramp) stays, not confident. Where the fits profile the
input out (:mod:`~suspenv.diagnosis.unrecorded`; its signal and blocks), one this keeps
is judged again on the fits without the profile, the gain alone taken out: one whose
gain switches and whose coefficient is off 1 by more than 1/2 either way (at the same
level) is withdrawn too: its shape is not in the residual at its fitted size, and the
switched input explains what it fits as well. Elements are judged from the last named
back and withdrawn while each one is (the model before a withdrawn last element is its
parent: no refit).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import signal, stats

from suspenv.diagnosis.checks import missing_input as mi
from suspenv.diagnosis.checks.finding import Context
from suspenv.diagnosis.family import Conclusion
from suspenv.diagnosis.fitting import FitResult, residuals
from suspenv.diagnosis.hypothesis import Hypothesis, Withdrawal
from suspenv.diagnosis.protocols import RecordingLike
from suspenv.diagnosis.unrecorded import unprofiled


def _improvements(
    ctx: Context, parent: FitResult, refit: FitResult, bare: bool = True
) -> Iterator[tuple[RecordingLike, np.ndarray, np.ndarray, np.ndarray]]:
    """(recording, r, d, parent's prediction) per recording and channel of ``refit``: the
    parent's residual ``r``, the element's improvement ``d`` (the refit's prediction less
    the parent's), in the channel's unit (with ``bare``, of the models without a profile)."""
    p_model, r_model = (unprofiled(f.model) if bare else f.model for f in (parent, refit))
    for rec in ctx.setup.split.recordings():
        (res,) = residuals(p_model, parent.theta, [rec], refit.channels)
        new, old = r_model.simulate(refit.theta, rec), p_model.simulate(parent.theta, rec)
        for ch in refit.channels:
            yield rec, res[ch], new[ch] - old[ch], old[ch]


def gain_lag1(r: np.ndarray, d: np.ndarray, length: int) -> tuple[float, float]:
    """(p, rho): the lag-1 autocorrelation ``rho`` of the gains ``<r, d> / |d|`` of
    ``r`` on ``d`` in blocks of ``length`` (:func:`~.missing_input.block_gains`) and its
    exact one-sided p-value for independent gains (:func:`~.missing_input.lag1_p`)."""
    g = mi.block_gains(r, d, length)
    if g.size < 3 or not np.ptp(g) > 0:
        return 1.0, 0.0
    rho, p = mi.lag1_p(g, np.ones((g.size, 1)))
    return p, rho


def gain_switching(
    ctx: Context, parent: FitResult, refit: FitResult, length: int
) -> dict[str, float]:
    """The switching test of the element's improvement (``refit`` less ``parent``) on
    the parent's residual (:func:`gain_lag1`) over the recordings and channels: the
    smallest p-value, Bonferroni-corrected, and its lag-1 correlation."""
    tried = [gain_lag1(r, d, length) for _, r, d, _ in _improvements(ctx, parent, refit)]
    p, rho = min(tried, default=(1.0, 0.0))
    return {"p_switching": min(1.0, p * max(len(tried), 1)), "gain_lag1": rho}


def beyond_switching(
    r: np.ndarray, d: np.ndarray, s: np.ndarray, length: int, trend: bool = True
) -> tuple[float, float]:
    """(beta, se): the coefficient of ``r`` on ``d`` with a gain on ``s`` (with ``trend``
    a level and a ramp too) taken out of both in each block of ``length``
    (:func:`~.missing_input.within_blocks`: the unrecorded input's reach, whatever its
    level in each block), and its standard error
    (the regression's residual and ``d`` whitened by the residual's autoregression,
    :func:`~.missing_input.whitening`; inf where nothing of ``d`` is left). Between 0
    and 1, equally precise, the likelihood decides at the midpoint 1/2."""
    rp, dp = (mi.within_blocks(x, [s], length, trend) for x in (r, d))
    dd = float(dp @ dp)
    if not dd > 1e-24 * max(float(d @ d), 1e-300):
        return 0.0, float("inf")
    beta = float(rp @ dp) / dd
    poly = mi.whitening(rp - beta * dp)
    ew, dw = (signal.lfilter(poly, [1.0], x) for x in (rp - beta * dp, dp))
    return beta, float(np.std(ew) / np.sqrt(max(float(dw @ dw), 1e-300)))


def element_beyond(
    ctx: Context, parent: FitResult, refit: FitResult, length: int, name: str, trend: bool
) -> dict[str, float]:
    """:func:`beyond_switching` of the element's improvement on its parent's residual
    (with ``trend`` of the fits as they are, else without a profile) over the recordings
    and channels, inverse-variance pooled, on the recorded input ``name`` whose gain
    switches (the model's prediction: the parent's, not holding the element's shape)."""
    num = den = 0.0
    for rec, r, d, old in _improvements(ctx, parent, refit, bare=not trend):
        s = old if name == mi.PREDICTION else rec.inputs.get(name)
        if s is None or r.size < 2 * length:
            continue
        beta, se = beyond_switching(r, d, np.asarray(s, float), length, trend)
        if np.isfinite(se) and se > 0:
            num, den = num + beta / se**2, den + 1.0 / se**2
    return {"beta": num / den, "se": 1.0 / np.sqrt(den)} if den else {"beta": 0.0, "se": np.inf}


@dataclass
class SwitchedWithdrawal(Withdrawal):
    """An element withdrawn beside a gain an unrecorded input sets block by block
    (``p_value_corrected``: its coefficient there against 0, :func:`beyond_switching`)."""

    beta: float = 0.0
    se: float = float("inf")

    def sentence(self) -> str:
        return (
            f"{self.hypothesis.words}, named in round {self.hypothesis.round}, is withdrawn: "
            f"beside {self.beside} its shape is not in the residual at its fitted size "
            f"(coefficient there {self.beta:.2f} +- {self.se:.2g}, 1 for a real element; p = "
            f"{self.p_value_corrected:.2g} against 0)"
        )


#: (block length [samples], the signal whose gain switches, whether the fits profile it)
Setting = tuple[int, str, bool]


def _setting(ctx: Context) -> Setting | None:
    """(block length, signal, profiled): the profile's where the fits profile an input
    out, else the missing-input finding's where it calls the residual unrecorded."""
    if (stretches := getattr(ctx.outcome.current.model, "stretches", None)) is not None:
        return int(stretches.blocks), str(stretches.signal), True
    f = ctx.found.findings.get("missing_input")
    if f is None or not f.remains or f.numbers.get("cause") != "unrecorded":
        return None
    return int(f.numbers["judged_blocks"]), str(f.numbers.get("judged_signal", "")), False


def _withdrawn(
    ctx: Context,
    named: list[Hypothesis],
    parents: list[FitResult | None],
    setting: Setting,
) -> tuple[
    list[SwitchedWithdrawal], FitResult | None, list[dict[str, Any]], dict[int, dict[str, float]]
]:
    """The elements withdrawn from the last named back (module docstring), the model
    left, the numbers of every element judged and the switching tests run on the way
    (:func:`gain_switching`, by the hypothesis' id)."""
    z = float(stats.norm.isf(ctx.rule.alpha / max(len(named), 1)))
    length, name, profiled = setting
    out, judged, final = list[SwitchedWithdrawal](), list[dict[str, Any]](), None
    switched: dict[int, dict[str, float]] = {}
    for h, parent in reversed(list(zip(named, parents, strict=True))):
        if h.fit is None or parent is None:
            break
        n = element_beyond(ctx, parent, h.fit, length, name, trend=True)
        if not (gone := (0.5 - n["beta"]) / n["se"] > z) and profiled:  # module docstring
            n = element_beyond(ctx, parent, h.fit, length, name, trend=False)
            switched[id(h)] = gain_switching(ctx, parent, h.fit, length)
            flagged = switched[id(h)]["p_switching"] < ctx.rule.alpha
            gone = flagged and (abs(n["beta"] - 1.0) - 0.5) / n["se"] > z
        judged.append({"candidate": h.candidate, "signal": name, **n})
        if not gone:
            break
        p = float(stats.norm.sf(n["beta"] / n["se"]))
        beside = f"a gain on {name} set anew in each block of {length} samples"
        out.append(SwitchedWithdrawal(h, beside, p, float("nan"), beta=n["beta"], se=n["se"]))
        final = parent
    return out, final, judged, switched


def run(ctx: Context) -> Conclusion | None:
    """The named elements whose gain switches beside the missing-input finding or the
    profiled input, not confident, and those withdrawn (module docstring; None without
    the finding or such an element)."""
    if (setting := _setting(ctx)) is None:
        return None
    named = list(ctx.outcome.named)
    parents = [ctx.outcome.base, *(h.fit for h in named)][: len(named)]
    withdrawn, final, judged, switched = _withdrawn(ctx, named, parents, setting)
    gone = {id(w.hypothesis) for w in withdrawn}
    out: list[dict[str, Any]] = []
    sentences = [w.sentence() for w in reversed(withdrawn)]
    for h, parent in zip(named, parents, strict=True):
        if h.fit is None or parent is None or id(h) in gone:
            continue
        n = switched.get(id(h)) or gain_switching(ctx, parent, h.fit, setting[0])
        if n["p_switching"] >= ctx.rule.alpha:
            continue
        out.append({"candidate": h.candidate, **n})
        sentences.append(
            f"{h.words} is not named with confidence: an unrecorded input may drive what it "
            f"fits (its gain on the residual switches and persists over blocks of {setting[0]} "
            f"samples: lag-1 correlation {n['gain_lag1']:.2f}, p = {n['p_switching']:.2g})"
        )
    if not out and not withdrawn:
        return None
    return Conclusion(
        withdrawn=list[Withdrawal](withdrawn),
        final_fit=final,
        sentences=sentences,
        confident=False,
        findings={"switched_elements": out, "beyond_switching": judged},
    )
