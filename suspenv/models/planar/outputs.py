"""Suspension outputs over a travel sweep: camber, half-track, roll centre, ratios, rate.

Frame, units and signs: see :mod:`suspenv.models.planar.geometry`. Inputs are SI
(:class:`~suspenv.models.planar.analytic.PlanarSweep`); outputs are in the usual
engineering units and say so in their names (mm, deg, N, N/mm).

Definitions:

- camber = static camber - upright rotation (CCW rotation tilts the top inboard);
- half-track change = lateral motion of the contact point (positive outboard);
- roll-centre height, from the contact-point motion (the kinematic definition): the
  contact point moves relative to the body perpendicular to the line joining it to the
  instant centre; that line, continued to the vehicle centreline ``y = 0``, gives the
  roll centre (left/right symmetric vehicle): ``z_rc = z_c + y_c * dy_c/dz_c``. Heights
  are measured from the design ground plane (the design contact height) and the body is
  fixed, so the pad is ``travel`` above that plane;
- motion ratio = spring compression per unit wheel travel (``-dl/ds``);
- wheel load = vertical pad force. Analytic: spring force times motion ratio (virtual
  work, rigid links, no friction, no gravity); pymunk: the measured pad reaction;
- wheel rate = d(wheel load)/d(travel); analytic: ``k MR^2 + F_spring dMR/ds``.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.planar.analytic import PlanarSweep
from suspenv.models.planar.geometry import PlanarGeometry


@dataclass
class SweepOutputs:
    """Curves over travel; every array has shape (B..., t) except ``travel_mm`` (t,)."""

    travel_mm: np.ndarray
    camber_deg: np.ndarray
    half_track_mm: np.ndarray
    roll_centre_mm: np.ndarray
    motion_ratio: np.ndarray
    wheel_load_N: np.ndarray  # noqa: N815 - unit in the name
    wheel_rate_N_per_mm: np.ndarray  # noqa: N815 - unit in the name
    camber_gain_deg_per_m: np.ndarray  # (B...) d camber / d travel at zero travel
    ok: np.ndarray | np.bool_  # (B...); a numpy bool scalar for an unbatched geometry

    def as_rows(self) -> list[dict[str, float]]:
        """Rows of a single sweep, for tables."""
        if self.camber_deg.ndim != 1:
            raise ValidationError(
                f"as_rows needs a single sweep, but got shape {self.camber_deg.shape}"
            )
        curves = [f.name for f in fields(self)][:7]  # travel_mm ... wheel_rate_N_per_mm
        return [{k: float(getattr(self, k)[i]) for k in curves} for i in range(self.travel_mm.size)]


def _at_zero(travel: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Linear interpolation of (B..., t) values at travel 0 (travel sorted ascending)."""
    i = int(np.clip(np.searchsorted(travel, 0.0), 1, travel.size - 1))
    t0, t1 = travel[i - 1], travel[i]
    w = 0.0 if t1 == t0 else (0.0 - t0) / (t1 - t0)
    return (1 - w) * values[..., i - 1] + w * values[..., i]


def sweep_outputs(geom: PlanarGeometry, sweep: PlanarSweep) -> SweepOutputs:
    """Outputs of a sweep. Uses the sweep's exact derivatives where it has them, else
    second-order finite differences along the (ascending) travel points."""
    s = sweep.travel
    if s.size < 3 or np.any(np.diff(s) <= 0):
        raise ValidationError(
            f"a sweep needs >= 3 strictly ascending travel points, but got {s.size} points"
        )
    c = sweep.points["contact"]
    z0 = geom.contact_point[..., 1][..., None]
    y0 = geom.contact_point[..., 0][..., None]
    camber = np.degrees(geom.static_camber[..., None] - sweep.theta)
    slope = sweep.contact_slope
    if slope is None:
        slope = np.gradient(c[..., 0], s, axis=-1, edge_order=2)
    roll_centre = c[..., 1] + c[..., 0] * slope - z0
    length = sweep.spring_length
    mr = (
        sweep.motion_ratio
        if sweep.motion_ratio is not None
        else -np.gradient(length, s, axis=-1, edge_order=2)
    )
    body, moving = geom.spring_points  # the spring's mounts; its length at design:
    length0 = np.linalg.norm(getattr(geom, body) - getattr(geom, moving), axis=-1)
    spring_force = geom.spring_preload[..., None] + geom.spring_rate[..., None] * (
        length0[..., None] - length
    )
    if sweep.wheel_load is not None:
        load = sweep.wheel_load
        rate = np.gradient(load, s, axis=-1, edge_order=2)
    else:
        load = spring_force * mr
        dmr = sweep.motion_ratio_slope
        if dmr is None:
            dmr = np.gradient(mr, s, axis=-1, edge_order=2)
        rate = geom.spring_rate[..., None] * mr**2 + spring_force * dmr
    if sweep.theta_slope is not None:
        gain = -np.degrees(_at_zero(s, sweep.theta_slope))
    else:
        gain = _at_zero(s, np.gradient(camber, s, axis=-1, edge_order=2))
    return SweepOutputs(
        travel_mm=1e3 * s,
        camber_deg=camber,
        half_track_mm=1e3 * (c[..., 0] - y0),
        roll_centre_mm=1e3 * roll_centre,
        motion_ratio=mr,
        wheel_load_N=load,
        wheel_rate_N_per_mm=1e-3 * rate,
        camber_gain_deg_per_m=gain,
        ok=sweep.ok,
    )


__all__ = ["SweepOutputs", "sweep_outputs"]
