"""The component family: a damper, MR damper or friction guide on a dyno, a quarter car on a rig.

The model is a :class:`~suspenv.models.components.base.ComponentModel` (a base law
plus effects of :mod:`suspenv.models.effects`). Its pieces of the one loop
(:mod:`suspenv.diagnosis.engine`):

* **split**: a fraction at the end of each recording, interleaved motion cycles, or
  separate recordings (:func:`~suspenv.diagnosis.component.motion.split`);
* **locate**: residual energy by test, channel, branch, near reversals, amplitude
  (:func:`suspenv.diagnosis.component.locate.locate`);
* **screen**: signature scores of each effect family on the residual
  (:mod:`suspenv.diagnosis.component.signatures`); a model with a force view (the quarter car's
  suspension force through its body equation) is screened in it for force effects,
  and in every recorded channel for sensor errors (a sensor error on each recorded
  channel is a candidate of its own, :func:`located_candidates`); the candidates of
  the ``screen_families`` strongest families are refitted (with a force view, every
  sensor placement too: the two scores are not on one scale);
* **refit**: the element added with start values read off its signature
  (:func:`suspenv.diagnosis.component.refit.refit_with`), then the refit checks
  (:meth:`ComponentFamily.refit_checks`);
* **ambiguities** (read by :mod:`suspenv.diagnosis.checks.separability`): an element
  that equals a combination of two others on most data (direction-dependent friction =
  Coulomb friction + a constant force) is refitted as that combination; an equal fit is
  reported as an ambiguity;
* **checks** after the search (:meth:`ComponentFamily.checks`): the damper bump/rebound
  asymmetry, elements withdrawn beside a delay or a drift, what the library lacks.

Units: SI; residuals divided by each channel's measured spread.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, cast

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.checks.finding import Check, Context, Finding
from suspenv.diagnosis.checks.residual_left import Left
from suspenv.diagnosis.component import plausible
from suspenv.diagnosis.component.assumed import estimate_unsprung_mass, mass_words, power_sign
from suspenv.diagnosis.component.asymmetry import asymmetry_check
from suspenv.diagnosis.component.dead_band import DEFICIT_KIND, dead_band_left
from suspenv.diagnosis.component.delay import (
    DelayLeft,
    check_lag_not_delay,
    delay_against_lag,
    delay_left,
    fit_delay,
    judge_beside_delay,
)
from suspenv.diagnosis.component.drift_check import judge_beside_drift
from suspenv.diagnosis.component.locate import Segment, locate
from suspenv.diagnosis.component.motion import (
    check_cycles,
    cycle_index,
    interleaved_cycles,
    motion,
    split,
    stroke,
)
from suspenv.diagnosis.component.motion_inputs import (
    OUTPUT_LOWPASS_HARMONICS,
    MotionCheck,
    choice_words,
    conditioned,
    harmonics_kept,
    low_passed_outputs,
    motion_versions,
    preferred_version,
)
from suspenv.diagnosis.component.plausible import branch_share_unresolved
from suspenv.diagnosis.component.refit import parameter_and_error, refit_with
from suspenv.diagnosis.component.residual_left import MOVING_FRACTION, ResidualLeft, residual_left
from suspenv.diagnosis.component.rig import (
    RigDescription,
    baseline_families,
    baseline_model,
    baseline_words,
    check_extra_inputs,
    describe_rig,
    drift_over_fit,
    oriented,
    read_model_file,
)
from suspenv.diagnosis.component.signatures import SIGNATURE_KINDS, SignalSet, score_signatures
from suspenv.diagnosis.component.transducer import curvature_left
from suspenv.diagnosis.component.withdrawal import without_element
from suspenv.diagnosis.decision import (
    EQUIVALENT_COMBINATIONS,
    DecisionRule,
    fit_alike,
    separating_test,
)
from suspenv.diagnosis.family import (
    Conclusion,
    OptionalSteps,
    Outcome,
    Screening,
    Setup,
    SignatureLike,
)
from suspenv.diagnosis.fitting import FitResult, fit, residuals
from suspenv.diagnosis.hypothesis import (
    Ambiguity,
    Hypothesis,
    Withdrawal,
    candidate_name,
    family_of,
    split_candidate,
)
from suspenv.diagnosis.protocols import DiagnosableModel, RecordingLike
from suspenv.diagnosis.screening import Location, Signature
from suspenv.diagnosis.split import Holdout, Recordings, Split, as_recordings
from suspenv.diagnosis.unrecorded import unprofiled
from suspenv.models.components import make_component
from suspenv.models.components.base import ComponentModel
from suspenv.models.effects import make_effect

#: the default held-out data: one motion cycle in four, interleaved, so the held-out data
#: span the amplitudes, frequencies and travel of the fitted ones (a fraction at the end
#: of a dyno programme holds only its last speeds, and a drift model fitted before it
#: would be extrapolated)
DEFAULT_HOLDOUT = "cycles"
#: fewer motion cycles than this in a recording: the default falls back to the last
#: :data:`FALLBACK_FRACTION` of each recording (the sufficiency rules then judge it). The
#: first and the last cycle of a recording are partial (:func:`cycle_index`), so the
#: first held-out cycle (the fourth, index 3) lies inside the recording from 5 cycles on;
#: a fallback fraction extrapolates the fitted zero drift into the held-out span
MIN_CYCLES_INTERLEAVED = 5
FALLBACK_FRACTION = 0.3
#: the held-out cycles' least share of a recording's samples (the default's is about a
#: quarter): uneven cycles (a road input whose bump makes most of the travel) can leave
#: the fourth cycles a few samples, and the default falls back to the fraction
MIN_HELDOUT_SHARE = 0.05


def default_holdout(recordings: Sequence[Any]) -> str | float:
    """:data:`DEFAULT_HOLDOUT`, or :data:`FALLBACK_FRACTION` when a recording has fewer
    than :data:`MIN_CYCLES_INTERLEAVED` motion cycles to interleave or its held-out
    cycles would hold under :data:`MIN_HELDOUT_SHARE` of its samples."""
    for rec in recordings:
        if int(cycle_index(motion(rec)[0]).max()) + 1 < MIN_CYCLES_INTERLEAVED or (
            np.mean(interleaved_cycles(rec)) < MIN_HELDOUT_SHARE
        ):
            return FALLBACK_FRACTION
    return DEFAULT_HOLDOUT


#: refit the candidates of this many signature families per round (default)
SCREEN_FAMILIES = 4
#: evaluation budget of each fit (default)
MAX_NFEV = 200
#: per model family, settings that replace those defaults (`suspenv diagnose` and the
#: benchmark alike): the quarter car is simulated by a time integrator, so each refit gets
#: fewer evaluations (it starts from an equation-error fit of the suspension force) and
#: the two strongest force signature families are refitted per round (plus sensor errors)
FAMILY_SETTINGS: dict[str, dict[str, int]] = {
    "quarter_car_rig": {"max_nfev": 15, "screen_families": 2},
}

#: the reported component benchmark's decision rule (a strong held-out drop lets the
#: uncorrected test decide: see :func:`suspenv.diagnosis.decision.decide`)
COMPONENT_RULE = DecisionRule(
    alpha=0.01, heldout_rule="fraction", min_heldout_gain=0.01, strong_heldout_gain=0.1
)


def _force_view_signal_set(fit: FitResult, sp: Split) -> SignalSet | None:
    """The signal set of a model's force view (``model.force_view(theta, rec)``, e.g. the
    suspension force of a quarter car through its body equation), or None."""
    seen = [fit.model.force_view(fit.theta, rec) for rec in sp.fit_recordings]
    views = [v for v in seen if v is not None]
    if len(views) < len(seen):
        return None
    sel = sp.fit_selections()

    def cat(key: str) -> np.ndarray:
        return np.concatenate([v[key][m] for v, m in zip(views, sel, strict=True)])

    meas = cat("measured")
    scale = float(np.std(meas)) or 1.0
    return _stacked(
        sp,
        sel,
        x=cat("x"),
        v=cat("v"),
        residual=(meas - cat("predicted")) / scale,
        prediction=cat("predicted") / scale,
        jacobian=cat("jacobian") / scale,
        scale=scale,
        unit="N",
        channel="force",
    )


def _stacked(sp: Split, sel: Sequence[np.ndarray], **signals: Any) -> SignalSet:
    """The :class:`SignalSet` of ``signals`` (stacked over the fitted recordings' samples
    ``sel``) with those samples' times and recording index as segment."""
    recs = zip(sp.fit_recordings, sel, strict=True)
    return SignalSet(
        t=np.concatenate([np.asarray(r.time, float)[m] for r, m in recs]),
        segment=np.concatenate([np.full(int(m.sum()), i) for i, m in enumerate(sel)]),
        **signals,
    )


