"""Where the optional physics of the McPherson axle can sit (all off by default).

Frame ISO 8855, SI units. The elements are the effects library's
(:class:`suspenv.models.effects.Effect`, ``kind`` + ``location`` + parameters); this
module is the one table of the places the solver puts them (:data:`LOCATIONS`: every
bushing, named groups of bushings, the strut) and of the kinds it simulates
(:data:`PLACEMENTS`). The solver carries their path state between rig steps.

* ``dahl_hysteresis`` at a bushing or a group of bushings: a Dahl element beside the
  linear stiffness in each of the six directions of every bushing there. Saturation
  ``f_c`` [N] in the translations and ``f_c * MOMENT_ARM`` [N*m] in the rotations;
  initial stiffness after a reversal ``sigma_ratio * K`` (``K`` the bushing's own
  stiffness in that direction).
* ``cubic_stiffness`` at a bushing or a group (progressive bushings): a cubic term
  ``k3 x^3`` beside each translational stiffness, ``k3 = ratio * K / x_ref^2`` (the
  cubic force is ``ratio`` times the linear force at a deflection of ``x_ref``).
* ``coulomb_friction`` at the ``strut``: a Dahl (rate-independent, smoothed Coulomb)
  friction force on the rod sliding in the tube, level ``f_c`` [N] (0: none),
  pre-sliding stiffness ``sigma`` [N/m].

At a bushing the stiffness of an element is given relative to the bushing's own
(``sigma_ratio``, ``ratio``); the library's absolute ``sigma`` (Dahl) and ``k3``
(cubic) are then not used and must stay at their defaults. The rig is quasi-static,
so the friction's velocity width ``v_eps`` is not used either.

Sign convention of every element (that of the effects library): the deflection is
positive in the direction the linear stiffness resists, and the element force
resists positive deflection.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.effects import Effect, get_kind, make_effect
from suspenv.models.mcpherson.params import BUSHINGS

#: the axle's bushings (each a 6-D linear spring between a body and the vehicle body)
BUSHING_NAMES = tuple(BUSHINGS)
#: moment saturation of bushing hysteresis per newton of its force saturation [m]
MOMENT_ARM = 0.05
#: where an effect can sit: location -> (bushings there, engineering words); the strut
#: (rod sliding in the tube) holds no bushing
LOCATIONS: dict[str, tuple[tuple[str, ...], str]] = {
    "lca_front": (("lca_front",), "front lower-arm bush"),
    "lca_rear": (("lca_rear",), "rear lower-arm bush"),
    "arb_bush": (("arb_bush",), "anti-roll bar bush"),
    "top_mount": (("top_mount",), "top mount"),
    "lower_arm": (("lca_front", "lca_rear"), "lower-arm bushes"),
    "lower_arm_and_top_mount": (
        ("lca_front", "lca_rear", "top_mount"),
        "lower-arm bushes and top mount",
    ),
    "bushings": (BUSHING_NAMES, "bushings"),
    "strut": ((), "strut"),
}
#: effect kinds the solver simulates -> (where: ``"bushing"`` any location with bushings,
#: or ``"strut"``; the parameters it reads)
PLACEMENTS: dict[str, tuple[str, tuple[str, ...]]] = {
    "dahl_hysteresis": ("bushing", ("f_c", "sigma_ratio")),
    "cubic_stiffness": ("bushing", ("ratio", "x_ref")),
    "coulomb_friction": ("strut", ("f_c", "sigma")),
}
#: library parameters that a placement replaces by a relative one: kind -> (unused, used)
_RELATIVE = {"dahl_hysteresis": ("sigma", "sigma_ratio"), "cubic_stiffness": ("k3", "ratio")}
#: parameters that must be > 0 (else >= 0)
_POSITIVE = {"sigma_ratio", "x_ref", "sigma"}
_KIND_POSITIVE = {("dahl_hysteresis", "f_c")}


def bushings_at(location: str) -> tuple[str, ...]:
    """The bushings at ``location`` (a bushing, a group of them, or ``()`` for the strut)."""
    if location not in LOCATIONS:
        raise ValidationError(
            f"axle effect location must be one of {sorted(LOCATIONS)}, but got {location!r}"
        )
    return LOCATIONS[location][0]


def location_words(location: str) -> str:
    """Engineering words of an axle location (``"lower_arm"`` -> ``"lower-arm bushes"``)."""
    bushings_at(location)  # refuses an unknown location
    return LOCATIONS[location][1]


def location_of(bushings: Sequence[str]) -> str:
    """The location whose bushings are exactly ``bushings`` (any order)."""
    want = set(bushings)
    for loc, (held, _) in LOCATIONS.items():
        if held and set(held) == want:
            return loc
    raise ValidationError(
        f"bushings {sorted(want)} are not one location of {sorted(LOCATIONS)}; place one "
        "effect per bushing instead"
    )


def check_placement(effect: Effect) -> None:
    """Raise :class:`ValidationError` unless the solver can place ``effect`` where it says."""
    where = f"axle effect {effect.name!r} ({effect.kind} at {effect.location!r})"
    if effect.kind not in PLACEMENTS:
        raise ValidationError(
            f"{where}: the McPherson solver simulates the kinds {sorted(PLACEMENTS)}, but got "
            f"kind {effect.kind!r}"
        )
    place, _ = PLACEMENTS[effect.kind]
    if effect.location not in LOCATIONS:
        raise ValidationError(
            f"{where}: `location` must be a bushing {BUSHING_NAMES}, a group of them or "
            f"'strut' (one of {sorted(LOCATIONS)}), but got {effect.location!r}"
        )
    at_bushing = bool(LOCATIONS[effect.location][0])
    if (place == "bushing") != at_bushing:
        rule = (
            "a bushing or a group of bushings (not 'strut')"
            if place == "bushing"
            else "'strut' (the rod sliding in the tube)"
        )
        raise ValidationError(
            f"{where}: a {effect.kind} element sits at {rule}, but got location {effect.location!r}"
        )
    for name in PLACEMENTS[effect.kind][1]:
        v = np.asarray(effect.params[name], float)
        positive = name in _POSITIVE or (effect.kind, name) in _KIND_POSITIVE
        if not (np.all(v > 0) if positive else np.all(v >= 0)):
            raise ValidationError(
                f"{where}: `{name} {'>' if positive else '>='} 0` must hold, but got "
                f"{effect.params[name]}"
            )
    if effect.kind in _RELATIVE:
        unused, used = _RELATIVE[effect.kind]
        default = get_kind(effect.kind).parameter(unused).reference
        if np.any(np.asarray(effect.params[unused], float) != default):
            raise ValidationError(
                f"{where}: at a bushing the element's stiffness is relative to the bushing's "
                f"own (`{used}`), so `{unused}` must stay at its default {default:g}, but got "
                f"{effect.params[unused]}"
            )


def axle_effect(kind: str, location: str, name: str | None = None, **params: float) -> Effect:
    """An effect of ``kind`` placed at ``location`` of the axle (name ``"<kind>@<location>"``)."""
    effect = make_effect(kind, name=name or f"{kind}@{location}", location=location, **params)
    check_placement(effect)
    return effect


__all__ = [
    "BUSHING_NAMES",
    "LOCATIONS",
    "MOMENT_ARM",
    "PLACEMENTS",
    "axle_effect",
    "bushings_at",
    "check_placement",
    "location_of",
    "location_words",
]
