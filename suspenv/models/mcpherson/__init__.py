"""Compliant McPherson strut front axle: parameters, quasi-static solver, vehicle files.

Frame inside: ISO 8855 (x forward, y left, z up), SI units. At the edges (design
vectors, vehicle files) the ADAMS/Car convention of the source paper (mm, x rearward,
y right, z up, left-side points). See ``docs/knc.md``.
"""

from suspenv.models.mcpherson.effects import (
    BUSHING_NAMES,
    LOCATIONS,
    MOMENT_ARM,
    PLACEMENTS,
    axle_effect,
    bushings_at,
    check_placement,
    location_words,
)
from suspenv.models.mcpherson.params import (
    N_PARAMETERS,
    PARAMETER_NAMES,
    Axle,
    AxleConstants,
    build_axle,
    design_space,
    reference_design,
)
from suspenv.models.mcpherson.solver import AxleSolver, AxleState

__all__ = [
    "BUSHING_NAMES",
    "LOCATIONS",
    "MOMENT_ARM",
    "N_PARAMETERS",
    "PARAMETER_NAMES",
    "PLACEMENTS",
    "Axle",
    "AxleConstants",
    "AxleSolver",
    "AxleState",
    "axle_effect",
    "build_axle",
    "bushings_at",
    "check_placement",
    "design_space",
    "location_words",
    "reference_design",
]
