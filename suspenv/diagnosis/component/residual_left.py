"""What the final component model leaves: noise, or a structure the library cannot name.

After the last named element, a residual made only of sensor noise (white or
coloured) and a slow zero drift is unrelated to the motion: the same state of the
component (deflection, velocity and direction), met again in another motion cycle,
meets an independent draw of noise. A model error is a function of that state and
repeats from cycle to cycle. The check therefore compares, state by state, the mean
residual with its cycle-to-cycle scatter:

0. **as recorded**: where a family compared its outputs low-passed with the motion
   (:attr:`~suspenv.models.components.base.ComponentModel.output_lowpass`, the
   guide), the check reads the outputs as recorded against the final model's
   prediction from the same motion (``recorded``): a force low-passed at a few hertz
   keeps a slow coloured noise or drift and loses what physics outside the library
   shows above the cut-off, so the residual the fit compared is not the one to judge;
   where the motion channels were low-passed, every step leaves out the samples near
   either end of a recording (:func:`settled`);
1. **detrend**: per recording, a Legendre polynomial in time of degree up to
   :data:`MAX_TREND_DEGREE` (one degree per :data:`CYCLES_PER_TREND_DEGREE` motion
   cycles) is removed from the residual: a drifting zero is not structure;
2. **state cells**: samples are binned by direction of motion (2), speed quartile (4)
   and deflection quartile (4): 32 cells;
3. **replicates**: each motion cycle (with fewer than :data:`MIN_CYCLES`, each of
   :data:`TIME_BLOCKS` time blocks; :func:`replicates`) gives one mean per cell it
   visits; a cell with at least :data:`MIN_REPLICATES` of them gives ``m`` (mean over
   replicates), ``s`` (their spread) and ``t = m / (s/sqrt k)``, whose two-sided
   p-value (Student t, k - 1 degrees of freedom) is turned into the chi-square(1) value
   with the same tail; their sum over cells is chi-square(cells) under the null. The
   scatter is measured, not assumed, so coloured noise with a correlation time well
   below a replicate does not count as structure;
4. **nearest states**: each sample is paired with the nearest state (deflection,
   velocity) met in another replicate; the mean product of the pair's residuals is the
   power ``S^2`` of the part that is a function of the state (noise is not shared),
   tested against zero over the replicates (:func:`neighbour_structure`); it sees
   structure finer than the cells (a position ripple). The two tests are combined by
   Bonferroni;
5. **size**: the noise RMS ``N`` from the differences of those pairs
   (:func:`neighbour_noise_power`), the structured RMS ``S`` from the rest of the
   residual's variance. **A residual remains** (the shared rule,
   :mod:`suspenv.diagnosis.checks.residual_left`, on :meth:`ResidualLeft.views`) when the
   test rejects at ``alpha`` *and* ``S > MATERIAL_RATIO * N``: what is left repeats with
   the motion and lifts the residual at least 17 % above the noise (:data:`LIMIT`).

6. **tails**: Gaussian noise, white or coloured, puts about 2e-9 of its samples beyond
   :data:`TAIL_Z` times its robust scale (1.4826 x the median absolute deviation, which
   the excursions barely move), so :data:`TAIL_MIN_SAMPLES` or more such samples carry
   something that is not noise, even when it repeats at no fixed state: impacts through
   free play, a stick-slip burst, a delayed channel at its fastest reversals. **A
   residual remains** there too when the power above the robust scale's, ``S_tail^2 =
   mean(r^2) - scale^2``, gives ``S_tail > MATERIAL_RATIO * scale``. The rule reads the
   samples of :func:`tail_read`: not the ends of a recording, where a model starts from
   rest and the motion's zero-phase filters meet the ends; not where the recorded
   motion contradicts itself (:func:`inconsistent_motion`: the model's input is wrong
   there); where the motion channels were low-passed (``lowpass_hz``), the residual
   low-passed alike (the prediction has no content above the cut-off, the recorded
   output has) and only where the part moves (at a standstill under a position loop
   the force answers motion below the channels' resolution, which the model cannot
   see).

Whiteness (Ljung-Box, 20 lags) of the detrended residual is reported beside it: a
white residual is noise; a non-white one may still be coloured noise, which is why
the decision rests on the cycle-to-cycle test.

Units: the channel's (SI); ``S`` and ``N`` in the channel's unit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from suspenv.diagnosis.checks.residual_left import Left
from suspenv.diagnosis.component.motion import cycle_index, motion
from suspenv.diagnosis.component.motion_inputs import (
    as_recorded,
    lowpass,
    robust_deviation,
    sampling_rate,
)
from suspenv.diagnosis.decision import DecisionRule
from suspenv.diagnosis.evidence import Comparison, compare, ljung_box
from suspenv.diagnosis.fitting import FitResult, drift_basis
from suspenv.diagnosis.record import Record
from suspenv.diagnosis.split import Split

#: per model family: words of the two directions of motion and of the displacement
MOTION_WORDS: dict[str, tuple[str, str, str]] = {
    "": ("in compression (v > 0)", "in rebound (v < 0)", "deflection"),
    "friction_guide": ("moving forward (v > 0)", "moving backward (v < 0)", "position"),
}
#: fewer motion cycles than this in a recording: replicates are time blocks instead
MIN_CYCLES = 16
#: time blocks per recording used as replicates when cycles are few
TIME_BLOCKS = 16
#: most degrees of the per-recording time trend removed before the check
MAX_TREND_DEGREE = 6
#: motion cycles per degree of that trend (a trend slower than a few cycles is drift)
CYCLES_PER_TREND_DEGREE = 4
#: cycles a state cell needs to count (its scatter is measured from them)
MIN_REPLICATES = 4
#: structured RMS / noise RMS above which a significant structure counts as a residual
#: left (above what the right element or a control leaves, below out-of-library physics)
MATERIAL_RATIO = 0.6
#: the same limit as the shared rule reads it, the residual's RMS in noise units:
#: ``sqrt(S^2 + N^2) / N = sqrt(1 + MATERIAL_RATIO^2)``, 1.17
LIMIT = float(np.hypot(1.0, MATERIAL_RATIO))
#: test level of the check
ALPHA = 0.01
#: periods of the motion's low-pass cut-off at either end of a recording that the check
#: leaves out where the motion channels were low-passed (:func:`settled`): there the
#: zero-phase filter rests on one side's samples (the true model's force error there is
#: several times the noise RMS, below it beyond one period)
SETTLING_PERIODS = 1.0
#: robust scales beyond which a sample is a tail sample (Gaussian noise: 2e-9 of them)
TAIL_Z = 6.0
#: tail samples that make a tail: at 2e-9 per sample, Gaussian noise does not give ten
#: in any recording (a coloured-noise excursion of a few samples stays below it)
TAIL_MIN_SAMPLES = 10
#: share of each recording at either end left out of the tail rule (a model started
#: from rest leaves its tail samples there)
TAIL_EDGE_FRACTION = 0.02
#: samples either side of an inconsistent motion sample also left out of the tail rule
INCONSISTENT_MARGIN = 5
#: fewest samples of a recording whose residual is low-passed for the tail rule (the
#: zero-phase filter's padding needs a few times its order)
MIN_FILTERED_SAMPLES = 52
#: where the motion channels were low-passed the tail rule reads the samples where the
#: speed exceeds this share of the recording's peak speed (a control's largest tail
#: samples lie at standstill, free play's while the part moves)
MOVING_FRACTION = 0.01


@dataclass
class ResidualLeft(Record):
    """The check's numbers for one channel (see the module docstring): the component
    family's noise model, judged by the shared rule through :meth:`views`.

    Attributes:
        channel: the output channel.
        unit: its unit.
        structured_rms: ``S`` [channel unit].
        noise_rms: ``N`` [channel unit].
        ratio: ``S / N``.
        chi2 / dof / p_value: the cycle-to-cycle test.
        whiteness_p: Ljung-Box p-value of the detrended residual.
        alpha: the level of the cycle-to-cycle test.
        where: the cells with the largest structure, in words.
        tail_samples: samples beyond :data:`TAIL_Z` robust scales (step 6).
        robust_scale: the robust scale [channel unit] (1.4826 x MAD; 0: tails not
            tested).
        tail_rms: ``S_tail`` [channel unit].
        tail_where: the largest tail samples, in words (time, state).
    """

    channel: str
    unit: str
    structured_rms: float
    noise_rms: float
    ratio: float
    chi2: float
    dof: int
    p_value: float
    whiteness_p: float
    alpha: float = ALPHA
    where: list[str] = field(default_factory=list)
    tail_samples: int = 0
    robust_scale: float = 0.0
    tail_rms: float = 0.0
    tail_where: list[str] = field(default_factory=list)
    derived = ("state_remains", "tail_remains", "remains")

    def views(self) -> list[Left]:
        """The shared rule's views (:mod:`suspenv.diagnosis.checks.residual_left`): the
        state rule (RMS in units of ``N``, ``sqrt(1 + (S/N)^2)``, against
        :data:`LIMIT`; structured where the cycle-to-cycle test rejects) and, where
        tested, the tail rule (RMS in units of the robust scale against :data:`LIMIT`;
        structured with :data:`TAIL_MIN_SAMPLES` samples beyond :data:`TAIL_Z`)."""
        state = Left(
            self.channel,
            float(np.hypot(1.0, self.ratio)),
            LIMIT,
            self.p_value < self.alpha,
            f"a part of {self.structured_rms:.3g} {self.unit} RMS repeats with the motion, "
            f"{self.ratio:.2f} x the noise of {self.noise_rms:.3g} {self.unit}; "
            f"cycle-to-cycle test p = {self.p_value:.2g}",
            "; ".join(self.where[:2]),
        )
        if not self.robust_scale > 0:
            return [state]
        tail = Left(
            self.channel,
            float(np.hypot(1.0, self.tail_rms / self.robust_scale)),
            LIMIT,
            self.tail_samples >= TAIL_MIN_SAMPLES,
            f"{self.tail_samples} samples beyond {TAIL_Z:g} x the noise's robust scale of "
            f"{self.robust_scale:.3g} {self.unit}, which Gaussian noise, white or coloured, "
            "does not give",
            "; ".join(self.tail_where[:2]),
        )
        return [state, tail]

    @property
    def state_remains(self) -> bool:
        """The state rule holds (step 5)."""
        return self.views()[0].remains

    @property
    def tail_remains(self) -> bool:
        """The tail rule holds (step 6; False where tails are not tested)."""
        return any(v.remains for v in self.views()[1:])

    @property
    def remains(self) -> bool:
        """A residual above the noise floor is left: the state rule or the tail rule."""
        return self.state_remains or self.tail_remains


def _detrend(t: np.ndarray, r: np.ndarray, cycles: int) -> np.ndarray:
    """``r`` less a Legendre polynomial in time of degree ``cycles / 4`` (1..6)."""
    deg = int(min(MAX_TREND_DEGREE, max(1, cycles // CYCLES_PER_TREND_DEGREE)))
    basis = drift_basis(t, deg, lowest=0)
    coef, *_ = np.linalg.lstsq(basis, r, rcond=None)
    return np.asarray(r - basis @ coef)


def replicates(t: np.ndarray, cycles: np.ndarray) -> np.ndarray:
    """Replicate index of each sample: its motion cycle when the recording has at least
    :data:`MIN_CYCLES` of them, else one of :data:`TIME_BLOCKS` equal time blocks (a
    guide run with a handful of long moves still meets each state many times).
    ``cycles``: each sample's motion cycle (:func:`cycle_index`)."""
    if int(cycles.max()) + 1 >= MIN_CYCLES:
        return cycles
    span = float(t[-1] - t[0]) or 1.0
    return np.minimum(((t - t[0]) / span * TIME_BLOCKS).astype(int), TIME_BLOCKS - 1)


