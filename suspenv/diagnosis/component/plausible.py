"""Plausibility of a refitted component element: rules a refit must pass to stand.

Each rule reads the element of the effects library in the refit (its fitted values and
their serial-correlation corrected errors) and refuses a refit whose element is not the
physics its kind names: a friction step as wide as a valve knee, a hysteresis loop as
narrow as friction's pre-sliding, a viscoelastic branch that carries the whole force, a
size not resolved from zero, stiction whose level rises with speed, a breakaway above
every recorded force. A refused refit is recorded as a failed hypothesis with the
rule's sentence (:class:`~suspenv.core.errors.ValidationError`), so a look-alike refitted
in the same round can be named. The rules read element kinds and parameters only, so
any family whose model holds these elements can list :func:`run` among its refit checks
(``family.refit_checks()``, run by :func:`suspenv.diagnosis.checks.refuse`).

Units: SI (speeds [m/s], displacements [m], forces [N]).
"""

from __future__ import annotations

from collections.abc import Container, Sequence
from typing import Any

import numpy as np
from scipy import stats

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.checks.finding import Context, Finding
from suspenv.diagnosis.component.motion import stroke
from suspenv.diagnosis.component.refit import SIZE_Z, parameter_and_error
from suspenv.diagnosis.fitting import FitResult
from suspenv.diagnosis.hypothesis import split_candidate
from suspenv.diagnosis.split import Split


def _judged_element(
    candidate: str, ext: FitResult, kinds: Container[str]
) -> tuple[str, Any] | None:
    """(kind, the refitted element at its fitted values) of ``candidate`` in ``ext`` when
    its kind is among ``kinds`` (those a rule judges) and the refit holds it; None
    otherwise (the rule does not apply)."""
    kind = split_candidate(candidate)[0]
    element = ext.element(kind) if kind in kinds else None
    return None if element is None else (kind, element)


def _fitted_with_covariance(
    ext: FitResult, kind: str, parameters: Sequence[str]
) -> tuple[dict[str, float], np.ndarray, list[str]]:
    """The fitted values of those of ``parameters`` of the element of ``kind`` in ``ext``
    that the fit frees (a parameter held fixed is left out), their covariance block
    (inflated like ``stderr_corrected``) and its order; empty without the element."""
    if (element := ext.element(kind)) is None:
        return {}, np.zeros((0, 0)), []
    names = list(ext.names)
    free = [q for q in parameters if f"{element.name}.{q}" in names]
    cols = [names.index(f"{element.name}.{q}") for q in free]
    values = {q: float(ext.theta[c]) for q, c in zip(free, cols, strict=True)}
    return values, ext.covariance_corrected()[np.ix_(cols, cols)], free


def ratio_and_error(ext: FitResult, kind: str, num: str, den: str) -> tuple[float, float]:
    """The ratio ``num / den`` of two fitted parameters of the element of ``kind`` in
    ``ext`` and its standard error (first order, with their covariance, inflated for
    serially correlated residuals like ``stderr_corrected``); NaN, NaN when either is
    not fitted or not positive."""
    values, cov, free = _fitted_with_covariance(ext, kind, (num, den))
    if free != [num, den]:  # no element, or one held fixed
        return np.nan, np.nan
    a, b = values[num], values[den]
    if not (a > 0 and b > 0):
        return np.nan, np.nan
    rel = cov[0, 0] / a**2 + cov[1, 1] / b**2 - 2.0 * cov[0, 1] / (a * b)
    return a / b, a / b * float(np.sqrt(max(rel, 0.0)))


