"""The identification's second half: add what the residual screen names, refit.

After the first fit (:func:`suspenv.methods.curves.curve_fit.fit_curves`) the K&C diagnosis'
signatures screen the residual (:func:`suspenv.methods.curves.identify.screen_residual`) and
name patterns. :func:`refine` turns each named pattern into model physics through the
same :class:`~suspenv.methods.curves.curve_fit.CurveModel` the first fit used:

* ``lr_asymmetry`` (left and right residuals differ): the sides apart, every free
  parameter but the one anti-roll bar gets a right-side twin (``sides = "both"``);
* a path-dependent or elastic pattern (``loop``: hysteresis or friction;
  ``progressive``: cubic stiffness): every candidate place the K&C diagnosis knows for
  that family (:attr:`suspenv.rigs.knc_axle.KncAxleModel.candidate_effects`,
  e.g. Dahl hysteresis in the lower-arm bushes, in the top mount, in both, Coulomb
  friction in the strut) is fitted alone (its parameters only, the diagnosis' start
  values and bounds) with the design free to first order (its Jacobian); the
  candidate with the least sum of squared residuals names the place. The screen is an
  approximation with a measured error (:func:`near_ties`): the places it cannot tell
  from the best (at most :data:`MAX_TIED` effect sets) are each refitted in full below
  and the one with the least BIC of its refit is kept;
* patterns of the sensors (load-cell gain or offset) are reported, not modelled.

Once the sides are apart the residual is screened again and only the patterns still
named are modelled (a left/right difference also leaves cubic-looking residuals); the
first fit's valleys are compared with the named physics in them (:func:`refine`). Each
near-tied place is then refitted in full, the design's and the effects' parameters
together, by secant steps (:func:`_refit`), the places side by side (:func:`_refits`),
and the one of the least BIC is kept.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.methods.curves.curve_fit import CurveFit, CurveModel
from suspenv.models.effects import Effect
from suspenv.rigs.knc_axle import effect_parameters
from suspenv.rigs.knc_fit import FAILED_RESIDUAL, PRIOR_WEIGHT, polish

#: residual families the loop models by adding an effect to the axle (the others: see
#: :data:`SIDES_FAMILY` and the sensor families, which are reported only)
EFFECT_FAMILIES = ("loop", "progressive")
#: the family that puts the sides apart
SIDES_FAMILY = "lr_asymmetry"
#: a place's refit takes secant steps (one rig evaluation each, where a differenced
#: Jacobian costs ``dim + 1``); each of its runs stops when a step changes the cost by
#: less than this (relative, the first fit's: a secant step is cheap, the valley's floor
#: is long)
SECANT_FTOL = 1e-5


@dataclass
class Candidate:
    """One place tried for a named pattern: its effect fitted alone (design held)."""

    family: str
    candidate: str
    words: str
    cost: float
    values: dict[str, float]
    #: the screen's measured error (cost units): the solved cost at the quadratic's
    #: minimiser minus the quadratic's prediction there, in magnitude
    error: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


@dataclass
class Refinement:
    """What the loop added and the refit's answer."""

    changes: list[str]
    candidates: list[Candidate]
    fit: CurveFit
    seconds: float
    skipped: list[str] = field(default_factory=list)

    @property
    def model(self) -> CurveModel:
        return self.fit.model


def effect_candidates(family: str) -> list[str]:
    """Candidate effects (``kind@location``) of a residual family that the axle's solver
    simulates: the K&C diagnosis' own list."""
    from suspenv.diagnosis.knc.signatures import FAMILY_KINDS
    from suspenv.models.mcpherson.effects import PLACEMENTS
    from suspenv.rigs.knc_axle import KncAxleModel, base_kind

    kinds = [k for k in FAMILY_KINDS.get(family, ()) if k in PLACEMENTS]
    return [c for c in KncAxleModel.candidate_effects if base_kind(c) in kinds]


#: screened places whose BIC differences to the best are below this are not positively
#: different (Kass & Raftery 1995, J. Am. Stat. Assoc. 90:773, the scale's first step)
BIC_TIE = 2.0
#: at most this many effect sets refitted in full (each refit solves rig loops step by step)
MAX_TIED = 3
#: an effect parameter's trial values for the place screen, as multiples of its start
TRIAL_FACTORS = (1.0, 2.5)


