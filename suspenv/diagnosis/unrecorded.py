"""An input the recording does not carry, modelled as a switched gain and profiled out.

When the missing-input check (:mod:`suspenv.diagnosis.checks.missing_input`) calls the
baseline's residual driven by an input the recording does not carry (an MR damper's
coil current switched between levels, its channel withheld), that input is modelled as
a gain on one recorded signal that is constant over stretches of time and changes from
stretch to stretch (:class:`Stretches`); the input acts on the true quantity, so the
model's sensors on the channel (a lag, a gain) act on its part as on the model's
(:meth:`Profiled._signal`). Its gains are **nuisance parameters, profiled
out** (linear least squares, :class:`Profiled`): in every fit, the baseline's and each
candidate's alike, and in the held-out scoring, so that each candidate element is judged
on what is left beside the switched part.

The stretches (:func:`stretches_of`: dynamic programming and the BIC on the baseline's
residual) are fixed before the search, the same for every model compared. The gains are
fitted on the fit and the held-out samples apart (no leak: :class:`Profiled`; on the
held-out samples with a slow zero drift of their own, :func:`_held_out_part`) and cost
every model the same degrees of freedom, so the likelihood-ratio test's and the BIC's
differences are those without them. The engine keeps the profile only where the final
model, without it, still leaves the switching (:func:`still_switching`); where a named
element explains what looked switched (a hysteresis has memory, which no time-invariant
function takes up) the diagnosis runs again without it. The verdict states the
assumption ("an unrecorded input switches the gain of X: a gain on it is fitted anew in
each of K stretches of about N s").
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, cast

import numpy as np

from suspenv.diagnosis.checks import missing_input
from suspenv.diagnosis.checks.finding import Context, Finding
from suspenv.diagnosis.family import DiagnosisFamily, Outcome, Setup
from suspenv.diagnosis.fitting import FitResult, ar1_effective_size, lag1_autocorrelation, residuals
from suspenv.diagnosis.protocols import DiagnosableModel, RecordingLike

#: most stretches of constant gain per recording
MAX_STRETCHES = 24
#: the stretches' boundaries lie on a grid this many times finer than the check's blocks
GRID_PER_BLOCK = 5
#: at most this many grid steps per recording (the dynamic programme's cost is square)
MAX_GRID_BLOCKS = 1000
#: columns of the held-out groups' zero drift: a cubic in time (:func:`_held_out_part`)
DRIFT_COLUMNS = 4
#: per recording name, its sample groups (mask, fitted: the fit or the held-out samples)
Groups = Mapping[str, Sequence[tuple[np.ndarray, bool]]]


def _segment_costs(sxy: np.ndarray, sxx: np.ndarray, syy: np.ndarray) -> np.ndarray:
    """``cost[i, j]``: what one gain leaves of blocks ``i`` to ``j - 1`` (inf for
    ``j <= i``), from the blocks' sums ``<r, s>``, ``<s, s>``, ``<r, r>``."""
    cxy, cxx, cyy = (np.r_[0.0, np.cumsum(a)] for a in (sxy, sxx, syy))
    dxy, dxx, dyy = (c[None, :] - c[:, None] for c in (cxy, cxx, cyy))
    with np.errstate(divide="ignore", invalid="ignore"):
        cost = dyy - np.where(dxx > 0, dxy**2 / dxx, 0.0)
    b = sxy.size + 1
    return np.where(np.triu(np.ones((b, b), bool), 1), cost, np.inf)