def stribeck_rise_and_error(ext: FitResult, kind: str, vmax: float) -> tuple[float, float]:
    """How much a Stribeck level rises from reversal to the peak speed ``vmax`` [m/s]:
    ``(f_c - f_s) (1 - exp(-(vmax / v_s)^2))`` [N] of the element of ``kind`` in ``ext``
    (positive: a level rising with speed), and its standard error (first order, with the
    covariance of ``f_c``, ``f_s`` and ``v_s``, inflated like ``stderr_corrected``; a
    parameter held fixed adds none). This is what the recorded speeds resolve: with
    ``v_s`` far above ``vmax`` only ``(f_c - f_s) / v_s^2`` is, and ``f_c - f_s`` alone
    can be any size. NaN, NaN when the element or a level is not fitted."""
    values, cov, free = _fitted_with_covariance(ext, kind, ("f_c", "f_s", "v_s"))
    if "f_c" not in values or "f_s" not in values:
        return np.nan, np.nan
    element = ext.element(kind)
    assert element is not None  # it holds fitted levels
    v_s = float(np.ravel(element.params["v_s"])[0])
    if not (vmax > 0 and v_s > 0):
        return np.nan, np.nan
    u = (vmax / v_s) ** 2
    reach = -float(np.expm1(-u))  # 1 - exp(-u), exact for small u
    drop = values["f_c"] - values["f_s"]
    grad = {"f_c": reach, "f_s": -reach, "v_s": -drop * np.exp(-u) * 2.0 * u / v_s}
    g = np.array([grad[q] for q in free])
    return drop * reach, float(np.sqrt(max(float(g @ cov @ g), 0.0)))


#: a friction step completes within a few percent of the speed range, a valve knee lies
#: at a tenth of it or more: a friction element fitted wider than FRICTION_MAX_FRACTION of
#: the peak speed is a knee, a digressive curve fitted narrower than KNEE_MIN_FRACTION is
#: a step; between the two both are fitted, and an equal fit is reported as inseparable
FRICTION_MAX_FRACTION = 0.10
KNEE_MIN_FRACTION = 0.03
#: the transition width [m/s] of each kind whose shape a step or a knee can take
TRANSITION_WIDTH = {
    "coulomb_friction": "v_eps",
    "stribeck_friction": "v_eps",
    "directional_friction": "v_eps",
    "digressive_damping": "v_knee",
}


def check_step_or_knee(candidate: str, ext: FitResult, vmax: float) -> None:
    """Refuse a refit whose fitted transition contradicts its kind.

    A regularised Coulomb step ``f_c tanh(v / v_eps)`` beside the viscous base and a
    digressive curve ``c_low v / (1 + |v| / v_knee)`` are nearly one function of velocity
    (both rise steeply and saturate): on a dyno the two fit much the same data, so the
    fitted width against the peak speed ``vmax`` [m/s] decides which physics it is
    (:data:`FRICTION_MAX_FRACTION`, :data:`KNEE_MIN_FRACTION`). Raises
    :class:`ValidationError` so the other kind, refitted in the same round, is named.
    """
    found = _judged_element(candidate, ext, TRANSITION_WIDTH) if vmax > 0 else None
    if found is None:
        return
    kind, element = found
    width = float(np.ravel(element.params[TRANSITION_WIDTH[kind]])[0])
    frac = width / vmax
    is_friction = kind != "digressive_damping"
    if is_friction and frac > FRICTION_MAX_FRACTION:
        raise ValidationError(
            f"{kind}: the fitted step is {1e3 * width:.3g} mm/s wide, {100 * frac:.1f} % of the "
            f"peak speed {vmax:.3g} m/s (> {100 * FRICTION_MAX_FRACTION:.0f} %): a gradual knee, "
            "which is a digressive damper curve, not a friction step"
        )
    if not is_friction and frac < KNEE_MIN_FRACTION:
        raise ValidationError(
            f"{kind}: the fitted knee is at {1e3 * width:.3g} mm/s, {100 * frac:.1f} % of the "
            f"peak speed {vmax:.3g} m/s (< {100 * KNEE_MIN_FRACTION:.0f} %): a force step at "
            "every reversal, which is friction, not a valve knee"
        )