def _candidate_fit(
    model: CurveModel,
    x: np.ndarray,
    r0: np.ndarray,
    family: str,
    name: str,
    J: np.ndarray | None = None,
) -> tuple[Candidate, Effect]:
    """Effect ``name`` added at design ``x``, its one fitted parameter ``p`` chosen by a
    quadratic in ``p`` through the residual without the effect (``r0``, p = 0) and at
    :data:`TRIAL_FACTORS` x its start (one rig call each) and minimised over the
    parameter's bounds; that minimiser is solved too (a third rig call), and the least
    cost solved is the place's. A cost is the sum of squares once the design takes its
    best first-order step (:func:`_free_cost` with the design's Jacobian ``J`` at
    ``x``; None: the design held)."""
    from suspenv.rigs.knc_axle import effect_words, make_candidate

    effect = make_candidate(name)
    (param,) = effect_parameters(effect)  # the K&C candidates fit one value each
    sub = model.variant(
        base=model.full(x)[0],
        free=[param.name],
        effects=(*model.effects, effect),
        effect_free=(*model.effect_free, param),
    )
    start = float(param.default if param.default is not None else param.low)
    p = np.array([0.0, *(f * start for f in TRIAL_FACTORS)])
    R = [r0] + [_residual(sub, v) for v in p[1:]]
    # r(p) = r0 + a p + b p^2 per residual, through the three points
    V = np.vander(p, 3, increasing=True)
    coef = np.linalg.solve(V, np.vstack(R))
    grid = np.geomspace(param.low, param.high, 400)
    pred = coef[0] + np.outer(grid, coef[1]) + np.outer(grid**2, coef[2])
    # the quadratic is a model of the loop's growth, far from exact where it extrapolates:
    # its minimiser is solved too, and the place's cost is the least one solved
    predicted = _free_cost(pred, J)
    values = np.r_[p[1:], grid[np.argmin(predicted)]]
    cost = _free_cost(np.vstack([*R[1:], _residual(sub, float(values[-1]))]), J)
    # the screen's own error, measured: the quadratic's miss where it was checked
    error = abs(float(cost[-1] - predicted.min()))
    best = float(values[np.argmin(cost)])
    short = param.name.partition(".")[2]
    cand = Candidate(family, name, effect_words(effect), float(cost.min()), {short: best}, error)
    return cand, effect.with_params({short: best})


def _free_cost(R: np.ndarray, J: np.ndarray | None) -> np.ndarray:
    """Sum of squares (k,) of residuals ``R`` (k, N) after the design's best first-order
    step ``d`` under the polish's pull towards its start: ``min_d |r + J d|^2 +
    w^2 |d|^2 = r'r - r'J (J'J + w^2 I)^-1 J'r`` (``w`` :data:`PRIOR_WEIGHT`). A place
    is judged by what the design cannot explain: held, the design's own error (a start
    in another valley, a side's offset) would be charged to the places alike, and the
    effect whose pattern happens to cancel it would win."""
    cost = np.einsum("ij,ij->i", R, R)
    if J is None:
        return cost
    Z = R @ J
    H = J.T @ J + PRIOR_WEIGHT**2 * np.eye(J.shape[1])
    return cost - np.einsum("ij,ji->i", Z, np.linalg.solve(H, Z.T))


def _residual(model: CurveModel, value: float) -> np.ndarray:
    """Residual of ``model``'s base design with its one free value set to ``value``."""
    X = model.base.copy()[None]
    X[:, model.free_index] = value
    R, ok, msg = model.residuals_x(X)
    if not ok[0]:
        return np.full(model.size, FAILED_RESIDUAL)
    return R[0]


@dataclass
class Valley:
    """A first-fit answer carried through the loop's screens: its model (sides apart
    when named), the design polished there, the Jacobian, the families still named and
    every family's near-tied places (:func:`near_ties`). ``cost``: the least screened
    cost of the last family's places (a valley is judged with the named physics in
    it), else the polished cost."""

    model: CurveModel
    x: np.ndarray
    ties: list[list[tuple[Candidate, Effect]]]
    tried: list[Candidate]
    named: list[str]
    cost: float