#: signature families of sensor errors: they live in a recorded channel, not in the force
#: a component transmits, so a force view cannot show them (a gain error on the measured
#: force is a scaled copy of the base force, inside the span of the base parameters)
SENSOR_FAMILIES = ("sensor_offset", "sensor_gain", "sensor_lag")


def _signal_set(fit: FitResult, sp: Split, channel: str) -> SignalSet:
    """Residual, prediction, motion and Jacobian rows of one recorded channel over the
    fit samples (a model's force view: :func:`_force_view_signal_set`)."""
    sel, scale = sp.fit_selections(), fit.scales[channel]
    xs, vs, meas, pred, rows = [], [], [], [], []
    offset = 0
    for rec, m in zip(sp.fit_recordings, sel, strict=True):
        x, v = motion(rec)
        xs.append(x[m])
        vs.append(v[m])
        meas.append(np.asarray(rec.outputs[channel], float)[m])
        pred.append(np.asarray(fit.model.simulate(fit.theta, rec)[channel], float)[m])
        n = int(np.count_nonzero(m))
        for c in fit.channels:
            if c == channel:
                rows.append(np.arange(offset, offset + n))
            offset += n
    J = fit.extra.get("jacobian")
    p = np.concatenate(pred)
    return _stacked(
        sp,
        sel,
        x=np.concatenate(xs),
        v=np.concatenate(vs),
        residual=(np.concatenate(meas) - p) / scale,
        prediction=p / scale,
        jacobian=J[np.concatenate(rows)] if J is not None and J.shape[0] == offset else None,
        scale=scale,
        unit=str(sp.fit_recordings[0].units.get(channel, "")),
        channel=channel,
    )


def _segments(fit: FitResult, sp: Split) -> list[Segment]:
    out = []
    parts = residuals(fit.model, fit.theta, sp.fit_recordings, fit.channels, sp.fit_masks)
    for i, (rec, sel) in enumerate(zip(sp.fit_recordings, sp.fit_selections(), strict=True)):
        x, v = motion(rec)
        out.append(
            Segment(
                test=str(rec.test or rec.name or f"recording {i}"),
                t=np.asarray(rec.time, float)[sel],
                x=x[sel],
                v=v[sel],
                residual={c: parts[i][c] / fit.scales[c] for c in fit.channels},
            )
        )
    return out