#: a hysteresis loop of a material (a bushing, the MR fluid before yield) builds up over
#: millimetres, the pre-sliding of friction over micrometres to tens of micrometres: on a
#: stroke of tens of millimetres a loop that completes within this fraction of the
#: half-stroke is a force step at every reversal with a pre-sliding stiffness
HYSTERESIS_MIN_FRACTION = 0.005


def hysteresis_transition(kind: str, params: dict[str, Any]) -> float | None:
    """The displacement [m] over which a hysteresis element's force builds up after a
    reversal: ``f_c / sigma`` (Dahl), the yield displacement ``x_y`` (Bouc-Wen); None for
    other kinds."""
    if kind == "dahl_hysteresis":
        return float(np.ravel(params["f_c"])[0]) / float(np.ravel(params["sigma"])[0])
    if kind == "bouc_wen_hysteresis":
        return float(np.ravel(params["x_y"])[0])
    return None


def _loop_narrower_than(candidate: str, ext: FitResult, limit: float) -> tuple[str, float] | None:
    """(kind, transition length [m]) of the hysteresis element refitted for ``candidate``
    in ``ext`` when its loop completes within ``limit`` [m] (> 0); None otherwise (no
    such element, a wider loop, or no limit; :func:`hysteresis_transition`)."""
    found = _judged_element(candidate, ext, ("dahl_hysteresis", "bouc_wen_hysteresis"))
    if found is None or not limit > 0:
        return None
    width = hysteresis_transition(found[0], found[1].params)
    return None if width is None or width >= limit else (found[0], width)


def fits_presliding(model: Any, candidates: Sequence[str]) -> bool:
    """True when ``candidates`` hold a friction law with a pre-sliding displacement of
    its own that ``model`` fits: LuGre with its bristle stiffness ``sigma0`` among the
    model's freed parameters (a guide's contact, a damper's seal: both creep before they
    slide). Which loop rules then apply: :func:`run`.
    """
    return rounds_own_step(model, "lugre_friction") and any(
        split_candidate(c)[0] == "lugre_friction" for c in candidates
    )


#: a loop is seen as a loop only when it builds up over more than this many standard
#: deviations of the displacement's noise
LOOP_NOISE_MULTIPLE = 2.0


def check_loop_resolved(candidate: str, ext: FitResult, displacement_noise: float) -> None:
    """Refuse a hysteresis refit whose loop completes within ``LOOP_NOISE_MULTIPLE``
    standard deviations of the recorded displacement's white noise ``displacement_noise``
    [m] (in place of :func:`check_loop_or_step`: :func:`run`).

    A force that builds up over less displacement than the displacement's own noise is,
    as far as the recording can tell, a force step at every reversal: the loop's shape is
    below the resolution of the motion it is read against, and a step at every reversal
    is friction's (the friction refitted in the same round competes for it). Raises
    :class:`ValidationError`; not applied when the displacement's noise is 0 (not measured).
    """
    narrow = _loop_narrower_than(candidate, ext, LOOP_NOISE_MULTIPLE * displacement_noise)
    if narrow is None:
        return
    kind, width = narrow
    raise ValidationError(
        f"{kind}: the fitted loop completes within {1e6 * width:.3g} micrometres after each "
        f"reversal, under {LOOP_NOISE_MULTIPLE:g} standard deviations of the displacement's "
        f"noise ({1e6 * displacement_noise:.3g} micrometres): a force step at every "
        "reversal as far as the recording can tell, not a loop it resolves"
    )


