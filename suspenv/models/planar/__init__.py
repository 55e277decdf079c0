"""Front-view planar suspension linkages (double wishbone, McPherson strut).

Two independent solvers: :mod:`.analytic` (closed-form loop closure + vectorised
Newton) and :mod:`.pymunk_model` (a pymunk rigid-body simulation settled at each
travel). :mod:`.outputs` turns either sweep into camber, half-track change, roll-centre
height, motion ratio and wheel rate; :mod:`suspenv.reports.planar` draws them. Frame and
units are stated in :mod:`.geometry`.
"""

from suspenv.models.planar.analytic import PlanarSweep, solve_single, solve_sweep
from suspenv.models.planar.geometry import (
    DoubleWishbone,
    McPherson,
    PlanarGeometry,
    bundled_geometries,
    geometry_from_dict,
    geometry_to_toml,
    load_geometry,
    stack_geometries,
)
from suspenv.models.planar.outputs import SweepOutputs, sweep_outputs

__all__ = [
    "DoubleWishbone",
    "McPherson",
    "PlanarGeometry",
    "PlanarSweep",
    "SweepOutputs",
    "bundled_geometries",
    "geometry_from_dict",
    "geometry_to_toml",
    "load_geometry",
    "solve_single",
    "stack_geometries",
    "solve_sweep",
    "sweep_outputs",
]