def effect_location(model: DiagnosableModel, kind: str) -> str:
    """Where a force effect of ``kind`` lives in ``model`` (sensor effects: "")."""
    return str(model.location or "") if make_effect(kind).spec.role == "force" else ""


def _score_round(
    current: FitResult, sp: Split, channel: str, cands: Sequence[str]
) -> tuple[list[Signature], bool]:
    """Signature scores of one round, strongest first (in the force view where the model
    has one: module docstring), and whether the model's force view was used."""
    open_fams = {family_of(split_candidate(k)[0]) for k in cands}
    fams_needed = [f for f in SIGNATURE_KINDS if f in open_fams] or list(SIGNATURE_KINDS)
    if (sset := _force_view_signal_set(current, sp)) is None:
        return score_signatures(_signal_set(current, sp, channel), fams_needed), False
    force_fams = [f for f in fams_needed if f not in SENSOR_FAMILIES]
    sensor_fams = [f for f in fams_needed if f in SENSOR_FAMILIES]
    sigs = score_signatures(sset, force_fams) if force_fams else []
    for ch in current.channels if sensor_fams else []:
        # each recorded channel may carry its own sensor error (its own candidates)
        for sig in score_signatures(_signal_set(current, sp, ch), sensor_fams):
            sig.evidence = f"{sig.evidence} in {ch}"
            sig.channel = ch
            sigs.append(sig)
    return sorted(sigs, key=lambda g: -g.score), True


def located_candidates(cands: Sequence[str], channels: Sequence[str]) -> list[str]:
    """The candidates with each sensor error (a bare kind) on each of the recorded
    ``channels`` where there are several (``sensor_lag@body_acceleration``, ...): an
    error sits on one sensor, and each placement is a candidate of its own."""
    if len(channels) < 2:
        return list(cands)
    out: list[str] = []
    for c in cands:
        kind, loc = split_candidate(c)
        sensor = not loc and family_of(kind) in SENSOR_FAMILIES
        out += [candidate_name(kind, ch) for ch in channels] if sensor else [c]
    return out


def _structural_ambiguity(
    h: Hypothesis, parent: FitResult, sp: Split, max_nfev: int
) -> list[Ambiguity]:
    """Refit the equivalent combination of a named effect; equal fit -> ambiguity."""
    if h.kind not in EQUIVALENT_COMBINATIONS:
        return []
    (k1, k2), words = EQUIVALENT_COMBINATIONS[h.kind]
    combo = parent
    for k in (k1, k2):
        combo = refit_with(combo, k, sp.fit_recordings, sp.fit_masks, max_nfev=max_nfev)
    lr_combo = 2.0 * (combo.log_likelihood() - parent.log_likelihood())
    if not fit_alike(h.lr_statistic, lr_combo):
        return []
    test, reason = separating_test(family_of(k1), family_of(k2))
    return [Ambiguity(h.kind, f"{k1}+{k2}", h.words, words, test, reason)]