def check_loop_or_step(candidate: str, ext: FitResult, half_stroke: float) -> None:
    """Refuse a hysteresis refit whose loop completes within ``HYSTERESIS_MIN_FRACTION``
    of the half-stroke ``half_stroke`` [m] after each reversal.

    Such a loop is a force step at every reversal whose rise is the pre-sliding of
    friction (LuGre, Dahl's friction model: tens of micrometres), not the loop of a
    material that yields over a fair part of the stroke. Raises :class:`ValidationError`,
    so the friction element refitted in the same round is named.
    """
    narrow = _loop_narrower_than(candidate, ext, HYSTERESIS_MIN_FRACTION * half_stroke)
    if narrow is None:
        return
    kind, width = narrow
    raise ValidationError(
        f"{kind}: the fitted loop completes within {1e6 * width:.3g} micrometres after each "
        f"reversal, {100 * width / half_stroke:.2g} % of the half-stroke "
        f"{1e3 * half_stroke:.3g} mm (< {100 * HYSTERESIS_MIN_FRACTION:.1f} %): a force step "
        "at every reversal with the pre-sliding of friction, not a hysteresis loop"
    )


def check_presliding_is_friction(candidate: str, ext: FitResult, half_stroke: float) -> None:
    """Refuse a LuGre refit whose bristle deflection while sliding, ``f_c / sigma0`` [m],
    is wider than ``HYSTERESIS_MIN_FRACTION`` of the half-stroke ``half_stroke`` [m] by
    more than ``SIZE_Z`` corrected standard errors of its logarithm
    (:func:`ratio_and_error`): the mirror of :func:`check_loop_or_step` where the model
    fits the bristle stiffness (:func:`fits_presliding`). Such a force builds up over a
    fair part of the stroke after each reversal, a material's loop, so the hysteresis
    refitted in the same round is named. Not judged where the width or its error is not
    known.
    """
    kind = split_candidate(candidate)[0]
    if kind != "lugre_friction" or half_stroke <= 0:
        return
    width, sd = ratio_and_error(ext, kind, "f_c", "sigma0")
    if not np.isfinite(sd):
        return
    bound = HYSTERESIS_MIN_FRACTION * half_stroke
    # a ratio of two positive parameters: its error read on the logarithm
    least = width * float(np.exp(-SIZE_Z * sd / width))
    if least <= bound:
        return
    raise ValidationError(
        f"{kind}: the fitted bristles deflect f_c / sigma0 = {1e6 * width:.3g} +- "
        f"{1e6 * sd:.2g} micrometres while sliding, {100 * width / half_stroke:.2g} % of the "
        f"half-stroke {1e3 * half_stroke:.3g} mm, and at least {1e6 * least:.3g} micrometres "
        f"({SIZE_Z:g} standard errors of its logarithm; > {100 * HYSTERESIS_MIN_FRACTION:.1f} "
        "%): a force that builds up over a fair part of the stroke after each reversal, "
        "which is a hysteresis loop, not the pre-sliding of friction"
    )


#: a Maxwell branch whose base keeps less than this share of the viscous coefficient
#: ``c + c_m`` carries the whole viscous force, however well the share is resolved
WHOLE_FORCE_BASE_SHARE = 0.05


def check_parallel_branch(candidate: str, ext: FitResult, alpha: float = 0.01) -> None:
    """Refuse a Maxwell refit whose base damping ``c`` [N s/m] is not resolved from zero
    (under the two-sided ``alpha`` quantile of the normal in standard errors: 2.58 at
    1 %, the test of the lag nested in the branch at ``c = 0``) or keeps under
    ``WHOLE_FORCE_BASE_SHARE`` of ``c + c_m``.

    With ``c`` at zero the branch beside the base damping (``F = c v + F_m``,
    ``dF_m/dt = k_m (v - F_m / c_m)``) is exactly a first-order lag of the whole force of
    a linear base: ``(k + c s) / (1 + tau s)`` is the spring beside a branch of
    ``c_m = c - k tau``, ``k_m = c_m / tau``, what a lagging force sensor gives with one
    parameter; the lag refitted in the same round is then the simpler law. A model
    without a viscous base parameter (``viscous_parameter``) is not checked.
    """
    if (found := _branch_base(candidate, ext)) is None:
        return
    name, c, sd, c_m = found
    z = float(stats.norm.isf(0.5 * alpha))
    if c >= z * sd and c >= WHOLE_FORCE_BASE_SHARE * (c + c_m):
        return
    raise ValidationError(
        f"{candidate.partition('@')[0]}: the fitted branch carries the whole viscous force "
        f"(base {name} = {c:.3g} +- {sd:.2g} N s/m beside the branch's c_m = {c_m:.4g} N s/m: "
        f"not {z:.3g} standard errors from zero, or under "
        f"{100 * WHOLE_FORCE_BASE_SHARE:.0f} % of the two): a lag of the whole force, which "
        "a lagging force sensor (or a compliant mount in series with the whole part) gives "
        "with one parameter, not a viscoelastic branch beside the damping"
    )


