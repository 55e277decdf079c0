"""The "test vehicle": a reference axle plus concealed effects and its sensor noise.

Tey et al. measured a real car whose loops show rubber hysteresis and whose sides
differ by manufacturing tolerances, while their model was linear and symmetric.
suspenv makes such a car reproducibly from a seed:

* left/right tolerance: every hard-point coordinate of each side moved uniformly
  within +-``hard_point_tol_mm``, every bushing stiffness within +-``stiffness_tol``
  (relative), static camber and toe within +-``alignment_tol_deg``;
* rubber hysteresis: Dahl elements in the lower-arm bushes and the top mount, 80 N
  (:data:`DEFAULT_HYSTERESIS`, effects-library elements placed as in
  :mod:`suspenv.models.mcpherson.effects`);
* sensor noise: independent Gaussian noise on every measured channel (standard
  deviations in :data:`CHANNEL_NOISE`, SI units).

This module describes the car (its axle and effects); the caller runs the rig on it
(e.g. :func:`suspenv.rigs.knc_truth.measure_car`). Channels and units as in
:mod:`suspenv.rigs.knc` (ISO 8855, SI).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.effects import Effect, perturb_pair
from suspenv.models.mcpherson.effects import axle_effect
from suspenv.models.mcpherson.params import (
    PARAMETER_NAMES,
    Axle,
    AxleConstants,
    build_axle,
    parameter_kind,
    reference_design,
)

#: measurement noise (1 sigma, SI units) of the rig's channels
CHANNEL_NOISE = {
    "toe": np.deg2rad(0.002),
    "camber": np.deg2rad(0.002),
    "caster": np.deg2rad(0.005),
    "kpi": np.deg2rad(0.005),
    "wheel_centre_x": 0.02e-3,
    "wheel_centre_y": 0.02e-3,
    "wheel_centre_z": 0.02e-3,
    "contact_x": 0.05e-3,
    "contact_y": 0.05e-3,
    "contact_z": 0.02e-3,
    "tyre_fz": 1.0,
}

#: left/right tolerances of the test car (uniform, +-): hard points [mm], bushing
#: stiffness [relative], static camber and toe [deg]
TOLERANCE = {"hard_point_tol_mm": 1.0, "stiffness_tol": 0.10, "alignment_tol_deg": 0.05}
#: the test car's rubber hysteresis (moments saturate at f_c * MOMENT_ARM = 4 N*m)
DEFAULT_HYSTERESIS: tuple[Effect, ...] = (
    axle_effect("dahl_hysteresis", "lower_arm_and_top_mount", f_c=80.0),
)


@dataclass(frozen=True)
class TruthVehicle:
    """A concealed-effect test vehicle: per-side designs (49,), effects and noise."""

    left: np.ndarray
    right: np.ndarray
    effects: tuple[Effect, ...]
    noise: dict[str, float] = field(default_factory=dict)
    seed: int = 0
    constants: AxleConstants = field(default_factory=AxleConstants)

    @property
    def mean_design(self) -> np.ndarray:
        """The symmetric design nearest to the car: mean of its left and right sides."""
        return 0.5 * (self.left + self.right)

    def axle(self) -> Axle:
        return build_axle(self.left[None, :], self.right[None, :], self.constants)


def truth_vehicle(
    seed: int = 0,
    base: np.ndarray | None = None,
    hysteresis: bool = True,
    tolerance: bool = True,
    noise: bool = True,
    hard_point_tol_mm: float = TOLERANCE["hard_point_tol_mm"],
    stiffness_tol: float = TOLERANCE["stiffness_tol"],
    alignment_tol_deg: float = TOLERANCE["alignment_tol_deg"],
    effects: Sequence[Effect] | None = None,
) -> TruthVehicle:
    """The reference vehicle (or ``base``) plus the concealed effects, reproducible by ``seed``.

    ``effects`` (axle effects, see :mod:`suspenv.models.mcpherson.effects`) replaces the
    default hysteresis (``hysteresis``) when given.
    """
    x = reference_design() if base is None else np.asarray(base, dtype=float).copy()
    if x.shape != (len(PARAMETER_NAMES),):
        raise ValidationError(f"base design must have {len(PARAMETER_NAMES)} values, got {x.shape}")
    left, right = x.copy(), x.copy()
    if tolerance:
        rng = np.random.default_rng(seed)
        # parameter kind -> (tolerance, relative)
        tol = {
            "point": (hard_point_tol_mm, False),
            "alignment": (alignment_tol_deg, False),
            "stiffness": (stiffness_tol, True),
        }
        for i, name in enumerate(PARAMETER_NAMES):
            if name != "arb_torsion":  # one bar
                t, relative = tol[parameter_kind(name)]
                left[i], right[i] = perturb_pair(x[i], t, rng, relative=relative)
    eff = tuple(effects) if effects is not None else (DEFAULT_HYSTERESIS if hysteresis else ())
    return TruthVehicle(left, right, eff, dict(CHANNEL_NOISE) if noise else {}, seed)
