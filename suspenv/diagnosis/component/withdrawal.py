"""The refit that leaves a named element out, for the checks that withdraw one after the
search (:func:`~suspenv.diagnosis.component.delay.judge_beside_delay`,
:func:`~suspenv.diagnosis.component.drift_check.judge_beside_drift`; the record:
:class:`~suspenv.diagnosis.hypothesis.Withdrawal`)."""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

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
    if name not in {e.name for e in current.model.effects}:
        raise ValidationError(
            f"the element to leave out must be in the model, but got {name!r}; the model "
            f"holds {[e.name for e in current.model.effects]}"
        )
    model, theta0 = reduced(current, {name})
    recs, masks = sp.fit_recordings, sp.fit_masks
    return fit(model, recs, masks, theta0=theta0, scales=current.scales, max_nfev=budget)


def reduced(current: FitResult, names: Collection[str]) -> tuple[Any, dict[str, float]]:
    """``current``'s model without its elements ``names``, and ``current``'s fitted values
    of the parameters left by name (the start of a refit without them)."""
    dropped = tuple(f"{n}." for n in names)
    model = current.model.with_effects([e for e in current.model.effects if e.name not in names])
    values = zip(current.names, current.theta, strict=True)
    return model, {k: float(v) for k, v in values if not k.startswith(dropped)}
