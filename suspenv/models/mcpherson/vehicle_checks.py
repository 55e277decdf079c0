"""Geometry rules of a McPherson vehicle file, checked on loading and before any rig work.

:func:`~suspenv.models.mcpherson.vehicle_file.load_vehicle` checks each value alone
(finite, stiffnesses positive, angles small); these rules check the linkage the values
make, so that an axle that cannot be a McPherson strut is named on loading and not
later, by a rig that prints a negative ride rate or "no static equilibrium". Each
failure is a :class:`~suspenv.core.errors.ValidationError` naming the rule, the side,
the points and their values in the file's units (ADAMS/Car: mm, x rearward, y to the
right, z up; both sides written in the left side's convention, so every y < 0).

Rules (ISO 8855 inside: x forward, y left, z up; side 0 left, 1 right):

1. **Own side**: every hard point of the left corner lies at y > 0, every point of
   the right corner at y < 0 (a point on the other side is a sign error of the file).
2. **Strut top above the ball joint**: ``strut_top`` higher than
   ``lower_ball_joint`` by at least :data:`MIN_LENGTH` (a strut carries the body on
   the knuckle from above).
3. **Links of non-zero length**: the points of each link of :data:`LINKS` at least
   :data:`MIN_LENGTH` apart.
4. **Positive ride rate at design**: the tyre load rises with the pad height at the
   static position (central difference of :data:`RIDE_STEP` about the static pad
   height, both wheels, :class:`~suspenv.models.mcpherson.solver.AxleSolver`). A
   design whose static position the solver does not reach is left to
   :func:`~suspenv.models.mcpherson.vehicle_file.check_assembles` and the rig, which
   name that failure.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.measurements.knc import SIDES
from suspenv.models.mcpherson.params import Axle

#: shortest link and smallest strut height over the ball joint [m]: below a millimetre a
#: link is a modelling error, not a part (the solver's position tolerance is 1e-6 m)
MIN_LENGTH = 1e-3
#: links (point pairs) of a McPherson corner: strut, tie rod, lower arm, drop link,
#: anti-roll bar arm, spring
LINKS: tuple[tuple[str, str], ...] = (
    ("strut_top", "strut_axis_point"),
    ("tie_rod_inner", "tie_rod_outer"),
    ("lca_front_bush", "lca_rear_bush"),
    ("lca_front_bush", "lower_ball_joint"),
    ("lca_rear_bush", "lower_ball_joint"),
    ("drop_link_strut", "arb_drop_link"),
    ("arb_bush", "arb_drop_link"),
    ("spring_upper_seat", "spring_lower_seat"),
)
#: pad step of the ride-rate difference [m]
RIDE_STEP = 1e-3


def _file_mm(p: np.ndarray, side: int) -> str:
    """A point [m, ISO 8855] as the file writes it: (x, y, z) [mm], left-side ADAMS."""
    x, y, z = p * 1e3
    return f"({-x:.1f}, {-y if side == 0 else y:.1f}, {z:.1f}) mm"


def check_geometry(axle: Axle, effects: Sequence = (), where: str = "vehicle") -> None:
    """Rules 1 to 4 of the module docstring on the first design of ``axle``."""
    check_links(axle, where)
    rate = ride_rate(axle, effects)
    for side in (0, 1):
        if rate is not None and not rate[side] > 0:
            raise ValidationError(
                f"{where} ({SIDES[side]}): the ride rate at design must be > 0 (the tyre "
                f"load rises with the pad), but is {rate[side] / 1e3:.4g} N/mm: the spring "
                "cannot carry the corner at this geometry"
            )


def check_links(axle: Axle, where: str = "vehicle") -> None:
    """Rules 1 to 3 of the module docstring (own side, strut top above the ball joint,
    links of non-zero length; no solve) on both corners of the first design of
    ``axle``, each corner's links first (a strut of zero length leaves the points built
    on its axis NaN)."""
    pts = {k: np.asarray(v[0], float) for k, v in axle.points.items()}  # (2, 3) [m]
    for side, sign in ((0, 1.0), (1, -1.0)):
        for a, b in LINKS:
            d = float(np.linalg.norm(pts[a][side] - pts[b][side]))
            if not d >= MIN_LENGTH:
                raise ValidationError(
                    f"{where} ({SIDES[side]}): `|{a} - {b}| >= {MIN_LENGTH * 1e3:g} mm` must "
                    f"hold (a link of non-zero length), but the points are {d * 1e3:.3g} mm "
                    f"apart ({_file_mm(pts[a][side], side)} and {_file_mm(pts[b][side], side)})"
                )
        for name, p in pts.items():
            if not sign * p[side, 1] > 0:
                raise ValidationError(
                    f"{where}: every point of the {SIDES[side]} corner must lie on its own "
                    f"side (file y < 0, left-side convention), but {name} is at "
                    f"{_file_mm(p[side], side)}"
                )
        top, ball = pts["strut_top"][side], pts["lower_ball_joint"][side]
        if not top[2] - ball[2] >= MIN_LENGTH:
            raise ValidationError(
                f"{where} ({SIDES[side]}): `strut_top_z - lower_ball_joint_z >= "
                f"{MIN_LENGTH * 1e3:g} mm` must hold (the strut carries the knuckle from "
                f"above), but got strut_top_z={top[2] * 1e3:.1f} mm and "
                f"lower_ball_joint_z={ball[2] * 1e3:.1f} mm"
            )


def ride_rate(axle: Axle, effects: Sequence = ()) -> np.ndarray | None:
    """Ride rate (2,) [N/m] of the first design at its static position: d(tyre load) /
    d(pad height), central difference of :data:`RIDE_STEP`; None when the solver does
    not reach the static position."""
    from suspenv.models.mcpherson.solver import AxleSolver

    try:
        with np.errstate(all="ignore"):
            solver = AxleSolver(axle.take(np.array([0])), effects)
            pad = solver.pad_static
            st, conv, _ = solver.solve(solver.initial_state(), pad)
            loads = []
            for dz in (RIDE_STEP, -RIDE_STEP):
                s2, c2, _ = solver.solve(st, pad + dz)
                conv = conv & c2
                loads.append(solver.outputs(s2, pad + dz, ["tyre_fz"])["tyre_fz"][0])
    except (EvaluationError, np.linalg.LinAlgError, ValidationError):
        return None
    if not conv.all():
        return None
    return (loads[0] - loads[1]) / (2 * RIDE_STEP)