@dataclass
class ComponentFamily(OptionalSteps):
    """The component family's steps of the diagnosis loop (see the module docstring).

    Args:
        model: a component model instance or its family name (``"damper"``, ...).
        max_effects: most elements added in turn.
        screen_families: refit the candidates of this many signature families with the
            strongest signatures per round (the rest are reported by signature only).
        max_nfev: budget of each fit.
        rule: the decision rule (default :data:`COMPONENT_RULE`).
    """

    model: ComponentModel | str
    max_effects: int = 2
    screen_families: int | None = None
    max_nfev: int | None = None
    rule: DecisionRule = COMPONENT_RULE
    name: str = field(default="component", init=False)
    #: what the last :meth:`prepare` read about the rig (None for a model instance)
    rig: RigDescription | None = field(default=None, init=False)
    rig_notes: list[str] = field(default_factory=list, init=False)
    #: the motion version the last :meth:`prepare` fitted (``motion_inputs.conditioned``)
    motion_version: str = field(default="channel", init=False)
    #: the lowest low-pass cut-off [Hz] of the motion channels in the last :meth:`prepare`
    #: (None: used as recorded)
    motion_lowpass_hz: float | None = field(default=None, init=False)
    #: by recording name, the output channels as recorded where the last :meth:`prepare`
    #: low-passed them with the motion (``output_lowpass``; empty: compared as recorded)
    recorded_outputs: dict[str, dict[str, np.ndarray]] = field(default_factory=dict, init=False)
    #: the largest white-noise standard deviation of the recorded displacement [m] in the
    #: last :meth:`prepare` (0: not measured)
    displacement_noise_m: float = field(default=0.0, init=False)
    #: recorded channel -> the test where a pure time delay beat a refitted sensor lag
    #: decisively in the last diagnosis (:mod:`~suspenv.diagnosis.component.delay`)
    delay_tests: dict[str, dict[str, Any]] = field(default_factory=dict, init=False)
    #: the rounds whose Maxwell refit was refused with its base share of the damping
    #: unresolved (:func:`~suspenv.diagnosis.component.plausible.branch_share_unresolved`):
    #: a sensor lag of the force named in such a round cannot be told from such a branch
    unresolved_branch_rounds: set[int] = field(default_factory=set, init=False)
    #: the round of the last :meth:`screen`
    _round: int = field(default=0, init=False, repr=False)
    #: the signs found where none was declared (last :meth:`prepare`), in words
    sign_words: list[str] = field(default_factory=list, init=False)
    #: the last :meth:`prepare` fitted the quarter car's unsprung mass (not declared) with
    #: the baseline; :meth:`settle` fits it again beside each winner
    mass_estimated: bool = field(default=False, init=False)
    #: the model :meth:`_delays_left` last read and its delays left
    _delays: tuple[FitResult | None, list[DelayLeft]] = field(
        default=(None, []), init=False, repr=False
    )

    def __post_init__(self) -> None:
        # an unknown model family or effect kind is an error before any work starts
        if isinstance(self.model, ComponentModel):
            family = self.model.family
        elif self.model.endswith(".toml"):
            family = str(read_model_file(self.model).get("family", ""))
        else:
            family = describe_rig(self.model, []).family
        own = FAMILY_SETTINGS.get(family, {})
        if self.screen_families is None:
            self.screen_families = own.get("screen_families", SCREEN_FAMILIES)
        if self.max_nfev is None:
            self.max_nfev = own.get("max_nfev", MAX_NFEV)

    @property
    def budget(self) -> int:
        """The evaluation budget of each fit (``max_nfev`` as resolved)."""
        return int(self.max_nfev or MAX_NFEV)

    def prepare(
        self, recordings: Recordings, holdout: Holdout, candidates: Sequence[str] | None
    ) -> Setup:
        """The baseline model (the family's standard physics, or the model given), the
        recordings in suspenv's signs, the split and the open candidates."""
        recs = as_recordings(recordings)
        held = holdout
        self.delay_tests = {}
        self.unresolved_branch_rounds = set()
        self.motion_lowpass_hz = None
        self.recorded_outputs = {}
        self.displacement_noise_m = 0.0
        if isinstance(self.model, ComponentModel):
            model = self.model  # an explicit model instance is the baseline as given
            self.rig, self.rig_notes = None, []
        else:
            rig = describe_rig(self.model, recs)
            rig, recs = self._signs(rig, recs)
            held_recs = None
            if holdout is not None and not isinstance(holdout, float | int | str):
                held_recs = oriented(as_recordings(holdout), rig)  # type: ignore[arg-type]
            self.rig_notes = check_extra_inputs(recs, rig)
            self.rig = rig
            model = baseline_model(rig, recs)
            # the motion as the component felt it: noise removed, rates consistent
            recs, held_recs = self._motion(model, rig, recs, held_recs, held)
            if held_recs is not None:
                held = held_recs
        known = baseline_families(model)
        cands = located_candidates(
            [
                c
                for c in (candidates if candidates is not None else model.candidate_effects)
                if family_of(split_candidate(c)[0]) not in known
            ],
            model.output_channels,
        )
        if held is None:
            held = default_holdout(recs)
        sp = split(recs, held)
        model = drift_over_fit(model, sp)
        self.mass_estimated = False
        if self.rig is not None and "m_u" in model.options and "m_u" not in self.rig.known:
            model = cast(ComponentModel, estimate_unsprung_mass(model, sp, self.budget).model)
            self.mass_estimated = True
        return Setup(sp, model, cands)

    def settle(self, winner: FitResult, setup: Setup) -> FitResult | None:
        """The winner with the quarter car's undeclared unsprung mass fitted again beside
        the element (:func:`~.assumed.estimate_unsprung_mass`): the baseline's mass took up
        part of what the element explains, and a mass ratio left wrong reads as a sensor
        gain in the next round. None where the mass is declared or the fit is no better."""
        if not self.mass_estimated or not isinstance(winner.model, ComponentModel):
            return None
        settled = estimate_unsprung_mass(winner.model, setup.split, self.budget, winner.theta)
        if not settled.log_likelihood() > winner.log_likelihood():
            return None
        settled.extra["effect"] = winner.extra["effect"]
        return settled

    def check_data(self, setup: Setup) -> None:
        """The motion reverses often enough (:func:`.motion.check_cycles`)."""
        check_cycles(setup)

    def _signs(
        self, rig: RigDescription, recs: list[RecordingLike]
    ) -> tuple[RigDescription, list[RecordingLike]]:
        """The recordings in suspenv's signs, read off the power the force takes from the
        motion where neither sign is declared (:mod:`~suspenv.diagnosis.component.assumed`),
        and the convention found said (:attr:`sign_words`)."""
        out = oriented(recs, rig)
        m_s = float(rig.known.get("m_s", make_component(rig.family).options.get("m_s", 1.0)))
        power = power_sign(out, m_s)
        self.sign_words = []
        if not np.isfinite(power) or {"positive_stroke", "positive_force"} & set(rig.declared):
            return rig, out
        has_force = all("force" in rec.outputs for rec in recs)
        if power < 0:
            flip = {"positive_force": "tension"} if has_force else {"positive_stroke": "extension"}
            rig = replace(rig, **flip)  # type: ignore[arg-type]
            out = oriented(recs, rig)
        if has_force:
            found = f"a positive stroke in compression and a positive force in {rig.positive_force}"
        else:
            found = (
                f"the suspension force m_s x body acceleration and a positive deflection in "
                f"{rig.positive_stroke} (a body accelerometer read downward-positive would "
                "give the same power)"
            )
        self.sign_words.append(
            "the stroke and force signs (not declared) read off the power the force takes "
            f"from the motion, mean F v = {abs(power):.3g} W > 0 with {found}"
        )
        return rig, out

    def assumptions(self, setup: Setup) -> list[str]:
        """The defaults and estimates used for what the recordings do not say: the signs
        (read off the dissipated power), the quarter car's masses (as the model of
        ``setup`` holds them: the final one, :mod:`~suspenv.diagnosis.checks.assumptions`)."""
        said = list(self.sign_words)
        model = unprofiled(setup.model)
        if self.rig is not None and isinstance(model, ComponentModel) and "m_s" in model.options:
            said += mass_words(model, list(self.rig.known), self.mass_estimated)
        return said

    def _motion(
        self,
        model: ComponentModel,
        rig: RigDescription,
        recs: list[RecordingLike],
        held_recs: list[RecordingLike] | None,
        held: Holdout,
    ) -> tuple[list[RecordingLike], list[RecordingLike] | None]:
        """The fitted and held-out recordings in the motion version the rig asks for
        (:mod:`~suspenv.diagnosis.component.motion_inputs`; ``"auto"``:
        :func:`~suspenv.diagnosis.component.motion_inputs.preferred_version`, or the
        version whose baseline fit leaves the smaller residual where it cannot tell)."""
        channels = model.input_channels
        source = rig.velocity_source
        if source == "channel":
            self.motion_version = "channel"
            return recs, held_recs
        versions, checks = motion_versions(recs, channels)
        self.rig_notes += [w for c in checks for w in c.words()]
        cutoffs = [c.cutoff_hz for c in checks if c.cutoff_hz is not None]
        self.motion_lowpass_hz = min(cutoffs) if cutoffs else None
        self.displacement_noise_m = max((c.displacement_noise for c in checks), default=0.0)
        version = source if source != "auto" else preferred_version(checks) or ""
        if not version:  # the displacement's noise could not be separated: fit both
            version = self._better_fitted(
                model, versions, checks, held if held_recs is None else held_recs
            )
        elif source == "auto" and version == "displacement":
            self.rig_notes.append(
                "the velocity (and acceleration) used are the derivatives of the "
                'displacement (declare velocity_source = "channel" to keep the channels)'
            )
        self.motion_version = version
        held_checks: list[MotionCheck] = []
        if held_recs is not None:
            held_recs, held_checks = conditioned(held_recs, channels, version)
        chosen = versions[version]
        if getattr(model, "output_lowpass", False) and self.motion_lowpass_hz is not None:
            return self._low_passed(model, [*checks, *held_checks], chosen, held_recs)
        return chosen, held_recs

    def _better_fitted(
        self,
        model: ComponentModel,
        versions: dict[str, list[RecordingLike]],
        checks: list[MotionCheck],
        held: Holdout | list[RecordingLike],
    ) -> str:
        """The motion version (of ``versions``) whose baseline fit leaves the smaller RMS
        residual of the first output channel (``held``: the held-out data), said in the
        rig notes."""
        rms: dict[str, float] = {}
        for name, cand in versions.items():
            sp = split(cand, held)
            fitted: Any = model  # a component model fits Recordings (the protocol's R)
            base = fit(fitted, sp.fit_recordings, sp.fit_masks, max_nfev=self.budget)
            rms[name] = base.rms()[model.output_channels[0]]
        unit = model.channel_units.get(model.output_channels[0], "")
        self.rig_notes.append(choice_words(checks, rms, unit))
        return min(rms, key=lambda k: rms[k])

    def _low_passed(
        self,
        model: ComponentModel,
        checks: list[MotionCheck],
        chosen: list[RecordingLike],
        held_recs: list[RecordingLike] | None,
    ) -> tuple[list[RecordingLike], list[RecordingLike] | None]:
        """The fitted and held-out recordings with their outputs low-passed like each
        recording's motion (and the prediction alike: ``ComponentModel.simulate``),
        where the cut-off of its ``checks`` keeps enough harmonics of the motion cycle;
        the outputs as recorded are kept for the residual check (:attr:`recorded_outputs`)."""
        cut = {c.recording: c.cutoff_hz for c in checks if c.cutoff_hz is not None}
        for r in [*chosen, *(held_recs or [])]:  # a held-out recording may repeat one
            name = str(r.name)
            if name in self.recorded_outputs or name not in cut:
                continue
            if harmonics_kept(r, cut[name]) >= OUTPUT_LOWPASS_HARMONICS:
                self.recorded_outputs[name] = dict(r.outputs)

        def alike(rs: list[RecordingLike]) -> list[RecordingLike]:
            return [
                low_passed_outputs(r, cut[str(r.name)])
                if str(r.name) in self.recorded_outputs
                else r
                for r in rs
            ]

        outs = ", ".join(model.output_channels)
        if self.recorded_outputs:
            self.rig_notes.append(
                f"the recorded {outs} is compared low-passed like the motion (at "
                f"{self.motion_lowpass_hz:.3g} Hz, which keeps "
                f"{OUTPUT_LOWPASS_HARMONICS} or more harmonics of the motion cycle), and "
                "so is the model's force beyond its inertia and damping, which the "
                "low-passed motion carries exactly; the check of the residual left "
                "reads it as recorded"
            )
        else:
            self.rig_notes.append(
                f"the recorded {outs} is compared as recorded: the motion's cut-off "
                f"({self.motion_lowpass_hz:.3g} Hz) keeps fewer than "
                f"{OUTPUT_LOWPASS_HARMONICS} harmonics of its cycle, too few for the "
                "shape of a step"
            )
        return alike(chosen), None if held_recs is None else alike(held_recs)

    def fit_baseline(self, setup: Setup) -> FitResult:
        sp = setup.split
        return fit(setup.model, sp.fit_recordings, sp.fit_masks, max_nfev=self.budget)

    def locate(self, base: FitResult, setup: Setup) -> tuple[Location, str]:
        return locate(_segments(base, setup.split)), base.main_channel()

    def screen(
        self, current: FitResult, setup: Setup, open_candidates: Sequence[str], round_: int
    ) -> Screening:
        self._round = round_
        channel = current.main_channel()
        sigs, viewed = _score_round(current, setup.split, channel, open_candidates)
        sig_of = {(s.kind, s.channel): s for s in reversed(sigs)}  # the strongest per key
        open_fams = {family_of(split_candidate(k)[0]) for k in open_candidates}
        # with a force view the sensor scores are not on its scale (module docstring):
        # every placement of a sensor error is refitted too, and the fits decide
        apart = SENSOR_FAMILIES if viewed else ()
        ranked = dict.fromkeys(s.kind for s in sigs if s.kind in open_fams and s.kind not in apart)
        fams = set(list(ranked)[: int(self.screen_families or SCREEN_FAMILIES)])
        chosen = []
        for k in open_candidates:
            kind, loc = split_candidate(k)
            sig = sig_of.get((family_of(kind), loc)) or sig_of.get((family_of(kind), ""))
            if family_of(kind) in fams.union(apart):
                chosen.append((k, sig))
        return Screening(sigs, chosen)

    def refit(
        self, current: FitResult, candidate: str, signature: SignatureLike | None, setup: Setup
    ) -> FitResult:
        kind, location = split_candidate(candidate)
        location = location or effect_location(setup.model, kind)
        if kind == "sensor_lag":
            # a sensor lag's channel (the model's first output unless located)
            refused = self.delay_tests.get(location or setup.model.output_channels[0])
            if refused is not None:  # a delay beat the lag of this channel in an earlier round
                check_lag_not_delay(refused)
        return refit_with(
            current,
            kind,
            setup.split.fit_recordings,
            setup.split.fit_masks,
            signature if isinstance(signature, Signature) else None,
            stroke(setup.split)[0],
            location=location,
            max_nfev=self.budget,
        )

    def without(self, current: FitResult, name: str, setup: Setup) -> FitResult:
        """``current`` refitted without its element ``name`` (:func:`without_element`)."""
        return without_element(current, name, setup.split, self.budget)

    def refit_checks(self) -> list[Check]:
        """The rules a refit must pass to stand as a hypothesis, in order
        (:func:`suspenv.diagnosis.checks.refuse`): the round of a Maxwell branch left
        unresolved is kept for the look-alikes, the element's plausibility
        (:func:`suspenv.diagnosis.component.plausible.run`), a sensor lag against a pure
        delay of its channel."""
        return [self._unresolved_branch, plausible.run, self._lag_against_delay]

    def _unresolved_branch(self, ctx: Context) -> None:
        """Keep the round of such a Maxwell refit (:attr:`unresolved_branch_rounds`)."""
        if ctx.refit is not None and branch_share_unresolved(
            ctx.candidate, ctx.refit, self.rule.alpha
        ):
            self.unresolved_branch_rounds.add(self._round)

    def _lag_against_delay(self, ctx: Context) -> Finding | None:
        """A refitted sensor lag against the same channel late by a pure delay (not a
        library element, :func:`~suspenv.diagnosis.component.delay.delay_against_lag`);
        the first decisive test of a channel is kept for the checks after the search."""
        ext = ctx.refit
        if ext is None or split_candidate(ctx.candidate)[0] != "sensor_lag":
            return None
        channel = str(ext.extra["effect"]["location"] or ctx.setup.model.output_channels[0])
        sp = ctx.setup.split
        start = parameter_and_error(ext, "sensor_lag", "tau")[0]
        delay = fit_delay(ctx.outcome.current, sp, channel, start, self.budget)
        test = delay_against_lag(ext, delay, sp, self.rule, channel, self.budget)
        ext.extra["delay_against_lag"] = test
        if test["decisive"]:
            self.delay_tests.setdefault(channel, test)
        try:
            check_lag_not_delay(test)
        except ValidationError as exc:
            return Finding("lag_against_delay", confident=False, sentence=str(exc))
        return None

    def words(self, candidate: str, setup: Setup) -> str:
        """Engineering words in the device's terms, e.g. "Coulomb friction in the guide",
        "yield force of the MR fluid (...)" (the model's ``device_words`` first)."""
        kind, channel = split_candidate(candidate)
        effect = make_effect(kind, location=channel or effect_location(setup.model, kind))
        if effect.spec.role == "sensor" and channel:
            return f"{effect.spec.words} on the {channel} channel"
        if isinstance(setup.model, ComponentModel):
            return setup.model.effect_words(effect)
        return effect.words

    def ambiguities(
        self, winner: Hypothesis, ranked: Sequence[Hypothesis], parent: FitResult, setup: Setup
    ) -> list[Ambiguity]:
        """The structural ambiguity of the winner (:func:`_structural_ambiguity`), and a
        sensor lag of the force named in a round of :attr:`unresolved_branch_rounds`
        beside the Maxwell branch it cannot be told from (with ``separating_test``)."""
        found = _structural_ambiguity(winner, parent, setup.split, self.budget)
        # a lag of the recorded force only: the force is the branch's whole effect there
        # (a quarter car's branch also moves its deflection, which a lag of the
        # accelerometer does not)
        if (
            setup.model.output_channels != ("force",)
            or winner.kind != "sensor_lag"
            or winner.location not in ("", "force")
            or winner.round not in self.unresolved_branch_rounds
        ):
            return found
        other = "maxwell_viscoelastic"
        test, reason = separating_test(family_of(winner.kind), family_of(other))
        words = self.words(other, setup)
        found.append(Ambiguity(winner.kind, other, winner.words, words, test, reason))
        return found

    def checks(self) -> list[Check]:
        """The checks after the search, in order (:func:`suspenv.diagnosis.checks.run`):
        the damper's asymmetry; the named elements judged again beside a delay and beside
        a zero drift of more shape; a force missing at low speed; a named sensor gain
        beside a reading error that grows with the signal's size; the delays left; a lag
        that stands for a delay; the baseline's offsets."""
        return [
            self._asymmetry,
            self._beside_delay,
            self._beside_drift,
            self._dead_band,
            self._gain_curvature,
            self._delays_said,
            self._lag_and_offsets,
        ]

    def _gain_curvature(self, ctx: Context) -> Conclusion | None:
        """Each channel a sensor gain is named on, judged beside a reading error that
        grows with the square of the signal (:mod:`~suspenv.diagnosis.component.transducer`):
        a lead sentence where one remains, a sentence and no confidence where the
        held-out samples do not refute it (not material, or not confirmed)."""
        final = ctx.outcome.current
        gains = [e for e in final.model.effects if e.kind == "sensor_gain"]
        if not gains or "sensor_gain" not in {h.kind for h in ctx.outcome.named}:
            return None
        found = Conclusion()
        for e in gains:
            channel = e.location or final.main_channel()
            left = curvature_left(final, ctx.setup.split, channel, self.rule)
            found.findings.setdefault("beyond_library", []).append(left)
            if left.remains:
                found.lead(left.sentence())
            elif left.significant:
                found.sentences.append(left.sentence())
            found.confident = found.confident and not left.significant
        return found

    def _asymmetry(self, ctx: Context) -> Conclusion | None:
        """Where a digressive curve was named: the asymmetric curve against the symmetric
        one plus a constant force (:mod:`~suspenv.diagnosis.component.asymmetry`)."""
        o, setup, rule = ctx.outcome, ctx.setup, self.rule
        if not (
            "digressive_damping" in [h.kind for h in o.named]
            and "damper_asymmetry" in setup.candidates
            and "damper_asymmetry" not in {h.family for h in o.named}
        ):
            return None
        asym = asymmetry_check(
            o.current, setup.split, rule.alpha, rule.min_heldout_gain, self.budget
        )
        found = Conclusion(findings={"asymmetry": asym})
        if asym is not None and asym.supported and asym.hypothesis is not None:
            found.named, found.final_fit = [asym.hypothesis], asym.hypothesis.fit
        elif asym is not None:
            found.sentences.append(asym.sentence)
        return found

    def _beside_delay(self, ctx: Context) -> Conclusion | None:
        """The elements named before a delay left after the search, judged again beside
        it (the checks after it read the model without those withdrawn)."""
        o = ctx.outcome
        left = next((d for d in self._delays_left(o.current, ctx.setup) if d.remains), None)
        if left is None or not o.named:
            return None
        final, gone = judge_beside_delay(
            o.current, o.named, left.channel, left.delay_s, ctx.setup.split, self.budget, self.rule
        )
        return Conclusion(withdrawn=gone, final_fit=final)

    def _beside_drift(self, ctx: Context) -> Conclusion | None:
        """The named elements judged again beside a zero drift of more shape
        (:mod:`~suspenv.diagnosis.component.drift_check`)."""
        o = ctx.outcome
        if not o.named:
            return None
        final, gone = judge_beside_drift(
            o.current, o.named, ctx.setup.split, self.budget, self.rule
        )
        return Conclusion(withdrawn=gone, final_fit=final)

    def residual_left(
        self, outcome: Outcome, setup: Setup, alpha: float
    ) -> tuple[list[Left], list[ResidualLeft]]:
        """The component's noise model for the shared residual rule: per output channel
        the cycle-to-cycle state test and the tail rule of the final model
        (:func:`~suspenv.diagnosis.component.residual_left.residual_left`), with the
        motion's low-pass cut-off (:attr:`motion_lowpass_hz`) for the tail rule (step 6
        of that module's docstring)."""
        left = residual_left(
            outcome.current,
            setup.split,
            alpha,
            lowpass_hz=self.motion_lowpass_hz,
            recorded=self.recorded_outputs or None,
        )
        return [v for r in left for v in r.views()], left

    def _dead_band(self, ctx: Context) -> Conclusion | None:
        """A force missing at low speed that no library element takes up
        (:mod:`~suspenv.diagnosis.component.dead_band`); where the motion was low-passed,
        how the residual rule reads the residual (:meth:`residual_left`)."""
        found, cut = Conclusion(), self.motion_lowpass_hz
        if cut is not None:
            found.findings["tail_rule"] = (
                f"applied to the residual low-passed at {cut:.3g} Hz, where the motion "
                "channels were low-passed (the prediction lacks the motion's content "
                f"above it), and where the part moves (above "
                f"{100 * MOVING_FRACTION:.0f} % of the peak speed)"
            )
        sp = ctx.setup.split
        where = effect_location(ctx.setup.model, DEFICIT_KIND)
        band = dead_band_left(ctx.outcome.current, sp, where, stroke(sp)[1], self.budget, self.rule)
        found.findings["beyond_library"] = [band]
        if band.remains:
            found.confident = False
            found.lead(band.sentence())
        return found

    def _delays_said(self, ctx: Context) -> Conclusion:
        """The delays left (a lead sentence where one remains) and the withdrawals (one
        beside a delay right after the delay's sentence)."""
        found = Conclusion()
        for left_delay in self._delays_left(ctx.outcome.current, ctx.setup):
            found.findings.setdefault("beyond_library", []).append(left_delay)
            if left_delay.remains:
                found.confident = False
                found.lead(left_delay.sentence())
            else:
                found.sentences.append(left_delay.sentence())
        gone: list[Withdrawal] = ctx.found.findings.get("withdrawn", [])
        for w in reversed([w for w in gone if w.beside_delay]):
            found.sentences.insert(1, w.sentence())
            found.leading += int(found.leading > 0)  # one of the leads where it follows one
        found.sentences.extend(w.sentence() for w in gone if not w.beside_delay)
        return found

    def _lag_and_offsets(self, ctx: Context) -> Conclusion:
        """A named lag that stands for a delay (not confident); the baseline's elements
        and offsets."""
        found = Conclusion(baseline=_baseline_effects(ctx.outcome.base, self))
        if lag := lag_or_delay(ctx.outcome.named, ctx.setup.split):
            found.confident = False
            found.sentences.append(lag)
        if offsets := baseline_offsets(ctx.outcome.current):
            found.findings["baseline_offsets"] = offsets
            found.sentences.extend(o["sentence"] for o in offsets if o["significant"])
        return found

    def _delays_left(self, final: FitResult, setup: Setup) -> list[DelayLeft]:
        """:func:`delay_left` of every channel whose lag the search refused for a delay
        (of the last model asked for: kept for the checks that read the same model)."""
        if self._delays[0] is final:
            return self._delays[1]
        delays = [
            delay_left(final, setup.split, channel, test, self.budget, self.rule)
            for channel, test in self.delay_tests.items()
        ]
        self._delays = (final, delays)
        return delays


