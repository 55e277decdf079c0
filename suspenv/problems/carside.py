"""Car side-impact design: a cheap, real vehicle problem with several objectives.

Seven panel thicknesses of a car body are chosen to keep a side-impact dummy safe
while the body stays light. The crash simulations were replaced by quadratic response
surfaces (Gu et al. 2001; Youn et al. 2004); this module evaluates those surfaces, so
a batch of thousands of designs costs microseconds.

Formulations (``variant``):

* ``"CRE31"`` (default): 3 objectives and 10 inequality constraints, as in Jain and
  Deb (2014), the constrained RE suite problem CRE31 (Tanabe and Ishibuchi 2020) and
  pymoo's ``Carside``.
* ``"RE41"``: the unconstrained 4-objective form of the RE suite (Tanabe and Ishibuchi
  2020): the three objectives above plus the total constraint violation
  ``sum_i max(0, r_i - limit_i)`` in the responses' own units (the RE suite's f4).

Sources: H. Jain and K. Deb, IEEE Trans. Evol. Comput. 18(4):602-622, 2014 (problem
statement); R. Tanabe and H. Ishibuchi, Applied Soft Computing 89:106078, 2020 (RE41,
CRE31, bounds). The original formulation has 11 variables; as in both sources, the
material variables are fixed (``x8 = 0.345``, ``x9 = 0.192``) and the barrier height and
hitting position (x10, x11) are at their mean 0, so their terms vanish.

Units and frame: a response-surface model, no coordinate frame. Its coefficients were
fitted in engineering units, so the units below are kept rather than converted to SI:
thicknesses in mm, mass in kg, forces in kN, viscous criteria and velocities in m/s
(= mm/ms), rib deflections in mm. Objectives are minimised.

Constraints are reported as ``g <= 0`` feasible (the RE suite states ``limit - r >= 0``;
here the sign is flipped). ``constraint_scale="relative"`` (default, as pymoo) gives
``g = r / limit - 1`` (dimensionless, comparable across responses);
``"absolute"`` gives ``g = r - limit`` in the response's unit and declares the limits
as :attr:`constraint_scales`, so the total violation is the same dimensionless number in
both modes (``sum_i max(0, r_i / limit_i - 1)``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem
from suspenv.core.options import choice

#: material variables of the original 11-variable formulation, fixed as in the sources
MATERIAL_X8 = 0.345
MATERIAL_X9 = 0.192

#: (name, lower, upper, description); bounds from Tanabe and Ishibuchi (2020), RE41
THICKNESSES: tuple[tuple[str, float, float, str], ...] = (
    ("b_pillar_inner", 0.5, 1.5, "thickness of B-pillar inner"),
    ("b_pillar_reinforcement", 0.45, 1.35, "thickness of B-pillar reinforcement"),
    ("floor_side_inner", 0.5, 1.5, "thickness of floor side inner"),
    ("cross_members", 0.5, 1.5, "thickness of cross members"),
    ("door_beam", 0.875, 2.625, "thickness of door beam"),
    ("door_beltline_reinforcement", 0.4, 1.2, "thickness of door beltline reinforcement"),
    ("roof_rail", 0.4, 1.2, "thickness of roof rail"),
)

#: (name, limit, unit) of the ten constrained responses r_i <= limit_i
RESPONSE_LIMITS: tuple[tuple[str, float, str], ...] = (
    ("abdomen_load", 1.0, "kN"),
    ("viscous_criterion_upper", 0.32, "m/s"),
    ("viscous_criterion_middle", 0.32, "m/s"),
    ("viscous_criterion_lower", 0.32, "m/s"),
    ("rib_deflection_upper", 32.0, "mm"),
    ("rib_deflection_middle", 32.0, "mm"),
    ("rib_deflection_lower", 32.0, "mm"),
    ("pubic_symphysis_force", 4.0, "kN"),
    ("b_pillar_velocity", 9.9, "m/s"),
    ("front_door_velocity", 15.7, "m/s"),
)

VARIANTS = ("CRE31", "RE41")
CONSTRAINT_SCALES = ("relative", "absolute")


def side_impact_responses(X: np.ndarray) -> dict[str, np.ndarray]:
    """All response surfaces for thicknesses X (n, 7) in mm -> dict of (n,) arrays.

    Keys: ``"mass"`` (kg) and the ten names of :data:`RESPONSE_LIMITS`.
    """
    X = np.asarray(X, dtype=float)
    x1, x2, x3, x4, x5, x6, x7 = X.T
    x8, x9 = MATERIAL_X8, MATERIAL_X9
    mass = 1.98 + 4.90 * x1 + 6.67 * x2 + 6.98 * x3 + 4.01 * x4 + 1.78 * x5 + 1e-5 * x6 + 2.73 * x7
    abdomen = 1.16 - 0.3717 * x2 * x4 - 0.0092928 * x3
    vc_upper = (
        0.261
        - 0.0159 * x1 * x2
        - 0.188 * x1 * x8
        - 0.019 * x2 * x7
        + 0.0144 * x3 * x5
        + 0.08045 * x6 * x9
    )
    vc_middle = (
        0.214
        + 0.00817 * x5
        - 0.131 * x1 * x8
        - 0.0704 * x1 * x9
        + 0.03099 * x2 * x6
        - 0.018 * x2 * x7
        + 0.0208 * x3 * x8
        + 0.121 * x3 * x9
        - 0.00364 * x5 * x6
        - 0.018 * x2**2
    )
    vc_lower = 0.74 - 0.61 * x2 - 0.031296 * x3 - 0.166 * x7 * x9 + 0.227 * x2**2
    rib_upper = 28.98 + 3.818 * x3 - 4.2 * x1 * x2 + 6.63 * x6 * x9 - 7.77 * x7 * x8
    rib_middle = (
        33.86 + 2.95 * x3 - 5.057 * x1 * x2 - 11.0 * x2 * x8 - 9.98 * x7 * x8 + 22.0 * x8 * x9
    )
    rib_lower = 46.36 - 9.9 * x2 - 12.9 * x1 * x8
    pubic = 4.72 - 0.5 * x4 - 0.19 * x2 * x3
    v_b_pillar = 10.58 - 0.674 * x1 * x2 - 1.95 * x2 * x8
    v_front_door = 16.45 - 0.489 * x3 * x7 - 0.843 * x5 * x6
    values = (
        abdomen,
        vc_upper,
        vc_middle,
        vc_lower,
        rib_upper,
        rib_middle,
        rib_lower,
        pubic,
        v_b_pillar,
        v_front_door,
    )
    out = {"mass": mass}
    out.update({name: v for (name, _, _), v in zip(RESPONSE_LIMITS, values, strict=True)})
    return out


class CarSideImpact(Problem):
    """Car side-impact crashworthiness (Jain and Deb 2014; RE suite CRE31 / RE41).

    Design variables (mm): the seven thicknesses of :data:`THICKNESSES`.

    Objectives (minimised):
        mass (kg); pubic_symphysis_force (kN); mean_velocity (m/s) =
        (b_pillar_velocity + front_door_velocity) / 2; with ``variant="RE41"`` also
        total_violation = sum_i max(0, r_i - limit_i) (mixed units, as in the RE suite).

    Constraints (``variant="CRE31"`` only, feasible when <= 0): one per response of
    :data:`RESPONSE_LIMITS`, scaled by ``constraint_scale`` (see the module docstring).

    Args (case is ignored; checked at construction):
        variant: ``"CRE31"`` (3 objectives, 10 constraints) or ``"RE41"`` (4 objectives).
        constraint_scale: ``"relative"`` (r / limit - 1) or ``"absolute"`` (r - limit).
    """

    name = "CarSideImpact"
    description = (
        "car side-impact response surfaces (RE suite): 7 thicknesses, 3 objectives "
        "+ 10 constraints (or RE41: 4 objectives)"
    )

    def __init__(self, variant: str = "CRE31", constraint_scale: str = "relative"):
        self.variant = choice(self.name, "variant", variant, VARIANTS, ignore_case=True)
        self.constraint_scale = choice(
            self.name, "constraint_scale", constraint_scale, CONSTRAINT_SCALES, ignore_case=True
        )
        self.space = DesignSpace(
            Parameter(name, lo, hi, unit="mm", description=text)
            for name, lo, hi, text in THICKNESSES
        )
        names = ["mass", "pubic_symphysis_force", "mean_velocity"]
        units = ["kg", "kN", "m/s"]
        if self.variant == "RE41":
            names.append("total_violation")
            units.append("mixed")
            self.constraint_names = ()
        else:
            self.constraint_names = tuple(name for name, _, _ in RESPONSE_LIMITS)
        self.objective_names = tuple(names)
        self.objective_units = tuple(units)
        self._limits = np.array([limit for _, limit, _ in RESPONSE_LIMITS])
        if self.variant != "RE41" and self.constraint_scale == "absolute":
            self.constraint_scales = tuple(float(limit) for limit in self._limits)

    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        r = side_impact_responses(X)
        R = np.column_stack([r[name] for name, _, _ in RESPONSE_LIMITS])
        mean_velocity = 0.5 * (r["b_pillar_velocity"] + r["front_door_velocity"])
        F = [r["mass"], r["pubic_symphysis_force"], mean_velocity]
        n = X.shape[0]
        if self.variant == "RE41":
            F.append(np.clip(R - self._limits, 0.0, None).sum(axis=1))
            G = np.zeros((n, 0))
        elif self.constraint_scale == "relative":
            G = R / self._limits - 1.0
        else:
            G = R - self._limits
        return EvaluationBatch(np.column_stack(F), G, np.ones(n, bool), [""] * n)

    def config(self) -> dict[str, Any]:
        return {"variant": self.variant, "constraint_scale": self.constraint_scale}