def refine(
    fit: CurveFit,
    named: Sequence[str],
    x0: np.ndarray,
    polish_nfev: int = 150,
    refit_nfev: int = 250,
    say: Callable[[str], None] | None = None,
    pool: Any = None,
    progress: bool = False,
    screen: Callable[[CurveModel, np.ndarray], list[str]] | None = None,
) -> Refinement | None:
    """Add to ``fit.model`` what the screen named (families ``named``, strongest first)
    and refit; None when nothing named is modelled. ``x0``: the start design of the
    first fit (the polish's weak pull stays towards it); ``polish_nfev``: budget of the
    sides-apart polish (path-independent, cheap), ``refit_nfev``: secant steps of each
    near-tied place's refit (each evaluation of a path-dependent model is a rig loop
    solved step by step);
    ``screen(model, x)``: the residual screen's named families at a design, asked again
    once the sides are apart (None: the families ``named`` stand).

    Every valley the first fit polished (:attr:`CurveFit.valleys`) is carried through
    the sides-apart polish and the place screen, and the one of the least screened cost
    is refitted: the model without the named physics has near-equal valleys (a loop is
    mimicked many ways), and which one a single polish reaches hinges on float-level
    details, while the places' costs in them differ by orders of magnitude."""
    t0 = time.perf_counter()
    say = say or (lambda _m: None)
    skipped = [f for f in named if f != SIDES_FAMILY and f not in EFFECT_FAMILIES]
    apart = SIDES_FAMILY in named and not fit.model.two_sided
    changes = []
    if apart:
        changes.append("sides apart: every free parameter but the anti-roll bar gets a right twin")
    starts = fit.valleys
    # the second valley's sides-apart polish in the second process when there is one
    there = (
        pool.submit(_apart, fit, starts[1], x0, polish_nfev)
        if apart and pool and starts[1:]
        else None
    )
    valleys = []
    for i, u in enumerate(starts):
        placed = (
            (there.result() if i == 1 and there else _apart(fit, u, x0, polish_nfev, progress))
            if apart
            else None
        )
        valleys.append(_valley(fit, u, placed, named, pool, screen, say))
    if len(valleys) > 1:
        say(
            "loop: the first fit's valleys, screened cost "
            + ", ".join(f"{v.cost:.1f}" for v in valleys)
        )
    best = min(valleys, key=lambda v: v.cost)
    skipped += [f for f in best.named if f in EFFECT_FAMILIES and not effect_candidates(f)]
    if not best.ties:
        return None
    plain = best.model
    options = tie_options(best.ties)
    if len(options) > 1:
        say(f"loop: near-tied places, each refitted in full: {' | '.join(map(_names, options))}")
    say("loop: all parameters refitted together, by secant steps until converged")
    models = [_with_effects(plain, best.x, [e for _, e in o]) for o in options]
    refits = _refits(models, x0, refit_nfev, pool, progress)
    scores = [bic(f.cost, f.model.dim, f.model.size) for f in refits]
    pick = int(np.argmin(scores))
    changes += [f"{c.words} ({c.candidate})" for c, _ in options[pick]]
    if len(options) > 1:
        changes.append(
            "near-tied places refitted in full, the least BIC kept: "
            + "; ".join(f"{_names(o)}: {v:.1f}" for o, v in zip(options, scores, strict=True))
        )
    out = refits[pick]
    out.final.name = "refit with " + "; ".join(changes)
    return Refinement(changes, best.tried, out, time.perf_counter() - t0, skipped)


def _apart(
    fit: CurveFit, u: np.ndarray, x0: np.ndarray, polish_nfev: int, progress: bool = False
) -> tuple[CurveModel, np.ndarray, np.ndarray, float]:
    """The first fit's answer ``u`` (a unit point of ``fit.model``) with the sides apart:
    (the two-sided model, the design polished there with the weak pull towards ``x0``,
    the Jacobian there, the cost)."""
    model = fit.model
    x = model.designs(u[None])[0]
    d = model.space.dim
    model = model.variant(two_sided=True, base=np.r_[x[:d], x[model.sides :]])
    stage, _, J = polish(
        model, model.unit(model.base), polish_nfev, progress=progress, prior=model.unit(x0)
    )
    return model, model.designs(stage.u[None])[0], J, stage.cost


def _valley(
    fit: CurveFit,
    u: np.ndarray,
    apart: tuple[CurveModel, np.ndarray, np.ndarray, float] | None,
    named: Sequence[str],
    pool: Any,
    screen: Callable[[CurveModel, np.ndarray], list[str]] | None,
    say: Callable[[str], None],
) -> Valley:
    """The first fit's answer ``u`` (sides apart: :func:`_apart`'s answer from it, the
    screen asked again there) and every named effect family's places screened there
    (:func:`_candidate_fit`)."""
    if apart is None:
        model, x, cost = fit.model, fit.model.designs(u[None])[0], float(np.inf)
        J = fit.jacobian if u is fit.u else model.jacobian(u)[1]
    else:
        model, x, J, cost = apart
        say(f"loop: sides apart (a right-side twin of every free parameter): cost {cost:.1f}")
        if screen is not None:  # what the sides apart leave: a pattern may have gone
            named = [SIDES_FAMILY, *screen(model, x)]
            say(f"loop: the screen now names {named[1:] or 'nothing more'}")
    plain, ties, tried = model, [], []
    for family in [f for f in named if f in EFFECT_FAMILIES]:
        names = effect_candidates(family)
        if not names:
            continue
        say(f"loop: {family}: each place alone ({', '.join(names)})")
        r0 = model.residual_at(x, "the design being refined")
        # half of the places in the second process when there is one
        there = [] if pool is None else names[1::2]
        futures = [pool.submit(_candidate_fit, model, x, r0, family, n, J) for n in there]
        fits = [_candidate_fit(model, x, r0, family, n, J) for n in names if n not in there]
        fits += [f.result() for f in futures]
        tried += [f[0] for f in fits]
        # the K&C candidates fit one value each: k = 1 apiece
        cands = [f[0] for f in fits]
        keep = near_ties(
            [c.cost for c in cands], [1] * len(fits), r0.size, [c.error for c in cands]
        )
        ties.append([fits[i] for i in keep])
        cost = min(c.cost for c in cands)
        model = _with_effects(plain, x, [t[0][1] for t in ties])
    return Valley(plain, x, ties, tried, list(named), cost)


