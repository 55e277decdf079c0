"""A residual driven by an input the recording does not carry.

An MR damper whose coil current switches, recorded without the current, leaves a
residual that is large, not white, and yet no function of the recorded inputs: within a
stretch of constant current the force follows the motion, but the relation changes
from stretch to stretch. Read as noise (it is not a function of the state), it would
hide a missing input. The check reads the final model's residual ``r`` of every
recording (as a whole, one series per output channel) and calls it **driven by an
unrecorded input** when all of these hold:

0. **far above the noise**: ``rms(r)`` is at least :data:`SIZE_LIMIT` times its white
   floor (:func:`white_floor`, from its second differences);
1. **switching**: the gain of ``r`` on the model's prediction, fitted block by block
   (lengths :data:`BLOCK_SAMPLES`: the switching time is not known; at least
   :data:`MIN_BLOCKS` blocks; the last :data:`GUARD_FRACTION` of each block left out,
   so that noise correlated over a few samples does not couple neighbouring blocks),
   less what the blocks' excitation explains, persists from block to block: the lag-1
   autocorrelation of those regression residuals, standardised by its exact mean and
   variance for independent normal gains (:func:`lag1_z`; regressing out ``p``
   columns biases it by about ``-p/B``), is standard normal for gains that do not
   persist; its one-sided p-value (Bonferroni over the block lengths and the judged
   channels) is below the rule's ``alpha``. Noise independent of the motion, white or
   coloured, gives gains that do not persist once a block outlasts its correlation;
2. **no linear relation**: the coherence of ``r`` (:func:`scipy.signal.coherence`,
   averaged over frequency with the weight of the residual's own spectrum: the share of
   its power a linear filter of that signal explains) with every recorded input and
   with the prediction stays below :data:`COHERENCE_LIMIT`;
3. **no static relation**: the residual's means over :data:`FINE_BINS` quantile bins
   of each of those signals (a fine ripple along one input) and over a grid of
   :data:`STATE_BINS` x :data:`STATE_BINS` quantile cells of every pair explain less than
   :data:`STATE_SHARE_LIMIT` of its variance (a stop, a dead band or a friction step is
   a function of the state and is left to the residual-left checks).

The verdict then says that an input the recording does not carry (or one it carries
that the model does not read) may drive the residual, with its size (RMS in % of the
output's, and in multiples of its white floor) and the evidence; it is
not confident. Recordings too short for the blocks (K&C loops) are not judged.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import combinations
from typing import Any

import numpy as np
from scipy import signal, stats

from suspenv.diagnosis.checks.assumptions import unread_inputs
from suspenv.diagnosis.checks.finding import Context, Finding
from suspenv.diagnosis.fitting import FitResult, lag1_autocorrelation, residuals
from suspenv.diagnosis.protocols import RecordingLike

#: block lengths [samples] of the switching test (the switching time is not known)
BLOCK_SAMPLES = (50, 100, 200, 400)
#: fewest blocks of a length tried
MIN_BLOCKS = 16
#: share of each block, at its end, left out of its gain (a gap between blocks)
GUARD_FRACTION = 0.2
#: the residual's RMS over its white noise floor above which it is "far above the noise"
SIZE_LIMIT = 3.0
#: largest spectrum-weighted coherence with a recorded signal of an unrecorded cause
COHERENCE_LIMIT = 0.5
#: quantile bins per signal of the static-relation test on a pair of signals
STATE_BINS = 6
#: quantile bins of a single signal (a fine ripple along one input, e.g. cogging along
#: the position), at most one per :data:`SAMPLES_PER_FINE_BIN` samples
FINE_BINS = 64
SAMPLES_PER_FINE_BIN = 20
#: the largest share of the residual's variance the cell means may explain
STATE_SHARE_LIMIT = 0.5
#: the name of the prediction among the signals
PREDICTION = "the model's prediction"
#: the switching test's numbers where it cannot be run (too few blocks, no prediction)
NO_SWITCHING = {"p_switching": 1.0, "block_samples": 0, "gain_lag1": 0.0, "blocks": 0}


def white_floor(r: np.ndarray) -> float:
    """The RMS of the white part of ``r``: ``std(second difference) / sqrt(6)`` (exact for
    white noise, whose second difference has variance ``6 sigma^2``; a smooth structure
    adds almost nothing to it)."""
    return float(np.std(np.diff(r, 2)) / np.sqrt(6.0)) if r.size > 2 else 0.0


def block_gains(r: np.ndarray, y: np.ndarray, length: int) -> np.ndarray:
    """The part of ``r`` along ``y`` in consecutive blocks of ``length``: ``<r, y> /
    |y|`` (the gain times ``|y|``, so that white noise gives the same spread in every
    block however little ``y`` moves there), each block with its own straight line in
    time removed first (a slowly drifting zero is not a gain) and its last
    :data:`GUARD_FRACTION` left out (a gap of that many samples between the blocks)."""
    blocks = r.size // length
    ramp = np.linspace(-1.0, 1.0, length)

    def detrended(x: np.ndarray) -> np.ndarray:
        b = x[: blocks * length].reshape(blocks, length)
        b = b - b.mean(axis=1, keepdims=True)
        return b - np.outer(b @ ramp / (ramp @ ramp), ramp)

    rb, yb = detrended(r), detrended(y)
    yb[:, length - int(GUARD_FRACTION * length) :] = 0.0
    norm = np.sqrt(np.sum(yb * yb, axis=1))
    return np.sum(rb * yb, axis=1) / np.where(norm > 0, norm, np.inf)


def lag1_z(g: np.ndarray, a: np.ndarray) -> tuple[float, float]:
    """The lag-1 autocorrelation ``rho = e'Ae / e'e`` of the residuals ``e = M g`` of
    ``g`` regressed on the columns of ``a`` (``M = I - P_a``; ``A`` the symmetric lag-1
    matrix with 1/2 beside its diagonal), and its standard score under independent
    normal ``g``: the ratio is independent of ``e'e``, so its mean is ``tr(MA) / m`` and
    its variance ``2 (tr(MAMA) - tr(MA)^2 / m) / (m (m + 2))`` exactly, ``m`` the
    residual degrees of freedom (the moments of the Durbin-Watson statistic). Returns
    (rho, z)."""
    b = g.size
    q, _ = np.linalg.qr(a)
    m = b - q.shape[1]
    e = g - q @ (q.T @ g)
    lag = 0.5 * (np.eye(b, k=1) + np.eye(b, k=-1))
    ma = lag - q @ (q.T @ lag)
    tr = float(np.trace(ma))
    var = 2.0 * (float(np.sum(ma * ma.T)) - tr**2 / m) / (m * (m + 2))
    rho = float(e @ lag @ e / max(float(e @ e), 1e-300))
    return rho, (rho - tr / m) / np.sqrt(max(var, 1e-300))


def block_features(signals: Sequence[np.ndarray], length: int) -> np.ndarray:
    """What each block of ``length`` excites, per signal: the log of its spread and of
    the spread of its first difference (amplitude and frequency of the motion)."""
    cols = []
    for s in signals:
        b = s[: s.size // length * length].reshape(-1, length)
        tiny = 1e-9 * float(np.std(s)) + 1e-300  # a block at rest: a floor, not log(0)
        cols += [np.log(np.std(b, axis=1) + tiny), np.log(np.std(np.diff(b), axis=1) + tiny)]
    return np.column_stack(cols)


def switching(r: np.ndarray, y: np.ndarray, signals: Sequence[np.ndarray]) -> dict[str, float]:
    """The regime test: the gains of ``r`` on the prediction ``y`` block by block, less
    what the blocks' excitation explains (:func:`block_features` of ``signals``, by least
    squares: a test programme's steps are a recorded cause), keep their value from one
    block to the next: one-sided p-value of the lag-1 autocorrelation's exact standard
    score (:func:`lag1_z`), Bonferroni over the block lengths tried (a residual
    independent of the motion gives gains that do not persist once a block outlasts its
    own correlation)."""
    tried = []
    for length in BLOCK_SAMPLES:
        g = block_gains(r, y, length)
        if g.size < MIN_BLOCKS:
            continue
        a = np.column_stack([np.ones(g.size), block_features(signals, length)])
        if g.size < a.shape[1] + 3:  # too few degrees of freedom left for the moments
            continue
        rho, z = lag1_z(g, a)
        tried.append((float(stats.norm.sf(z)), length, rho, g.size))
    if not tried:
        return dict(NO_SWITCHING)
    p, length, rho, blocks = min(tried)
    return {
        "p_switching": min(1.0, p * len(tried)),
        "block_samples": length,
        "gain_lag1": rho,
        "blocks": blocks,
    }


def weighted_coherence(r: np.ndarray, s: np.ndarray, fs: float) -> float:
    """Coherence of ``r`` with ``s`` averaged over frequency, weighted by ``r``'s power
    spectrum (0: no linear relation; 1: ``r`` is a linear filter of ``s``)."""
    nper = int(min(256, max(16, r.size // 8)))
    f, c = signal.coherence(r, s, fs=fs, nperseg=nper)
    _, prr = signal.welch(r, fs=fs, nperseg=nper)
    c = np.nan_to_num(c)
    return float(np.sum(c * prr) / max(float(np.sum(prr)), 1e-300))


def state_share(r: np.ndarray, signals: Sequence[np.ndarray], bins: int) -> float:
    """Share of ``r``'s variance its means over the cells of ``bins`` quantile bins of
    each of ``signals`` explain."""
    cells = np.zeros(r.size, dtype=int)
    for s in signals:
        edges = np.quantile(s, np.linspace(0.0, 1.0, bins + 1)[1:-1])
        cells = cells * bins + np.searchsorted(edges, s)
    counts = np.bincount(cells)
    means = np.bincount(cells, weights=r) / np.maximum(counts, 1)
    var = float(np.var(r))
    return float(np.var(means[cells]) / var) if var > 0 else 0.0


def judge(
    r: np.ndarray, y: np.ndarray, signals: dict[str, np.ndarray], fs: float
) -> dict[str, Any]:
    """The tests on one residual ``r`` of the output ``y`` with the recorded
    ``signals`` (name -> series: the inputs and the prediction)."""
    named = {k: np.asarray(s, float) for k, s in signals.items() if np.ptp(s) > 0}
    pred = named.get(PREDICTION)
    out: dict[str, Any] = dict(
        switching(r, pred, list(named.values())) if pred is not None else NO_SWITCHING
    )
    out["size"] = float(np.sqrt(np.mean(r**2)) / max(white_floor(r), 1e-300))
    coh = {k: weighted_coherence(r, s, fs) for k, s in named.items()}
    out["coherence"] = coh
    fine = int(min(FINE_BINS, r.size // SAMPLES_PER_FINE_BIN))
    shares = {k: state_share(r, [s], fine) for k, s in named.items()}
    shares |= {
        f"{a} & {b}": state_share(r, [named[a], named[b]], STATE_BINS)
        for a, b in combinations(named, 2)
    }
    out["state_shares"] = shares
    out["state_share"] = max(shares.values(), default=0.0)
    out["share_of_output"] = float(np.std(r) / max(float(np.std(y)), 1e-300))
    out["lag1"] = lag1_autocorrelation(r)
    return out


def judge_recording(fit: FitResult, rec: RecordingLike) -> dict[str, dict[str, Any]]:
    """Per output channel of ``fit``, the numbers of the tests on its residual in ``rec``
    (empty when ``rec`` is too short for the blocks or has no input)."""
    if len(rec.time) < MIN_BLOCKS * BLOCK_SAMPLES[0] or not rec.inputs:
        return {}
    (res,) = residuals(fit.model, fit.theta, [rec], fit.channels)
    pred = fit.model.simulate(fit.theta, rec)
    fs = 1.0 / float(np.median(np.diff(np.asarray(rec.time, float))))
    return {
        ch: judge(
            res[ch], np.asarray(rec.outputs[ch], float), {**rec.inputs, PREDICTION: pred[ch]}, fs
        )
        for ch in fit.channels
    }


def _cells(ctx: Context) -> list[tuple[str, str, dict[str, Any]]]:
    """(recording, channel, numbers) for every judged recording and output channel."""
    return [
        (str(rec.name), ch, n)
        for rec in ctx.setup.split.recordings()
        for ch, n in judge_recording(ctx.outcome.current, rec).items()
    ]


def relations(n: dict[str, Any]) -> list[set[str]]:
    """The signals (one, or a pair of the static test) the residual is a function of."""
    out = [{k} for k, c in n["coherence"].items() if c >= COHERENCE_LIMIT]
    return out + [
        set(k.split(" & ")) for k, v in n["state_shares"].items() if v >= STATE_SHARE_LIMIT
    ]


def cause(n: dict[str, Any], alpha: float, unread: Sequence[str] = ()) -> str | None:
    """What the tests say at level ``alpha`` on the numbers ``n``: ``"unrecorded"`` (an
    input the recording does not carry), ``"unread"`` (a recorded input in ``unread``
    the model does not read: every relation found involves one) or None."""
    if not (n["p_switching"] < alpha and n["size"] >= SIZE_LIMIT):
        return None
    found = relations(n)
    if not found:
        return "unrecorded"
    return "unread" if all(s & set(unread) for s in found) else None


def sentence(rec: str, ch: str, n: dict[str, Any], unread: Sequence[str]) -> str:
    """The finding in words."""
    head = (
        f"a residual of {100 * n['share_of_output']:.0f} % of the {ch} RMS is left in "
        f"{rec}, {n['size']:.3g} times its white noise floor and not white (lag-1 "
        f"correlation {n['lag1']:.2f}); its gain on the prediction switches and persists "
        f"over blocks of {n['block_samples']} samples (lag-1 correlation of the gains "
        f"{n['gain_lag1']:.2f} over {n['blocks']} blocks, p = {n['p_switching']:.2g})"
    )
    found = relations(n)
    if found:
        names = sorted(set.union(*found) & set(unread))
        share = max(n["state_share"], *n["coherence"].values())
        return (
            f"{head}, and it follows the recorded {', '.join(names)} (coherence or cell "
            f"means of the state explain {100 * share:.0f} % of it), which the model does "
            "not read: that input drives it; give it to a model that reads it"
        )
    best = max(n["coherence"], key=lambda k: n["coherence"][k])
    return (
        f"{head}, yet it is no function of any recorded input (coherence at most "
        f"{n['coherence'][best]:.2f}, with {best}; cell means of the state explain "
        f"{100 * n['state_share']:.0f} % of it): an input the recording does not carry "
        "may drive it; it is not noise"
    )


def run(ctx: Context) -> Finding | None:
    """The missing-input finding (None when no recording is long enough to judge)."""
    cells = _cells(ctx)
    if not cells:
        return None
    alpha, unread = ctx.rule.alpha / len(cells), unread_inputs(ctx.setup)
    fired = [(c, cause(c[2], alpha, unread)) for c in cells]
    fired = [f for f in fired if f[1] is not None]
    numbers: dict[str, Any] = {"judged": {f"{r} {ch}": n for r, ch, n in cells}}
    if not fired:
        return Finding("missing_input", numbers=numbers)
    (rec, ch, n), why = max(fired, key=lambda f: f[0][2]["share_of_output"])
    numbers["cause"] = why
    numbers["short"] = f"{100 * n['share_of_output']:.0f} % of the {ch} RMS, " + (
        "switching with no recorded cause" if why == "unrecorded" else "driven by an unread input"
    )
    return Finding("missing_input", True, False, sentence(rec, ch, n, unread), True, numbers)