def _quartile(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    edges = np.quantile(a, [0.25, 0.5, 0.75])
    return np.searchsorted(edges, a, side="right"), edges


@dataclass(frozen=True)
class _Run:
    """One recording as the check reads it: the recording, the model's prediction
    {channel: array}, times ``t`` [s], motion ``x`` [m] and ``v`` [m/s], each sample's
    motion cycle and replicate (unique over the split), the samples the tail rule reads,
    the samples the check reads (past the filter's settling, :func:`settled`) and the
    cut-off [Hz] of the residual it reads (None: the residual as it is)."""

    rec: Any
    pred: Mapping[str, np.ndarray]
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    cycles: np.ndarray
    replicate: np.ndarray
    read: np.ndarray
    settled: np.ndarray
    lowpass_hz: float | None = None

    def residual(self, channel: str) -> np.ndarray:
        """Recorded less predicted ``channel``, detrended (step 1)."""
        r = np.asarray(self.rec.outputs[channel], float) - np.asarray(self.pred[channel], float)
        return _detrend(self.t, r, int(self.cycles.max()) + 1)

    def low_passed(self, r: np.ndarray) -> np.ndarray:
        """This recording's residual ``r`` as the tail rule reads it: low-passed at
        :attr:`lowpass_hz` by the filter the motion channels got
        (:func:`~suspenv.diagnosis.component.motion_inputs.lowpass`), where the recording
        is uniformly sampled and the cut-off is below its Nyquist frequency; else as
        it is."""
        fs = sampling_rate(self.t)
        if self.lowpass_hz is None or fs is None or r.size < MIN_FILTERED_SAMPLES:
            return r
        if not 0.0 < self.lowpass_hz < 0.45 * fs:
            return r
        return lowpass(r, fs, self.lowpass_hz)


def _runs(
    fit: FitResult,
    sp: Split,
    lowpass_hz: float | None,
    recorded: Mapping[str, Mapping[str, np.ndarray]] | None = None,
) -> list[_Run]:
    """Every recording of the split, simulated and its motion read once for all
    channels; a recording named in ``recorded`` with those output channels."""
    runs = []
    offset = 0
    for rec in sp.recordings():
        if recorded is not None and str(rec.name) in recorded:
            rec = as_recorded(rec, recorded[str(rec.name)])
        t = np.asarray(rec.time, float)
        x, v = motion(rec)
        cycles = cycle_index(x)
        c = replicates(t, cycles)
        keep = settled(t, lowpass_hz)
        read = tail_read(t, x, v, lowpass_hz) & keep
        pred = fit.model.simulate(fit.theta, rec)
        runs.append(_Run(rec, pred, t, x, v, cycles, c + offset, read, keep, lowpass_hz))
        offset += int(c.max()) + 1
    return runs


def residual_left(
    fit: FitResult,
    sp: Split,
    alpha: float = ALPHA,
    lowpass_hz: float | None = None,
    recorded: Mapping[str, Mapping[str, np.ndarray]] | None = None,
) -> list[ResidualLeft]:
    """The check on every output channel of ``fit`` over all samples of the split's
    recordings (fit and held-out; the handful of fitted parameters barely shape a
    residual of thousands of samples), with the tail rule (step 6); ``lowpass_hz``: the
    cut-off [Hz] at which the motion channels were low-passed (None: not low-passed);
    ``recorded``: by recording name, the output channels as recorded where the fit
    compared them low-passed (step 0 of the module docstring)."""
    runs = _runs(fit, sp, lowpass_hz, recorded)
    words = MOTION_WORDS.get(str(getattr(fit.model, "family", "")), MOTION_WORDS[""])
    out = []
    for ch in fit.channels:
        if not (have := [run for run in runs if ch in run.rec.outputs]):
            continue
        parts = [run.residual(ch) for run in have]
        r = np.concatenate(parts)
        x = np.concatenate([run.x for run in have])
        v = np.concatenate([run.v for run in have])
        replicate = np.concatenate([run.replicate for run in have])
        unit = str(runs[0].rec.units.get(ch, ""))
        ok = np.concatenate([run.settled for run in have])
        left = _cell_test(words, r[ok], x[ok], v[ok], replicate[ok], ch, unit, alpha)
        keep = np.concatenate([run.read for run in have])
        t = np.concatenate([run.t for run in have])
        names = np.concatenate([np.full(run.t.size, str(run.rec.name)) for run in have])
        recording = names[keep] if len(have) > 1 else None
        rt = np.concatenate([run.low_passed(q) for run, q in zip(have, parts, strict=True)])
        _tail_test(left, words, rt[keep], x[keep], v[keep], t[keep], recording)
        out.append(left)
    return out


def beyond_library(
    before: FitResult, after: FitResult, sp: Split, channel: str, rule: DecisionRule
) -> tuple[Comparison, float, bool]:
    """An element outside the library that a probe adds to the final model ``before``
    (``after``: with it), judged as a refit is (corrected p below ``rule.alpha``, held-out
    error down by ``rule.min_heldout_gain``) and by the size rule: the RMS of the part of
    ``channel``'s fitted residual it removes over the RMS of the residual it leaves (its
    power ``ssr_before - ssr_after`` against ``ssr_after``; 0 where nothing is left) above
    :data:`MATERIAL_RATIO`. Returns (the comparison, that ratio, all three hold)."""
    c = compare(before, after, sp)
    ssr_before, ssr_after = before.ssr.get(channel, np.nan), after.ssr.get(channel, np.nan)
    ratio = float(np.sqrt(max(ssr_before / ssr_after - 1.0, 0.0))) if ssr_after > 0 else 0.0
    p, gain = c.lr.p_value_corrected, c.heldout_reduction
    passes = p < rule.alpha and gain >= rule.min_heldout_gain and ratio > MATERIAL_RATIO
    return c, ratio, bool(passes)


def settled(t: np.ndarray, lowpass_hz: float | None) -> np.ndarray:
    """The samples (bool) of one recording (times ``t`` [s]) more than
    :data:`SETTLING_PERIODS` periods of the motion's cut-off ``lowpass_hz`` [Hz] from
    either end (all where the motion was not low-passed, or where that would leave fewer
    than half of them)."""
    keep = np.ones(t.size, bool)
    if lowpass_hz is None or not lowpass_hz > 0 or t.size < 3:
        return keep
    span = SETTLING_PERIODS / float(lowpass_hz)
    keep = (t - t[0] >= span) & (t[-1] - t >= span)
    return keep if 2 * int(keep.sum()) >= t.size else np.ones(t.size, bool)


def tail_read(
    t: np.ndarray, x: np.ndarray, v: np.ndarray, lowpass_hz: float | None = None
) -> np.ndarray:
    """The samples (bool) of one recording (times ``t`` [s], motion ``x`` [m], ``v``
    [m/s]; ``lowpass_hz``: the motion's cut-off [Hz] or None) that the tail rule reads
    (step 6 of the module docstring): all but the first and last
    :data:`TAIL_EDGE_FRACTION` and those of :func:`inconsistent_motion`; where the
    motion was low-passed, only where ``|v|`` exceeds :data:`MOVING_FRACTION` of its peak."""
    edge = int(TAIL_EDGE_FRACTION * t.size)
    rows = np.arange(t.size)
    read = (rows >= edge) & (rows < t.size - edge) & ~inconsistent_motion(t, x, v)
    if lowpass_hz is not None and v.size:
        read &= np.abs(v) > MOVING_FRACTION * float(np.max(np.abs(v)))
    return read


def inconsistent_motion(t: np.ndarray, x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Samples (bool) where the velocity ``v`` [m/s] is more than :data:`TAIL_Z` robust
    scales (1.4826 x MAD) of ``v - dx/dt`` from the derivative of the displacement ``x``
    [m] (times ``t`` [s]), widened by :data:`INCONSISTENT_MARGIN` samples either side;
    none where the two agree exactly (a velocity made from the displacement)."""
    if x.size < 3:
        return np.zeros(x.size, bool)
    dev, scale = robust_deviation(v - np.gradient(x, t))
    if not scale > 0:
        return np.zeros(x.size, bool)
    bad = dev > TAIL_Z * scale
    if not bad.any():
        return bad
    width = 2 * INCONSISTENT_MARGIN + 1
    return np.convolve(bad.astype(float), np.ones(width), mode="same") > 0


def _tail_test(
    left: ResidualLeft,
    words: tuple[str, str, str],
    r: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    t: np.ndarray,
    recording: Sequence[str] | np.ndarray | None = None,
) -> None:
    """Step 6 of the module docstring on one channel's pooled residual ``r``, its
    motion ``x`` [m], ``v`` [m/s] and times ``t`` [s] (``recording``: each sample's
    recording name, where there are several): fills the tail fields of ``left`` and
    so the tail rule (``left.tail_remains``)."""
    if r.size < 2 * TAIL_MIN_SAMPLES:
        return
    centre = float(np.median(r))
    dev, scale = robust_deviation(r)
    if not scale > 0:
        return
    tail = np.flatnonzero(dev > TAIL_Z * scale)
    excess = max(float(np.mean(r * r)) - scale * scale, 0.0)
    left.tail_samples = int(tail.size)
    left.robust_scale = scale
    left.tail_rms = float(np.sqrt(excess))
    largest = tail[np.argsort(-dev[tail])][:3]
    left.tail_where = [
        ("" if recording is None else f"in {recording[i]} ")
        + f"at t = {t[i]:.3f} s, {words[0] if v[i] > 0 else words[1]} at {abs(v[i]):.3g} m/s, "
        f"{words[2]} {x[i] * 1e3:.3g} mm: {r[i] - centre:+.3g} {left.unit}"
        for i in largest
    ]


def _cell_test(
    words: tuple[str, str, str],
    r: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    cycle: np.ndarray,
    channel: str,
    unit: str,
    alpha: float,
) -> ResidualLeft:
    """Steps 2-4 of the module docstring on one channel's pooled residual."""
    direction = (v < 0).astype(int)  # 0: compression (v > 0), 1: rebound
    speed_q, speed_edges = _quartile(np.abs(v))
    x_q, x_edges = _quartile(x)
    cell = direction * 16 + speed_q * 4 + x_q
    key = cell.astype(np.int64) * (int(cycle.max()) + 1) + cycle
    uniq, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
    means = np.bincount(inv, weights=r) / counts
    cell_of = uniq // (int(cycle.max()) + 1)
    chi2, dof = 0.0, 0
    tops: list[tuple[float, int, float]] = []
    for c in np.unique(cell_of):
        m_c = means[cell_of == c]
        k = m_c.size
        if k < MIN_REPLICATES:
            continue
        mean = float(np.mean(m_c))
        sd = float(np.std(m_c, ddof=1))
        se2 = sd * sd / k
        if se2 <= 0:
            continue
        t_stat = mean / np.sqrt(se2)
        p = 2.0 * float(stats.t.sf(abs(t_stat), k - 1))
        chi2 += float(stats.chi2.isf(max(p, 1e-300), 1))
        dof += 1
        tops.append((abs(mean), int(c), mean))
    total = float(np.mean(r * r))
    pairs = neighbour_pairs(x, v, cycle)
    p_neighbour = neighbour_structure(r, cycle, pairs)
    # noise power from pairs in the same state (never negative); structure: the rest
    n2 = max(min(neighbour_noise_power(r, pairs), total), 1e-12 * total, 1e-300)
    s2 = max(total - n2, 0.0)
    ratio = float(np.sqrt(s2 / n2))
    p_cells = float(stats.chi2.sf(chi2, dof)) if dof else 1.0
    # two views of one question (state cells; nearest states): Bonferroni over the two
    p_value = min(1.0, 2.0 * min(p_cells, p_neighbour))
    _, white_p = ljung_box(r)
    tops.sort(reverse=True)
    where = [_cell_words(words, c, mean, unit, speed_edges, x_edges) for _, c, mean in tops[:3]]
    return ResidualLeft(
        channel=channel,
        unit=unit,
        structured_rms=float(np.sqrt(s2)),
        noise_rms=float(np.sqrt(n2)),
        ratio=ratio,
        chi2=chi2,
        dof=dof,
        p_value=p_value,
        whiteness_p=float(white_p),
        alpha=alpha,
        where=where,
    )


def neighbour_structure(
    r: np.ndarray, replicate: np.ndarray, pairs: tuple[np.ndarray, np.ndarray]
) -> float:
    """One-sided p-value that no part of ``r`` is a function of the state.

    ``pairs`` (:func:`neighbour_pairs`) joins each sample to the nearest state met in
    another replicate; a function of the state is shared by the pair, noise is not, so
    ``mean(r_i r_nb(i))`` estimates the structure's power. The test is a t-test of that
    mean over the replicates' own means (products of neighbouring samples are correlated
    through coloured noise; replicates are not)."""
    i, nb = pairs
    if i.size < 8:
        return 1.0
    prod = r[i] * r[nb]
    uniq, inv = np.unique(replicate[i], return_inverse=True)
    if uniq.size < 3:
        return 1.0
    means = np.bincount(inv, weights=prod) / np.bincount(inv)
    sd = float(np.std(means, ddof=1))
    m = float(np.mean(means))
    if sd <= 0:
        return 1.0 if m <= 0 else 0.0
    return float(stats.t.sf(m / (sd / np.sqrt(uniq.size)), uniq.size - 1))


def neighbour_pairs(
    x: np.ndarray, v: np.ndarray, replicate: np.ndarray, neighbours: int = 16
) -> tuple[np.ndarray, np.ndarray]:
    """Indices ``(i, nb)``: each sample and its nearest neighbour in (deflection,
    velocity), each scaled by its spread, from another replicate (samples with none among
    their ``neighbours`` nearest are left out)."""
    from scipy.spatial import cKDTree

    pts = np.column_stack([x / (np.std(x) or 1.0), v / (np.std(v) or 1.0)])
    k = min(neighbours, x.size)
    _, idx = cKDTree(pts).query(pts, k=k)
    idx = np.atleast_2d(idx)
    other = replicate[idx] != replicate[:, None]
    has = other.any(axis=1)
    first = np.argmax(other, axis=1)
    nb = idx[np.arange(x.size), first]
    return np.flatnonzero(has), nb[has]


def neighbour_noise_power(r: np.ndarray, pairs: tuple[np.ndarray, np.ndarray]) -> float:
    """Noise power of ``r`` [unit^2] from pairs of samples in the same state of motion in
    different replicates (:func:`neighbour_pairs`): half the mean square difference of
    their residuals. A model error that is a function of the state cancels in the
    difference; noise, white or coloured, does not (the two samples are far apart in time)."""
    i, nb = pairs
    if i.size == 0:
        return float(np.mean(r * r))
    d = r[i] - r[nb]
    return 0.5 * float(np.mean(d * d))


def _cell_words(
    words: tuple[str, str, str],
    cell: int,
    mean: float,
    unit: str,
    speed_edges: np.ndarray,
    x_edges: np.ndarray,
) -> str:
    """E.g. "in rebound at 0.12-0.25 m/s, deflection -3.1 to 2.0 mm: mean -41 N"."""
    direction = words[1] if cell // 16 else words[0]
    sq, xq = (cell % 16) // 4, cell % 4
    s_lo, s_hi = (float(e) for e in np.r_[0.0, speed_edges, np.inf][sq : sq + 2])
    x_lo, x_hi = (float(e) * 1e3 for e in np.r_[-np.inf, x_edges, np.inf][xq : xq + 2])
    speed = f"{s_lo:.3g}-{s_hi:.3g} m/s" if np.isfinite(s_hi) else f"above {s_lo:.3g} m/s"
    if not np.isfinite(x_lo):
        defl = f"{words[2]} below {x_hi:.3g} mm"
    elif not np.isfinite(x_hi):
        defl = f"{words[2]} above {x_lo:.3g} mm"
    else:
        defl = f"{words[2]} {x_lo:.3g} to {x_hi:.3g} mm"
    return f"{direction} at {speed}, {defl}: mean {mean:+.3g} {unit}"
