"""The diagnosis engine: fit -> locate -> name -> model -> show.

``diagnose(recording, model, holdout=...)`` fits the baseline model, locates where
the residual lives, scores every signature, refits the model with the candidate
effects whose signatures are strongest, decides which are significant (see
:mod:`suspenv.diagnosis.name`), adds the winner as a physical element and repeats
(up to ``max_effects``), then compares the final model with the baseline on data
not used for fitting. The returned :class:`Diagnosis` holds everything and turns
into JSON with :meth:`Diagnosis.to_dict`.

Recordings: objects with ``name``, ``test``, ``time`` [s], ``inputs`` and ``outputs``
(dicts of channel arrays, SI units) and ``units``. The motion that drives the
component is the deflection ``x`` [m] (positive = compression / bump) and its
velocity ``v`` [m/s], found among the inputs by name, or the measured deflection of
a rig that imposes a road input (see :func:`motion`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.evidence import (
    Comparison,
    baseline_summary,
    compare,
    heldout_rms,
    scaled_rms,
)
from suspenv.diagnosis.fit import FitResult, as_list, fit_model, residuals
from suspenv.diagnosis.locate import Segment, locate
from suspenv.diagnosis.matched_speed import MatchedSpeedAsymmetry, matched_speed_asymmetry
from suspenv.diagnosis.name import (
    EQUIVALENT_COMBINATIONS,
    Ambiguity,
    Hypothesis,
    ambiguities,
    corrected_delta_bic,
    decide,
    family_of,
    rank,
    separating_test,
)
from suspenv.diagnosis.refit import current_effects, refit_with
from suspenv.diagnosis.signatures import SIGNATURE_KINDS, SignalSet, Signature, score_signatures
from suspenv.models.effects import make_effect

#: input names tried, in order, for the deflection and the velocity
DISPLACEMENT_KEYS = ("x", "displacement", "deflection", "stroke", "position", "q", "travel")
VELOCITY_KEYS = ("v", "velocity", "speed", "qd", "stroke_velocity")


def _find(d: dict[str, Any], keys: Sequence[str]) -> np.ndarray | None:
    lowered = {k.lower(): k for k in d}
    for k in keys:
        if k in lowered:
            return np.asarray(d[lowered[k]], float)
    for k in keys:  # prefix match, e.g. "position_measured"
        for low, orig in lowered.items():
            if low.startswith(k + "_") or low.startswith(k + " "):
                return np.asarray(d[orig], float)
    return None


def motion(rec: Any) -> tuple[np.ndarray, np.ndarray]:
    """Deflection ``x`` [m] and velocity ``v`` [m/s] driving the component in ``rec``."""
    t = np.asarray(rec.time, float)
    x = _find(rec.inputs, DISPLACEMENT_KEYS)
    v = _find(rec.inputs, VELOCITY_KEYS)
    if x is None and v is None:
        # a rig that imposes a road input and measures the deflection (quarter car)
        measured = [k for k in rec.outputs if "deflection" in k.lower()]
        if measured:
            x = np.asarray(rec.outputs[measured[0]], float)
    if x is None and v is None:
        if not rec.inputs:
            raise ValidationError(
                f"recording {rec.name!r} must have a motion input, but got no inputs"
            )
        x = np.asarray(next(iter(rec.inputs.values())), float)
    if x is None:
        x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    if v is None:
        v = np.gradient(x, t)
    return x, v


# ------------------------------------------------------------------ holdout
@dataclass
class Split:
    """Fit data and held-out data."""

    fit_recordings: list[Any]
    fit_masks: list[np.ndarray] | None
    heldout_recordings: list[Any]
    heldout_masks: list[np.ndarray] | None
    description: str
    cycles_every: int | None = None


def cycle_index(x: np.ndarray) -> np.ndarray:
    """Index of the motion cycle each sample belongs to (cycles start at the upward
    crossings of the deflection ``x`` [m] through its median; samples before the
    first crossing are cycle 0)."""
    xc = np.asarray(x, float) - float(np.median(x))
    starts = np.flatnonzero((xc[:-1] < 0.0) & (xc[1:] >= 0.0)) + 1
    return np.searchsorted(starts, np.arange(xc.size), side="right")


def interleaved_cycles(rec: Any, every: int = 4) -> np.ndarray:
    """Held-out mask: every ``every``-th motion cycle of ``rec`` (cycles 3, 7, 11, ...
    for ``every=4``), so fit and held-out data span the same amplitudes and speeds and
    each held-out block is a whole cycle (longer than the residual's correlation)."""
    if not (isinstance(every, int) and every >= 2):
        raise ValidationError(f"`every >= 2` (an integer) must hold, but got every={every!r}")
    cyc = cycle_index(motion(rec)[0])
    if cyc.max() + 1 < every:
        raise ValidationError(
            f"interleaved cycle hold-out needs at least {every} motion cycles, but recording "
            f"{getattr(rec, 'name', '?')!r} has {int(cyc.max()) + 1}"
        )
    return (cyc % every) == every - 1


def split(recordings: Any, holdout: Any) -> Split:
    """``holdout``: a fraction in (0, 1) (the last part of each recording is held
    out), ``"cycles"`` / ``"cycles:N"`` (every N-th motion cycle held out, N = 4 by
    default: see :func:`interleaved_cycles`), or one or more recordings not used for
    fitting."""
    recs = as_list(recordings)
    if holdout is None:
        holdout = 0.3
    if isinstance(holdout, str):
        head, _, num = holdout.partition(":")
        if head != "cycles":
            raise ValidationError(
                f"a text hold-out must be 'cycles' or 'cycles:N', but got holdout={holdout!r}"
            )
        try:
            every = int(num) if num else 4
        except ValueError:
            raise ValidationError(
                f"'cycles:N' needs an integer N, but got holdout={holdout!r}"
            ) from None
        hold_m = [interleaved_cycles(r, every) for r in recs]
        return Split(
            recs,
            [~m for m in hold_m],
            recs,
            hold_m,
            f"one motion cycle in {every} of each recording (interleaved: same speeds as the fit)",
            cycles_every=every,
        )
    if isinstance(holdout, float | int) and not isinstance(holdout, bool):
        f = float(holdout)
        if not 0.0 < f < 1.0:
            raise ValidationError(f"`0 < holdout < 1` must hold, but got holdout={f}")
        fit_m, hold_m = [], []
        for r in recs:
            n = len(r.time)
            cut = int(round(n * (1.0 - f)))
            m = np.arange(n) < cut
            fit_m.append(m)
            hold_m.append(~m)
        return Split(recs, fit_m, recs, hold_m, f"last {100 * f:.0f} % of each recording")
    hold = as_list(holdout)
    names = ", ".join(str(getattr(h, "name", "?")) for h in hold)
    return Split(recs, None, hold, None, f"separate recording(s): {names}")


# ------------------------------------------------------------------ signals
def _force_view_signal_set(fit: FitResult, sp: Split) -> SignalSet | None:
    """The signal set of a model's force view (``model.force_view(theta, rec)``, e.g. the
    suspension force of a quarter car through its body equation), or None."""
    view_of = getattr(fit.model, "force_view", None)
    if not callable(view_of):
        return None
    views = [view_of(fit.theta, rec) for rec in sp.fit_recordings]
    if any(v is None for v in views):
        return None
    sel = [
        np.ones(len(r.time), bool) if sp.fit_masks is None else sp.fit_masks[i]
        for i, r in enumerate(sp.fit_recordings)
    ]
    meas = np.concatenate([v["measured"][m] for v, m in zip(views, sel, strict=True)])
    scale = float(np.std(meas)) or 1.0

    def cat(key: str) -> np.ndarray:
        return np.concatenate([v[key][m] for v, m in zip(views, sel, strict=True)])

    return SignalSet(
        t=np.concatenate(
            [np.asarray(r.time, float)[m] for r, m in zip(sp.fit_recordings, sel, strict=True)]
        ),
        x=cat("x"),
        v=cat("v"),
        residual=(meas - cat("predicted")) / scale,
        prediction=cat("predicted") / scale,
        jacobian=cat("jacobian") / scale,
        segment=np.concatenate([np.full(int(m.sum()), i) for i, m in enumerate(sel)]),
        scale=scale,
        unit="N",
        channel="force",
    )


#: signature families of sensor errors: they live in a recorded channel, not in the force
#: a component transmits, so a force view cannot show them (a gain error on the measured
#: force is a scaled copy of the base force, inside the span of the base parameters)
SENSOR_FAMILIES = ("sensor_offset", "sensor_gain", "sensor_lag")


def _signal_set(fit: FitResult, sp: Split, channel: str, view: bool = True) -> SignalSet:
    """Residual, prediction, motion and Jacobian rows of one channel over the fit samples.

    A model with a force view (see :func:`_force_view_signal_set`) is screened in it
    instead (unless ``view`` is False): its signatures are those of the missing force
    itself.
    """
    viewed = _force_view_signal_set(fit, sp) if view else None
    if viewed is not None:
        return viewed
    ts, xs, vs, rs, ps, seg, rows = [], [], [], [], [], [], []
    offset = 0
    for i, rec in enumerate(sp.fit_recordings):
        m = None if sp.fit_masks is None else sp.fit_masks[i]
        pred = fit.model.simulate(fit.theta, rec)
        x, v = motion(rec)
        sel = np.ones(len(rec.time), bool) if m is None else m
        n = int(np.count_nonzero(sel))
        for c in fit.channels:
            if c == channel:
                rows.append(np.arange(offset, offset + n))
            offset += n
        ts.append(np.asarray(rec.time, float)[sel])
        xs.append(x[sel])
        vs.append(v[sel])
        meas = np.asarray(rec.outputs[channel], float)[sel]
        p = np.asarray(pred[channel], float)[sel]
        rs.append((meas - p) / fit.scales[channel])
        ps.append(p / fit.scales[channel])
        seg.append(np.full(n, i))
    J = fit.extra.get("jacobian")
    jac = None
    if J is not None and J.shape[0] == offset:
        jac = J[np.concatenate(rows)]
    unit = ""
    units = getattr(sp.fit_recordings[0], "units", {}) or {}
    unit = str(units.get(channel, ""))
    return SignalSet(
        t=np.concatenate(ts),
        x=np.concatenate(xs),
        v=np.concatenate(vs),
        residual=np.concatenate(rs),
        prediction=np.concatenate(ps),
        jacobian=jac,
        segment=np.concatenate(seg),
        scale=fit.scales[channel],
        unit=unit,
        channel=channel,
    )


def _segments(fit: FitResult, sp: Split) -> list[Segment]:
    out = []
    parts = residuals(fit.model, fit.theta, sp.fit_recordings, fit.channels, sp.fit_masks)
    for i, rec in enumerate(sp.fit_recordings):
        m = None if sp.fit_masks is None else sp.fit_masks[i]
        sel = np.ones(len(rec.time), bool) if m is None else m
        x, v = motion(rec)
        out.append(
            Segment(
                test=str(getattr(rec, "test", "") or getattr(rec, "name", f"recording {i}")),
                t=np.asarray(rec.time, float)[sel],
                x=x[sel],
                v=v[sel],
                residual={c: parts[i][c] / fit.scales[c] for c in fit.channels},
            )
        )
    return out


def main_channel(fit: FitResult) -> str:
    """The channel holding the largest scaled residual of a fit."""
    return max(fit.channels, key=lambda c: fit.ssr[c] / (fit.scales[c] ** 2))


# ---------------------------------------------------------------- diagnosis
@dataclass
class Findings:
    """What a diagnosis found, in the form every diagnosis (components, K&C, ride) shares;
    ``to_dict()`` is the machine-readable report.

    ``location`` and ``signatures`` are the flavour's own residual map and signature
    records (each with ``to_dict()``).
    """

    recording: str
    family: str
    holdout: str
    channel: str
    baseline: dict[str, Any]
    location: Any
    signatures: list[Any]
    hypotheses: list[Hypothesis]
    named: list[Hypothesis]
    ambiguities: list[Ambiguity]
    verdict: str
    comparison: Comparison | None
    final_params: dict[str, dict[str, float]]
    seconds: float
    base_fit: FitResult = field(repr=False)
    final_fit: FitResult = field(repr=False)

    @property
    def named_kinds(self) -> list[str]:
        return [h.kind for h in self.named]

    @property
    def named_families(self) -> list[str]:
        return [h.family for h in self.named]

    def to_dict(self) -> dict[str, Any]:
        return {
            "recording": self.recording,
            "family": self.family,
            "holdout": self.holdout,
            "channel": self.channel,
            "verdict": self.verdict,
            "named": [
                {"kind": h.kind, "family": h.family, "words": h.words, "params": h.params}
                for h in self.named
            ],
            "ambiguities": [a.to_dict() for a in self.ambiguities],
            "baseline": self.baseline,
            "final_params": self.final_params,
            "comparison": self.comparison.to_dict() if self.comparison else None,
            "location": self.location.to_dict(),
            "signatures": [s.to_dict() for s in self.signatures],
            "hypotheses": [h.to_dict() for h in self.hypotheses],
            "seconds": self.seconds,
        }


@dataclass
class Diagnosis(Findings):
    """Everything the component engine found (:class:`Findings` plus its data split and
    the damper asymmetry check)."""

    split: Split = field(repr=False)
    asymmetry: AsymmetryCheck | None = None

    def to_dict(self) -> dict[str, Any]:
        out = super().to_dict()
        out["asymmetry"] = self.asymmetry.to_dict() if self.asymmetry else None
        return out


@dataclass
class AsymmetryCheck:
    """Bump/rebound asymmetry of a damper curve, tested against a constant force.

    ``ratio`` is the rebound force over the bump force of the velocity-dependent
    curve (linear base plus digressive element) at ``v_ref`` [m/s], minus one
    (positive: rebound stronger); ``ratio_stderr`` its standard error from the
    parameter covariance inflated for serially correlated residuals (AR(1)
    effective sample size); with an interleaved-cycle split, ``fold_ratios`` and
    ``fold_heldout_reductions`` repeat the comparison with each group of cycles held
    out in turn (block cross-validation, robust to serial correlation) and
    ``ratio_stderr_folds`` is their jackknife standard error. The null model has the
    symmetric curve plus a constant force (gas force / offset; the base model's own
    ``f_0`` where it has one); the
    alternative gives bump and rebound their own slope and knee. ``matched_speed`` is
    the model-free check on cyclic strokes (:mod:`suspenv.diagnosis.matched_speed`):
    the bump + rebound force at matched speeds, against a constant and a drifting zero.
    """

    v_ref: float
    ratio: float
    ratio_stderr: float
    offset: float
    heldout_reduction: float
    lr_statistic_corrected: float
    p_value_corrected: float
    delta_bic_corrected: float
    supported: bool
    sentence: str
    params: dict[str, dict[str, float]] = field(default_factory=dict)
    fold_ratios: list[float] = field(default_factory=list)
    fold_heldout_reductions: list[float] = field(default_factory=list)
    ratio_stderr_folds: float = float("nan")
    matched_speed: MatchedSpeedAsymmetry | None = None
    hypothesis: Hypothesis | None = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        out = {k: v for k, v in self.__dict__.items() if k not in ("hypothesis", "matched_speed")}
        out["matched_speed"] = self.matched_speed.to_dict() if self.matched_speed else None
        return out


def _curve_force(fit: FitResult, v: float) -> float:
    """Velocity-dependent damper force [N] at velocity ``v``: linear base plus the
    (a)symmetric digressive element of ``fit`` (hysteresis, lag and offset left out)."""
    p = dict(zip(fit.names, fit.theta, strict=True))
    f = float(p.get("c", 0.0)) * v
    for e in current_effects(fit.model):
        if e.kind in ("digressive_damping", "asymmetric_digressive_damping"):
            own = {k.split(".", 1)[1]: val for k, val in p.items() if k.startswith(e.name + ".")}
            f += float(e.with_params(own).force(np.zeros(1), np.array([v]))[0])
    return f


def _rebound_bump_ratio(fit: FitResult, v_ref: float) -> tuple[float, float]:
    """Rebound over bump force of the curve at ``v_ref``, minus one, and its standard
    error (delta method; covariance inflated like ``stderr_corrected``)."""

    def ratio(theta: np.ndarray) -> float:
        trial = FitResult(**{**fit.__dict__, "theta": theta})
        return -_curve_force(trial, -v_ref) / _curve_force(trial, v_ref) - 1.0

    r0 = ratio(fit.theta)
    grad = np.zeros(fit.theta.size)
    for i in range(fit.theta.size):
        h = 1e-6 * max(abs(fit.theta[i]), 1.0)
        th = fit.theta.copy()
        th[i] += h
        grad[i] = (ratio(th) - r0) / h
    infl = np.where(fit.stderr > 0, fit.stderr_corrected / np.maximum(fit.stderr, 1e-300), 1.0)
    cov = fit.covariance * np.outer(infl, infl)
    return r0, float(np.sqrt(max(grad @ cov @ grad, 0.0)))


def asymmetry_check(
    fit: FitResult,
    sp: Split,
    alpha: float = 0.01,
    min_heldout_gain: float = 0.01,
    max_nfev: int = 200,
) -> AsymmetryCheck | None:
    """Is the damper curve of ``fit`` asymmetric between bump and rebound?

    Needs a ``digressive_damping`` element in ``fit.model`` (else None). Null model:
    the fitted model plus a constant force (unless it has one); alternative: the same
    with the digressive element replaced by ``asymmetric_digressive_damping`` (start:
    both branches at the symmetric values). The asymmetry is *supported* when the
    likelihood-ratio test corrected for serial correlation passes (p < ``alpha``), the
    corrected BIC falls, the held-out error falls by at least ``min_heldout_gain``, and
    the ratio differs from zero by more than two standard errors; or when the
    model-free matched-speed check rejects a constant force and a drifting zero and the
    asymmetric refit lowers the held-out error.
    """
    effects = current_effects(fit.model)
    dig = [e for e in effects if e.kind == "digressive_damping"]
    if not dig:
        return None
    null = fit
    base_offset = "f_0" in fit.names  # a base model with its own constant force
    if not base_offset and not any(e.kind in ("force_offset", "gas_spring") for e in effects):
        null = refit_with(fit, "force_offset", sp.fit_recordings, sp.fit_masks, max_nfev=max_nfev)
    vals = dict(zip(null.names, null.theta, strict=True))
    d = dig[0]
    c_low, v_knee = vals[f"{d.name}.c_low"], vals[f"{d.name}.v_knee"]
    asym = make_effect(
        "asymmetric_digressive_damping",
        location=d.location,
        c_bump=c_low,
        v_knee_bump=v_knee,
        c_rebound=c_low,
        v_knee_rebound=v_knee,
    )
    alt_effects = tuple(asym if e.name == d.name else e for e in current_effects(null.model))
    alt_model = null.model.with_effects(alt_effects)
    theta0 = {k: v for k, v in vals.items() if not k.startswith(d.name + ".")}
    theta0.update({f"{asym.name}.{k}": float(v) for k, v in asym.params.items()})
    alt = fit_model(alt_model, sp.fit_recordings, sp.fit_masks, theta0=theta0, max_nfev=max_nfev)
    alt.extra["effect"] = asym.to_dict()
    comp = compare(
        null, alt, sp.fit_recordings, sp.fit_masks, sp.heldout_recordings, sp.heldout_masks
    )
    v_all = np.concatenate([np.abs(motion(r)[1]) for r in sp.fit_recordings])
    v_ref = float(np.percentile(v_all, 99))
    ratio, se = _rebound_bump_ratio(alt, v_ref)
    dbic = corrected_delta_bic(comp.lr.statistic_corrected, comp.lr.dof, null.n_samples)
    fold_r, fold_h = _cycle_folds(null, alt, sp, v_ref, max_nfev)
    se_folds = float("nan")
    if len(fold_r) > 1:
        k = len(fold_r)
        se_folds = float(np.sqrt((k - 1) / k * np.sum((np.array(fold_r) - np.mean(fold_r)) ** 2)))
    se_all = float(np.nanmax([se, se_folds]))
    folds_agree = not fold_h or float(np.mean(fold_h)) >= min_heldout_gain
    supported = bool(
        comp.lr.p_value_corrected < alpha
        and dbic < 0.0
        and comp.heldout_reduction >= min_heldout_gain
        and folds_agree
        and abs(ratio) > 2.0 * se_all
    )
    matched = _matched_speed(sp, alpha)
    if matched is not None and matched.supported and comp.heldout_reduction > 0.0:
        supported = True
    off_name = next(
        (e.name for e in current_effects(null.model) if e.kind in ("force_offset", "gas_spring")),
        "",
    )
    off_keys = (f"{off_name}.offset", f"{off_name}.f_0") + (("f_0",) if base_offset else ())
    off_key = next((k for k in off_keys if k in alt.names), None)
    offset = float(alt.theta[alt.names.index(off_key)]) if off_key else float("nan")
    side = "rebound" if ratio >= 0 else "bump"
    folds = ""
    if fold_h:
        folds = (
            f", mean held-out change over {len(fold_h)} cycle folds "
            f"{-100 * float(np.mean(fold_h)):+.1f} %"
        )
    numbers = (
        f"bump/rebound asymmetry of {100 * ratio:+.1f} % ± {100 * se_all:.1f} % ({side} "
        f"stronger at {v_ref:.3g} m/s, {abs(ratio) / se_all:.1f} standard errors; constant "
        f"force (gas force / offset) {offset:.3g} N in both models; held-out error change "
        f"{-100 * comp.heldout_reduction:+.1f} %{folds}; corrected p = "
        f"{comp.lr.p_value_corrected:.2g}, corrected BIC change {dbic:+.1f})"
    )
    if supported:
        sentence = f"{numbers}: supported by this recording"
    elif matched is not None:
        sentence = f"{numbers}: not supported by the fitted curve alone"
    else:
        sentence = (
            f"{numbers}: below what this recording can separate from an offset; a test at "
            "higher velocity / a pure sine sweep would separate them (an asymmetry grows "
            "with speed, a gas force or offset does not)"
        )
    if matched is not None:
        sentence = f"{sentence}. Model-free check, {matched.sentence}"
    own = {k: v for k, v in alt.params().items() if k.startswith(asym.name + ".")}
    hyp = Hypothesis(
        kind=asym.kind,
        family=family_of(asym.kind),
        words=_effect_words(asym.kind, fit.model),
        round=0,
        signature_score=float("nan"),
        signature_evidence=numbers,
        lr_statistic=comp.lr.statistic,
        lr_statistic_corrected=comp.lr.statistic_corrected,
        lr_dof=comp.lr.dof,
        p_value_corrected=comp.lr.p_value_corrected,
        delta_bic_corrected=dbic,
        heldout_reduction=comp.heldout_reduction,
        params=own,
        significant=supported,
        fit=alt,
        comparison=comp,
    )
    return AsymmetryCheck(
        v_ref=v_ref,
        ratio=float(ratio),
        ratio_stderr=float(se),
        offset=offset,
        heldout_reduction=float(comp.heldout_reduction),
        lr_statistic_corrected=float(comp.lr.statistic_corrected),
        p_value_corrected=float(comp.lr.p_value_corrected),
        delta_bic_corrected=float(dbic),
        supported=supported,
        sentence=sentence,
        params=own,
        fold_ratios=fold_r,
        fold_heldout_reductions=fold_h,
        ratio_stderr_folds=se_folds,
        matched_speed=matched,
        hypothesis=hyp,
    )


def _matched_speed(sp: Split, alpha: float) -> MatchedSpeedAsymmetry | None:
    """The model-free matched-speed test (:mod:`suspenv.diagnosis.matched_speed`) on
    the first fitted recording with a force channel and enough matched speeds."""
    for rec in sp.fit_recordings:
        force = getattr(rec, "outputs", {}).get("force")
        if force is None:
            continue
        x, v = motion(rec)
        out = matched_speed_asymmetry(rec.time, v, force, x, alpha=alpha)
        if out is not None:
            return out
    return None


def _cycle_folds(
    null: FitResult, alt: FitResult, sp: Split, v_ref: float, max_nfev: int
) -> tuple[list[float], list[float]]:
    """Block cross-validation over interleaved cycles (only for a ``"cycles"`` split):
    for each group ``g`` of cycles (cycle index mod N == g) refit both models on the
    other cycles, and return the asymmetry ratio of each refit and the relative
    reduction of the held-out RMS error on group ``g`` (same scaling as ``compare``)."""
    every = sp.cycles_every
    if not every or sp.fit_masks is None:
        return [], []
    recs = sp.fit_recordings
    cycs = [cycle_index(motion(r)[0]) for r in recs]
    ratios, gains = [], []
    for g in range(every):
        hold = [(c % every) == g for c in cycs]
        fit_m = [~m for m in hold]
        n0 = fit_model(null.model, recs, fit_m, theta0=null.theta, max_nfev=max_nfev)
        n1 = fit_model(alt.model, recs, fit_m, theta0=alt.theta, max_nfev=max_nfev)
        before = scaled_rms(heldout_rms(n0, recs, hold), n0.scales)
        after = scaled_rms(heldout_rms(n1, recs, hold), n0.scales)
        ratios.append(_rebound_bump_ratio(n1, v_ref)[0])
        gains.append(float(1.0 - after / before) if before > 0 else 0.0)
    return ratios, gains


def resolve_model(model: Any) -> Any:
    """A component model instance, or a family name (``suspenv.models.components``)."""
    if not isinstance(model, str):
        return model
    from suspenv.models.components import make_component

    return make_component(model)


def effect_location(model: Any, kind: str) -> str:
    """Where a force effect of ``kind`` lives in ``model`` (sensor effects: "")."""
    if make_effect(kind).spec.role != "force":
        return ""
    return str(getattr(model, "location", "") or "")


def _effect_words(kind: str, model: Any = None) -> str:
    """Engineering words, e.g. "Coulomb friction in the guide"."""
    return make_effect(kind, location=effect_location(model, kind)).words


def _hypothesis(
    kind: str,
    rnd: int,
    sig: Signature | None,
    current: FitResult,
    ext: FitResult,
    sp: Split,
) -> Hypothesis:
    comp = compare(
        current, ext, sp.fit_recordings, sp.fit_masks, sp.heldout_recordings, sp.heldout_masks
    )
    own = {k: v for k, v in ext.params().items() if k.startswith(ext.extra["effect"]["name"] + ".")}
    return Hypothesis(
        kind=kind,
        family=family_of(kind),
        words=_effect_words(kind, current.model),
        round=rnd,
        signature_score=float(sig.score) if sig else float("nan"),
        signature_evidence=sig.evidence if sig else "",
        lr_statistic=comp.lr.statistic,
        lr_statistic_corrected=comp.lr.statistic_corrected,
        lr_dof=comp.lr.dof,
        p_value_corrected=comp.lr.p_value_corrected,
        delta_bic_corrected=corrected_delta_bic(
            comp.lr.statistic_corrected, comp.lr.dof, current.n_samples
        ),
        heldout_reduction=comp.heldout_reduction,
        params=own,
        fit=ext,
        comparison=comp,
    )


def diagnose(
    recording: Any,
    model: Any,
    holdout: Any = 0.3,
    candidates: Sequence[str] | None = None,
    max_effects: int = 2,
    screen_families: int = 4,
    alpha: float = 0.01,
    min_heldout_gain: float = 0.01,
    strong_heldout_gain: float | None = 0.1,
    max_nfev: int = 200,
    check_asymmetry: bool = True,
) -> Diagnosis:
    """Diagnose what ``model`` leaves out of ``recording``.

    Args:
        recording: one recording or a list (fitted jointly).
        model: a component model instance or its family name.
        holdout: fraction of each recording held out at its end, or separate recordings.
        candidates: effect kinds to consider (default: the model's ``candidate_effects``).
        max_effects: most effects added in turn.
        screen_families: refit the candidates of this many families with the strongest
            signatures per round (the rest are reported by signature only).
        alpha: family-wise significance level (Bonferroni over the refits of a round).
        min_heldout_gain: least relative reduction of held-out RMS error to claim an effect.
        strong_heldout_gain: a held-out reduction this large also lets the uncorrected
            likelihood-ratio test decide (None: only the corrected test).
        check_asymmetry: where a digressive damper curve is named and bump/rebound
            asymmetry is a candidate (not yet named), test the asymmetric curve against
            the symmetric one plus a constant force (:func:`asymmetry_check`); when it is
            supported it is named too.
    """
    t0 = time.perf_counter()
    model = resolve_model(model)
    sp = split(recording, holdout)
    cands = list(candidates if candidates is not None else model.candidate_effects)
    base = fit_model(model, sp.fit_recordings, sp.fit_masks, max_nfev=max_nfev)
    channel = main_channel(base)
    location = locate(_segments(base, sp))
    x_all = np.concatenate([motion(r)[0] for r in sp.fit_recordings])
    v_all = np.concatenate([motion(r)[1] for r in sp.fit_recordings])
    half = 0.5 * float(np.ptp(x_all))
    vmax = float(np.max(np.abs(v_all)))

    current = base
    all_hyps: list[Hypothesis] = []
    named: list[Hypothesis] = []
    first_sigs: list[Signature] = []
    amb: list[Ambiguity] = []
    parents: list[FitResult] = []
    for rnd in range(1, max_effects + 1):
        sigs, viewed = _score_round(current, sp, channel, cands)
        if rnd == 1:
            first_sigs = sigs
        sig_of = {s.kind: s for s in sigs}
        done = {h.family for h in named}
        fams = [s.kind for s in sigs if s.kind not in done][:screen_families]
        if viewed:
            # sensor families are scored in the recorded channels, force families in the
            # force view: the two scores are not on one scale, so besides the strongest
            # families of either kind the strongest sensor family is always refitted
            fams += [s.kind for s in sigs if s.kind in SENSOR_FAMILIES and s.kind not in done][:1]
            fams = list(dict.fromkeys(fams))
        kinds = [k for k in cands if family_of(k) in fams]
        hyps = []
        for kind in kinds:
            try:
                ext = refit_with(
                    current,
                    kind,
                    sp.fit_recordings,
                    sp.fit_masks,
                    sig_of.get(family_of(kind)),
                    half,
                    vmax,
                    location=effect_location(model, kind),
                    max_nfev=max_nfev,
                )
            except (ValidationError, np.linalg.LinAlgError) as exc:  # pragma: no cover
                ext = None
                msg = str(exc)
            if ext is None:
                all_hyps.append(
                    Hypothesis(
                        kind,
                        family_of(kind),
                        _effect_words(kind, model),
                        rnd,
                        0.0,
                        msg,
                        0.0,
                        0.0,
                        0,
                        1.0,
                        np.inf,
                        0.0,
                    )
                )
                continue
            hyps.append(_hypothesis(kind, rnd, sig_of.get(family_of(kind)), current, ext, sp))
        decide(hyps, len(hyps), alpha, min_heldout_gain, strong_heldout_gain)
        ranked = rank(hyps)
        all_hyps += ranked
        amb += ambiguities(ranked)
        if not ranked or not ranked[0].significant:
            break
        named.append(ranked[0])
        parents.append(current)
        current = ranked[0].fit

    for h, parent in zip(named, parents, strict=True):
        amb += _structural_ambiguity(h, parent, cands, sp, max_nfev)

    asym = None
    if (
        check_asymmetry
        and "digressive_damping" in [h.kind for h in named]
        and "damper_asymmetry" in cands
        and "damper_asymmetry" not in {h.family for h in named}
    ):
        asym = asymmetry_check(current, sp, alpha, min_heldout_gain, max_nfev)
        if asym is not None and asym.supported and asym.hypothesis is not None:
            named.append(asym.hypothesis)
            all_hyps.append(asym.hypothesis)
            current = asym.hypothesis.fit

    comparison = None
    if named:
        comparison = compare(
            base, current, sp.fit_recordings, sp.fit_masks, sp.heldout_recordings, sp.heldout_masks
        )
    verdict = _verdict(named, all_hyps, amb)
    if asym is not None and not asym.supported:
        verdict += f". {asym.sentence[0].upper()}{asym.sentence[1:]}"
    baseline = baseline_summary(
        base, sp.fit_recordings, sp.heldout_recordings, sp.fit_masks, sp.heldout_masks
    )
    baseline["effects"] = [e.to_dict() for e in current_effects(base.model)]
    names = ", ".join(str(getattr(r, "name", "?")) for r in sp.fit_recordings)
    return Diagnosis(
        recording=names,
        family=str(getattr(model, "family", type(model).__name__)),
        holdout=sp.description,
        channel=channel,
        baseline=baseline,
        location=location,
        signatures=first_sigs,
        hypotheses=all_hyps,
        named=named,
        ambiguities=amb,
        verdict=verdict,
        comparison=comparison,
        final_params=current.params(),
        seconds=time.perf_counter() - t0,
        base_fit=base,
        final_fit=current,
        split=sp,
        asymmetry=asym,
    )


def _score_round(
    current: FitResult, sp: Split, channel: str, cands: Sequence[str]
) -> tuple[list[Signature], bool]:
    """Signature scores of one round, strongest first, and whether the model's force
    view was used. Where the model has a force view, force families are scored in it and
    sensor families in each recorded channel."""
    fams_needed = [f for f in SIGNATURE_KINDS if f in {family_of(k) for k in cands}]
    fams_needed = fams_needed or list(SIGNATURE_KINDS)
    sset = _force_view_signal_set(current, sp)
    if sset is None:
        return score_signatures(_signal_set(current, sp, channel, view=False), fams_needed), False
    force_fams = [f for f in fams_needed if f not in SENSOR_FAMILIES]
    sensor_fams = [f for f in fams_needed if f in SENSOR_FAMILIES]
    sigs = score_signatures(sset, force_fams) if force_fams else []
    best: dict[str, Signature] = {}
    for ch in current.channels if sensor_fams else []:
        # each recorded channel may carry its own sensor error: keep the strongest
        for sig in score_signatures(_signal_set(current, sp, ch, view=False), sensor_fams):
            if sig.kind not in best or sig.score > best[sig.kind].score:
                sig.evidence = f"{sig.evidence} in {ch}"
                best[sig.kind] = sig
    return sorted(sigs + list(best.values()), key=lambda g: -g.score), True


def _structural_ambiguity(
    h: Hypothesis, parent: FitResult, cands: Sequence[str], sp: Split, max_nfev: int
) -> list[Ambiguity]:
    """Refit the equivalent combination of a named effect; equal fit -> ambiguity."""
    if h.kind not in EQUIVALENT_COMBINATIONS:
        return []
    (k1, k2), words = EQUIVALENT_COMBINATIONS[h.kind]
    fit = parent
    for k in (k1, k2):
        fit = refit_with(fit, k, sp.fit_recordings, sp.fit_masks, max_nfev=max_nfev)
    lr_combo = 2.0 * (fit.log_likelihood() - parent.log_likelihood())
    if abs(lr_combo - h.lr_statistic) > max(0.05 * h.lr_statistic, 10.0):
        return []
    test, reason = separating_test(family_of(k1), family_of(k2))
    return [Ambiguity(h.kind, f"{k1}+{k2}", h.words, words, test, reason)]


def _verdict(named: list[Hypothesis], hyps: list[Hypothesis], amb: list[Ambiguity]) -> str:
    if not named:
        best = min(hyps, key=lambda h: h.p_value_corrected, default=None)
        tail = ""
        if best is not None:
            tail = (
                f" (strongest candidate, {best.words}: corrected p = {best.p_value_corrected:.2g}, "
                f"held-out error change {-100 * best.heldout_reduction:+.1f} %)"
            )
        return "no significant missing physics" + tail
    words = "; then ".join(h.words for h in named)
    text = f"missing physics: {words}"
    if amb:
        text += ". " + " ".join(a.sentence() for a in amb)
    return text
