"""Model: add a candidate effect to the fitted model as a physical element and refit.

The extended model is ``model.with_effects(current effects + [new effect])``; the
refit starts from the baseline's fitted values for the parameters the two models
share, and from values read off the residual signature for the new element's own
parameters where the signature gives them (the model's own scaled guess otherwise).
Shape parameters make the problem non-convex (transition displacement, knee
velocity, stop gap, relaxation time): the signature's values start them near the
feature the residual shows.

Units: SI throughout (see :mod:`suspenv.models.effects`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from suspenv.diagnosis.fitting import FitResult, fit
from suspenv.diagnosis.protocols import RecordingLike
from suspenv.diagnosis.screening import Signature
from suspenv.models.effects import make_effect

#: a size counts as resolved when it is this many corrected standard errors from zero
#: (:func:`parameter_and_error`): the size rule of every element and probe
SIZE_Z = 2.0


def parameter_and_error(fit: FitResult, kind: str, parameter: str) -> tuple[float, float]:
    """The fitted value of ``parameter`` of the element of ``kind`` in ``fit`` and its
    serial-correlation corrected standard error (NaN, NaN when the model holds none or
    holds the parameter fixed)."""
    if (element := fit.element(kind)) is None:
        return np.nan, np.nan
    row = fit.params().get(f"{element.name}.{parameter}", {})
    return float(row.get("value", np.nan)), float(row.get("stderr_corrected", np.nan))


def _friction_guess(kind: str, n: dict[str, float], half_stroke: float) -> dict[str, float]:
    """Starting values of a friction or hysteresis element from its signature's numbers
    ``n`` (empty for another kind)."""
    if kind in ("coulomb_friction", "stribeck_friction", "lugre_friction"):
        fc = max(0.5 * n.get("step", 0.0), 1e-3)
        return {"f_c": fc} if kind == "coulomb_friction" else {"f_c": fc, "f_s": 1.2 * fc}
    if kind == "directional_friction":
        fc = max(0.5 * n.get("step", 0.0), 1e-3)
        return {"f_pos": fc, "f_neg": fc}
    if kind == "dahl_hysteresis":
        fc = max(0.5 * n.get("loop_width", 0.0), 1e-3)
        delta = max(n.get("transition_fraction", 0.1) * half_stroke, 1e-6)
        return {"f_c": fc, "sigma": fc / delta}
    if kind == "bouc_wen_hysteresis":
        fy = max(0.5 * n.get("loop_width", 0.0), 1e-3)
        return {"f_y": fy, "x_y": max(n.get("transition_fraction", 0.1) * half_stroke / 3, 1e-6)}
    return {}


def signature_guess(kind: str, sig: Signature | None, half_stroke: float) -> dict[str, float]:
    """Starting values for an effect's parameters read off its residual signature
    (``half_stroke`` [m]: the motion's half stroke)."""
    if sig is None:
        return {}
    n = sig.numbers
    if g := _friction_guess(kind, n, half_stroke):
        return g
    if kind == "cubic_stiffness" and half_stroke > 0:
        g = {"k3": n.get("extra_at_full_stroke", 0.0) / half_stroke**3}
    elif kind in ("bump_stop", "rebound_stop") and np.isfinite(n.get("threshold_m", np.nan)):
        g = {"gap": abs(n["threshold_m"])}
    elif kind == "bump_and_rebound_stops" and np.isfinite(n.get("threshold_m", np.nan)):
        # a side without its own threshold starts at the other side's travel
        one = abs(n["threshold_m"])
        g = {
            "gap_bump": max(n.get("threshold_bump_m", one), 0.0),
            "gap_rebound": max(-n.get("threshold_rebound_m", -one), 0.0),
        }
    elif kind == "digressive_damping":
        g = {"v_knee": max(n.get("knee_velocity", 0.1), 1e-3)}
    elif kind == "maxwell_viscoelastic":
        tau = max(n.get("relaxation_time_s", 0.05), 1e-3)
        g = {"c_m": 1000.0, "k_m": 1000.0 / tau}
    elif kind == "gas_spring":
        g = {"k_gas": n.get("stiffness", 0.0)}
    elif kind in ("force_offset", "sensor_offset"):
        g = {"offset": n.get("offset", 0.0)}
    elif kind == "sensor_gain":
        g = {"gain": 1.0 + n.get("gain_error", 0.0)}
    elif kind == "sensor_lag":
        g = {"tau": max(n.get("lag_s", 0.0), 1e-4)}
    return g


def refit_with(
    base: FitResult,
    kind: str,
    recordings: RecordingLike | Sequence[RecordingLike],
    masks: Sequence[np.ndarray | None] | None,
    signature: Signature | None = None,
    half_stroke: float = 0.0,
    location: str = "",
    max_nfev: int = 200,
    guess_given: dict[str, float] | None = None,
) -> FitResult:
    """Refit ``base.model`` with one more effect of ``kind``, started as the module
    docstring says; ``guess_given``: starting values of the new element's own parameters
    that replace those read off the signature (non-finite ones are dropped)."""
    names_taken = {e.name for e in base.model.effects}
    name = kind if kind not in names_taken else f"{kind}_{len(names_taken)}"
    guess = signature_guess(kind, signature, half_stroke)
    guess.update({k: v for k, v in (guess_given or {}).items() if np.isfinite(v)})
    # a model may fix shape constants of its elements (e.g. the quarter car's friction
    # regularisation width, which its time integrator needs wider)
    fixed = dict(base.model.effect_defaults.get(kind, {}))
    effect = make_effect(kind, name=name, location=location, **fixed)
    lo, hi = effect.bounds()
    clipped = {
        k: float(np.clip(v, lo[i], hi[i]))
        for i, k in enumerate(effect.spec.parameter_names)
        if (v := guess.get(k)) is not None
    }
    effect = effect.with_params(clipped)
    model = base.model.with_effects((*base.model.effects, effect))
    theta0 = dict(zip(base.names, base.theta, strict=True))
    # the rest of the new element's parameters come from the model's own guess
    theta0.update({f"{name}.{k}": v for k, v in clipped.items()})
    res = fit(model, recordings, masks, theta0=theta0, max_nfev=max_nfev)
    res.extra["effect"] = effect.to_dict() | {"name": name}
    return res
