"""McPherson axle parameters: the 49 design parameters, vehicle constants, batched axle data.

Frames and units
----------------
* **Edges** (design vectors, vehicle files, published tables): the ADAMS/Car
  convention of Tey et al. 2014: millimetres, x rearward, y to the right, z up;
  hard points are given for the *left* side (negative y). Bushing translational
  stiffness in N/mm, rotational in N*mm/deg, angles in degrees.
* **Inside** (:class:`Axle` and everything built on it): SI units and ISO 8855
  (x forward, y left, z up). Left side has y > 0. The conversion of a left-side
  ADAMS point (x, y, z) [mm] is ``(-x, -y, z) / 1000`` [m]; the right side is its
  mirror image ``(-x, +y, z) / 1000`` (both sides are given in the left-side
  convention, so a mirrored axle is two identical parameter sets).
* Side index 0 is left, 1 is right; ``SIDE_SIGN = (+1, -1)`` is the sign of y.
* Bushing frames are parallel to the vehicle axes unless the vehicle gives an
  orientation (:func:`bushing_frames`); a mirror about the x-z plane maps each axis
  onto itself, so a diagonal stiffness is the same on both sides and in both
  conventions.
* Bushing orientation (optional, as ADAMS/Car bushings have): Euler angles
  ``(a, b, c)`` [deg], body-fixed 3-1-3 (z, then the new x, then the new z: ADAMS's
  default ``ori``), of the bushing frame in the left-side ADAMS/Car frame,
  ``R = Rz(a) Rx(b) Rz(c)`` (columns: the bushing axes). The stiffness is diagonal in
  the bushing frame, ``K_vehicle = R K R^T``. The right bushing is the mirror image
  of the left one: in ISO 8855 each side's frame is ``Q = M R M`` with ``M`` the
  side's point map (``diag(-1, -1, 1)`` left, ``diag(-1, +1, 1)`` right), a proper
  rotation on both sides.

Sign conventions of the static alignment parameters: camber negative when the top
of the wheel leans inboard; toe positive for toe-in. Both apply to each wheel.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from functools import cache, cached_property
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.space import DesignSpace, Parameter

SIDE_SIGN = np.array([1.0, -1.0])
DEG = np.pi / 180.0

#: hard points that are design variables, in table order
HARD_POINTS = (
    "lower_ball_joint",
    "lca_front_bush",
    "lca_rear_bush",
    "strut_axis_point",
    "strut_top",
    "tie_rod_inner",
    "tie_rod_outer",
    "arb_drop_link",
)

#: the paper's ranges (mm, ADAMS/Car, left side)
PAPER_RANGES = {
    "lower_ball_joint": ((-15, 5), (-710, -690), (-50, -30)),
    "lca_front_bush": ((0, 20), (-380, -360), (-50, -30)),
    "lca_rear_bush": ((310, 330), (-370, -350), (-40, -20)),
    "strut_axis_point": ((-5, 15), (-610, -590), (125, 145)),
    "strut_top": ((20, 40), (-560, -540), (560, 580)),
    "tie_rod_inner": ((150, 170), (-320, -300), (85, 105)),
    "tie_rod_outer": ((120, 140), (-660, -640), (100, 120)),
    "arb_drop_link": ((45, 65), (-550, -530), (50, 70)),
}

#: the paper's identified values (its Table 1), the reference vehicle of suspenv
PAPER_IDENTIFIED_POINTS = {
    "lower_ball_joint": (-15.4, -688.6, -39.1),
    "lca_front_bush": (-2.1, -383.2, -47.1),
    "lca_rear_bush": (309.3, -346.7, -29.1),
    "strut_axis_point": (1.6, -581.8, 217.2),
    "strut_top": (39.5, -536.9, 558.9),
    "tie_rod_inner": (163.0, -317.6, 85.9),
    "tie_rod_outer": (136.7, -642.7, 105.3),
    "arb_drop_link": (65.1, -533.7, 70.6),
}

#: bushings and their stiffness components that are design variables
BUSHINGS = {
    "lca_front": ("kx", "ky", "rx", "ry", "rz"),
    "lca_rear": ("kx", "ky", "rx", "ry", "rz"),
    "arb_bush": ("kx", "ky", "kz", "rx", "ry", "rz"),
    "top_mount": ("kx", "ky", "kz", "rx", "ry", "rz"),
}
COMPONENTS = ("kx", "ky", "kz", "rx", "ry", "rz")

PAPER_IDENTIFIED_BUSHINGS = {
    "lca_front": (9483.4, 8811.48, 32268.7, 760.3, 6019.3),
    "lca_rear": (3721.1, 21425.1, 5496.9, 18353.0, 4399.7),
    "arb_bush": (36581.3, 2625.1, 39097.8, 24386.0, 10380.0, 1160.5),
    "top_mount": (5401.2, 33553.1, 2463.9, 16494.0, 23121.0, 3396.7),
}

#: margin (mm) kept between a reference value and a widened bound
RANGE_MARGIN_MM = 2.0
#: lower bound of bushing stiffness: the paper's 0 makes the linkage a mechanism
BUSHING_LOW = 50.0
#: upper bound of bushing stiffness in the paper's design space (identification bound of
#: the reference car only; a vehicle file's stiffness is limited by physics, > 0)
BUSHING_HIGH = 50000.0
#: the steering system's default stiffnesses (:class:`AxleConstants`): rack mounts [N/mm]
#: and column [N*m/deg]. Chosen (the split is not from a source) so that the reference
#: car's in-phase aligning-torque compliance is 1.0 deg/kN*m, the middle of the 0.5-1.5
#: deg/kN*m of production cars (docs/knc.md "Steering system"; the range gathered in
#: shared/spec/knc_sheet.md from public K&C rig descriptions); with a rigid steering
#: system the reference car gives 0.19 deg/kN*m
RACK_MOUNT_RATE = 20000.0
COLUMN_TORSION_RATE = 12.0

#: physical limit of the static alignment: |static_camber| and |static_toe| < 10 deg
ALIGNMENT_LIMIT_DEG = 10.0
#: default identification bounds of a vehicle file (see :func:`default_bounds`)
DEFAULT_POINT_HALF_RANGE_MM = 10.0
DEFAULT_STIFFNESS_FACTOR = 10.0
DEFAULT_ALIGNMENT_HALF_RANGE_DEG = 1.0


def design_parameters() -> tuple[Parameter, ...]:
    """The 49 design parameters (ADAMS/Car units, left side) with the published ranges.

    Ranges are the paper's, widened where its own identified value (our reference)
    lies outside them, by the minimum that keeps a 2 mm margin; see ``docs/knc.md``.
    Bushing lower bounds are 50 instead of 0 (a zero stiffness leaves the linkage
    free to move without load, so no equilibrium exists).
    """
    out: list[Parameter] = []
    for hp in HARD_POINTS:
        for axis, (lo, hi), v in zip(
            "xyz", PAPER_RANGES[hp], PAPER_IDENTIFIED_POINTS[hp], strict=True
        ):
            # the paper's range, widened just enough to hold ``v`` with a margin
            wlo, whi = min(lo, v - RANGE_MARGIN_MM), max(hi, v + RANGE_MARGIN_MM)
            note = "" if (wlo, whi) == (lo, hi) else f" (paper range [{lo}, {hi}] widened)"
            out.append(
                Parameter(
                    f"{hp}_{axis}",
                    wlo,
                    whi,
                    "mm",
                    default=v,
                    description=f"{hp.replace('_', ' ')} {axis}, ADAMS/Car frame, left side{note}",
                )
            )
    for bush, comps in BUSHINGS.items():
        for comp, v in zip(comps, PAPER_IDENTIFIED_BUSHINGS[bush], strict=True):
            unit = "N/mm" if comp.startswith("k") else "N*mm/deg"
            out.append(
                Parameter(
                    f"{bush}_{comp}",
                    BUSHING_LOW,
                    BUSHING_HIGH,
                    unit,
                    default=v,
                    description=f"{bush.replace('_', ' ')} bushing stiffness {comp}",
                )
            )
    for name, low, high, unit, default, description in (
        ("arb_torsion", 30.0, 3000.0, "N*m/rad", 930.6,
         "anti-roll bar torsional stiffness (twist of one half against the other)"),
        ("static_camber", -1.0, 1.0, "deg", -0.52,
         "static camber, negative = top of wheel inboard"),
        ("static_toe", -1.0, 1.0, "deg", 0.0032, "static toe, positive = toe-in"),
    ):  # fmt: skip
        out.append(Parameter(name, low, high, unit, default=default, description=description))
    return tuple(out)


def paper_initial_values() -> dict[str, float]:
    """The paper's initial model (file units): hard points at the centres of its ranges,
    every bushing stiffness 500 (N/mm, N*mm/deg), anti-roll bar 300 N*m/rad, camber and
    toe 0 deg."""
    values: dict[str, float] = {}
    for hp in HARD_POINTS:
        for axis, (lo, hi) in zip("xyz", PAPER_RANGES[hp], strict=True):
            values[f"{hp}_{axis}"] = 0.5 * (lo + hi)
    for bush, comps in BUSHINGS.items():
        for comp in comps:
            values[f"{bush}_{comp}"] = 500.0
    values.update(arb_torsion=300.0, static_camber=0.0, static_toe=0.0)
    return values


def design_space() -> DesignSpace:
    """The 49-parameter :class:`DesignSpace` (reference = the paper's identified values).

    The reference car's space with the paper's (widened) bounds; a vehicle file's own
    space is :meth:`suspenv.models.mcpherson.vehicle_file.VehicleFile.space`.
    """
    return DesignSpace(design_parameters())


PARAMETER_NAMES: tuple[str, ...] = tuple(p.name for p in design_parameters())
N_PARAMETERS = len(PARAMETER_NAMES)
#: the design vector's column of each parameter
_COLUMN = {name: i for i, name in enumerate(PARAMETER_NAMES)}
#: bushing stiffnesses and the anti-roll bar's torsional stiffness: physics needs > 0
STIFFNESS_PARAMETERS: tuple[str, ...] = tuple(
    f"{b}_{c}" for b, comps in BUSHINGS.items() for c in comps
) + ("arb_torsion",)
#: static alignment [deg]: physics needs |value| < ALIGNMENT_LIMIT_DEG
ALIGNMENT_PARAMETERS = ("static_camber", "static_toe")


def parameter_kind(name: str) -> str:
    """``"point"`` (hard-point coordinate, mm), ``"stiffness"`` (> 0) or ``"alignment"`` (deg)."""
    if name in STIFFNESS_PARAMETERS:
        return "stiffness"
    if name in ALIGNMENT_PARAMETERS:
        return "alignment"
    if name in PARAMETER_NAMES:
        return "point"
    raise ValidationError(f"unknown parameter {name!r}; known are {list(PARAMETER_NAMES)}")


def physics_errors(name: str, value: float) -> list[str]:
    """Physical rules one design value breaks (empty: none), each naming rule and value.

    Every value is finite; stiffnesses (bushing ``k*`` [N/mm], ``r*`` [N*mm/deg],
    ``arb_torsion`` [N*m/rad]) are > 0; ``static_camber`` and ``static_toe`` [deg]
    satisfy ``|value| < ALIGNMENT_LIMIT_DEG`` (10 deg). Hard points are limited only by
    the linkage assembling (:func:`suspenv.models.mcpherson.vehicle_file.check_assembles`).
    """
    v = float(value)
    if not math.isfinite(v):
        return [f"`{name}` must be finite, but got {name}={v}"]
    kind = parameter_kind(name)
    if kind == "stiffness" and not v > 0:
        return [f"`{name} > 0` must hold (a stiffness), but got {name}={v:g}"]
    if kind == "alignment" and not abs(v) < ALIGNMENT_LIMIT_DEG:
        return [
            f"`|{name}| < {ALIGNMENT_LIMIT_DEG:g} deg` must hold (physical limit), but got "
            f"{name}={v:g} deg"
        ]
    return []


def design_physics_errors(x: np.ndarray) -> list[str]:
    """:func:`physics_errors` of every value of one design vector (49,)."""
    arr = np.asarray(x, dtype=float).reshape(-1)
    if arr.size != N_PARAMETERS:
        raise ValidationError(f"a design must have {N_PARAMETERS} values, but got {arr.size}")
    return [m for n, v in zip(PARAMETER_NAMES, arr, strict=True) for m in physics_errors(n, v)]


def default_bounds(name: str, values: Sequence[float]) -> tuple[float, float, bool]:
    """Default identification bounds ``(low, high, log)`` of ``name`` around ``values``
    (the nominal values of both sides, file units).

    Rule: hard points ``[min - 10, max + 10]`` mm, linear; stiffnesses (bushings and
    ``arb_torsion``) ``[min / 10, max * 10]`` on a log scale (the nominal at the centre
    of the unit interval); camber and toe ``[min - 1, max + 1]`` deg, linear, kept
    inside the physical limit (+-10 deg): a bound beyond it is moved to half way
    between the nominal and the limit.
    """
    lo, hi = float(min(values)), float(max(values))
    kind = parameter_kind(name)
    if kind == "stiffness":
        return lo / DEFAULT_STIFFNESS_FACTOR, hi * DEFAULT_STIFFNESS_FACTOR, True
    if kind == "alignment":
        lim = ALIGNMENT_LIMIT_DEG
        return (
            max(lo - DEFAULT_ALIGNMENT_HALF_RANGE_DEG, 0.5 * (lo - lim)),
            min(hi + DEFAULT_ALIGNMENT_HALF_RANGE_DEG, 0.5 * (hi + lim)),
            False,
        )
    return lo - DEFAULT_POINT_HALF_RANGE_MM, hi + DEFAULT_POINT_HALF_RANGE_MM, False


def bounds_errors(name: str, low: float, high: float, log: bool = False) -> list[str]:
    """Rules the bounds of ``name`` break: finite, ``low < high``, inside physics
    (stiffness ``low > 0``; alignment ``-10 < low``, ``high < 10`` deg); ``log`` needs
    ``low > 0``."""
    lo, hi = float(low), float(high)
    where = f"bounds of `{name}`"
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return [f"{where} must be finite, but got [{lo}, {hi}]"]
    if not lo < hi:
        return [f"{where}: `low < high` must hold, but got [{lo:g}, {hi:g}]"]
    kind = parameter_kind(name)
    if kind == "stiffness" and not lo > 0:
        return [f"{where}: `low > 0` must hold (a stiffness), but got low={lo:g}"]
    if kind == "alignment" and not (lo > -ALIGNMENT_LIMIT_DEG and hi < ALIGNMENT_LIMIT_DEG):
        return [
            f"{where}: `-{ALIGNMENT_LIMIT_DEG:g} < low` and `high < {ALIGNMENT_LIMIT_DEG:g}` "
            f"deg must hold (physical limit), but got [{lo:g}, {hi:g}]"
        ]
    if log and not lo > 0:
        return [f"{where}: a log scale needs `low > 0`, but got low={lo:g}"]
    return []


def euler_313(angles_deg: Sequence[float] | np.ndarray) -> np.ndarray:
    """Rotation matrix ``Rz(a) Rx(b) Rz(c)`` (3, 3) of body-fixed 3-1-3 Euler angles [deg]
    (ADAMS's default orientation convention); its columns are the rotated frame's axes."""
    a, b, c = (math.radians(float(t)) for t in angles_deg)

    def rz(t: float) -> np.ndarray:
        return np.array(
            [[math.cos(t), -math.sin(t), 0.0], [math.sin(t), math.cos(t), 0.0], [0.0, 0.0, 1.0]]
        )

    def rx(t: float) -> np.ndarray:
        return np.array(
            [[1.0, 0.0, 0.0], [0.0, math.cos(t), -math.sin(t)], [0.0, math.sin(t), math.cos(t)]]
        )

    return rz(a) @ rx(b) @ rz(c)


def bushing_frames(orientation: Mapping[str, Sequence[float]]) -> dict[str, np.ndarray]:
    """ISO 8855 bushing frames (2, 3, 3) per side of the oriented bushings.

    ``orientation``: bushing name -> ADAMS 3-1-3 Euler angles [deg] of the left bushing's
    frame in the left-side ADAMS/Car frame (module docstring). Side ``s`` gets
    ``M_s R M_s``, ``M_s = diag(-1, -SIDE_SIGN[s], 1)``: the right bushing mirrors the
    left one. Unknown bushings and non-finite angles are refused.
    """
    out = {}
    for name, angles in orientation.items():
        if name not in BUSHINGS:
            raise ValidationError(
                f"bushing orientation: unknown bushing {name!r}; known are {list(BUSHINGS)}"
            )
        a = np.asarray(angles, dtype=float)
        if a.shape != (3,) or not np.isfinite(a).all():
            raise ValidationError(
                f"bushing orientation of {name!r} must be three finite Euler angles [deg], "
                f"but got {list(np.atleast_1d(a))}"
            )
        R = euler_313(a)
        out[name] = np.stack([np.diag(_MIRROR[s]) @ R @ np.diag(_MIRROR[s]) for s in (0, 1)])
    return out


#: the scalar constants of :class:`AxleConstants` not required to be > 0 (other rules)
_NOT_POSITIVE = (
    "spring_upper_seat_d",
    "spring_lower_seat_d",
    "front_share",
    "front_brake_share",
    "front_drive_share",
)


@dataclass(frozen=True)
class AxleConstants:
    """Vehicle data that are not design variables (ADAMS/Car mm for points, left side).

    Attributes:
        wheel_centre: wheel centre [mm] (fixed: track is not a design variable).
        arb_bush: anti-roll bar bush position [mm] (the bar's mounting to the body).
        spring_upper_seat_d: distance [mm] of the upper seat along the strut line from
            the strut top (Psu = ST + a * d).
        spring_lower_seat_d, spring_lower_seat_offset: lower seat
            Psl = ST + a * d + V, V [mm] projected perpendicular to the strut line.
        drop_link_d, drop_link_offset: drop-link-to-strut point Pdts = ST + a * d + V.
        spring_rate: coil spring rate [N/mm].
        tyre_rate: tyre vertical rate [N/mm]; wheel_radius [mm].
        sprung_mass [kg], front_share [-], wheel_mass [kg] (per wheel, hangs on the knuckle).
        wheelbase [mm], cg_height [mm] (centre of gravity above the ground): anti-dive,
            anti-lift and Ackermann of the K&C report.
        front_brake_share [-]: front axle's share of the braking force; front_drive_share
            [-]: front axle's share of the tractive force (1 for front-wheel drive).
        rack_travel_per_rev [mm/rev]: rack travel per steering-wheel revolution (the
            steering gear's c-factor), for the overall steer ratio and the handwheel
            torque.
        rack_mount_rate [N/mm]: lateral (y) stiffness of the rack housing's mounts to
            the body, both mounts together.
        column_torsion_rate [N*m/deg]: torsional stiffness between the held handwheel
            and the pinion (column, intermediate shaft, the steering gear's input). With the
            mounts in series it lets the rack move by ``F (1 / k_mount + c^2 /
            k_column)`` under the net lateral force ``F`` of the tie rods (``c`` the
            rack travel per pinion radian): the steering system's share of the
            aligning-torque compliance (:meth:`rack_compliance`).
    """

    wheel_centre: tuple[float, float, float] = (0.0, -745.0, 20.0)
    arb_bush: tuple[float, float, float] = (255.0, -450.0, 60.0)
    spring_upper_seat_d: float = 40.0
    spring_lower_seat_d: float = 260.0
    spring_lower_seat_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    drop_link_d: float = 290.0
    drop_link_offset: tuple[float, float, float] = (55.0, 40.0, 0.0)
    spring_rate: float = 25.0
    tyre_rate: float = 252.18
    wheel_radius: float = 277.0
    sprung_mass: float = 1175.6
    front_share: float = 0.58
    wheel_mass: float = 27.5
    wheelbase: float = 2600.0
    cg_height: float = 550.0
    front_brake_share: float = 0.7
    front_drive_share: float = 1.0
    rack_travel_per_rev: float = 50.0
    rack_mount_rate: float = RACK_MOUNT_RATE
    column_torsion_rate: float = COLUMN_TORSION_RATE

    def __post_init__(self) -> None:
        """Validate every constant; an error names the rule and the value.

        Rules: points (``wheel_centre``, ``arb_bush``, ``spring_lower_seat_offset``,
        ``drop_link_offset``) are three finite numbers [mm]; ``spring_rate``,
        ``tyre_rate``, ``wheel_radius``, ``sprung_mass``, ``wheel_mass``, ``wheelbase``,
        ``cg_height``, ``rack_travel_per_rev``, ``drop_link_d``, ``rack_mount_rate`` and
        ``column_torsion_rate`` are finite and > 0;
        the seats are ordered along the strut line, ``0 <= spring_upper_seat_d <
        spring_lower_seat_d``; ``0 < front_share < 1``; ``front_brake_share`` and
        ``front_drive_share`` lie in [0, 1].
        """
        for f in fields(self):
            name, v = f.name, getattr(self, f.name)
            if isinstance(f.default, tuple):  # a point
                try:
                    arr = np.asarray(v, dtype=float)
                except (TypeError, ValueError):
                    arr = np.array([np.nan])
                if arr.shape != (3,) or not np.isfinite(arr).all():
                    raise ValidationError(
                        f"AxleConstants: `{name}` must be a point of three finite numbers "
                        f"[mm], but got {name}={v!r}"
                    )
            elif name not in _NOT_POSITIVE and not (
                isinstance(v, int | float) and math.isfinite(v) and v > 0
            ):
                raise ValidationError(
                    f"AxleConstants: `{name} > 0` must hold (finite), but got {name}={v!r}"
                )
        up, low = self.spring_upper_seat_d, self.spring_lower_seat_d
        if not (
            isinstance(up, int | float)
            and isinstance(low, int | float)
            and math.isfinite(up)
            and math.isfinite(low)
            and 0 <= up < low
        ):
            raise ValidationError(
                "AxleConstants: `0 <= spring_upper_seat_d < spring_lower_seat_d` must hold "
                f"(seats ordered along the strut line from its top, mm), but got "
                f"spring_upper_seat_d={up!r}, spring_lower_seat_d={low!r}"
            )
        if not 0 < self.front_share < 1:
            raise ValidationError(
                f"AxleConstants: `0 < front_share < 1` must hold, but got "
                f"front_share={self.front_share!r}"
            )
        for name in ("front_brake_share", "front_drive_share"):
            v = getattr(self, name)
            if not 0 <= v <= 1:
                raise ValidationError(
                    f"AxleConstants: `0 <= {name} <= 1` must hold, but got {name}={v!r}"
                )

    @property
    def rack_gain(self) -> float:
        """Rack travel per radian of the pinion (and of the held handwheel) [m/rad]."""
        return self.rack_travel_per_rev / 1000.0 / (2.0 * math.pi)

    @property
    def rack_compliance(self) -> float:
        """Rack travel per newton of net lateral tie-rod force [m/N]: the rack mounts
        and the column in series, ``1 / k_mount + c^2 / k_column`` (``c`` =
        :attr:`rack_gain`; 0 for a rigid steering system)."""
        k_mount = self.rack_mount_rate * 1e3  # N/m
        k_column = self.column_torsion_rate * 180.0 / math.pi  # N*m/rad
        return 1.0 / k_mount + self.rack_gain**2 / k_column

    @property
    def corner_sprung_load(self) -> float:
        """Sprung weight on one front wheel [N]."""
        return self.sprung_mass * 9.81 * self.front_share / 2.0

    @cached_property
    def iso_points(self) -> dict[str, np.ndarray]:
        """The constant points (2, 3) [m] per side, ISO 8855 (:func:`_to_iso`): wheel
        centre, anti-roll bar bush and the perpendicular offsets of the spring seats and
        the drop link (made once per instance, read-only)."""
        out = {
            "wheel_centre": self.wheel_centre,
            "arb_bush": self.arb_bush,
            "spring_upper_seat": (0.0, 0.0, 0.0),
            "spring_lower_seat": self.spring_lower_seat_offset,
            "drop_link_strut": self.drop_link_offset,
        }
        iso = {name: _to_iso(np.array(v)) for name, v in out.items()}
        for v in iso.values():
            v.flags.writeable = False
        return iso

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_dict(cls, d: dict) -> AxleConstants:
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValidationError(f"unknown axle constant(s) {unknown}; known are {sorted(known)}")
        # Any: a point field takes a tuple of floats, a scalar field a float (per key)
        conv: dict[str, Any] = {
            k: tuple(float(x) for x in v) if isinstance(v, list | tuple) else float(v)
            for k, v in d.items()
        }
        return replace(cls(), **conv)


@dataclass
class Axle:
    """Batched axle data in SI / ISO 8855; every array has leading shape (n, 2) (design, side).

    Attributes:
        points: name -> (n, 2, 3) [m] positions at the design (assembly) position.
        bush: name -> (n, 2, 6) stiffness [N/m x3, N*m/rad x3] in vehicle axes.
        arb_torsion: (n,) [N*m/rad].
        camber0, toe0: (n, 2) static alignment [rad] (camber <0 top in, toe >0 toe-in).
        spring_rate, tyre_rate, wheel_radius, wheel_weight, corner_load: (n, 2) SI.
        frames: bushing -> (n, 2, 3, 3) ISO 8855 rotation of the bushing frame (columns:
            the bushing axes) for the bushings with an orientation; a bushing not listed
            has its frame parallel to the vehicle axes (``bush`` is then in vehicle axes,
            otherwise in the bushing frame).
        rack_compliance: (n,) [m/N] rack travel per newton of net lateral tie-rod
            force, per design (None: every design's is ``constants.rack_compliance``).
    """

    points: dict[str, np.ndarray]
    bush: dict[str, np.ndarray]
    arb_torsion: np.ndarray
    camber0: np.ndarray
    toe0: np.ndarray
    spring_rate: np.ndarray
    tyre_rate: np.ndarray
    wheel_radius: np.ndarray
    wheel_weight: np.ndarray
    corner_load: np.ndarray
    constants: AxleConstants = field(default_factory=AxleConstants)
    frames: dict[str, np.ndarray] = field(default_factory=dict)
    rack_compliance: np.ndarray | None = None

    @property
    def n(self) -> int:
        return self.arb_torsion.shape[0]

    def take(self, rows: np.ndarray) -> Axle:
        """The sub-batch of the given design rows (every array and dict of arrays;
        ``constants`` shared)."""
        idx = np.asarray(rows)

        def pick(v: Any) -> Any:
            if isinstance(v, dict):
                return {k: a[idx] for k, a in v.items()}
            return v[idx] if isinstance(v, np.ndarray) else v

        return Axle(**{f.name: pick(getattr(self, f.name)) for f in fields(self)})


def _unit(v: np.ndarray) -> np.ndarray:
    """Unit vectors (..., 3) along ``v`` (``np.linalg.norm``'s sum and root, in fewer calls)."""
    return v / np.sqrt((v * v).sum(axis=-1, keepdims=True))


#: the mirror of the left-side ADAMS/Car frame into ISO 8855, per side (2, 3)
_MIRROR = np.stack([np.array([-1.0, -SIDE_SIGN[s], 1.0]) for s in (0, 1)])


def _to_iso(p_mm: np.ndarray) -> np.ndarray:
    """Points [mm] in the left-side ADAMS/Car frame -> ISO 8855 [m], per side (..., 2, 3)."""
    return np.asarray(p_mm, dtype=float) / 1000.0 * _MIRROR


@cache
def _columns() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The design vector's columns of the hard points (K, 3) (x, y, z) and bushings
    (B, 6) (:data:`COMPONENTS`; the lower-arm bushes' kz is their ky: axisymmetric about
    their x axis), and the bushing components' unit factors (6,) (kN/mm -> N/m,
    N*mm/deg -> N*m/rad)."""
    idx = _COLUMN
    hp = np.array([[idx[f"{p}_{a}"] for a in "xyz"] for p in HARD_POINTS])
    cols = []
    for b in BUSHINGS:
        row = []
        for comp in COMPONENTS:
            name = f"{b}_{comp}" if f"{b}_{comp}" in idx or comp != "kz" else f"{b}_ky"
            if name not in idx:  # pragma: no cover - every bushing lists its rotations
                raise ValidationError(f"bushing {b} lacks component {comp}")
            row.append(idx[name])
        cols.append(row)
    scale = np.array([1e3 if comp.startswith("k") else 1e-3 / DEG for comp in COMPONENTS])
    return hp, np.array(cols), scale


def build_axle(
    left: np.ndarray,
    right: np.ndarray | None = None,
    constants: AxleConstants | None = None,
    orientation: Mapping[str, Sequence[float]] | None = None,
) -> Axle:
    """Build an :class:`Axle` from design vectors (n, 49) in the spec's units.

    ``right`` defaults to ``left`` (a mirrored axle). Both are given in the left-side
    ADAMS/Car convention; the right side is mirrored here. ``arb_torsion`` (one bar)
    is taken from ``left``. ``orientation``: bushing -> ADAMS 3-1-3 Euler angles [deg]
    of its frame (module docstring; none: frames parallel to the vehicle axes).
    """
    c = constants or AxleConstants()
    XL = np.atleast_2d(np.asarray(left, dtype=float))
    XR = XL if right is None else np.atleast_2d(np.asarray(right, dtype=float))
    if XL.shape[1] != N_PARAMETERS or XR.shape != XL.shape:
        raise ValidationError(
            f"design vectors must have shape (n, {N_PARAMETERS}) on both sides, but got "
            f"left {XL.shape} and right {XR.shape}"
        )
    n = XL.shape[0]
    X = np.stack([XL, XR], axis=1)  # (n, 2, 49)
    _, bush_cols, bush_scale = _columns()
    k_all = X[..., bush_cols] * bush_scale  # (n, 2, B, 6) [N/m, N*m/rad]
    ones = np.ones((n, 2))
    return Axle(
        points=_points(X, c),
        bush={b: k_all[..., i, :] for i, b in enumerate(BUSHINGS)},
        arb_torsion=XL[:, _COLUMN["arb_torsion"]].copy(),
        camber0=X[..., _COLUMN["static_camber"]] * DEG,
        toe0=X[..., _COLUMN["static_toe"]] * DEG,
        spring_rate=ones * c.spring_rate * 1e3,
        tyre_rate=ones * c.tyre_rate * 1e3,
        wheel_radius=ones * c.wheel_radius / 1e3,
        wheel_weight=ones * c.wheel_mass * 9.81,
        corner_load=ones * c.corner_sprung_load,
        constants=c,
        frames={
            k: np.broadcast_to(v, (n, 2, 3, 3)).copy()
            for k, v in bushing_frames(orientation or {}).items()
        },
    )


def _points(X: np.ndarray, c: AxleConstants) -> dict[str, np.ndarray]:
    """Every point (n, 2, 3) [m], ISO 8855, of the design vectors ``X`` (n, 2, 49)
    (ADAMS/Car, left-side convention on both sides) with the constants ``c``: the hard
    points mirrored per side, the wheel centre and bar bush, and the spring seats and
    the drop link's strut point along the strut line from the strut top."""
    n = X.shape[0]
    hp_cols = _columns()[0]
    # every hard point in one product [mm -> m], mirrored per side: (n, 2, K, 3)
    hp = X[..., hp_cols] / 1000.0 * _MIRROR[:, None, :]
    pts: dict[str, np.ndarray] = {name: hp[..., i, :] for i, name in enumerate(HARD_POINTS)}
    iso = c.iso_points
    for name in ("wheel_centre", "arb_bush"):
        pts[name] = np.repeat(iso[name][None], n, axis=0)
    st, sp = pts["strut_top"], pts["strut_axis_point"]
    a = _unit(sp - st)
    for name, d_mm in (
        ("spring_upper_seat", c.spring_upper_seat_d),
        ("spring_lower_seat", c.spring_lower_seat_d),
        ("drop_link_strut", c.drop_link_d),
    ):
        v = iso[name] + 0.0 * st
        off = v - (v * a).sum(-1, keepdims=True) * a  # the offset perpendicular to ``a``
        pts[name] = st + a * (d_mm / 1000.0) + off
    return pts


def reference_design() -> np.ndarray:
    """The reference vehicle's design vector (49,): the paper's identified values."""
    return design_space().reference()
