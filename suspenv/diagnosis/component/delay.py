"""A pure time delay of a recorded channel: the evidence that tells it from a sensor lag.

A first-order sensor lag ``tau`` and a pure delay ``T`` both make a channel late. Under a
sinusoid of angular frequency ``w`` the lag shifts the phase by ``atan(w tau)`` and scales
the gain by ``1 / sqrt(1 + (w tau)^2)``; the delay shifts it by ``w T`` at unit gain. To a
force step (friction at a reversal) the lag answers with an exponential rise, the delay
with the whole step, shifted. A delay (a digital filter's or a transport delay of the
acquisition) is not an element of the diagnosis's library: it is fitted here only as a
probe, in two places.

1. **Lag or delay** (:func:`delay_against_lag`): where a sensor lag is refitted, the same
   model with a delay of the same channel instead is fitted too. The two fits have one
   parameter each, so their corrected BIC difference is a likelihood ratio of non-nested
   models. A delay decisively better refuses the lag (:func:`check_lag_not_delay`): a
   difference above ``DELAY_DECISIVE_BIC``, the held-out samples confirming it
   (:func:`heldout_z_of_delay`: the held-out chi-square drop in noise units, at the
   decision rule's ``alpha``; a relative drop of the held-out error would ask for more
   than the noise floor leaves when the lag already fits close to it, as a first-order
   lag does a delay at small ``w T``), and the encompassing test: the lag and the delay
   fitted together, the delay is significant beside the lag and the lag is not beside
   the delay (the corrected likelihood ratio of every refit, at the decision rule's
   ``alpha``), and where the lag carries more than ``LAG_SHARE_AT_BOUND`` of the two's
   lateness (below it the lag sits on its bound 0), the delay resolved from zero by
   ``SIZE_Z`` standard errors and the lag not. Under a misfit elsewhere in the model a
   difference of 1 % in residual power is "significant" on thousands of samples; fitted
   together, the two then share the lateness, neither resolved. Once refused for a
   channel, the lag is not refitted on it again.
2. **Delay left** (:func:`delay_left`): after the last named element, a delay of that
   channel is added to the final model. It is physics outside the library when it passes
   the test every refit passes *and* the residual check's size rule
   (:func:`~suspenv.diagnosis.component.residual_left.beyond_library`).
3. **Phase against frequency** (:func:`phase_by_frequency`): the evidence stated with
   both: per motion frequency, how late the recorded channel is behind the model without
   its lag and delay, beside what the fitted lag and the fitted delay predict.
4. **Named before the delay** (:func:`judge_beside_delay`): an element named in a round
   before the delay was found may have stood in for part of the lateness (a hysteresis
   loop or a Maxwell branch also makes a force late). With a delay left, each named
   element is judged again as a refit is, against the model with the delay and without
   it (one test per element: the benefit of the doubt goes to the element named); one
   that is no longer significant beside the delay is withdrawn (the weakest first, then
   the others judged again), and the final model is refitted without it (and without
   the delay, which is not a library element).

Units: delays in seconds; residuals in the channel's unit; phases in degrees.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.component.matched_speed import relative_clusters
from suspenv.diagnosis.component.motion import cycle_index, motion
from suspenv.diagnosis.component.refit import SIZE_Z, parameter_and_error, refit_with
from suspenv.diagnosis.component.residual_left import beyond_library
from suspenv.diagnosis.component.withdrawal import element_name, without_element
from suspenv.diagnosis.decision import DecisionRule, decide
from suspenv.diagnosis.evidence import (
    compare,
    fit_residual_series,
    heldout_confirmation_z,
    heldout_residuals,
    likelihood_ratio,
    relative_drop,
)
from suspenv.diagnosis.fitting import FitResult, ar1_effective_size
from suspenv.diagnosis.hypothesis import Hypothesis, Withdrawal
from suspenv.diagnosis.record import Record
from suspenv.diagnosis.split import Split

#: corrected BIC difference above which one of two fits of equal size is decisively
#: better ("very strong" evidence on Kass and Raftery's scale)
DELAY_DECISIVE_BIC = 10.0
#: fitted beside a delay, a lag that carries at most this share of the two's lateness
#: (``tau / (tau + T)``) is on its bound 0: there its derivative and the delay's nearly
#: coincide (both about the signal's rate, ``w T`` small) and the standard errors of
#: the split say nothing
LAG_SHARE_AT_BOUND = 0.01

#: whole motion cycles whose frequencies differ by less than this fraction share a row of
#: the phase table
PHASE_FREQUENCY_TOLERANCE = 0.1
#: rows of the phase table at most (the frequencies with the most cycles)
PHASE_ROWS = 6
#: samples a motion cycle needs for its phase to be measured
PHASE_MIN_SAMPLES = 8
#: a motion cycle's stroke (peak to peak) at least this fraction of the recording's
#: largest cycle's: crossings of the median by noise at a standstill or a turnaround
#: make short cycles of no stroke, whose phase says nothing
PHASE_MIN_STROKE = 0.1
#: the elements that make a channel late, and the parameter that says how late [s]
LATENESS_KINDS = {"sensor_lag": "tau", "sensor_delay": "delay"}


@dataclass(frozen=True)
class PhaseRow:
    """How late a recorded channel is at one motion frequency (:func:`phase_by_frequency`).

    Attributes:
        frequency_hz: the motion cycles' frequency [Hz] (median over the row's cycles).
        cycles: whole motion cycles measured.
        measured_deg: the recorded channel's phase lag behind the model without a lag or a
            delay, at the cycle's own frequency [deg] (positive: late; median over the
            cycles).
        lag_deg: the fitted first-order lag's phase lag ``atan(w tau)`` [deg].
        delay_deg: the fitted pure delay's ``w T`` [deg].
    """

    frequency_hz: float
    cycles: int
    measured_deg: float
    lag_deg: float
    delay_deg: float

    def words(self) -> str:
        return (
            f"{self.frequency_hz:.3g} Hz: {self.measured_deg:.3g} deg (lag "
            f"{self.lag_deg:.3g}, delay {self.delay_deg:.3g})"
        )


def phase_words(rows: Sequence[PhaseRow], channel: str) -> str:
    """The phase table in one clause ("" without rows)."""
    if not rows:
        return ""
    return (
        f"phase lag of the {channel} behind the model without lag or delay, per motion "
        f"frequency (what each predicts in brackets): " + "; ".join(r.words() for r in rows)
    )


def phase_by_frequency(
    together: FitResult, sp: Split, channel: str, tau: float, delay: float
) -> list[PhaseRow]:
    """The phase table of the module docstring (3), a :class:`PhaseRow` per motion
    frequency, of ``channel`` against ``together`` (the fit with both a lag and a delay,
    neither favoured by the physics it fits) with its lateness elements taken out, beside
    a lag ``tau`` [s] and a delay ``delay`` [s].

    Each whole motion cycle of every recording of the split (cycles between
    upward crossings of the motion's median) gives its frequency ``1 / period`` and its
    phase: the angle between the recorded and the modelled channel's Fourier
    coefficients at that frequency over the cycle (cycles of under ``PHASE_MIN_STROKE`` of
    the recording's largest stroke are left out). Cycles within
    ``PHASE_FREQUENCY_TOLERANCE`` of a row's first frequency share the row (the median of
    each column); the ``PHASE_ROWS`` rows with the most cycles are kept, by frequency.
    """
    # the same model and values without the lateness elements (values by parameter name)
    _, effects = together.model.unpack(together.theta)
    bare = together.model.with_effects([e for e in effects if e.kind not in LATENESS_KINDS])
    names, values = together.model.parameter_names, np.asarray(together.theta, float)
    value = dict(zip(names, values, strict=True))
    theta = np.array([value[name] for name in bare.parameter_names])
    cycles: list[tuple[float, float]] = []  # (frequency [Hz], lateness [rad])
    for rec in sp.recordings():
        if channel not in rec.outputs:
            continue
        y = np.asarray(rec.outputs[channel], float)
        model_y = np.asarray(bare.simulate(theta, rec)[channel], float)
        t = np.asarray(rec.time, float)
        x = motion(rec)[0]
        index = cycle_index(x)
        # whole cycles (not the first or last) and their strokes
        whole = [sel for sel in (index == k for k in range(1, int(index.max()))) if sel.any()]
        largest = max((float(np.ptp(x[sel])) for sel in whole), default=0.0)
        for sel in whole:
            n = int(sel.sum())
            if n < PHASE_MIN_SAMPLES or float(np.ptp(x[sel])) < PHASE_MIN_STROKE * largest:
                continue
            ts = t[sel]
            period = float(ts[-1] - ts[0]) * n / (n - 1)
            turn = np.exp(-2j * np.pi * ts / period)
            recorded, modelled = np.sum(y[sel] * turn), np.sum(model_y[sel] * turn)
            if abs(modelled) > 0 and abs(recorded) > 0:
                cycles.append((1.0 / period, -float(np.angle(recorded / modelled))))
    freqs = np.array([f for f, _ in cycles])
    groups = [[cycles[i] for i in g] for g in relative_clusters(freqs, PHASE_FREQUENCY_TOLERANCE)]
    kept = sorted(sorted(groups, key=len, reverse=True)[:PHASE_ROWS], key=lambda g: g[0][0])
    rows = []
    for g in kept:
        f = float(np.median([c[0] for c in g]))
        w = 2.0 * np.pi * f
        measured = float(np.degrees(np.median([c[1] for c in g])))
        lag, late = float(np.degrees(np.arctan(w * tau))), float(np.degrees(w * delay))
        rows.append(PhaseRow(f, len(g), measured, lag, late))
    return rows


def bic_difference(a: FitResult, b: FitResult) -> float:
    """The corrected BIC of fit ``a`` less that of fit ``b``, two fits of equal size on the
    same samples (positive favours ``b``): ``sum_c n_c ln(ssr_a,c / ssr_b,c)`` scaled by
    ``n_eff / n = (1 - rho) / (1 + rho)``, ``rho`` the lag-1 autocorrelation of the better
    fit's residual (the correction every likelihood ratio of the diagnosis takes:
    :func:`~suspenv.diagnosis.evidence.likelihood_ratio`)."""
    total = 0.0
    for c in a.channels:
        sa, sb = a.ssr.get(c, np.nan), b.ssr.get(c, np.nan)
        if sa > 0 and sb > 0:
            total += a.n[c] * float(np.log(sa / sb))
    better = b if total > 0 else a
    return ar1_effective_size(total, better.extra.get("lag1_autocorrelation", 0.0))


def fit_delay(
    current: FitResult,
    sp: Split,
    channel: str,
    start: float,
    budget: int,
    kind: str = "sensor_delay",
) -> FitResult:
    """``current``'s model with a pure delay (or another of :data:`LATENESS_KINDS`) of
    ``channel``, started ``start`` [s] late, refitted on the fit samples."""
    return refit_with(
        current,
        kind,
        sp.fit_recordings,
        sp.fit_masks,
        location=channel,
        max_nfev=budget,
        guess_given={LATENESS_KINDS[kind]: start},
    )


#: the lag and the delay fitted together start from each one's own fit with the other
#: element at this fraction of its own fitted size
TOGETHER_START = 0.1


def fit_together(
    lag: FitResult, delay: FitResult, sp: Split, channel: str, budget: int
) -> FitResult:
    """A sensor lag and a pure delay of ``channel`` fitted together (the encompassing
    model of :func:`delay_against_lag`), from two starts: the lag's fit with a delay
    added, and the delay's fit with a lag added, the added element at
    ``TOGETHER_START`` times its own fitted size. The fit of lower residual is kept.

    Their sum is well resolved, their split is not (a long valley of the fit), and a fit
    of a few evaluations ends near its start: one start alone would favour the element it
    starts from (a start of both at full size, the lateness counted twice, splits it
    anywhere along the valley)."""
    tau = parameter_and_error(lag, "sensor_lag", "tau")[0]
    late = parameter_and_error(delay, "sensor_delay", "delay")[0]
    from_lag = fit_delay(lag, sp, channel, TOGETHER_START * late, budget)
    from_delay = fit_delay(delay, sp, channel, TOGETHER_START * tau, budget, "sensor_lag")
    return min(from_lag, from_delay, key=lambda f: float(sum(f.ssr.values())))


def delay_decisive(
    bic: float,
    heldout_z: float,
    p_lag: float,
    p_delay: float,
    together: tuple[float, float, float, float],
    rule: DecisionRule,
) -> bool:
    """Whether a pure delay beats a sensor lag decisively by the rule of the module
    docstring (1), from the corrected BIC difference ``bic``, the held-out confirmation
    ``heldout_z`` (:func:`heldout_z_of_delay`, against the one-sided normal quantile of
    ``rule.alpha``), the corrected p-values of the lag beside the delay ``p_lag`` and of
    the delay beside the lag ``p_delay``, and the two fitted together (``together``: lag
    [s], its corrected standard error, delay [s], its error)."""
    tau, tau_sd, late, late_sd = together
    off_bound = tau > LAG_SHARE_AT_BOUND * (tau + late)
    if off_bound and not (late > SIZE_Z * late_sd and tau <= SIZE_Z * tau_sd):
        return False
    return bool(
        bic > DELAY_DECISIVE_BIC
        and heldout_z >= float(stats.norm.isf(rule.alpha))
        and p_delay < rule.alpha
        and not p_lag < rule.alpha
    )


def heldout_z_of_delay(
    lag: FitResult,
    delay: FitResult,
    lag_heldout: dict[str, np.ndarray],
    delay_heldout: dict[str, np.ndarray],
) -> float:
    """The held-out confirmation of the delay's fit over the lag's
    (:func:`~suspenv.diagnosis.evidence.heldout_confirmation_z`, positive: the delay
    predicts the held-out samples better than a change fitted to noise would) from the
    two fits' held-out residuals, each channel's noise scale the better fit's residual RMS
    on the fit samples, and its lag-1 autocorrelation."""
    lag_rms, delay_rms = lag.rms(), delay.rms()
    noise = {c: min(lag_rms[c], delay_rms[c]) for c in lag.channels}
    better = delay if sum(delay.ssr.values()) < sum(lag.ssr.values()) else lag
    rho = float(better.extra.get("lag1_autocorrelation", 0.0))
    return heldout_confirmation_z(lag_heldout, delay_heldout, noise, rho)


def delay_against_lag(
    lag: FitResult, delay: FitResult, sp: Split, rule: DecisionRule, channel: str, budget: int
) -> dict[str, Any]:
    """A sensor lag's fit (``lag``) against a pure delay's of the same channel
    (``delay``), by name: the numbers of the rule of the module docstring (1) (the
    corrected BIC difference, > 0 favouring the delay; the held-out confirmation; the
    p-values of each beside the other; the two fitted together, values and corrected
    standard errors [s]), ``"decisive"`` (1.0 when :func:`delay_decisive`, else 0.0), the
    held-out error's relative drop, each fit's value [s] and ssr (summed over the
    channels), and ``"phases"`` (:func:`phase_by_frequency` of the two fitted together,
    which the delay's finding states; empty where not decisive)."""
    bic = bic_difference(lag, delay)
    # each fit's held-out residuals once: the relative drop and the confirmation
    lag_heldout = heldout_residuals(lag, sp.heldout_recordings, sp.heldout_masks)
    delay_heldout = heldout_residuals(delay, sp.heldout_recordings, sp.heldout_masks)
    reduction = relative_drop(lag_heldout, delay_heldout, lag.scales)
    z = heldout_z_of_delay(lag, delay, lag_heldout, delay_heldout)
    # both fitted together (the encompassing model): the lag's time constant must vanish
    # within its error beside a resolved delay
    delay_s = parameter_and_error(delay, "sensor_delay", "delay")[0]
    both = fit_together(lag, delay, sp, channel, budget)
    residual = fit_residual_series(both, sp.fit_recordings, sp.fit_masks)
    p_lag = likelihood_ratio(delay, both, residual).p_value_corrected  # the lag beside a delay
    p_delay = likelihood_ratio(lag, both, residual).p_value_corrected  # the delay beside a lag
    together = (
        *parameter_and_error(both, "sensor_lag", "tau"),
        *parameter_and_error(both, "sensor_delay", "delay"),
    )
    decisive = delay_decisive(bic, z, p_lag, p_delay, together, rule)
    lag_s = parameter_and_error(lag, "sensor_lag", "tau")[0]
    return {
        "bic_difference": bic,
        "heldout_reduction": reduction,
        "heldout_z": z,
        "p_lag_beside_delay": p_lag,
        "p_delay_beside_lag": p_delay,
        "together_lag_s": together[0],
        "together_lag_stderr": together[1],
        "together_delay_s": together[2],
        "together_delay_stderr": together[3],
        "decisive": float(decisive),
        "delay_s": delay_s,
        "lag_s": lag_s,
        "ssr_lag": float(sum(lag.ssr.values())),
        "ssr_delay": float(sum(delay.ssr.values())),
        "phases": (
            tuple(phase_by_frequency(both, sp, channel, lag_s, delay_s)) if decisive else ()
        ),
    }


def check_lag_not_delay(test: dict[str, Any]) -> None:
    """Refuse a sensor lag that a pure time delay of the same channel fits decisively
    better (``test`` from :func:`delay_against_lag`). Raises :class:`ValidationError`
    (the hypothesis is recorded as failed with this reason); whether the delay is
    physics left is for :func:`delay_left` to say."""
    if not test["decisive"]:
        return
    raise ValidationError(
        f"sensor_lag: a pure time delay of {1e3 * test['delay_s']:.3g} ms (not in the "
        f"library) fits the channel better than a first-order lag of "
        f"{1e3 * test['lag_s']:.3g} ms (corrected BIC lower by {test['bic_difference']:.3g}, "
        f"held-out error {-100 * test['heldout_reduction']:+.2g} %, confirmed at z = "
        f"{test['heldout_z']:.2g} in noise units; the lag leaves "
        f"{test['ssr_lag'] / test['ssr_delay']:.3g} x the delay's residual power)"
    )


@dataclass(frozen=True)
class DelayLeft(Record):
    """A pure delay of a channel added to the final model (:func:`delay_left`).

    Attributes:
        channel: the recorded channel.
        delay_s: the fitted delay [s] (positive: the recording is late).
        p_value_corrected / heldout_reduction / structured_ratio: the final model with
            the delay against without, as every probe is judged
            (:func:`~suspenv.diagnosis.component.residual_left.beyond_library`).
        lag_bic: the corrected BIC difference that refused a sensor lag of the channel.
        remains: the delay is physics left that the library does not hold.
        phases: the phase lag of the channel per motion frequency beside what the lag and
            the delay predict (:func:`phase_by_frequency`, from the test that refused
            the lag).
    """

    channel: str
    delay_s: float
    p_value_corrected: float
    heldout_reduction: float
    structured_ratio: float
    lag_bic: float
    remains: bool
    phases: tuple[PhaseRow, ...] = ()

    def short(self) -> str:
        """A few words for the headline."""
        late = f"{1e3 * self.delay_s:.3g} ms"
        return f"the recorded {self.channel} is late by a pure time delay of {late}"

    def sentence(self) -> str:
        """One sentence for the verdict."""
        evidence = (
            f"it removes {self.structured_ratio:.2g} x the residual it leaves, corrected p = "
            f"{self.p_value_corrected:.2g}, held-out error {-100 * self.heldout_reduction:+.1f} "
            f"%; the library's first-order sensor lag fits worse, its corrected BIC higher by "
            f"{self.lag_bic:.3g}"
        )
        if table := phase_words(self.phases, self.channel):
            evidence += f"; {table}"
        if self.remains:
            return (
                f"unexplained, not in the library: the recorded {self.channel} is late by a "
                f"pure time delay of {1e3 * self.delay_s:.3g} ms at unit gain, a transport or "
                f"digital-filter delay of the acquisition ({evidence})"
            )
        return (
            f"a pure time delay of the {self.channel} ({1e3 * self.delay_s:.3g} ms) fits "
            f"better than a sensor lag but is not a finding added to the final model "
            f"({evidence})"
        )


def delay_left(
    final: FitResult, sp: Split, channel: str, test: dict[str, Any], budget: int, rule: DecisionRule
) -> DelayLeft:
    """Whether a pure delay of ``channel``, refitted on top of ``final`` from the delay of
    ``test`` (:func:`delay_against_lag`, the test that refused the lag), is physics left
    after the final model (module docstring, 2: judged by
    :func:`~suspenv.diagnosis.component.residual_left.beyond_library`); the test's BIC
    difference and phase table are carried as evidence."""
    delayed = fit_delay(final, sp, channel, test["delay_s"], budget)
    c, ratio, remains = beyond_library(final, delayed, sp, channel, rule)
    return DelayLeft(
        channel=channel,
        delay_s=parameter_and_error(delayed, "sensor_delay", "delay")[0],
        p_value_corrected=c.lr.p_value_corrected,
        heldout_reduction=c.heldout_reduction,
        structured_ratio=ratio,
        lag_bic=test["bic_difference"],
        remains=remains,
        phases=tuple(test.get("phases", ())),
    )


def judge_beside_delay(
    final: FitResult,
    named: Sequence[Hypothesis],
    channel: str,
    start: float,
    sp: Split,
    budget: int,
    rule: DecisionRule,
) -> tuple[FitResult, list[Withdrawal]]:
    """The elements ``named`` (each in ``final``'s model) judged again beside a pure delay
    of ``channel`` fitted on top from ``start`` [s] (module docstring, 4), by ``rule``
    (:func:`~suspenv.diagnosis.decision.decide`). Returns (the final model, the
    withdrawals in order)."""
    withdrawals: list[Withdrawal] = []
    left = [h for h in named if element_name(h) in {e.name for e in final.model.effects}]
    while left:
        delayed = fit_delay(final, sp, channel, start, budget)
        judged: list[tuple[Hypothesis, Hypothesis]] = []
        for h in left:
            reduced = without_element(delayed, str(element_name(h)), sp, budget)
            c = compare(reduced, delayed, sp)
            again = Hypothesis.from_comparison(
                h.kind, h.location, h.words, h.round, reduced, delayed, c
            )
            judged.append((h, again))
        decide([again for _, again in judged], 1, rule)
        if not (out := [(h, again) for h, again in judged if not again.significant]):
            break
        h, again = max(out, key=lambda pair: pair[1].p_value_corrected)
        late = parameter_and_error(delayed, "sensor_delay", "delay")[0]
        withdrawals.append(
            Withdrawal(
                hypothesis=h,
                beside=f"the delay of the {channel} found after it ({1e3 * late:.3g} ms)",
                p_value_corrected=again.p_value_corrected,
                delta_bic_corrected=again.delta_bic_corrected,
                heldout_reduction=again.heldout_reduction,
                beside_delay=True,
            )
        )
        final = without_element(final, str(element_name(h)), sp, budget)
        left = [x for x in left if x is not h]
    return final, withdrawals
