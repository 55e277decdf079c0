"""A K&C diagnosis told as an engineer reads it: what was named and fitted, and how
each curve fits against its noise before and after.

:func:`knc_story` takes a finished K&C :class:`~suspenv.diagnosis.engine.Diagnosis`
(no new fit) and returns a :class:`KncStory`: the named elements with their fitted
parameters (value, corrected standard error), per curve (rig test x channel, each side
apart) the RMS residual in noise units of the baseline and of the final model on the
fitted and the held-out tests (:func:`~suspenv.diagnosis.knc.family.curves_in_noise_units`:
1 = at the noise), the sides whose curves differ after the fit, and the residual left.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.engine import Diagnosis
from suspenv.diagnosis.knc.family import curves_in_noise_units
from suspenv.diagnosis.record import Record

#: a curve whose two sides' RMS (noise units) after the fit differ by more than this
#: factor is listed as differing between the sides
SIDE_RATIO = 2.0


@dataclass
class KncStory(Record):
    """The named elements, each curve's fit against its noise, what is left.

    Attributes:
        verdict / headline / confident / unexplained / assumptions: the diagnosis'.
        elements: per named element (``kind@location``): its words and parameters
            ``{name: {"value", "stderr_corrected"}}``.
        curves: rows ``{"test", "channel", "data": "fit" | "held-out", "before",
            "after"}``, RMS residual in noise units of the baseline and final model.
        sides_differ: (test, channel without side) whose left and right RMS after the
            fit differ by more than :data:`SIDE_RATIO`, with both values.
    """

    verdict: str
    headline: str
    confident: bool
    unexplained: bool
    assumptions: list[str]
    elements: dict[str, dict[str, Any]] = field(default_factory=dict)
    curves: list[dict[str, Any]] = field(default_factory=list)
    sides_differ: list[dict[str, Any]] = field(default_factory=list)


def _rms(cells: dict[tuple[str, str], np.ndarray]) -> dict[tuple[str, str], float]:
    return {k: float(np.sqrt(np.mean(np.asarray(v) ** 2))) for k, v in cells.items()}


def knc_story(diagnosis: Diagnosis) -> KncStory:
    """The story of a finished K&C diagnosis (see the module docstring).

    Raises:
        ValidationError: for a diagnosis of another family.
    """
    if diagnosis.family != "knc":
        raise ValidationError(f"knc_story reads a K&C diagnosis, but got {diagnosis.family!r}")
    d = diagnosis
    story = KncStory(d.verdict, d.headline, d.confident, d.unexplained, d.assumptions)
    for h in d.named:
        params = {
            k: {"value": v["value"], "stderr_corrected": v["stderr_corrected"]}
            for k, v in h.params.items()
        }
        story.elements[h.candidate] = {"words": h.words, "params": params}
    after: dict[tuple[str, str], float] = {}
    for data, recs in (("fit", d.fit_recordings), ("held-out", d.heldout_recordings)):
        if not recs:
            continue
        before = _rms(curves_in_noise_units(d.base_fit, recs))
        now = _rms(curves_in_noise_units(d.final_fit, recs))
        for (test, ch), b in before.items():
            story.curves.append(
                {"test": test, "channel": ch, "data": data, "before": b, "after": now[(test, ch)]}
            )
        after.update(now)
    for (test, ch), left in after.items():
        right = after.get((test, ch[:-5] + "_right")) if ch.endswith("_left") else None
        if right is not None and max(left, right) > SIDE_RATIO * max(min(left, right), 1.0):
            story.sides_differ.append(
                {"test": test, "channel": ch[:-5], "left": left, "right": right}
            )
    return story
