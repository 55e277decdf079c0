"""A residual driven by an input the recording does not carry.

An MR damper whose coil current switches, recorded without the current, leaves a
residual that is large, not white, and yet no function of the recorded inputs: within a
stretch of constant current the force follows the motion, but the relation changes
from stretch to stretch. Read as noise (it is not a function of the state), it would
hide a missing input. The check reads the final model's residual ``r`` of every
recording (as a whole, one series per output channel), takes out what a time-invariant
function of the signals the model reads explains (:func:`time_invariant`: linear
filters of each and their play operators, a rate-independent loop; cell means of a pair
and of one: a stop, a dead band, a friction step, cogging) and calls the rest **driven
by an unrecorded input** when both hold:

0. **far above the noise**: its RMS is at least :data:`SIZE_LIMIT` times the residual's
   white floor (:func:`white_floor`, from its second differences);
1. **switching**: its gain on a recorded signal or the prediction, fitted block by block,
   persists from block to block (:func:`switching`; Bonferroni also over the judged
   channels) at the rule's ``alpha``. A switched damping ``c v`` is such a gain on the
   velocity: its mean over time is a function of the state and taken out, the switching
   is not.

A recorded input the model does not read (an MR damper's coil current given to a
passive model) is named instead where it explains the switching (:func:`cause`). The
verdict says what may drive the residual, with its size (RMS in % of the output's, and
in multiples of its white floor) and the evidence; it is not confident. Recordings too
short for the blocks at the residual's pass-band rate (:func:`judge_recording`: K&C
loops, short guide runs compared low-passed) are not judged.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import combinations, pairwise
from typing import Any

import numpy as np
from scipy import integrate, linalg, signal

from suspenv.diagnosis.checks.assumptions import unread_inputs
from suspenv.diagnosis.checks.finding import Context, Finding
from suspenv.diagnosis.fitting import (
    DRIFT_ORDER,
    FitResult,
    drift_basis,
    lag1_autocorrelation,
    residuals,
)
from suspenv.diagnosis.protocols import RecordingLike
from suspenv.models.components.base import OUTPUT_LOWPASS_KEY

#: block lengths [samples] of the switching test (the switching time is not known)
BLOCK_SAMPLES = (25, 50, 100, 200, 400)
#: fewest and most blocks of a length tried: over more, the little that the time-invariant
#: fit leaves of a function of the state (a ripple finer than its cells) keeps its gain
#: between short neighbouring blocks, which hundreds of blocks would call switching
MIN_BLOCKS = 16
MAX_BLOCKS = 128
#: fewest samples (at the pass-band rate) of a residual judged: the fewest blocks of the
#: shortest length
MIN_SAMPLES = MIN_BLOCKS * BLOCK_SAMPLES[0]
#: share of each block, at its end, left out of its gain (a gap between blocks)
GUARD_FRACTION = 0.2
#: the residual's RMS over its white noise floor above which it is "far above the noise"
SIZE_LIMIT = 3.0
#: lags [samples] either side of the time-invariant linear filters removed first
LAGS = 8
#: order of the autoregression that whitens the residual before the block gains
AR_ORDER = 2
#: quantile bins per signal of the cell means on a pair of signals
STATE_BINS = 6
#: quantile bins of a single signal (a fine ripple along one input, e.g. cogging along
#: the position), at most one per :data:`SAMPLES_PER_FINE_BIN` samples
FINE_BINS = 64
SAMPLES_PER_FINE_BIN = 20
#: widths of the play operators (:func:`play`) of every signal, in shares of its range
#: (2nd to 98th percentile): a rate-independent loop's pre-sliding and yield, up to
#: 3 % of the travel
PLAY_WIDTHS = (0.001, 0.003, 0.01, 0.03)
#: the name of the prediction among the signals
PREDICTION = "the model's prediction"
#: the switching test's numbers where it cannot be run (too few blocks or no signal)
NO_SWITCHING = {"p_switching": 1.0, "block_samples": 0, "gain_lag1": 0.0, "blocks": 0, "signal": -1}


def white_floor(r: np.ndarray) -> float:
    """The RMS of the white part of ``r``: ``std(second difference) / sqrt(6)`` (exact for
    white noise, whose second difference has variance ``6 sigma^2``; a smooth structure
    adds almost nothing to it)."""
    return float(np.std(np.diff(r, 2)) / np.sqrt(6.0)) if r.size > 2 else 0.0


def block_gains(r: np.ndarray, y: np.ndarray, length: int) -> np.ndarray:
    """The part of ``r`` along ``y`` in consecutive blocks of ``length``: ``<r, y> /
    |y|`` (the gain times ``|y|``, so that white noise gives the same spread in every
    block however little ``y`` moves there), the last :data:`GUARD_FRACTION` of each
    block left out (a gap of that many samples between the blocks). Nothing is removed
    within a block: a slow motion's gain lives in its block means."""
    blocks = r.size // length
    rb = r[: blocks * length].reshape(blocks, length)
    yb = y[: blocks * length].reshape(blocks, length).copy()
    yb[:, length - int(GUARD_FRACTION * length) :] = 0.0
    norm = np.sqrt(np.sum(yb * yb, axis=1))
    return np.sum(rb * yb, axis=1) / np.where(norm > 0, norm, np.inf)


