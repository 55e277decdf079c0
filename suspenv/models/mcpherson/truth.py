"""The "test vehicle": a reference axle plus concealed effects, and its measurement.

Tey et al. measured a real car whose loops show rubber hysteresis and whose sides
differ by manufacturing tolerances, while their model was linear and symmetric.
suspenv makes such a car reproducibly from a seed:

* left/right tolerance: every hard-point coordinate of each side moved uniformly
  within +-``hard_point_tol_mm``, every bushing stiffness within +-``stiffness_tol``
  (relative), static camber and toe within +-``alignment_tol_deg``;
* rubber hysteresis: Dahl elements in the lower-arm bushes and the top mount
  (:class:`~suspenv.models.mcpherson.effects.AxleEffects`);
* sensor noise: independent Gaussian noise on every measured channel (standard
  deviations in :data:`CHANNEL_NOISE`, SI units).

Channels and units as in :mod:`suspenv.rigs.knc` (ISO 8855, SI).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.effects import perturb_pair
from suspenv.models.mcpherson.effects import AxleEffects
from suspenv.models.mcpherson.params import (
    HARD_POINTS,
    PARAMETER_NAMES,
    AxleConstants,
    build_axle,
    reference_design,
)
from suspenv.rigs.knc import KCResult, run_tests

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

DEFAULT_HYSTERESIS = AxleEffects(
    hysteresis_bushings=("lca_front", "lca_rear", "top_mount"),
    hysteresis_sigma_ratio=1.0,
    hysteresis_fc_force=80.0,
    hysteresis_fc_moment=4.0,
)


@dataclass(frozen=True)
class TruthVehicle:
    """A concealed-effect test vehicle: per-side designs (49,), effects and noise."""

    left: np.ndarray
    right: np.ndarray
    effects: AxleEffects
    noise: dict[str, float] = field(default_factory=dict)
    seed: int = 0
    constants: AxleConstants = field(default_factory=AxleConstants)

    @property
    def mean_design(self) -> np.ndarray:
        """The symmetric design nearest to the car: mean of its left and right sides."""
        return 0.5 * (self.left + self.right)

    def axle(self):
        return build_axle(self.left[None, :], self.right[None, :], self.constants)


def truth_vehicle(
    seed: int = 0,
    base: np.ndarray | None = None,
    hysteresis: bool = True,
    tolerance: bool = True,
    noise: bool = True,
    hard_point_tol_mm: float = 1.0,
    stiffness_tol: float = 0.10,
    alignment_tol_deg: float = 0.05,
    effects: AxleEffects | None = None,
) -> TruthVehicle:
    """The reference vehicle (or ``base``) plus the concealed effects, reproducible by ``seed``."""
    x = reference_design() if base is None else np.asarray(base, dtype=float).copy()
    if x.shape != (len(PARAMETER_NAMES),):
        raise ValidationError(f"base design must have {len(PARAMETER_NAMES)} values, got {x.shape}")
    left, right = x.copy(), x.copy()
    if tolerance:
        rng = np.random.default_rng(seed)
        hp_names = {f"{hp}_{a}" for hp in HARD_POINTS for a in "xyz"}
        for i, name in enumerate(PARAMETER_NAMES):
            if name == "arb_torsion":
                continue  # one bar
            if name in hp_names:
                left[i], right[i] = perturb_pair(x[i], hard_point_tol_mm, rng, relative=False)
            elif name.startswith("static_"):
                left[i], right[i] = perturb_pair(x[i], alignment_tol_deg, rng, relative=False)
            else:
                left[i], right[i] = perturb_pair(x[i], stiffness_tol, rng, relative=True)
    eff = effects if effects is not None else (DEFAULT_HYSTERESIS if hysteresis else AxleEffects())
    return TruthVehicle(left, right, eff, dict(CHANNEL_NOISE) if noise else {}, seed)


def measure(truth: TruthVehicle, amplitude: float = 0.040, steps: int = 30) -> dict[str, KCResult]:
    """Run the three rig tests on the truth vehicle and add its sensor noise (seeded)."""
    results = run_tests(truth.axle(), amplitude=amplitude, steps=steps, effects=truth.effects)
    rng = np.random.default_rng(10_000 + truth.seed)
    for test in sorted(results):
        res = results[test]
        if not res.ok.all():
            raise ValidationError(f"the truth vehicle fails the {test} test: {res.messages[0]}")
        for name in sorted(truth.noise):
            ch = res.channels[name]
            res.channels[name] = ch + rng.normal(0.0, truth.noise[name], ch.shape)
    return results