#: below this product of the lag and the motion's angular frequency a first-order lag
#: and a pure time delay shift the phase alike and their gains differ by under 12 %
LAG_DELAY_SEPARABLE = 0.5


def lag_or_delay(named: Sequence[Hypothesis], sp: Split) -> str:
    """When a sensor lag is named where it cannot be told from a pure time delay (not in
    the library), the sentence that says so and names the test that would separate them;
    "" otherwise. The verdict is then not confident: the named lag may be the library's
    nearest element to a delay. Read at the motion's highest angular frequency ``w =
    v_max / x_half`` (a sine's) against :data:`LAG_DELAY_SEPARABLE`; the gain difference
    left there is absorbed by the model's other parameters."""
    lag = next((h for h in named if h.kind == "sensor_lag"), None)
    if lag is None:
        return ""
    tau = float(lag.params.get("sensor_lag.tau", {}).get("value", np.nan))
    half, vmax = stroke(sp)
    if not (np.isfinite(tau) and tau > 0 and half > 0):
        return ""
    wt = tau * vmax / half
    if wt >= LAG_DELAY_SEPARABLE:
        return ""
    return (
        f"the sensor lag ({1e3 * tau:.3g} ms) cannot be told from a pure time delay (a "
        f"digital filter's or a transport delay, not in the library) at these frequencies "
        f"(w tau <= {wt:.2g}); a test at {1.0 / (2 * np.pi * tau):.3g} Hz or above would "
        "separate them (a lag's gain falls there, a delay's does not)"
    )