def lag1_p(g: np.ndarray, a: np.ndarray, cov: np.ndarray | None = None) -> tuple[float, float]:
    """The lag-1 autocorrelation ``rho = e'Ae / e'e`` of the residuals ``e = M g`` of
    ``g`` regressed on the columns of ``a`` (``M = I - P_a``; ``A`` the symmetric lag-1
    matrix with 1/2 beside its diagonal), and its exact one-sided p-value for normal
    ``g`` of covariance ``cov`` (default: independent, of equal variance):
    ``P(rho' >= rho) = P(g' M (A - rho I) M g >= 0)``, a weighted sum of chi-squares with
    the eigenvalues of ``S M (A - rho I) M S`` (``S`` the square root of ``cov``) as
    weights, by Imhof's (1961) inversion integral (the Durbin-Watson test's exact
    distribution). Returns (rho, p)."""
    b = g.size
    q, _ = np.linalg.qr(a)
    e = g - q @ (q.T @ g)
    rho = float(e @ np.convolve(e, [0.5, 0.0, 0.5])[1:-1] / max(float(e @ e), 1e-300))
    mat = 0.5 * (np.eye(b, k=1) + np.eye(b, k=-1)) - rho * np.eye(b)
    mat = mat - q @ (q.T @ mat)
    mat = mat - (mat @ q) @ q.T
    if cov is not None:
        w, v = np.linalg.eigh(cov)
        root = (v * np.sqrt(np.clip(w, 0.0, None))) @ v.T
        mat = root @ mat @ root
    lam = np.linalg.eigvalsh(mat)
    lam = lam[np.abs(lam) > 1e-12 * np.max(np.abs(lam))]

    def integrand(u: float) -> float:
        theta = 0.5 * np.sum(np.arctan(lam * u))
        # 1 / prod (1 + (lam u)^2)^(1/4), in logarithms (the product overflows)
        return float(np.sin(theta) / u * np.exp(-0.25 * np.sum(np.log1p((lam * u) ** 2))))

    tail, _ = integrate.quad(integrand, 0.0, np.inf, limit=200)
    return rho, float(np.clip(0.5 + tail / np.pi, 0.0, 1.0))


