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
from suspenv.diagnosis.evidence import Comparison, compare, heldout_rms, ljung_box
from suspenv.diagnosis.evidence import fit_residual_series as _fit_residual_series
from suspenv.diagnosis.fit import FitResult, as_list, fit_model, residuals
from suspenv.diagnosis.locate import Location, Segment, locate
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


def split(recordings: Any, holdout: Any) -> Split:
    """``holdout``: a fraction in (0, 1) (the last part of each recording is held
    out), or one or more recordings not used for fitting."""
    recs = as_list(recordings)
    if holdout is None:
        holdout = 0.3
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
def _signal_set(fit: FitResult, sp: Split, channel: str) -> SignalSet:
    """Residual, prediction, motion and Jacobian rows of one channel over the fit samples."""
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


def _main_channel(fit: FitResult) -> str:
    return max(fit.channels, key=lambda c: fit.ssr[c] / (fit.scales[c] ** 2))


# ---------------------------------------------------------------- diagnosis
@dataclass
class Diagnosis:
    """Everything the engine found; ``to_dict()`` is the machine-readable report."""

    recording: str
    family: str
    holdout: str
    channel: str
    baseline: dict[str, Any]
    location: Location
    signatures: list[Signature]
    hypotheses: list[Hypothesis]
    named: list[Hypothesis]
    ambiguities: list[Ambiguity]
    verdict: str
    comparison: Comparison | None
    final_params: dict[str, dict[str, float]]
    seconds: float
    base_fit: FitResult = field(repr=False)
    final_fit: FitResult = field(repr=False)
    split: Split = field(repr=False)

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
    """
    t0 = time.perf_counter()
    model = resolve_model(model)
    sp = split(recording, holdout)
    cands = list(candidates if candidates is not None else model.candidate_effects)
    base = fit_model(model, sp.fit_recordings, sp.fit_masks, max_nfev=max_nfev)
    channel = _main_channel(base)
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
        sset = _signal_set(current, sp, channel)
        fams_needed = [f for f in SIGNATURE_KINDS if f in {family_of(k) for k in cands}]
        sigs = score_signatures(sset, fams_needed or SIGNATURE_KINDS)
        if rnd == 1:
            first_sigs = sigs
        sig_of = {s.kind: s for s in sigs}
        done = {h.family for h in named}
        fams = [s.kind for s in sigs if s.kind not in done][:screen_families]
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

    comparison = None
    if named:
        comparison = compare(
            base, current, sp.fit_recordings, sp.fit_masks, sp.heldout_recordings, sp.heldout_masks
        )
    verdict = _verdict(named, all_hyps, amb)
    base_res = _fit_residual_series(base, sp.fit_recordings, sp.fit_masks)
    baseline = {
        "params": base.params(),
        "fit_rms": base.rms(),
        "heldout_rms": heldout_rms(base, sp.heldout_recordings, sp.heldout_masks),
        "aic": base.aic(),
        "bic": base.bic(),
        "ljung_box": dict(zip(("Q", "p"), ljung_box(base_res), strict=True)),
        "effects": [e.to_dict() for e in current_effects(base.model)],
    }
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
    )


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
