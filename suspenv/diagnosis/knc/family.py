"""The K&C family: what the symmetric, linear McPherson axle model leaves out of K&C rig
recordings.

Its pieces of the one loop (:mod:`suspenv.diagnosis.engine`):

1. **Split** (:func:`split_tests`): fit on some rig tests (default parallel + opposite
   travel), hold out the others (default single-wheel travel) or other recordings.
2. **Baseline**: the plain model's small parameter subset
   (:data:`~suspenv.rigs.knc_axle.FIT_PARAMETERS`) under channel scales fixed for
   every model compared (:meth:`KncFamily.fit_baseline`).
3. **Locate**: residual map test x channel x branch x side
   (:mod:`~suspenv.diagnosis.knc.locate`).
4. **Screen**: score tests of the residual against each effect's pattern
   (:mod:`~suspenv.diagnosis.knc.signatures`) and, for the elastic and sensor elements,
   against the model itself (:mod:`~suspenv.diagnosis.knc.score_test`); each family
   keeps its stronger score. The first round refits every candidate family: a weak
   effect can stay under the screen's threshold in its signature pattern (a top-mount
   Dahl element opens a wheel-load loop of a few newtons) while the refit of the
   element itself, which has the exact shape, is the stronger test.
5. **Refit** (:func:`refit_frozen`) and **settle** (:func:`settle`) of the winner, the
   next round's model; when nothing is named, the smallest hysteresis and strut
   friction these tests would have shown (:mod:`~suspenv.diagnosis.knc.detectability`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.space import DesignSpace
from suspenv.diagnosis.checks.finding import Check, Context
from suspenv.diagnosis.checks.residual_left import Left, from_cells
from suspenv.diagnosis.decision import DecisionRule, fit_alike
from suspenv.diagnosis.family import Conclusion, Outcome, Screening, Setup, SignatureLike
from suspenv.diagnosis.fitting import (
    PENALTY,
    FitResult,
    evaluate,
    fitted_channels,
    noise_scales,
    residuals,
    spread_scales,
    stacked_residual,
)
from suspenv.diagnosis.hypothesis import Ambiguity, Hypothesis, split_candidate
from suspenv.diagnosis.knc.detectability import detection_limits, limits_sentence
from suspenv.diagnosis.knc.locate import ResidualMap, residual_map
from suspenv.diagnosis.knc.score_test import SCORE_TESTED, score_signatures_by_model
from suspenv.diagnosis.knc.signatures import SCREEN_FAMILY, KncSignature, score_signatures
from suspenv.diagnosis.protocols import DiagnosableModel, RecordingLike
from suspenv.diagnosis.split import Holdout, Recordings, Split, as_recordings, heldout_recordings
from suspenv.measurements.knc import FORCE_INPUTS, INPUTS, is_force_test, rig_test
from suspenv.rigs.knc_axle import KncAxleModel, effect_words, make_candidate
from suspenv.rigs.knc_fit import UnitFit, polish

#: the reported K&C benchmark's decision rule: the held-out rig test is judged in noise
#: units (it sees a refit's change only where it moves the bushings the change is about)
KNC_RULE = DecisionRule(alpha=0.01, heldout_rule="noise", min_heldout_gain=0.01)


PATH_DEPENDENT = ("dahl_hysteresis", "coulomb_friction")
#: stopping tolerances (relative change of cost and parameters) of fits of models with
#: and without path-dependent elements; a relative cost change of 1e-4 moves the
#: log-likelihood by about n * 1e-4 / 2 (well below one unit for K&C data sets)
COARSE_TOL = 1e-4
FINE_TOL = 1e-7
#: the noise level of a channel is never read below this share of its recorded spread
#: (noise-free curves leave a residual of round-off, which is not the noise)
NOISE_FLOOR = 1e-5


def axle_model(model: object) -> KncAxleModel:
    """``model`` as the K&C axle model (the only model this family fits)."""
    if not isinstance(model, KncAxleModel):
        raise ValidationError(f"the K&C family fits a KncAxleModel, but got {type(model).__name__}")
    return model


def current_slow(model: DiagnosableModel) -> bool:
    """True when ``model`` holds a path-dependent (slow to simulate) element."""
    return any(e.kind in PATH_DEPENDENT for e in model.effects)


def split_tests(recordings: Recordings, holdout: Holdout) -> Split:
    """Fit and held-out K&C recordings: ``holdout`` is rig test name(s) among the
    recordings (e.g. ``"single"``) or separate recordings (e.g. another amplitude)."""
    recs = as_recordings(recordings)
    if isinstance(holdout, str) or (
        isinstance(holdout, list | tuple) and holdout and all(isinstance(h, str) for h in holdout)
    ):
        names = {holdout} if isinstance(holdout, str) else set(holdout)
        held = [r for r in recs if rig_test(r) in names]
        fitr = [r for r in recs if rig_test(r) not in names]
        if not held or not fitr:
            raise ValidationError(
                f"holdout {sorted(names)} must name some but not all of the recorded tests "
                f"{[rig_test(r) for r in recs]}"
            )
        return Split.separate(fitr, held, f"rig test(s) {', '.join(sorted(names))}")
    return Split.separate(recs, heldout_recordings(holdout))


def _start_values(kind: str, sig: KncSignature | None) -> dict[str, float]:
    """Start of a new element's parameters read off its signature."""
    if split_candidate(kind)[0] in PATH_DEPENDENT and sig is not None:
        w = abs(sig.numbers.get("tyre_fz_loop_width_n", 0.0))
        return {"f_c": float(np.clip(0.5 * w, 5.0, 500.0))}
    return {}