def branch_share_unresolved(candidate: str, ext: FitResult, alpha: float = 0.01) -> bool:
    """Whether a Maxwell refit leaves open a branch beside the damping: its base
    coefficient ``c`` not resolved from zero (within the two-sided ``alpha`` quantile
    ``z`` of the normal, in standard errors: :func:`check_parallel_branch`) while the
    data do not exclude a base share of ``WHOLE_FORCE_BASE_SHARE`` either
    (``c + z sd`` at least that share of ``c + c_m``). The data then fit a lag of the
    whole force and a branch beside part of the damping alike (at ``w tau`` small the two
    differ only at second order: Limits in ``docs/diagnosis.md``). A base bounded below
    the share (``c = 4 +- 7`` beside ``c_m = 1100``) is a lag of the whole force, and a
    share resolved and small is too: nothing to separate."""
    if (found := _branch_base(candidate, ext)) is None:
        return False
    _, c, sd, c_m = found
    z = float(stats.norm.isf(0.5 * alpha))
    return bool(c < z * sd and c + z * sd >= WHOLE_FORCE_BASE_SHARE * (c + c_m))


def _branch_base(candidate: str, ext: FitResult) -> tuple[str, float, float, float] | None:
    """(name of the base viscous parameter, its value [N s/m], its standard error, the
    branch's ``c_m`` [N s/m]) of a Maxwell refit; None for another candidate, a model
    without a viscous base parameter (``viscous_parameter``) or an error not computed."""
    found = _judged_element(candidate, ext, ("maxwell_viscoelastic",))
    name = getattr(ext.model, "viscous_parameter", "")
    fitted = ext.params()
    if found is None or name not in fitted or not np.isfinite(fitted[name]["stderr"]):
        return None
    c, sd = fitted[name]["value"], fitted[name]["stderr"]
    return name, float(c), float(sd), float(np.ravel(found[1].params["c_m"])[0])


#: the parameters that give each element kind its size, all with zero for "no element"
#: (linear parameters only: a log-scaled one's standard error is not in its unit): an
#: element is a finding only when one of them is resolved from zero
ELEMENT_SIZE: dict[str, tuple[str, ...]] = {
    "coulomb_friction": ("f_c",),
    "stribeck_friction": ("f_c", "f_s"),
    "directional_friction": ("f_pos", "f_neg"),
    "lugre_friction": ("f_c", "f_s"),
    "dahl_hysteresis": ("f_c",),
    "bouc_wen_hysteresis": ("f_y",),
    "cubic_stiffness": ("k3",),
    "progressive_stiffness": ("k_p",),
    "bump_stop": ("k_stop",),
    "rebound_stop": ("k_stop",),
    "bump_and_rebound_stops": ("k_bump", "k_rebound"),
    "digressive_damping": ("c_low",),
    "asymmetric_digressive_damping": ("c_bump", "c_rebound"),
    "damper_asymmetry": ("dc_rebound",),
    "sensor_lag": ("tau",),
    "sensor_offset": ("offset",),
    "force_offset": ("offset",),
}


