"""What a component diagnosis assumes where the recording does not say, and what it
estimates instead of assuming.

* **Masses** (quarter car): body acceleration and suspension deflection under an
  imposed road fix the masses only up to a common scale (scaling the masses, spring,
  damping and tyre rates alike leaves both outputs unchanged), so the sprung mass is
  taken as declared or :data:`~suspenv.models.components.quarter_car` 's default, and
  an undeclared unsprung mass is fitted with the baseline, and again with each element
  named (:func:`estimate_unsprung_mass`): a wrong mass ratio would otherwise leave a
  residual that a sensor gain takes up. A declared actuator force fixes the scale; both masses
  are then still only as good as declared.
* **Signs**: a damper's force dissipates power, ``mean(F v) > 0`` in suspenv's signs
  (positive stroke compression, positive force pushing back against it). Where the
  recording declares neither sign, the sign is read off that power
  (:func:`power_sign`) and the convention found is said. Without a force channel (the
  quarter car) the force is the suspension force through the body equation, ``m_s``
  times the body acceleration, and the deflection's sign is read off its power (a
  body accelerometer read downward-positive gives the same power; the words say so).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from suspenv.diagnosis.component.motion import motion
from suspenv.diagnosis.fitting import FitResult, fit
from suspenv.diagnosis.protocols import RecordingLike
from suspenv.diagnosis.split import Split
from suspenv.models.components.base import ComponentModel

#: the unsprung mass is searched between these shares of the sprung mass
MASS_RATIO_RANGE = (0.03, 0.6)


def estimate_unsprung_mass(
    model: ComponentModel, sp: Split, max_nfev: int, theta0: np.ndarray | None = None
) -> FitResult:
    """The fit of ``model`` on the fit data of ``sp`` with its unsprung mass ``m_u`` [kg]
    fitted too: the ``m_u`` whose fit (from ``theta0`` where given) has the largest
    log-likelihood, by a bounded scalar search over ``log m_u`` (:data:`MASS_RATIO_RANGE`
    of ``m_s``)."""
    opts = dict(model.options)
    m_s = float(opts["m_s"])

    def fitted(log_mu: float) -> FitResult:
        with_mass: Any = type(model)(model.effects, **{**opts, "m_u": float(np.exp(log_mu))})
        return fit(with_mass, sp.fit_recordings, sp.fit_masks, theta0, max_nfev=max_nfev)

    tried: dict[float, FitResult] = {}  # the search returns a point it evaluated

    def cost(log_mu: float) -> float:
        tried[log_mu] = fitted(log_mu)
        return -tried[log_mu].log_likelihood()

    lo, hi = (float(np.log(r * m_s)) for r in MASS_RATIO_RANGE)
    best = minimize_scalar(cost, bounds=(lo, hi), method="bounded", options={"xatol": 0.01})
    return tried.get(float(best.x)) or fitted(float(best.x))


def mass_words(model: ComponentModel, declared: Sequence[str], estimated: bool) -> list[str]:
    """The assumptions about the quarter car's masses, in words."""
    m_s, m_u = float(model.options["m_s"]), float(model.options["m_u"])
    out = []
    if "m_s" not in declared:
        out.append(
            f"the sprung mass m_s = {m_s:.4g} kg (not declared; the recording fixes only the "
            "mass ratio, so the fitted rates and damping scale with this mass)"
        )
    if estimated:
        out.append(
            f"the unsprung mass m_u = {m_u:.4g} kg (not declared; fitted with the model, "
            f"m_u / m_s = {m_u / m_s:.3g})"
        )
    return out


def _force(rec: RecordingLike, sprung_mass: float) -> np.ndarray | None:
    """The force [N] a recording shows: its ``force`` channel, or where it has none the
    suspension force through the body equation, ``sprung_mass`` times the
    ``body_acceleration`` less a recorded ``actuator_force`` (the quarter car's signs);
    None without either."""
    if "force" in rec.outputs:
        return np.asarray(rec.outputs["force"], float)
    if "body_acceleration" not in rec.outputs:
        return None
    acc = np.asarray(rec.outputs["body_acceleration"], float)
    return sprung_mass * acc - np.asarray(rec.inputs.get("actuator_force", 0.0), float)


def power_sign(recordings: Sequence[RecordingLike], sprung_mass: float = 1.0) -> float:
    """The mean power ``mean(F v)`` [W] the recorded force (:func:`_force`; ``sprung_mass``
    [kg] where it is read through the body equation) takes from the motion over
    ``recordings`` (suspenv's signs; NaN without a force)."""
    num, n = 0.0, 0
    for rec in recordings:
        if (f := _force(rec, sprung_mass)) is None:
            return float("nan")
        v = motion(rec)[1]
        num += float(np.sum(f * v))
        n += v.size
    return num / n if n else float("nan")