def find_stretches(
    r: np.ndarray, s: np.ndarray, length: int, n_eff: float | None = None
) -> tuple[np.ndarray, float]:
    """(starts, bic): the sample indices where the stretches of constant gain of ``r``
    on ``s`` begin (the first 0, then the ends, the last ``r.size``): for every ``K`` up
    to :data:`MAX_STRETCHES`, the partition over blocks of ``length`` samples that
    leaves the least ``sum (r - g_k s)^2``, by dynamic programming, ``K`` chosen by the
    BIC, ``n log(SSR / n) + 2 K log n`` (a gain and a boundary per stretch); and the
    least BIC over ``K`` with ``n_eff`` in place of ``n`` in its weights (where given:
    the samples a correlated residual leaves independent, to compare signals)."""
    n = r.size
    blocks = max(n // length, 1)
    edges = np.r_[np.arange(blocks) * length, n]
    sums = [np.add.reduceat(v, edges[:-1]) for v in (r * s, s * s, r * r)]
    cost = _segment_costs(*sums)
    best = cost[0].copy()  # best[j]: blocks 0..j-1 in k stretches
    back, ssr = [np.zeros(blocks + 1, int)], [best[-1]]
    for _ in range(2, min(MAX_STRETCHES, blocks) + 1):
        total = best[:, None] + cost
        back.append(np.argmin(total, axis=0))
        best = np.min(total, axis=0)
        ssr.append(best[-1])
    ks, log_ssr = np.arange(1, len(ssr) + 1), np.log(np.maximum(ssr, 1e-300) / n)
    m = float(n_eff or n)
    k = int(np.argmin(n * log_ssr + 2.0 * ks * np.log(n))) + 1
    cuts, j = [blocks], blocks
    for level in range(k - 1, 0, -1):
        j = int(back[level][j])
        cuts.append(j)
    return edges[np.array([0, *reversed(cuts)])], float(np.min(m * log_ssr + 2.0 * ks * np.log(m)))


@dataclass(frozen=True)
class Stretches:
    """The unrecorded input's stretches, per recording name: the ``signal`` whose gain it
    switches (:data:`~.checks.missing_input.PREDICTION`: the baseline's prediction), its
    ``series`` over the recording (unit of the signal) and the sample indices where the
    stretches begin (``starts``; the last: the recording's length); the output ``channel``
    the gains are profiled out of, the first recording's sample interval ``dt`` [s] (for
    the words) and the missing-input check's block length ``blocks`` [samples]."""

    signal: str
    channel: str
    series: Mapping[str, np.ndarray]
    starts: Mapping[str, np.ndarray]
    dt: float
    blocks: int

    def words(self) -> str:
        k = sum(len(v) - 1 for v in self.starts.values())
        n = sum(int(v[-1]) for v in self.starts.values())
        return (
            f"an unrecorded input switches the gain of {self.signal}: a gain on it is fitted "
            f"anew in each of {k} stretches of about {n * self.dt / max(k, 1):.3g} s (found on "
            "the baseline's residual), on the fit and the held-out samples apart, for every "
            "model compared"
        )


def _supports(
    starts: np.ndarray, groups: Sequence[tuple[np.ndarray, bool]]
) -> list[tuple[np.ndarray, np.ndarray, bool]]:
    """The gains' supports of one recording: per sample group (mask, fitted) with
    samples, its sample indices, the positions among them where a stretch begins, and
    whether it is fitted."""
    out = []
    for g, fitted in groups:
        idx = np.flatnonzero(g)
        stretch = np.searchsorted(starts, idx, side="right")
        if idx.size:
            out.append((idx, np.flatnonzero(np.diff(stretch, prepend=-1)), fitted))
    return out


def _gains_part(
    d: np.ndarray, s: np.ndarray, supports: Sequence[tuple[np.ndarray, np.ndarray, bool]]
) -> np.ndarray:
    """What the gains take of the residual ``d[..., T]`` (unit of the channel; a batch of
    designs along the leading axis, as ``s``): per fitted group and stretch of more than
    one sample, the least-squares gain of ``d`` on the signal ``s`` times ``s``, less the
    group's one common gain, which stays the model's (a damping rate the switched gain
    multiplies); held-out groups: :func:`_held_out_part`."""
    d, s = np.broadcast_arrays(d, s)
    out = np.zeros(d.shape)
    for idx, first, fitted in supports:
        if not fitted:
            out[..., idx] += _held_out_part(d[..., idx], s[..., idx], first)
            continue
        ds, ss = d[..., idx] * s[..., idx], s[..., idx] * s[..., idx]
        sizes = np.diff(first, append=idx.size)
        num, den = (np.add.reduceat(v, first, axis=-1) for v in (ds, ss))
        ok = (sizes > 1) & (den > 0)
        gain = np.repeat(np.divide(num, den, out=np.zeros_like(num), where=ok), sizes, axis=-1)
        if idx.size > 1:
            tot, common = ss.sum(axis=-1, keepdims=True), ds.sum(axis=-1, keepdims=True)
            gain = gain - np.divide(common, tot, out=np.zeros_like(tot), where=tot > 0)
        out[..., idx] += gain * s[..., idx]
    return out


def _held_out_part(d: np.ndarray, s: np.ndarray, first: np.ndarray) -> np.ndarray:
    """What a held-out group's own gains and zero drift take of its residual ``d[..., n]``
    (signal ``s``, stretches from the positions ``first``): least squares on ``s`` in each
    stretch and a cubic in time (the input's level and the zero there are not known from
    the fit: a held-out block is the last part of a recording or a whole cycle of a few,
    where the fitted drift is extrapolated)."""
    # the cubic projected out first, then the gains from their small normal equations
    q = np.linalg.qr(np.vander(np.linspace(-1.0, 1.0, d.shape[-1]), DRIFT_COLUMNS))[0]
    dq = d - (d @ q) @ q.T
    qc = np.add.reduceat(q * s[..., :, None], first, axis=-2)  # (..., K, drift): Q' C
    cc = np.add.reduceat(s * s, first, axis=-1)
    normal = cc[..., :, None] * np.eye(first.size) - qc @ np.swapaxes(qc, -1, -2)
    g = np.einsum(
        "...kj,...j->...k", np.linalg.pinv(normal), np.add.reduceat(s * dq, first, axis=-1)
    )
    sizes = np.diff(first, append=d.shape[-1])
    cg = s * np.repeat(g, sizes, axis=-1)
    return cg + ((d - cg) @ q) @ q.T


class Profiled:
    """``model`` with the unrecorded input's gains profiled out: its prediction of a
    recording of the split plus, in each stretch and sample group (fit, held-out), the
    least-squares gain on the signal of what the model leaves (so the residual is the
    model's less its projection on the signal there). Every other member is the
    model's; :meth:`with_effects` and :meth:`jacobian_model` stay profiled."""

    def __init__(self, model: DiagnosableModel[Any, Any], stretches: Stretches, groups: Groups):
        self.model = model
        self.stretches = stretches
        self.groups = groups
        self._supports = {
            name: _supports(starts, groups[name]) for name, starts in stretches.starts.items()
        }

    def __getattr__(self, name: str) -> Any:
        if "model" not in self.__dict__:  # not yet built (a copy)
            raise AttributeError(name)
        return getattr(self.__dict__["model"], name)

    def with_effects(self, effects: Sequence[Any]) -> Profiled:
        return Profiled(self.model.with_effects(effects), self.stretches, self.groups)

    def jacobian_model(self) -> Any:
        twin = self.model.jacobian_model()
        return self if twin is self.model else Profiled(twin, self.stretches, self.groups)

    def simulate(self, theta: np.ndarray, rec: RecordingLike) -> dict[str, np.ndarray]:
        pred = self.model.simulate(theta, rec)
        name, ch = str(rec.name), self.stretches.channel
        starts = self.stretches.starts.get(name)
        if starts is None or int(starts[-1]) != len(rec.time) or ch not in {*pred} & {*rec.outputs}:
            return pred
        p = np.asarray(pred[ch], float)
        d = np.asarray(rec.outputs[ch], float) - p
        return {**pred, ch: p + _gains_part(d, self._signal(theta, rec), self._supports[name])}

    def _signal(self, theta: np.ndarray, rec: RecordingLike) -> np.ndarray:
        """The signal the gains multiply, as the model's sensors on the channel record it
        (one row per design of a batch): the unrecorded input acts on the true quantity,
        so a sensor lag filters its part as it filters the model's (the baseline's
        prediction, a prediction of the recorded channel, as it is)."""
        s = self.stretches.series[str(rec.name)]
        sensed = getattr(self.model, "sensed", None)
        if sensed is None or self.stretches.signal == missing_input.PREDICTION:
            return s
        return np.asarray(sensed(theta, s, rec, self.stretches.channel), float)


def unprofiled(model: Any) -> Any:
    """The model without the profiled gains (itself where it has none)."""
    return model.model if isinstance(model, Profiled) else model


def _groups(setup: Setup) -> dict[str, list[tuple[np.ndarray, bool]]]:
    """Per recording name, the sample groups whose gains are fitted apart: its fit
    samples (True) and its held-out samples (False)."""
    sp = setup.split
    out: dict[str, list[tuple[np.ndarray, bool]]] = {}
    fit, held = (sp.fit_recordings, sp.fit_masks), (sp.heldout_recordings, sp.heldout_masks)
    for (recs, masks), fitted in ((fit, True), (held, False)):
        for i, rec in enumerate(recs):
            m = np.ones(len(rec.time), bool) if masks is None else np.asarray(masks[i], bool)
            out.setdefault(str(rec.name), []).append((m, fitted))
    return out


def _signals(setup: Setup, base: FitResult, rec: RecordingLike, ch: str) -> dict[str, np.ndarray]:
    """The signals a gain may be switched on: the recorded inputs the model reads and
    the baseline's prediction."""
    unread = set(missing_input.unread_inputs(setup))
    out = {k: np.asarray(v, float) for k, v in rec.inputs.items() if k not in unread}
    out[missing_input.PREDICTION] = np.asarray(base.model.simulate(base.theta, rec)[ch], float)
    return {k: v for k, v in out.items() if np.ptp(v) > 0}


def _tried(
    base: FitResult, setup: Setup, rec: RecordingLike, length: int
) -> dict[str, tuple[float, np.ndarray, np.ndarray]]:
    """Per signal of ``rec`` (:func:`_signals`): the BIC of its stretches, the signal and
    the stretch starts. They are found on what no time-invariant function of the signals
    explains of the baseline's residual in its first channel
    (:func:`~suspenv.diagnosis.checks.missing_input.time_invariant`: an element's own
    shape is not switching), on a grid :data:`GRID_PER_BLOCK` times finer than the
    check's blocks of ``length``; the BIC that compares the signals counts the samples
    that residual's lag-1 correlation leaves independent, the stretches' own count all."""
    ch = base.channels[0]
    (res,) = residuals(base.model, base.theta, [rec], [ch])
    signals = _signals(setup, base, rec, ch)
    left = res[ch] - missing_input.time_invariant(res[ch], list(signals.values()))
    n_eff = ar1_effective_size(left.size, lag1_autocorrelation(left))
    grid = max(length // GRID_PER_BLOCK, -(-left.size // MAX_GRID_BLOCKS), 1)
    found = {name: find_stretches(left, s, grid, n_eff) for name, s in signals.items()}
    return {name: (bic, signals[name], starts) for name, (starts, bic) in found.items()}


def stretches_of(base: FitResult, setup: Setup, length: int) -> Stretches | None:
    """The stretches of an unrecorded input (:func:`find_stretches` in blocks of
    ``length`` samples on every recording, :func:`_tried`), on the signal whose stretches
    leave the lowest BIC summed over the recordings (None: no signal in every one)."""
    recs = setup.split.recordings()
    tried = {str(rec.name): _tried(base, setup, rec, length) for rec in recs}
    if not (common := set.intersection(*(set(t) for t in tried.values()))):
        return None
    name = min(sorted(common), key=lambda k: sum(t[k][0] for t in tried.values()))
    series = {r: t[name][1] for r, t in tried.items()}
    starts = {r: t[name][2] for r, t in tried.items()}
    return Stretches(name, base.channels[0], series, starts, recs[0].sample_interval, length)


def profile(
    fam: DiagnosisFamily, setup: Setup, base: FitResult, found: Finding | None = None
) -> tuple[FitResult, Finding] | None:
    """Where the missing-input check calls the baseline's residual driven by an input the
    recording does not carry (or ``found``, its finding on a later model, says so: a
    switching the baseline's misfit kept under the check's size): the baseline refitted
    with that input's gains profiled out (:class:`Profiled`) and the finding that says
    the assumption; None otherwise."""
    if found is None:
        empty = Outcome(base, base, [], [], [], cast(Any, None))  # it reads no location
        found = missing_input.run(Context(fam, setup, empty, fam.rule))
    if found is None or found.numbers.get("cause") != "unrecorded":
        return None
    if (stretches := stretches_of(base, setup, int(found.numbers["judged_blocks"]))) is None:
        return None
    model = Profiled(setup.model, stretches, _groups(setup))
    profiled = fam.fit_baseline(replace(setup, model=model))
    said = f"{found.sentence}; the fits assume it: {stretches.words()}"
    numbers = {**found.numbers, "signal": stretches.signal, "stretches": stretches.words()}
    return profiled, Finding("missing_input", True, False, said, False, numbers)


def switched_left(ctx: Context) -> Finding | None:
    """The missing-input finding of ``ctx`` where it calls the final model's residual
    driven by an input the recording does not carry (None otherwise)."""
    found = ctx.found.findings.get("missing_input")
    return found if found is not None and found.numbers.get("cause") == "unrecorded" else None


def still_switching(ctx: Context) -> bool:
    """Whether the final model of ``ctx``, without the profiled gains, still leaves a
    residual whose gain switches with no recorded cause (the missing-input check at the
    rule's alpha, whatever the residual's size: the named elements take their own part
    of it, which leaves less above the noise; False: they explain what looked switched
    on the baseline)."""
    current = ctx.outcome.current
    bare = replace(ctx.outcome, current=replace(current, model=unprofiled(current.model)))
    found = missing_input.run(replace(ctx, outcome=bare), size_limit=0.0)
    return found is not None and found.numbers.get("cause") == "unrecorded"
