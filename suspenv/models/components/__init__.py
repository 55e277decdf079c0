"""Component models as "base + effects": damper on a dyno, MR damper, friction guide
(EMPS), quarter car on a rig; plus the truth generator. (Fitting is
:func:`suspenv.diagnosis.fitting.fit`.)

``make_component(family, effects=(), **options)`` builds a model by family name.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from suspenv.core.errors import ValidationError
from suspenv.models.components.base import ComponentModel
from suspenv.models.components.damper import DamperDynoModel
from suspenv.models.components.friction_guide import FrictionGuideModel
from suspenv.models.components.mr_damper import MRDamperModel, MRFieldDamperModel
from suspenv.models.components.quarter_car import QuarterCarRigModel
from suspenv.models.components.truth import simulate_truth
from suspenv.models.effects import Effect

FAMILIES: dict[str, type[ComponentModel]] = {
    cls.family: cls
    for cls in (DamperDynoModel, MRDamperModel, FrictionGuideModel, QuarterCarRigModel)
}


def make_component(family: str, effects: Sequence[Effect] = (), **options: Any) -> ComponentModel:
    """A component model by family name (``"damper"``, ``"mr_damper"``, ``"friction_guide"``,
    ``"quarter_car_rig"``); an MR damper with the option ``field`` (a coil channel) is
    :class:`MRFieldDamperModel`."""
    if family == MRDamperModel.family and options.get("field"):
        return MRFieldDamperModel(effects, **options)
    try:
        cls = FAMILIES[family]
    except KeyError:
        raise ValidationError(
            f"unknown component family {family!r}; known families are {sorted(FAMILIES)}"
        ) from None
    return cls(effects, **options)


__all__ = [
    "FAMILIES",
    "ComponentModel",
    "DamperDynoModel",
    "FrictionGuideModel",
    "MRDamperModel",
    "MRFieldDamperModel",
    "QuarterCarRigModel",
    "make_component",
    "simulate_truth",
]
