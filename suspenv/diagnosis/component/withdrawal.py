"""A named element withdrawn after the search, and the refit that leaves one out.

The search names an element when its refit is significant against the model of the
round. A check after the search can find something that element stood in for (a delay of
the recording found later, :func:`~suspenv.diagnosis.component.delay.judge_beside_delay`;
a drift of the zero with more shape than the baseline's,
:func:`~suspenv.diagnosis.component.drift_check.judge_beside_drift`). Each judges the
element again beside it and withdraws one no longer significant; the record here states
what it was judged beside and the numbers of that test.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.fitting import FitResult, fit
from suspenv.diagnosis.hypothesis import Hypothesis
from suspenv.diagnosis.split import Split


@dataclass
class Withdrawal:
    """A named element withdrawn after the search.

    Attributes:
        hypothesis: the element as it was named.
        beside: what it was judged again beside, in words (e.g. "the delay of the force
            found after it").
        p_value_corrected, delta_bic_corrected: the element's likelihood-ratio test
            (serial-correlation corrected) and corrected BIC change against the model
            with that and without the element.
        heldout_reduction: the relative drop of the held-out RMS error the element gives
            there (NaN where the check does not judge held-out data).
    """

    hypothesis: Hypothesis
    beside: str
    p_value_corrected: float
    delta_bic_corrected: float
    heldout_reduction: float = float("nan")

    def to_dict(self) -> dict[str, Any]:
        return {
            "candidate": self.hypothesis.candidate,
            "words": self.hypothesis.words,
            "round": self.hypothesis.round,
            "beside": self.beside,
            "p_value_corrected": self.p_value_corrected,
            "delta_bic_corrected": self.delta_bic_corrected,
            "heldout_reduction": self.heldout_reduction,
            "sentence": self.sentence(),
        }

    def sentence(self) -> str:
        """One sentence for the verdict."""
        held = (
            ""
            if math.isnan(self.heldout_reduction)  # not judged
            else f", held-out error {-100 * self.heldout_reduction:+.1f} %"
        )
        return (
            f"{self.hypothesis.words}, named in round {self.hypothesis.round}, is withdrawn: "
            f"beside {self.beside} it is no longer significant (corrected p = "
            f"{self.p_value_corrected:.2g}, corrected BIC change "
            f"{self.delta_bic_corrected:+.3g}{held})"
        )


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