def check_resolved_size(candidate: str, ext: FitResult) -> None:
    """Refuse a refit whose element's size parameters (``ELEMENT_SIZE``) are all zero
    within ``SIZE_Z`` corrected standard errors.

    Such a fit improves the residual through something else than the element: its shape
    at a size the data cannot tell from zero (LuGre's bristle damping ``sigma1 dz/dt``, a
    viscous force at standstill, absorbs a drifting zero), or the base parameters moving
    to a better optimum from the refit's new start. Raises :class:`ValidationError`.
    """
    if (found := _judged_element(candidate, ext, ELEMENT_SIZE)) is None:
        return
    kind, element = found
    fitted = ext.params()
    seen = []
    for q in ELEMENT_SIZE[kind]:
        key = f"{element.name}.{q}"
        if key not in fitted:  # a size held fixed is not judged here
            return
        value, sd = fitted[key]["value"], fitted[key]["stderr_corrected"]
        if not np.isfinite(sd) or abs(value) > SIZE_Z * sd:
            return
        seen.append(f"{q} = {value:.3g} +- {sd:.2g}")
    raise ValidationError(
        f"{kind}: its fitted size is zero within {SIZE_Z:g} standard errors "
        f"({', '.join(seen)}): the fit improves through something else than this element"
    )


#: the friction kinds with a breakaway (static) level ``f_s`` beside their sliding level
#: ``f_c``: stiction, whose friction falls from ``f_s`` at reversal to ``f_c`` with speed
STICTION_KINDS = ("stribeck_friction", "lugre_friction")


#: the parameter that rounds each stiction law's step at reversal by itself: the width
#: of the regularised step (Stribeck) or the bristle stiffness, whose pre-sliding
#: displacement ``f / sigma0`` rounds the step over the travel after the reversal (LuGre)
STEP_ROUNDING = {"stribeck_friction": "v_eps", "lugre_friction": "sigma0"}


def rounds_own_step(model: Any, kind: str) -> bool:
    """True when ``model`` fits the parameter that rounds the stiction law ``kind``'s step
    (:data:`STEP_ROUNDING` among its ``freed_parameters``); that law then needs no rising
    level to round its step (:func:`check_stiction_decays`)."""
    freed = getattr(model, "freed_parameters", {})
    return STEP_ROUNDING.get(kind, "") in freed.get(kind, ())


def check_stiction_decays(
    candidate: str, ext: FitResult, vmax: float, rounded: bool = False
) -> None:
    """Refuse a stiction refit whose level rises with speed: the rise up to the peak
    speed ``vmax`` [m/s] (:func:`stribeck_rise_and_error`) more than ``SIZE_Z`` standard
    errors, over a Stribeck velocity ``v_s`` beyond ``FRICTION_MAX_FRACTION`` of
    ``vmax`` (within it, a fixed-width step's rounding looks alike) or over any ``v_s``
    where the law rounds its step by a parameter of its own (``rounded``:
    :func:`rounds_own_step`).

    Stiction breaks away at ``f_s >= f_c`` and falls to ``f_c`` over ``v_s``; a level
    that rises instead (with ``f_s`` near zero about ``f_c (v / v_s)^2``) is a
    velocity-dependent damping the shape absorbs without being friction. A friction
    step of another kind refitted in the same round can still be named.
    """
    found = _judged_element(candidate, ext, STICTION_KINDS) if vmax > 0 else None
    if found is None:
        return
    kind, element = found
    v_s = float(np.ravel(element.params["v_s"])[0])
    if not rounded and v_s <= FRICTION_MAX_FRACTION * vmax:
        return
    # NaN for a level held fixed, which is not judged here
    f_c, sd_c = parameter_and_error(ext, kind, "f_c")
    f_s, sd_s = parameter_and_error(ext, kind, "f_s")
    # the rise over the recorded speeds, not f_c - f_s (:func:`stribeck_rise_and_error`)
    rise, sd = stribeck_rise_and_error(ext, kind, vmax)
    if not np.isfinite(sd) or rise <= SIZE_Z * sd:
        return
    raise ValidationError(
        f"{kind}: the fitted breakaway level f_s = {f_s:.3g} +- {sd_s:.2g} N is below the "
        f"sliding level f_c = {f_c:.4g} +- {sd_c:.2g} N, reached over v_s = {v_s:.3g} m/s "
        f"({100 * v_s / vmax:.0f} % of the peak speed {vmax:.3g} m/s, "
        + (
            f"the step rounded by its own {STEP_ROUNDING[kind]}"
            if rounded
            else f"> {100 * FRICTION_MAX_FRACTION:.0f} %"
        )
        + f"; it rises by {rise:.3g} +- {sd:.2g} N up to the peak speed): a force that "
        "grows gradually with speed from the reversal, which is a "
        "velocity-dependent damping force, not stiction (whose breakaway exceeds its "
        "sliding level)"
    )