#: baseline elements that are a constant zero error of a channel: reported with their
#: value when it differs from zero (the element is not missing physics, but the user
#: should hear that the zero is off)
OFFSET_KINDS = ("force_offset", "sensor_offset")
#: a baseline offset this many (serial-correlation corrected) standard errors from zero
#: is said in the verdict
OFFSET_Z = 5.0


def baseline_offsets(fit: FitResult) -> list[dict[str, Any]]:
    """The constant zero errors the baseline holds (``OFFSET_KINDS``), each with its
    value, corrected standard error, whether it is ``OFFSET_Z`` standard errors from zero,
    and a sentence in the channel's unit (``"the baseline's constant offset of force is
    +3.14 +- 0.02 N ..."``)."""
    out: list[dict[str, Any]] = []
    fitted, model = fit.params(), fit.model
    for e in getattr(model, "effects", ()):
        key = f"{e.name}.offset"
        if e.kind not in OFFSET_KINDS or key not in fitted:
            continue
        value, sd = fitted[key]["value"], fitted[key]["stderr_corrected"]
        # a sensor element sits on its channel; a force element acts on the output force
        sensor = e.spec.role == "sensor" and e.location
        channel = e.location if sensor else (model.output_channels or ("",))[0]
        unit = model.channel_units.get(channel, "") if hasattr(model, "channel_units") else ""
        significant = bool(np.isfinite(sd) and sd > 0 and abs(value) > OFFSET_Z * sd)
        z = abs(value) / sd if significant else 0.0
        out.append(
            {
                "element": e.name,
                "channel": channel,
                "value": value,
                "stderr_corrected": sd,
                "significant": significant,
                "sentence": (
                    f"the baseline's constant offset of {channel} is {value:+.3g} +- {sd:.2g} "
                    f"{unit} ({z:.0f} standard errors from zero): a zero error "
                    "of the sensor or a constant force, part of the standard model, not "
                    "missing physics"
                ),
            }
        )
    return out


def _baseline_effects(base: FitResult, family: ComponentFamily) -> dict[str, Any]:
    model = unprofiled(base.model)
    out: dict[str, Any] = {
        "effects": [e.to_dict() for e in model.effects],
        "words": baseline_words(model) if isinstance(model, ComponentModel) else "",
    }
    if family.rig is not None:
        out["rig"] = family.rig.to_dict()
        out["rig_notes"] = list(family.rig_notes)
        out["motion_version"] = family.motion_version
    return out