def block_features(signals: Sequence[np.ndarray], length: int, means: bool = False) -> np.ndarray:
    """What each block of ``length`` excites, per signal: the log of its spread and of
    the spread of its first difference (amplitude and frequency of the motion), and with
    ``means`` its mean (the level of a recorded current or voltage)."""
    cols = []
    for s in signals:
        b = s[: s.size // length * length].reshape(-1, length)
        tiny = 1e-9 * float(np.std(s)) + 1e-300  # a block at rest: a floor, not log(0)
        cols += [np.log(np.std(b, axis=1) + tiny), np.log(np.std(np.diff(b), axis=1) + tiny)]
        cols += [b.mean(axis=1)] if means else []
    return np.column_stack(cols)


def whitening(e: np.ndarray) -> np.ndarray:
    """The polynomial ``[1, -phi_1, ..., -phi_p]`` (``p`` = :data:`AR_ORDER`) of the
    Yule-Walker autoregression of ``e``: filtering by it leaves ``e`` about white."""
    e = e - e.mean()
    acf = np.array([e[: e.size - k] @ e[k:] for k in range(AR_ORDER + 1)]) / e.size
    if acf[0] <= 0.0:
        return np.array([1.0])
    return np.r_[1.0, -linalg.solve_toeplitz(acf[:-1], acf[1:])]


def within_blocks(
    r: np.ndarray, signals: Sequence[np.ndarray], length: int, trend: bool = False
) -> np.ndarray:
    """``r`` less its least-squares fit on ``signals`` (and with ``trend`` a level and a
    ramp) in each block of ``length`` samples (the last takes the remainder): what no
    gain set anew in each block explains."""
    out = r.copy()
    for a, b in pairwise([*range(0, length * max(r.size // length, 1), length), r.size]):
        level_ramp = np.vander(np.linspace(-1.0, 1.0, b - a), 2 * trend)  # or no column
        x = np.column_stack([*(s[a:b] for s in signals), level_ramp])
        out[a:b] -= x @ np.linalg.lstsq(x, r[a:b], rcond=None)[0]
    return out


def pass_band_step(fs: float, fc: float | None) -> int:
    """Every how many samples (at ``fs`` [Hz]) a residual low-passed at ``fc`` [Hz] is
    taken, at its pass-band rate ``2 fc`` (its neighbouring samples are not independent):
    ``floor(fs / (2 fc))``; 1 when not low-passed (``fc`` None)."""
    return max(1, int(fs / (2.0 * fc) * (1.0 + 1e-9))) if fc else 1  # 1e-9: rounding


def switching(
    r: np.ndarray, signals: Sequence[np.ndarray], causes: Sequence[np.ndarray] = ()
) -> dict[str, float]:
    """The regime test: the gains of ``r`` on each of ``signals`` block by block, less
    what the blocks' excitation explains (:func:`block_features` of ``signals``, and of
    the recorded ``causes`` with their block means, by least squares: a test programme's
    steps are a recorded cause), keep their value from one block to the next: one-sided
    p-value of the lag-1 autocorrelation's exact distribution (:func:`lag1_p`),
    Bonferroni over the block lengths and signals tried; ``signal``: the index in
    ``signals`` of the one whose gain switches most clearly. The noise: a drifting zero
    (powers 0-3 of time and the drift check's Legendre P4 ... P\\ :data:`DRIFT_ORDER`,
    its ``drift_basis``) and the autoregression (:func:`whitening`) of what the drift
    and gains set anew in each block leave of ``r`` (:func:`within_blocks`), by which
    ``r``, the signals and the drift are filtered; the whitened drift is taken out of
    ``r``: the gains' covariance that
    leaves, ``I - (G Q)(G Q)'`` (``G`` the gains' rows, ``Q`` an orthonormal basis of the
    whitened drift), is part of the exact null."""
    if r.size < MIN_SAMPLES or not signals:
        return dict(NO_SWITCHING)
    t = np.linspace(-1.0, 1.0, r.size)
    base = np.column_stack([np.vander(t, 4), drift_basis(t, DRIFT_ORDER)])
    drift = base @ np.linalg.lstsq(base, r, rcond=None)[0]
    poly = whitening(within_blocks(r - drift, signals, BLOCK_SAMPLES[0]))
    q, _ = np.linalg.qr(signal.lfilter(poly, [1.0], base, axis=0))
    rw = signal.lfilter(poly, [1.0], r)
    rw = rw - q @ (q.T @ rw)
    tried = []
    for length in BLOCK_SAMPLES:
        blocks = r.size // length
        a = np.column_stack(
            [np.ones(blocks), block_features(signals, length)]
            + ([block_features(causes, length, means=True)] if causes else [])
        )
        if not max(MIN_BLOCKS, a.shape[1] + 3) <= blocks <= MAX_BLOCKS:
            continue  # too few degrees of freedom left, or too many blocks (MAX_BLOCKS)
        for i, s in enumerate(signals):
            sw = signal.lfilter(poly, [1.0], s)
            gq = np.column_stack([block_gains(c, sw, length) for c in q.T])
            cov = np.eye(blocks) - gq @ gq.T
            rho, p = lag1_p(block_gains(rw, sw, length), a, cov)
            tried.append((p, length, rho, blocks, i))
    if not tried:
        return dict(NO_SWITCHING)
    p, length, rho, blocks, i = min(tried)  # NO_SWITCHING's keys, in its order:
    return dict(zip(NO_SWITCHING, (min(1.0, p * len(tried)), length, rho, blocks, i), strict=True))


def cell_means(r: np.ndarray, signals: Sequence[np.ndarray], bins: int) -> np.ndarray:
    """``r``'s means over the cells of ``bins`` quantile bins of each of ``signals``, at
    every sample."""
    cells = np.zeros(r.size, dtype=int)
    for s in signals:
        edges = np.quantile(s, np.linspace(0.0, 1.0, bins + 1)[1:-1])
        cells = cells * bins + np.searchsorted(edges, s)
    counts = np.bincount(cells)
    return (np.bincount(cells, weights=r) / np.maximum(counts, 1))[cells]


def play(s: np.ndarray, width: float) -> np.ndarray:
    """The play (backlash) operator of ``s`` of ``width`` (unit of ``s``): it stays
    while ``s`` moves within ``width / 2`` of it and is dragged along beyond, starting
    at ``s[0]`` (the elementary hysteresis of the Prandtl-Ishlinskii model: a
    time-invariant function of ``s`` with memory, independent of its rate)."""
    out, y, h = np.empty(s.size), float(s[0]), 0.5 * width
    for i, x in enumerate(s.tolist()):
        y = min(max(y, x - h), x + h)
        out[i] = y
    return out


def plays(signals: Sequence[np.ndarray]) -> list[np.ndarray]:
    """Every signal's play operators (:func:`play`) less the signal, of the widths
    :data:`PLAY_WIDTHS` of its range."""
    out = []
    for s in signals:
        span = float(np.subtract(*np.percentile(s, [98, 2])))
        out += [play(s, w * span) - s for w in PLAY_WIDTHS if span > 0]
    return out


def time_invariant(
    r: np.ndarray, signals: Sequence[np.ndarray], memory: bool = False
) -> np.ndarray:
    """The part of ``r`` a time-invariant function of ``signals`` explains: linear
    filters (least squares on each signal shifted by up to :data:`LAGS` samples either
    way, and with ``memory`` on their play operators, :func:`plays`: a rate-independent
    loop), then the cell means of the pair of signals (:data:`STATE_BINS` quantile bins
    each) and of the single signal (:data:`FINE_BINS`, a fine ripple along one input)
    that explain most of what is left (a stop, a dead band, a friction step, cogging)."""
    n = r.size
    pad = [np.pad(s, LAGS, mode="edge") for s in signals]
    cols = [np.ones(n)] + [p[k : k + n] for p in pad for k in range(2 * LAGS + 1)]
    a = np.column_stack(cols + (plays(signals) if memory else []))
    fitted = a @ np.linalg.lstsq(a, r, rcond=None)[0]
    fine = int(min(FINE_BINS, n // SAMPLES_PER_FINE_BIN))
    pairs = list(combinations(signals, 2))
    for group, bins in ((pairs, STATE_BINS), ([(s,) for s in signals], fine)):
        if group:
            parts = [cell_means(r - fitted, g, bins) for g in group]
            fitted = fitted + max(parts, key=lambda m: float(m @ m))
    return fitted


def judge(
    r: np.ndarray, y: np.ndarray, signals: dict[str, np.ndarray], unread: Sequence[str] = ()
) -> dict[str, Any]:
    """The tests on one residual ``r`` of the output ``y`` with the recorded
    ``signals`` (name -> series: the inputs and the prediction), of which the model does
    not read ``unread``: what no time-invariant function of the signals the model reads
    explains, with memory (:func:`time_invariant`: a small rate-independent loop is not
    switching) is tested for switching (:func:`switching`; the
    name of the signal whose gain switches as ``signal``), once with the unread signals'
    block levels as recorded causes (``p_switching_all``)."""
    named = {k: np.asarray(s, float) for k, s in signals.items() if np.ptp(s) > 0}
    names = [k for k in named if k not in unread]
    read = [named[k] for k in names]
    other = [s for k, s in named.items() if k in unread]
    left = r - time_invariant(r, read, memory=True) if read else r
    out: dict[str, Any] = switching(left, read)
    out["signal"] = names[out["signal"]] if out["signal"] >= 0 else ""
    if other:
        out["p_switching_all"] = switching(left, read, other)["p_switching"]
    out["size"] = float(np.sqrt(np.mean(left**2)) / max(white_floor(r), 1e-300))
    out["time_invariant_share"] = float(1.0 - np.var(left) / max(float(np.var(r)), 1e-300))
    out["share_of_output"] = float(np.std(r) / max(float(np.std(y)), 1e-300))
    out["lag1"] = lag1_autocorrelation(r)
    return out


def judge_recording(
    fit: FitResult, rec: RecordingLike, unread: Sequence[str] = ()
) -> dict[str, dict[str, Any]]:
    """Per output channel of ``fit``, the numbers of the tests on its residual in ``rec``
    (:func:`judge`; the model does not read the inputs ``unread``), every sample or, for
    outputs compared low-passed (the cut-off ``OUTPUT_LOWPASS_KEY`` in its meta), at their
    pass-band rate (:func:`pass_band_step`); empty when ``rec`` is too short for the
    blocks at that rate or has no input."""
    step = pass_band_step(1.0 / rec.sample_interval, rec.meta.get(OUTPUT_LOWPASS_KEY))
    if len(rec.time) // step < MIN_SAMPLES or not rec.inputs:
        return {}
    (res,) = residuals(fit.model, fit.theta, [rec], fit.channels)
    pred = fit.model.simulate(fit.theta, rec)
    cut = {k: np.asarray(s, float)[::step] for k, s in rec.inputs.items()}
    return {
        ch: judge(
            res[ch][::step],
            np.asarray(rec.outputs[ch], float)[::step],
            {**cut, PREDICTION: np.asarray(pred[ch], float)[::step]},
            unread,
        )
        for ch in fit.channels
    }


def cause(n: dict[str, Any], alpha: float, size_limit: float = SIZE_LIMIT) -> str | None:
    """What the tests say at level ``alpha`` on the numbers ``n``: ``"unrecorded"`` (an
    input the recording does not carry), ``"unread"`` (a recorded input the model does
    not read explains the switching: with its block levels as a cause, the gains no
    longer persist) or None. ``size_limit``: the least size (in white floors) called."""
    if not (n["p_switching"] < alpha and n["size"] >= size_limit):
        return None
    return "unread" if n.get("p_switching_all", 0.0) >= alpha else "unrecorded"


def sentence(rec: str, ch: str, n: dict[str, Any], why: str, unread: Sequence[str]) -> str:
    """The finding in words."""
    head = (
        f"a residual of {100 * n['share_of_output']:.0f} % of the {ch} RMS is left in "
        f"{rec}, not white (lag-1 correlation {n['lag1']:.2f}); what no time-invariant "
        f"function of the recorded signals explains ({100 * (1 - n['time_invariant_share']):.0f}"
        f" % of its variance) is {n['size']:.3g} times its white noise floor, and its gain "
        f"on a recorded signal switches and persists over blocks of {n['block_samples']} "
        f"samples (lag-1 correlation of the gains {n['gain_lag1']:.2f} over {n['blocks']} "
        f"blocks, p = {n['p_switching']:.2g})"
    )
    if why == "unread":
        return f"{head}, and the levels of the recorded {', '.join(unread)} explain the " + (
            "switching, which the model does not read: that input drives it; give it to a "
            "model that reads it"
        )
    return f"{head}, with no recorded cause: an input the recording does not carry may " + (
        "drive it; it is not noise"
    )


def run(ctx: Context, size_limit: float = SIZE_LIMIT) -> Finding | None:
    """The missing-input finding (None when no recording is long enough to judge), of a
    residual at least ``size_limit`` times its white floor (:func:`cause`)."""
    unread, recs = unread_inputs(ctx.setup), ctx.setup.split.recordings()
    cells = [  # (recording, channel, numbers) for every judged recording and channel
        (str(rec.name), ch, n)
        for rec in recs
        for ch, n in judge_recording(ctx.outcome.current, rec, unread).items()
    ]
    if not cells:
        return None
    alpha = ctx.rule.alpha / len(cells)
    fired = [(c, why) for c in cells if (why := cause(c[2], alpha, size_limit)) is not None]
    numbers: dict[str, Any] = {"judged": {f"{r} {ch}": n for r, ch, n in cells}}
    if not fired:
        return Finding("missing_input", numbers=numbers)
    (rec, ch, n), why = max(fired, key=lambda f: f[0][2]["share_of_output"])
    numbers["cause"] = why
    numbers["judged_blocks"] = n["block_samples"]
    numbers["judged_signal"] = n["signal"]
    numbers["short"] = f"{100 * n['share_of_output']:.0f} % of the {ch} RMS, " + (
        "switching with no recorded cause" if why == "unrecorded" else "driven by an unread input"
    )
    text = sentence(rec, ch, n, str(why), unread)
    return Finding("missing_input", True, False, text, True, numbers)