def check_breakaway_recorded(candidate: str, ext: FitResult, sp: Split) -> None:
    """Refuse a stiction refit whose breakaway level ``f_s`` [N] exceeds every recorded
    force of the split: a part that moves is pushed past its breakaway at each reversal,
    so the fitted level is one only over a Stribeck velocity too small for any sample to
    see, and the shape fits the transient it drives (a loop over the stroke). Models
    without a recorded ``force`` channel are not judged.
    """
    found = _judged_element(candidate, ext, STICTION_KINDS)
    forces = [
        np.asarray(r.outputs["force"], float) for r in sp.recordings() if "force" in r.outputs
    ]
    if found is None or not forces:
        return
    kind, element = found
    f_s = float(np.ravel(element.params["f_s"])[0])
    largest = max(float(np.max(np.abs(f))) for f in forces if f.size)
    if f_s <= largest:
        return
    raise ValidationError(
        f"{kind}: the fitted breakaway level f_s = {f_s:.4g} N is above every recorded force "
        f"(largest {largest:.4g} N), which a part that moves cannot hold; the shape fits "
        "the transient it drives over a Stribeck velocity too small to see, a loop over "
        "the stroke, not stiction"
    )


def run(ctx: Context) -> Finding | None:
    """The refit of ``ctx`` against the rules of its element's kind, in order; the first
    rule it breaks refuses it (a Finding with the rule's sentence). The half-stroke and
    peak speed are the fitted motion's; the displacement's noise is the family's
    ``displacement_noise_m`` [m] (0: not measured).

    Where the candidates hold a friction law whose pre-sliding the model fits
    (:func:`fits_presliding`), that pre-sliding is bounded like a loop's width
    (:func:`check_presliding_is_friction`); where the test also dwells between moves
    (``dwells_between_moves``: a loop holds its force at rest, friction does not), a
    small loop and friction compete on the data (friction's law has the stiction and
    Stribeck fall a rate-independent loop lacks, so a loop that fits better is a loop),
    and a loop is judged against the displacement's noise only
    (:func:`check_loop_resolved`). Elsewhere a small loop is a step
    (:func:`check_loop_or_step`: the width decides)."""
    setup, ext, candidate = ctx.setup, ctx.refit, ctx.candidate
    if ext is None:
        return None
    half, vmax = stroke(setup.split)
    try:
        check_step_or_knee(candidate, ext, vmax)
        presliding = fits_presliding(setup.model, setup.candidates)
        if presliding and getattr(setup.model, "dwells_between_moves", False):
            noise = float(getattr(ctx.family, "displacement_noise_m", 0.0))
            check_loop_resolved(candidate, ext, noise)
        else:
            check_loop_or_step(candidate, ext, half)
        if presliding:
            check_presliding_is_friction(candidate, ext, half)
        check_parallel_branch(candidate, ext, ctx.rule.alpha)
        check_resolved_size(candidate, ext)
        rounded = rounds_own_step(setup.model, split_candidate(candidate)[0])
        check_stiction_decays(candidate, ext, vmax, rounded)
        check_breakaway_recorded(candidate, ext, setup.split)
    except ValidationError as exc:
        return Finding("plausible", confident=False, sentence=str(exc))
    return None