class AxleCurves(UnitFit):
    """The scaled residual (:func:`~suspenv.diagnosis.fitting.stacked_residual`) of a
    K&C axle model on recordings as a problem of the shared K&C fit: ``theta``'s values
    after the first ``held`` (which stay at ``theta0``'s) in the unit cube of
    :attr:`~suspenv.rigs.knc_axle.KncAxleModel.space`."""

    #: the rig's solver converges to a tolerance: differences must move the outputs well
    #: above it (0.1 % of a range, as :meth:`KncAxleModel.difference_step`'s floor)
    fd_step = 1e-3

    def __init__(
        self,
        model: KncAxleModel,
        recs: Sequence[Any],
        scales: Mapping[str, float],
        theta0: np.ndarray,
        held: int = 0,
    ):
        self.model, self.recs, self.scales = model, list(recs), dict(scales)
        self.base = np.asarray(theta0, float)
        self.free_index = np.arange(held, self.base.size)
        self.sub = DesignSpace(model.space.parameters[held:])
        self.size = sum(len(r.time) for r in self.recs) * len(self.scales)

    def jacobian_theta(self, J: np.ndarray, u: np.ndarray) -> np.ndarray:
        """A Jacobian ``J`` (size, dim) in the unit cube as one in ``theta`` (size, p) at
        the unit point ``u``: divided by d theta / d u, zero for the held values."""
        out = np.zeros((J.shape[0], self.base.size))
        out[:, self.free_index] = J / self.sub.slope(u)
        return out

    def residuals_x(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
        R = stacked_residual(self.model, X, self.recs, list(self.scales), self.scales)
        ok = ~np.any(R == PENALTY, axis=1)
        return R, ok, ["the rig cannot solve the design or a channel is not finite"] * len(R)


def fit_axle(
    model: DiagnosableModel,
    recs: Sequence[Any],
    scales: Mapping[str, float] | None = None,
    starts: Sequence[np.ndarray | None] = (None,),
    max_nfev: int = 40,
    tol: float = FINE_TOL,
    hold_base: bool = False,
) -> FitResult:
    """``model`` fitted to ``recs`` by the shared K&C fit (:func:`suspenv.rigs.knc_fit.polish`:
    unit cube, restarted until a restart gains under half a unit of log-likelihood,
    ``max_nfev`` evaluations in all, ``tol`` its relative cost change) under ``scales``
    (default: the measured spread) from each of ``starts`` (None: the model's initial
    guess); the fit of the largest log-likelihood (the first of equals) is the answer.
    ``hold_base``: the base parameters stay at the start's, only the effects' are fitted.

    The fit's weak pull is towards :meth:`~suspenv.rigs.knc_axle.KncAxleModel.start_theta`
    (the start design, each effect's K&C start value) whatever the start, so a model and
    its extension with a candidate carry the same pull on the parameters they share; the
    result's log-likelihood, which the likelihood-ratio test reads, is of the data alone.
    """
    axle = axle_model(model)
    held = len(axle.base_names) if hold_base else 0
    fits = []
    for start in starts:
        t0 = time.perf_counter()
        x0 = axle.initial_guess() if start is None else np.asarray(start, float)
        if scales is None:
            scales = spread_scales(recs, fitted_channels(axle, recs[0], x0))
        pb = AxleCurves(axle, recs, scales, x0, held)
        stage, r, J = polish(pb, pb.unit(x0), max_nfev, prior=pb.unit(axle.start_theta()), ftol=tol)
        theta = pb.designs(stage.u)[0]
        fits.append(
            evaluate(
                axle,
                theta,
                recs,
                scales,
                jacobian=pb.jacobian_theta(J, stage.u),
                scaled_residual=r,
                success=stage.stop.startswith("converged"),
                message=stage.stop,
                nfev=stage.evaluations,
                seconds=time.perf_counter() - t0,
            )
        )
    best = max(fits, key=lambda f: f.log_likelihood())
    best.nfev = sum(f.nfev for f in fits)
    return best


def refit_frozen(
    current: FitResult,
    kind: str,
    recs: Sequence[Any],
    start: Mapping[str, float] | None = None,
    max_nfev: int = 30,
) -> FitResult:
    """Add an effect of ``kind`` to ``current.model`` and refit. Path-dependent effects:
    the effects' parameters only, base parameters held at their current values (the
    full model is polished once the effect is named); others: all parameters jointly.
    Returns the full model's fit."""
    model = axle_model(current.model)
    base, effs = model.parts(current.theta)
    new = make_candidate(kind).with_params(dict(start or {}))
    full = model.with_effects([*effs, new])
    guess = full.initial_guess()
    here = np.concatenate([current.theta, guess[current.theta.size :]])
    if new.kind in PATH_DEPENDENT:
        res = fit_axle(full, recs, current.scales, [here], max_nfev, COARSE_TOL, hold_base=True)
        # uncertainties of the held base parameters: the current fit's
        for name in ("stderr", "stderr_corrected"):
            getattr(res, name)[: len(base)] = getattr(current, name)[: len(base)]
    else:
        # elastic and sensor effects are cheap to simulate: refit everything jointly
        # two starts: the current fit, and the start design (the current base values may
        # have bent to mimic the missing effect); the better fit is kept
        slow = current_slow(full)
        starts = [here] if slow else [here, guess]
        tol = COARSE_TOL if slow else FINE_TOL
        res = fit_axle(full, recs, current.scales, starts, max_nfev, tol)
    res.extra["effect"] = new.to_dict()
    return res


def settle(
    start: FitResult, recs: Sequence[Any], max_nfev: int, tol: float, rounds: int = 3
) -> FitResult:
    """The named winner made ready to be the next round's null model.

    Every candidate of the next round is one more fit from this model under its
    channel scales, and the likelihood ratio compares the profile likelihoods (each
    channel's noise at its own estimate). Two things would let a candidate win what
    the null merely missed: a null stopped short of convergence (so the fit is
    restarted until a restart gains under half a unit), and weights that no longer match
    the residual (a channel the named element now explains, e.g. the wheel load after
    strut friction, keeps the large scale of the baseline's misfit and is then ignored
    by the fit but counted by the likelihood). So the scales are set to the fit's own
    residual levels and the fit repeated until they change by less than 25 % (at most
    ``rounds`` times). Each fit is restarted by the shared rule (:func:`fit_axle`).
    """
    best = fit_axle(start.model, recs, start.scales, [start.theta], max_nfev, tol)
    for _ in range(rounds):
        new = noise_scales(best)
        change = max(abs(np.log(new[c] / best.scales[c])) for c in new)
        if change < np.log(1.25):
            break
        best = fit_axle(best.model, recs, new, [best.theta], max_nfev, tol)
    return best


def location_ambiguities(win: Hypothesis, ranked: Sequence[Hypothesis]) -> list[Ambiguity]:
    """Other locations of the winner's kind that the data cannot tell apart from it
    (significant, corrected LR statistics alike: :func:`~suspenv.diagnosis.decision.fit_alike`)."""
    test = (
        "a K&C test that loads the candidate locations differently (lateral or "
        "longitudinal force at the contact patch, or a top-mount load test)"
    )
    reason = (
        "in vertical travel the top mount sits in series with the spring, so its "
        "hysteresis barely changes the wheel load"
    )
    alike = [
        h
        for h in ranked
        if h is not win and h.kind == win.kind and h.significant
        if fit_alike(win.lr_statistic_corrected, h.lr_statistic_corrected)
    ]
    return [Ambiguity(win.candidate, h.candidate, win.words, h.words, test, reason) for h in alike]


def curves_in_noise_units(
    fit_: FitResult, recs: Sequence[Any]
) -> dict[tuple[str, str], np.ndarray]:
    """The residual of ``fit_`` on ``recs`` in noise units, per (rig test, channel): each
    channel's noise estimated from the roughness of this residual
    (:func:`~suspenv.diagnosis.knc.locate.residual_map`), never below
    :data:`NOISE_FLOOR` of the channel's recorded spread (noise-free curves)."""
    res = residuals(fit_.model, fit_.theta, recs, fit_.channels)
    floor = {
        c: NOISE_FLOOR * max(float(np.ptp(np.asarray(r.outputs[c], float))) for r in recs)
        for c in fit_.channels
    }
    noise = residual_map(recs, res, fit_.scales, floor).noise
    return {
        (rig_test(rec), c): np.asarray(r[c], float) / noise[c]
        for rec, r in zip(recs, res, strict=True)
        for c in fit_.channels
    }


def check_loop(rec: RecordingLike) -> None:
    """Refuse a K&C rig recording that does not hold its whole loop design -> bump ->
    rebound -> design (``2 steps + 1`` samples, ``meta["steps"]``, the grid indices and
    loop legs as inputs) with a finite, non-zero ``meta["amplitude"]``: a part loop
    cannot separate the branches. Raises :class:`~suspenv.core.errors.ValidationError`."""
    where = f"K&C recording {rec.name!r}"
    amp, steps = rec.meta.get("amplitude"), rec.meta.get("steps")
    if not isinstance(amp, int | float) or isinstance(amp, bool) or not np.isfinite(amp) or not amp:
        raise ValidationError(
            f"{where}: meta['amplitude'] must be a finite non-zero number (the test's "
            f"amplitude, m or N), but got {amp!r}"
        )
    if not isinstance(steps, int) or isinstance(steps, bool) or steps < 2:
        raise ValidationError(
            f"{where}: meta['steps'] must be a whole number >= 2 (grid intervals of the "
            f"loop), but got {steps!r}"
        )
    need = 2 * steps + 1
    if len(rec.time) != need:
        raise ValidationError(
            f"{where}: {len(rec.time)} samples, but the whole loop design -> bump -> rebound "
            f"-> design of steps={steps} has {need}; a part loop cannot separate the branches"
        )
    needed = FORCE_INPUTS if is_force_test(rec) else INPUTS
    if missing := [k for k in needed if k not in rec.inputs]:
        raise ValidationError(
            f"{where}: missing input channel(s) {missing}; inputs are {sorted(rec.inputs)}"
        )
    grid = np.asarray(rec.inputs["grid"], float)
    if np.any(grid != np.round(grid)) or grid.min() != 0 or grid.max() != steps:
        raise ValidationError(
            f"{where}: input 'grid' must hold whole grid indices from 0 to steps={steps}, "
            f"but ranges {float(np.min(grid)):g}..{float(np.max(grid)):g}"
        )
    branch = np.asarray(rec.inputs["branch"], float)
    if not np.all(np.isin(branch, (0.0, 1.0, 2.0))):
        raise ValidationError(
            f"{where}: input 'branch' must hold the loop legs 0, 1 and 2, but holds "
            f"{sorted(set(branch.tolist()))[:6]}"
        )


@dataclass
class KncFamily:
    """The K&C family's steps of the diagnosis loop (see the module docstring).

    Args:
        model: the base model (default: the plain symmetric :class:`KncAxleModel` of the
            fitted rig tests).
        max_effects: most elements added in turn.
        screen_families / screen_threshold: from the second round, refit the signature
            families scoring above the threshold (at most this many; the default, 5, is
            every family: the model score tests of the elastic and sensor elements also
            respond to other missing physics, so a cap could crowd out the loop family);
            none above it ends the search. The first round refits every candidate
            family (step 4).
        max_nfev / polish_nfev: budgets of the fits and of each fit of the joint polish
            of a winner (default ``max_nfev``; see :func:`settle`).
        rule: the decision rule (default :data:`KNC_RULE`).
    """

    model: KncAxleModel | None = None
    max_effects: int = 2
    screen_families: int = 5
    screen_threshold: float = 3.0
    max_nfev: int = 40
    polish_nfev: int | None = None
    rule: DecisionRule = KNC_RULE
    name: str = field(default="knc", init=False)
    #: the baseline fit's channel scales (noise levels), fixed for the run (set by
    #: :meth:`fit_baseline`; the screen's noise estimate reads them in every round)
    _scales: dict[str, float] = field(default_factory=dict, repr=False, init=False)

    def prepare(
        self, recordings: Recordings, holdout: Holdout, candidates: Sequence[str] | None
    ) -> Setup:
        sp = split_tests(recordings, "single" if holdout is None else holdout)
        tests = tuple(dict.fromkeys(rig_test(r) for r in sp.fit_recordings))
        model = self.model or KncAxleModel(tests=tests)
        cands = list(candidates if candidates is not None else model.candidate_effects)
        if unknown := [k for k in cands if split_candidate(k)[0] not in SCREEN_FAMILY]:
            raise ValidationError(
                f"candidates must be among {sorted(SCREEN_FAMILY)}, but got {unknown}"
            )
        return Setup(sp, model, cands)

    def check_data(self, setup: Setup) -> None:
        """Every rig recording holds its whole loop (:func:`check_loop`)."""
        for rec in setup.split.recordings():
            check_loop(rec)

    def fit_baseline(self, setup: Setup) -> FitResult:
        """Fit weighted by the measured spread, then by each channel's residual (its noise
        scale), then once more under the scales of that fit, from it and from the start
        design (as every candidate is), so that no candidate gains likelihood from the
        change of weights alone. These scales stay fixed for every model compared."""
        model, recs = setup.model, setup.split.fit_recordings
        first = fit_axle(model, recs, max_nfev=self.max_nfev, tol=COARSE_TOL)
        scales = noise_scales(first)
        base = fit_axle(model, recs, scales, [first.theta], self.max_nfev, FINE_TOL)
        scales = noise_scales(base)
        starts = (base.theta, model.initial_guess(recs[0]))
        best = fit_axle(model, recs, scales, starts, self.max_nfev, FINE_TOL)
        best.nfev += first.nfev + base.nfev
        self._scales = dict(scales)
        return best

    def locate(self, base: FitResult, setup: Setup) -> tuple[ResidualMap, str]:
        recs = setup.split.fit_recordings
        location = residual_map(
            recs, residuals(base.model, base.theta, recs, base.channels), self._scales
        )
        strongest = location.strongest(1)
        return location, (f"{strongest[0][0][1]}" if strongest else "")

    def screen(
        self, current: FitResult, setup: Setup, open_candidates: Sequence[str], round_: int
    ) -> Screening:
        recs = setup.split.fit_recordings
        res = residuals(current.model, current.theta, recs, current.channels)
        pred = [current.model.simulate(current.theta, r) for r in recs]
        fams = {SCREEN_FAMILY[split_candidate(k)[0]] for k in open_candidates}
        noise = residual_map(recs, res, self._scales).noise  # independent of the fit's scale
        sigs = [s for s in score_signatures(recs, res, pred, noise) if s.kind in fams]
        # score tests against the model: effects the fitted parameters partly mimic
        tested = [c for c in open_candidates if c in SCORE_TESTED]
        strongest: dict[str, KncSignature] = {}
        for sg in sigs + score_signatures_by_model(current, recs, tested):
            if sg.kind not in strongest or sg.score > strongest[sg.kind].score:
                strongest[sg.kind] = sg
        ordered = sorted(strongest.values(), key=lambda sg: -sg.score)
        if round_ == 1:
            picked = ordered
        else:
            picked = [s for s in ordered if s.score > self.screen_threshold][: self.screen_families]
        chosen = [
            (c, sig)
            for sig in picked
            for c in open_candidates
            if SCREEN_FAMILY[split_candidate(c)[0]] == sig.kind
        ]
        return Screening(ordered, chosen)

    def refit(
        self, current: FitResult, candidate: str, signature: SignatureLike | None, setup: Setup
    ) -> FitResult:
        return refit_frozen(
            current,
            candidate,
            setup.split.fit_recordings,
            _start_values(candidate, signature if isinstance(signature, KncSignature) else None),
            self.max_nfev,
        )

    def words(self, candidate: str, setup: Setup) -> str:
        return effect_words(make_candidate(candidate))

    def settle(self, winner: FitResult, setup: Setup) -> FitResult | None:
        polished = settle(
            winner,
            setup.split.fit_recordings,
            self.max_nfev if self.polish_nfev is None else self.polish_nfev,
            COARSE_TOL if current_slow(winner.model) else FINE_TOL,
        )
        if polished.log_likelihood() < winner.log_likelihood():
            return None
        polished.extra["effect"] = winner.extra["effect"]
        return polished

    def ambiguities(
        self, winner: Hypothesis, ranked: Sequence[Hypothesis], parent: FitResult, setup: Setup
    ) -> list[Ambiguity]:
        return location_ambiguities(winner, ranked)

    def residual_left(
        self, outcome: Outcome, setup: Setup, alpha: float
    ) -> tuple[list[Left], dict[str, Any]]:
        """The final model's residual over the fitted rig tests in noise units
        (:func:`curves_in_noise_units`), judged against a known noise level
        (:func:`~suspenv.diagnosis.checks.residual_left.from_cells`)."""
        return from_cells(curves_in_noise_units(outcome.current, setup.split.fit_recordings), alpha)

    def assumptions(self, setup: Setup) -> list[str]:
        """What the K&C diagnosis takes as given."""
        model = axle_model(setup.model)
        return [
            f"the axle's parameters other than {', '.join(model.fit_parameters)} at the "
            "start design (the reference vehicle unless given)",
            "left and right alike (the model is symmetric) unless an asymmetry is named",
            "each channel's noise read from the roughness of the residual along the loops",
        ]

    def checks(self) -> list[Check]:
        return [self._detection_limits]

    def _detection_limits(self, ctx: Context) -> Conclusion:
        """The fit's numbers for the report; where nothing is named, the smallest
        elements these tests would have shown (:func:`detection_limits`)."""
        outcome, setup = ctx.outcome, ctx.setup
        model = axle_model(setup.model)
        found = Conclusion(
            baseline={"scales": dict(self._scales), "fit_parameters": list(model.fit_parameters)}
        )
        if not outcome.named:  # say what these tests could not have seen
            noise = cast(ResidualMap, outcome.location).noise  # :meth:`locate`'s map
            limits = detection_limits(outcome.base, setup.split.fit_recordings, noise)
            found.findings["detection_limits"] = limits
            if limits:
                found.sentences.append(limits_sentence(limits))
        return found
