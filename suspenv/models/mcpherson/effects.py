"""Optional physics of the McPherson axle (all off by default).

Frame ISO 8855, SI units. Elements come from :mod:`suspenv.models.effects`; this
module only says where they act and carries their path state between rig steps.

* Rubber-bushing hysteresis: a Dahl element beside the linear stiffness in each of
  the six directions of the named bushings. Initial stiffness after a reversal
  ``sigma = hysteresis_sigma_ratio * K``; saturation force ``hysteresis_fc_force``
  [N] (translations) and ``hysteresis_fc_moment`` [N*m] (rotations).
* Progressive bushing stiffness: cubic term ``k3 x^3`` beside each translational
  stiffness, ``k3 = cubic_ratio * K / x_ref^2`` (the cubic force equals
  ``cubic_ratio`` times the linear force at a deflection of ``x_ref``).
* Strut friction: a Dahl (rate-independent, smoothed Coulomb) friction force on the
  rod sliding in the tube, level ``strut_friction`` [N], initial stiffness
  ``strut_friction_sigma`` [N/m].

Sign convention of every element (that of the effects library): the deflection is
positive in the direction the linear stiffness resists, and the element force
resists positive deflection.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from suspenv.core.errors import ValidationError

BUSHING_NAMES = ("lca_front", "lca_rear", "arb_bush", "top_mount")


@dataclass(frozen=True)
class AxleEffects:
    """Effect switches and parameters; the default is the plain (linear, elastic) model."""

    hysteresis_bushings: tuple[str, ...] = ()
    hysteresis_sigma_ratio: float = 1.0
    hysteresis_fc_force: float = 60.0
    hysteresis_fc_moment: float = 3.0
    cubic_bushings: tuple[str, ...] = ()
    cubic_ratio: float = 0.1
    cubic_x_ref: float = 1e-3
    strut_friction: float = 0.0
    strut_friction_sigma: float = 2e6

    def __post_init__(self) -> None:
        for group in ("hysteresis_bushings", "cubic_bushings"):
            bad = [b for b in getattr(self, group) if b not in BUSHING_NAMES]
            if bad:
                raise ValidationError(
                    f"AxleEffects.{group}: every name must be one of {BUSHING_NAMES}, but got {bad}"
                )
        for name in (
            "hysteresis_sigma_ratio",
            "hysteresis_fc_force",
            "hysteresis_fc_moment",
            "cubic_x_ref",
            "strut_friction_sigma",
        ):
            v = getattr(self, name)
            if not v > 0:
                raise ValidationError(f"AxleEffects: `{name} > 0` must hold, but got {v}")
        if self.strut_friction < 0:
            raise ValidationError(
                f"AxleEffects: `strut_friction >= 0` must hold, but got {self.strut_friction}"
            )

    @property
    def path_dependent(self) -> bool:
        """True when the response depends on the travel history (hysteresis, friction)."""
        return bool(self.hysteresis_bushings) or self.strut_friction > 0

    @property
    def active(self) -> bool:
        return self.path_dependent or bool(self.cubic_bushings)

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}
