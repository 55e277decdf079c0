"""Reference minibus: vehicle data, load cases, the study's 8 design variables.

Frame and units: ISO 8855 (x forward, y left, z up), SI units inside (m, kg, N, s,
rad). The study's design variables keep the study's units at the edge (N/mm,
N*mm/deg, dimensionless scales); :func:`design_to_si` converts them once.
Corner order everywhere: FL, FR, RL, RR. Suspension deflection is positive in
compression (bump); damper velocity is positive in compression (bump).

Every number carries its source or the reason for the choice (see also
``docs/minibus.md``). Sources named below:

- [UAZ]   UAZ-452 van/bus multibody model data (ride_standards.md, public data points).
- [VAN]   VW Vanagon vehicle-dynamics model data (same list).
- [HIACE] Hiace-class minibus masses and wheelbase (same list).
- [STUDY] the minibus ride/handling study (minibus_ride_handling.md).
- [CONV]  the conversion notes of ride_standards.md ("Conversions").
- [CHOICE] an engineering choice, with the reason given next to it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.space import DesignSpace, Parameter
from suspenv.models.minibus.suspension import (
    DamperCurve,
    leaf_static_deflection,
    torsion_bar_wheel_rate,
)

G = 9.81  # m/s^2, standard gravity (rounded)
NMM_PER_DEG_TO_NM_PER_RAD = 1e-3 * 180.0 / np.pi  # N*mm/deg -> N*m/rad
N_PER_MM_TO_N_PER_M = 1e3

# ------------------------------------------------------------------ design variables
#: the study's 8 design variables: (name, min, max, unit, study's pick, meaning) [STUDY]
DESIGN_VARIABLES: tuple[Parameter, ...] = tuple(
    Parameter(name, low, high, unit, default=pick, description=meaning)
    for name, low, high, unit, pick, meaning in (
        ("K1", 60.0, 85.0, "N/mm", 73.5, "rear leaf spring primary rate, per side"),
        ("K2", 130.0, 180.0, "N/mm", 151.5,
         "rear leaf spring composite rate after helper contact, per side"),
        ("K3", 1.0e3, 5.0e3, "N/mm", 3.5e3, "leaf-eye bush radial stiffness, per bush"),
        ("T1", 7.0e4, 1.5e5, "N*mm/deg", 8.8e4,
         "front torsion bar torsional stiffness, per side"),
        ("T2", 2.0e5, 9.0e5, "N*mm/deg", 6.8e5, "front stabiliser, as axle roll stiffness"),
        ("T3", 2.0e5, 9.0e5, "N*mm/deg", 8.2e5, "rear stabiliser, as axle roll stiffness"),
        ("C1", 0.6, 1.8, "-", 1.12, "front damper characteristic-curve force scale"),
        ("C2", 0.6, 1.8, "-", 0.88, "rear damper characteristic-curve force scale"),
    )
)  # fmt: skip
DESIGN_NAMES: tuple[str, ...] = tuple(p.name for p in DESIGN_VARIABLES)
#: the study's ride-focused pick, physical study units [STUDY]
STUDY_PICK = np.array([p.default for p in DESIGN_VARIABLES], dtype=float)
#: the baseline (pre-optimisation) design: centre of every range [CHOICE: the study
#: does not publish its initial values; the centre keeps the reference unbiased]
BASELINE_DESIGN = np.array([(p.low + p.high) / 2 for p in DESIGN_VARIABLES], dtype=float)


def design_space() -> DesignSpace:
    """The study's 8-variable design space; the reference design is the study's pick."""
    return DesignSpace(DESIGN_VARIABLES)


# ------------------------------------------------------------------ data classes
@dataclass(frozen=True)
class LoadCase:
    """Sprung body of one load case.

    Attributes:
        name: "no_load" or "full_load".
        sprung_mass: kg (body + powertrain + payload, without unsprung parts).
        cg_x: m, distance of the sprung CoM behind the front axle.
        cg_z: m, height of the sprung CoM above ground.
        roll_gyration, pitch_gyration, yaw_gyration: m, radii of gyration of the sprung
            body about its own CoM (inertia = mass * radius^2).
    """

    name: str
    sprung_mass: float
    cg_x: float
    cg_z: float
    roll_gyration: float
    pitch_gyration: float
    yaw_gyration: float

    @property
    def roll_inertia(self) -> float:
        """kg*m^2 about the x axis through the sprung CoM."""
        return self.sprung_mass * self.roll_gyration**2

    @property
    def pitch_inertia(self) -> float:
        """kg*m^2 about the y axis through the sprung CoM."""
        return self.sprung_mass * self.pitch_gyration**2

    @property
    def yaw_inertia(self) -> float:
        """kg*m^2 about the z axis through the sprung CoM."""
        return self.sprung_mass * self.yaw_gyration**2


@dataclass(frozen=True)
class Minibus:
    """Reference minibus. All fields SI; see module docstring for sources."""

    # geometry -------------------------------------------------------------
    wheelbase: float = 2.60  # m [HIACE]
    track_front: float = 1.465  # m [UAZ] (one published track value; used front and rear)
    track_rear: float = 1.465  # m [UAZ]
    # rear leaf springs: lateral spacing of the two spring seats on the axle.
    leaf_spacing: float = 1.00  # m [CHOICE: leaves sit inboard of the wheels, ~0.7 x track]
    leaf_length: float = 1.30  # m eye to eye [CHOICE: typical light-commercial leaf]
    #: deflection (from the free, unloaded spring) at which the helper leaf engages.
    #: [CHOICE] 70 mm: above the no-load static deflection for every K1 in range
    #: (max 62 mm at K1 = 60) and below the full-load one, so the empty vehicle rides
    #: on the primary rate and the loaded one on the composite rate (the study's intent).
    helper_engagement: float = 0.070  # m
    #: torsion-bar lever from bar axis to wheel centre; wheel rate = T/l^2 [CONV]
    torsion_bar_lever: float = 0.33  # m
    #: stabiliser convention: T2/T3 are axle roll stiffness (moment per body-minus-axle
    #: roll angle), not bar twist stiffness [CONV, one of the two stated options].
    front_damper_spacing: float = 1.465  # m, dampers act at the wheel [CHOICE]
    rear_damper_spacing: float = 1.00  # m, dampers beside the leaf seats [CHOICE]
    # roll-centre geometry (used by the report and the handling model) ---------
    #: front double-wishbone instant centre: lateral distance inboard of the contact
    #: patch and height above ground [CHOICE: long, low swing arm of a van front end]
    front_ic_inboard: float = 2.0  # m
    front_ic_height: float = 0.15  # m
    #: rear rigid axle on leaves: the leaves locate the axle laterally at the spring
    #: seats, so the roll centre lies at about the seat height (Gillespie, *Fundamentals
    #: of Vehicle Dynamics*, 1992, ch. 7; Milliken & Milliken, *Race Car Vehicle
    #: Dynamics*, 1995, ch. 17). [CHOICE] 0.30 m: seats on the axle tube, about the
    #: wheel-centre height (loaded radius 0.33 m) of a low-floor van. The earlier 0.45 m
    #: (seats 0.12 m above the wheel centre), with the earlier trail and steering
    #: compliance, put 6.5x the front's geometric load transfer on the rear and made 1,902
    #: of 2,002 random designs limit-oversteer empty (docs/minibus_handling.md, "Handling
    #: balance"; docs/benchmarks/minibus_limit.json).
    rear_roll_centre_height: float = 0.30  # m
    # unsprung ---------------------------------------------------------------
    #: per front corner: hub, brake, wishbones share, wheel and tyre [CHOICE: ~2.3 % of
    #: gross mass per corner, typical of independent fronts of this size]
    unsprung_front: float = 45.0  # kg per corner
    #: per rear side: half of a 150 kg live axle with wheels [CHOICE: live beam axle]
    unsprung_rear: float = 75.0  # kg per side
    # tyres --------------------------------------------------------------------
    tyre_vertical_stiffness: float = 223e3  # N/m [UAZ]
    tyre_vertical_damping: float = 150.0  # N*s/m [CHOICE: small radial-tyre damping]
    tyre_loaded_radius: float = 0.33  # m [CHOICE: 195R15C light-truck tyre]
    #: vertical contact length used to filter short obstacles [CHOICE: ~0.16 m footprint
    #: of a 195R15C tyre at ~7 kN]
    tyre_contact_length: float = 0.16  # m
    #: compression travel from the static ride position to bump-stop contact, front
    #: (spring at the wheel) and rear (leaf at its seat), for the working-space
    #: constraint. [CHOICE] 75 mm both: the sources give none; the lower end of the
    #: 70-100 mm of jounce travel a light-commercial van typically keeps at design ride
    #: height (the smaller the travel, the sooner the constraint binds)
    bump_stop_travel_front: float = 0.075  # m
    bump_stop_travel_rear: float = 0.075  # m
    # rear axle lateral compliance / roll steer (handling side) -----------------
    #: geometric roll steer of the leaf-sprung axle (rad axle steer per rad body roll)
    #: [CHOICE: small understeering value typical of level leaves]
    rear_roll_steer: float = 0.05
    # steering (handling side) ------------------------------------------------
    steering_ratio: float = 20.0  # - [CHOICE: light bus recirculating-ball/rack range 18-22]
    # dampers: baseline curves at the wheel, scale 1 ------------------------------
    #: [CHOICE] sized for a per-axle damping ratio ~0.3 at no load and scale 1 (mean of
    #: bump and rebound low-speed rates, ride rate, sprung mass per side), rebound:bump
    #: = 3:1, digressive knee 0.13 m/s, high-speed slope 40 % of the low-speed slope.
    #: At full load the rear leaf's composite rate is close to the tyre rate, so the
    #: axle moves with the body and the rear body mode's modal damping falls to ~0.05.
    damper_front: DamperCurve = field(
        default_factory=lambda: DamperCurve(1300.0, 520.0, 0.13, 3900.0, 1560.0, 0.13)
    )
    damper_rear: DamperCurve = field(
        default_factory=lambda: DamperCurve(1370.0, 548.0, 0.13, 4110.0, 1644.0, 0.13)
    )
    # load cases -------------------------------------------------------------
    #: no load: 1950 kg kerb [HIACE] minus unsprung 2*45 + 2*75 = 240 kg -> 1710 kg.
    #: CoM 1.15 m behind the front axle (56/44 front/rear, cab-over engine) [CHOICE];
    #: CoM height 0.75 m [VAN]. Radii of gyration: mean of [UAZ] and [VAN]
    #: (roll 0.576 m; pitch/yaw 1.141/1.192 m) with pitch/yaw scaled by the wheelbase
    #: ratio 2.60/2.385 -> 1.244/1.300 m.
    no_load: LoadCase = field(
        default_factory=lambda: LoadCase("no_load", 1710.0, 1.15, 0.75, 0.576, 1.244, 1.300)
    )
    #: full load: 3100 kg gross [HIACE] minus 240 kg unsprung -> 2860 kg. CoM moves
    #: rearward and up when loaded [HIACE]: 1.45 m behind the front axle, 0.85 m high
    #: [CHOICE: 1150 kg payload seated at ~1.0 m height, centred ~1.9 m behind the front
    #: axle]. Same radii of gyration: passengers spread over the whole cabin.
    full_load: LoadCase = field(
        default_factory=lambda: LoadCase("full_load", 2860.0, 1.45, 0.85, 0.576, 1.244, 1.300)
    )

    def load_case(self, name: str | LoadCase) -> LoadCase:
        """The named load case ("no_load" / "full_load"), or a LoadCase passed through."""
        if isinstance(name, LoadCase):
            return name
        cases = {"no_load": self.no_load, "full_load": self.full_load}
        if name not in cases:
            raise ValidationError(f"load case must be one of {sorted(cases)}, but got {name!r}")
        return cases[name]

    def with_(self, **changes: Any) -> Minibus:
        """A copy with some fields changed."""
        # Any: each field has its own type (float, int, DamperCurve, LoadCase...)
        return replace(self, **changes)


#: the documented reference vehicle
REFERENCE_MINIBUS = Minibus()
LOAD_CASES: tuple[str, str] = ("no_load", "full_load")


# ------------------------------------------------------------------ design -> SI
@dataclass(frozen=True)
class DesignSI:
    """The 8 design variables in SI, arrays of shape (n,).

    Attributes:
        rear_primary_rate: N/m per side, leaf rate before helper contact (K1).
        rear_composite_rate: N/m per side, leaf rate after helper contact (K2).
        leaf_bush_radial: N/m per bush (K3).
        front_torsion_bar: N*m/rad per side (T1).
        front_wheel_rate: N/m per side, T1 / lever^2.
        front_roll_arb: N*m/rad, front stabiliser as axle roll stiffness (T2).
        rear_roll_arb: N*m/rad, rear stabiliser as axle roll stiffness (T3).
        front_damper_scale, rear_damper_scale: - (C1, C2).
    """

    rear_primary_rate: np.ndarray
    rear_composite_rate: np.ndarray
    leaf_bush_radial: np.ndarray
    front_torsion_bar: np.ndarray
    front_wheel_rate: np.ndarray
    front_roll_arb: np.ndarray
    rear_roll_arb: np.ndarray
    front_damper_scale: np.ndarray
    rear_damper_scale: np.ndarray

    @property
    def n(self) -> int:
        return len(self.rear_primary_rate)


def check_designs(X: np.ndarray) -> np.ndarray:
    """``X`` as float (n, 8) in the study's units; reject bad shapes and non-physical values."""
    arr = np.asarray(X, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != len(DESIGN_NAMES):
        raise ValidationError(
            f"minibus designs must have shape (n, {len(DESIGN_NAMES)}) with columns "
            f"{list(DESIGN_NAMES)}, but got {np.shape(X)}"
        )
    # smallest > 0 and largest < inf (NaN fails both): two reductions instead of a mask
    if arr.size and not (arr.min() > 0 and arr.max() < np.inf):
        r, c = np.argwhere(~(np.isfinite(arr) & (arr > 0)))[0]
        raise ValidationError(
            f"every design variable must be finite and > 0, but row {r} has "
            f"{DESIGN_NAMES[c]}={arr[r, c]}"
        )
    return arr


#: the factors of the design columns (study units) to SI: N/mm -> N/m, N*mm/deg ->
#: N*m/rad, - (read-only)
DESIGN_TO_SI = np.array(3 * [N_PER_MM_TO_N_PER_M] + 3 * [NMM_PER_DEG_TO_NM_PER_RAD] + [1.0, 1.0])
DESIGN_TO_SI.flags.writeable = False


def design_to_si(X: np.ndarray, vehicle: Minibus = REFERENCE_MINIBUS) -> DesignSI:
    """Convert designs (n, 8) in the study's units [N/mm, N*mm/deg, -] to :class:`DesignSI`.

    Inside the study's ranges K2 >= K1 always holds (130 > 85); a K2 below K1 (possible
    with other ranges) is rejected because the helper leaf can only add stiffness.
    """
    X = check_designs(X)
    K1, K2 = X[:, 0], X[:, 1]
    if (K2 < K1).any():
        r = int(np.argmax(K2 < K1))
        raise ValidationError(
            f"`K2 >= K1` must hold (the helper leaf adds stiffness), but got "
            f"(K1={K1[r]}, K2={K2[r]}) in row {r}"
        )
    # one product, then each variable's row C-contiguous (8, n)
    k1, k2, k3, t1, t2, t3, c1, c2 = (X * DESIGN_TO_SI).T.copy()
    return DesignSI(
        rear_primary_rate=k1,
        rear_composite_rate=k2,
        leaf_bush_radial=k3,
        front_torsion_bar=t1,
        front_wheel_rate=torsion_bar_wheel_rate(t1, vehicle.torsion_bar_lever),
        front_roll_arb=t2,
        rear_roll_arb=t3,
        front_damper_scale=c1,
        rear_damper_scale=c2,
    )


# ------------------------------------------------------------------ batch parameters
@dataclass(frozen=True)
class VehicleParams:
    """Everything the ride and handling models need for a batch of n designs, SI.

    Scalars are shared by the batch; arrays have shape (n,). Static quantities are
    for the given load case. ``a``/``b``: CoM to front/rear axle (m).
    """

    vehicle: Minibus
    load: LoadCase
    design: DesignSI
    a: float
    b: float
    front_static_load: float  # N per front corner, sprung share only
    rear_static_load: float  # N per rear spring seat, sprung share only
    front_static_deflection: np.ndarray  # m, spring compression at rest, (n,)
    rear_static_deflection: np.ndarray  # m, leaf compression from free at rest, (n,)
    rear_on_helper: np.ndarray  # bool (n,), helper leaf engaged at rest
    rear_static_rate: np.ndarray  # N/m per side at rest (K1 or K2), (n,)

    @property
    def n(self) -> int:
        return self.design.n

    def take(self, rows: slice) -> VehicleParams:
        """The parameters of the designs ``rows`` of the batch."""
        design = DesignSI(*(a[rows] for a in vars(self.design).values()))
        changes = {
            k: getattr(self, k)[rows]
            for k in (
                "front_static_deflection", "rear_static_deflection", "rear_on_helper",
                "rear_static_rate",
            )
        }  # fmt: skip
        return replace(self, design=design, **changes)


def stacked_vehicle_parameters(
    X: np.ndarray, load_cases: Sequence[str | LoadCase], vehicle: Minibus = REFERENCE_MINIBUS
) -> list[VehicleParams]:
    """:func:`vehicle_parameters` of designs X for each load case, in order (the ride
    model stacks them row-wise); the designs converted once. An evaluation that needs
    them for several models (ride and handling) computes them once and passes them on
    (``params`` of :func:`suspenv.problems.minibus_ride.ride_objectives_all` and
    :func:`suspenv.models.minibus.handling_model.handling_parameters`)."""
    design = design_to_si(X, vehicle)
    return [_apply(design, lc, vehicle) for lc in load_cases]


def vehicle_parameters(
    X: np.ndarray, load_case: str | LoadCase = "no_load", vehicle: Minibus = REFERENCE_MINIBUS
) -> VehicleParams:
    """Apply designs X (n, 8; study units) to the reference vehicle in one load case.

    Static loads come from the sprung CoM position (moment balance about the axles);
    the static leaf deflection uses the two-stage law (K1 up to the helper-engagement
    deflection, K2 beyond).
    """
    return _apply(design_to_si(X, vehicle), load_case, vehicle)


def _apply(design: DesignSI, load_case: str | LoadCase, vehicle: Minibus) -> VehicleParams:
    """:func:`vehicle_parameters` of designs already in SI."""
    load = vehicle.load_case(load_case)
    if not 0.0 < load.cg_x < vehicle.wheelbase:
        raise ValidationError(
            f"`0 < cg_x < wheelbase` must hold, but got (cg_x={load.cg_x}, "
            f"wheelbase={vehicle.wheelbase})"
        )
    a = load.cg_x
    b = vehicle.wheelbase - a
    w = load.sprung_mass * G
    front = w * b / vehicle.wheelbase / 2.0
    rear = w * a / vehicle.wheelbase / 2.0
    if rear < 0:
        raise ValidationError(f"`sprung_mass >= 0` must hold, but got {load.sprung_mass}")
    # the design's rates are > 0 (design_to_si)
    rear_defl, on_helper = leaf_static_deflection(
        rear, design.rear_primary_rate, design.rear_composite_rate, vehicle.helper_engagement
    )
    return VehicleParams(
        vehicle=vehicle,
        load=load,
        design=design,
        a=a,
        b=b,
        front_static_load=front,
        rear_static_load=rear,
        front_static_deflection=front / design.front_wheel_rate,
        rear_static_deflection=rear_defl,
        rear_on_helper=on_helper,
        rear_static_rate=np.where(on_helper, design.rear_composite_rate, design.rear_primary_rate),
    )
