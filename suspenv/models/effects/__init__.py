"""Effect elements: the optional physics a base model leaves out.

A model is "base + list of :class:`Effect`", so a rich truth model and a plain fit
model are the same code with different effect lists. One module per family, each
element a physical element with named SI parameters, vectorised over a leading
batch axis, in state-derivative form (time integration) and, where meaningful,
path/series form (quasi-static sweeps). See ``docs/effects.md``.
"""

from suspenv.models.effects import catalogue as _catalogue  # noqa: F401  (registers kinds)
from suspenv.models.effects.asymmetry import (
    perturb_pair,
    split_pair,
)
from suspenv.models.effects.damper_curves import (
    damper_digressive,
    damper_digressive_asymmetric,
    extra_rebound_damping,
)
from suspenv.models.effects.effect import (
    Effect,
    EffectKind,
    effect_kinds,
    get_kind,
    make_effect,
    register_kind,
)
from suspenv.models.effects.friction import (
    coulomb_directional,
    coulomb_smooth,
    lugre_dzdt,
    lugre_force,
    lugre_series,
    stribeck_friction,
    stribeck_level,
)
from suspenv.models.effects.hysteresis import (
    berg_path,
    bouc_wen_dzdt,
    bouc_wen_force_path,
    bouc_wen_path,
    bouc_wen_ultimate,
    dahl_dzdt,
    dahl_path,
)
from suspenv.models.effects.pointwise import PointwiseElement
from suspenv.models.effects.sensor import (
    sensor_delay,
    sensor_lag,
    sensor_offset_gain,
)
from suspenv.models.effects.stiffness import (
    bump_and_rebound_stops,
    bump_stop,
    cubic_stiffness,
    progressive_spring,
    rebound_stop,
)
from suspenv.models.effects.viscoelastic import (
    kelvin_voigt,
    maxwell_dfdt,
    maxwell_series,
)

__all__ = [
    "Effect",
    "EffectKind",
    "PointwiseElement",
    "berg_path",
    "bouc_wen_dzdt",
    "bouc_wen_force_path",
    "bouc_wen_path",
    "bouc_wen_ultimate",
    "bump_and_rebound_stops",
    "bump_stop",
    "coulomb_directional",
    "coulomb_smooth",
    "cubic_stiffness",
    "dahl_dzdt",
    "dahl_path",
    "damper_digressive",
    "damper_digressive_asymmetric",
    "effect_kinds",
    "extra_rebound_damping",
    "get_kind",
    "kelvin_voigt",
    "lugre_dzdt",
    "lugre_force",
    "lugre_series",
    "make_effect",
    "maxwell_dfdt",
    "maxwell_series",
    "perturb_pair",
    "progressive_spring",
    "rebound_stop",
    "register_kind",
    "sensor_delay",
    "sensor_lag",
    "sensor_offset_gain",
    "split_pair",
    "stribeck_friction",
    "stribeck_level",
]