def bic(cost: float, k: int, n: int) -> float:
    """Bayesian information criterion of a least-squares fit in noise units: ``cost``
    (sum of squared residuals / noise, i.e. -2 log likelihood up to a constant) plus
    ``k ln n`` for ``k`` fitted values and ``n`` residuals."""
    return float(cost) + k * float(np.log(n))


def near_ties(
    costs: Sequence[float], ks: Sequence[int], n: int, errors: Sequence[float] | None = None
) -> list[int]:
    """Indices of the screened places carried to the full refit, best first (at most
    :data:`MAX_TIED`): those the screen cannot tell from the best. The screen is an
    approximation with a measured error per place (``errors``, cost units; None: 0): a
    place is tied when its screened :func:`bic` exceeds the least by less than
    :data:`BIC_TIE` (not positively different) plus both places' errors (their cost
    intervals overlap)."""
    score = np.array([bic(c, k, n) for c, k in zip(costs, ks, strict=True)])
    err = np.zeros(score.size) if errors is None else np.abs(np.asarray(errors, float))
    order = np.argsort(score, kind="stable")
    b = order[0]
    return [int(i) for i in order if score[i] - score[b] < BIC_TIE + err[b] + err[i]][:MAX_TIED]


def tie_options(
    ties: Sequence[Sequence[tuple[Candidate, Effect]]],
) -> list[list[tuple[Candidate, Effect]]]:
    """The effect sets refitted in full: every family's best place, then each near-tied
    place of a family in place of its best (the others at their best), at most
    :data:`MAX_TIED` in all."""
    best = [t[0] for t in ties]
    out = [best]
    for j, t in enumerate(ties):
        out += [[*best[:j], alt, *best[j + 1 :]] for alt in t[1:]]
    return out[:MAX_TIED]


def _names(option: Sequence[tuple[Candidate, Effect]]) -> str:
    return " + ".join(c.candidate for c, _ in option)


def _with_effects(model: CurveModel, x: np.ndarray, effects: Sequence[Effect]) -> CurveModel:
    """``model`` at design ``x`` with ``effects`` added, their parameters fitted."""
    params = [p for e in effects for p in effect_parameters(e)]
    return model.variant(
        base=x,
        free=[*model.free, *(p.name for p in params)],
        effects=(*model.effects, *effects),
        effect_free=(*model.effect_free, *params),
    )


def _refits(
    models: Sequence[CurveModel], x0: np.ndarray, nfev: int, pool: Any, progress: bool
) -> list[CurveFit]:
    """:func:`_refit` of each of ``models``, every second one in the second process when
    there is one (a refit's secant steps are single rig loops: the places' refits, not a
    batch's halves, share the two processes; the same numbers either way)."""
    there = {i: pool.submit(_refit, m, x0, nfev) for i, m in enumerate(models) if pool and i % 2}
    here = {i: _refit(m, x0, nfev, progress) for i, m in enumerate(models) if i not in there}
    return [here[i] if i in here else there[i].result() for i in range(len(models))]


def _refit(model: CurveModel, x0: np.ndarray, nfev: int, progress: bool = False) -> CurveFit:
    """All of ``model``'s parameters polished together from its base by secant steps
    (:func:`~suspenv.rigs.knc_fit.polish` with Broyden's update), restarted with a
    differenced Jacobian until a restart gains less than
    :data:`~suspenv.rigs.knc_fit.RESTART_GAIN`, the weak pull towards the first
    fit's start design ``x0`` (effects at their starts); ``nfev`` evaluations at most.
    The answer's Jacobian is a differenced one."""
    prior = model.unit(_start(model, x0))
    u0 = model.unit(model.base)
    polished = polish(
        model, u0, nfev, nfev, progress=progress, prior=prior, ftol=SECANT_FTOL, broyden=True
    )
    return CurveFit.of(model, polished)


def _start(model: CurveModel, x0: np.ndarray) -> np.ndarray:
    """The first fit's start design as a design of ``model`` (effects at their starts)."""
    starts = {p.name: p.reference for e in model.effects for p in effect_parameters(e)}
    x = model.full(np.asarray(x0, float)[: model.space.dim])[0]
    x[model.sides :] = [
        starts.get(p.name, v) for p, v in zip(model.effect_free, x[model.sides :], strict=True)
    ]
    return x
