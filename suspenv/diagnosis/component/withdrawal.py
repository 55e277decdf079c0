"""The refit that leaves a named element out, for the checks that withdraw one after the
search (:func:`~suspenv.diagnosis.component.delay.judge_beside_delay`,
:func:`~suspenv.diagnosis.component.drift_check.judge_beside_drift`; the record:
:class:`~suspenv.diagnosis.hypothesis.Withdrawal`)."""

from __future__ import annotations

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.fitting import FitResult, fit
from suspenv.diagnosis.hypothesis import Hypothesis
from suspenv.diagnosis.split import Split


def element_name(h: Hypothesis) -> str | None:
    """The name of ``h``'s element in the models (None for a hypothesis without a fit)."""
    if h.fit is None:
        return None
    effect = h.fit.extra.get("effect") or {}
    return str(effect["name"]) if "name" in effect else None


def without_element(current: FitResult, name: str, sp: Split, budget: int) -> FitResult:
    """``current``'s model without its element ``name``, refitted on the fit samples from
    ``current``'s values of the other parameters (the same channel scales)."""
    kept = [e for e in current.model.effects if e.name != name]
    if len(kept) == len(current.model.effects):
        raise ValidationError(
            f"the element to leave out must be in the model, but got {name!r}; the model "
            f"holds {[e.name for e in current.model.effects]}"
        )
    theta0 = {
        k: float(v)
        for k, v in zip(current.names, current.theta, strict=True)
        if not k.startswith(f"{name}.")
    }
    return fit(
        current.model.with_effects(kept),
        sp.fit_recordings,
        sp.fit_masks,
        theta0=theta0,
        scales=current.scales,
        max_nfev=budget,
    )
