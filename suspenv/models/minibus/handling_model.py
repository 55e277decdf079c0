"""Handling model of the reference minibus: lateral, yaw and roll, vectorised over a batch.

Frame, units, signs: ISO 8855 vehicle axes (x forward, y left, z up), SI units (m, kg,
N, s, rad). Yaw rate ``r`` is positive to the left (counter-clockwise seen from above);
body roll ``phi`` is positive right-side-down about +x, so a left turn (a_y > 0) rolls
the body positively. Steer angles (road wheels) are positive to the left. Tyre slip
angles follow :mod:`suspenv.models.minibus.tyre` (positive when the force is to the
left). The forward speed ``u`` is constant in every manoeuvre.

Model (a single-track model with a rolling sprung mass, after Segel's three-degree-of-
freedom car, with the axle's two wheels kept separate for the load transfer)::

    m (v' + u r) - ms h' p'                 = Fyf + Fyr               (lateral)
    Iz r'                                   = a Fyf - b Fyr           (yaw)
    Ixs p' - ms h' (v' + u r) = (ms g h' - Kphi) phi - Mdamp          (roll, p = phi')

``ms h'`` couples the sprung mass (CoM a height h' above the roll axis) to the lateral
motion; ``Ixs`` is the sprung roll inertia about the roll axis. Per axle the roll
stiffness is springs + stabiliser (T2/T3 taken as axle roll stiffness, the vehicle's
stated convention) in series with the tyres' vertical stiffness, so ``phi`` is the
body roll relative to the ground. The lateral load transfer of axle i is::

    dFz_i = (Kphi_i phi + Mdamp_i + ms_i h_rc_i a_y + mu_i r_w a_y) / t_i

(elastic, damper, roll-centre and unsprung parts; ``ms_i`` the sprung-mass share of
the axle, ``h_rc_i`` its roll-centre height, ``mu_i`` its unsprung mass at wheel-centre
height ``r_w``). An axle whose inner wheel has lifted transfers no more; the torsionally
rigid body passes the excess roll moment to the other axle (both lifted: rollover).
Both wheels of an axle share its slip angle, so with a load-sensitive tyre the axle's
lateral capacity falls as load is transferred: the roll-stiffness split (T1, T2, K1/K2,
T3) moves the handling balance. Damper roll moments use the nonlinear damper curves
(scaled by C1/C2) at the roll-induced damper speeds.

Rear axle steer (leaf-sprung rigid axle)::

    delta_r = (eps_geo + eps_bush) phi + c_F Fyr

``eps_geo`` is the leaf's geometric roll steer; the bush terms follow from the
leaf-eye bushes' radial stiffness K3: (1) roll loads one leaf more than the other, the
shackle turns part of that extra vertical load into a longitudinal load on the front
eye whose bush yields, so the axle yaws (``eps_bush = k_leaf (l1/Ls) tan(beta) / K3``,
``beta`` the shackle angle, signed); (2) the axle's lateral force is shared by the front
eye bushes (stiffness 2 K3) and the shackle ends (2 eta K3, the shackle's swing makes
them softer), the unequal deflections yaw the axle
(``c_F = (l2 / (2 K3) - l1 / (2 eta K3)) / Ls^2``; ``l1``/``l2`` the front-eye-to-axle
and axle-to-shackle lengths). Front axle steer adds a roll steer (default 0) and the
steering-system compliance under the tyres' aligning moment,
``delta_f = delta + eps_f phi + c_Ff Fyf`` with ``c_Ff = -t / k_steer`` (trail t,
steering stiffness k_steer at the road wheels).

Left out (documented limits): tyre relaxation length, combined slip, camber, steering
compliance, aerodynamics, pitch and heave coupling, the unsprung masses' own roll,
cos(delta) of the steered tyre forces (small-angle single-track kinematics).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.identity_cache import IdentityCache
from suspenv.core.options import number, positive
from suspenv.models.minibus import handling_kernel
from suspenv.models.minibus.handling_kernel import axle_transfer
from suspenv.models.minibus.suspension import (
    damper_force,
    damper_mean_coefficient,
    spring_pair_roll_stiffness,
)
from suspenv.models.minibus.tyre import LIGHT_TRUCK_TYRE, LateralTyre
from suspenv.models.minibus.vehicle import (
    REFERENCE_MINIBUS,
    G,
    LoadCase,
    Minibus,
    VehicleParams,
    stacked_vehicle_parameters,
)


@dataclass(frozen=True)
class LeafAxleGeometry:
    """Leaf-spring axle location data for the bush compliance steer (SI).

    Attributes:
        axle_from_front_eye: l1, m, front eye to axle seat along the leaf (l2 = Ls - l1).
        shackle_lateral_ratio: eta, lateral stiffness of a shackle end relative to a
            front eye bush (< 1: the shackle swings sideways).
        shackle_angle_deg: beta, deg; sign chosen so that positive values make the bush
            roll steer understeering. Default -15 deg: the compliance adds a little roll
            oversteer (the usual direction for leaf-eye compliance).
        front_roll_steer: rad of front road-wheel steer per rad of body roll.
        steering_trail: m, pneumatic + caster trail of the front tyres' lateral force.
        steering_stiffness: N*m/rad, torsional stiffness of the steering system at the
            road wheels (both wheels together, steering wheel held).
    """

    axle_from_front_eye: float = 0.60  # m [CHOICE: axle slightly ahead of leaf centre]
    shackle_lateral_ratio: float = 0.5  # - [CHOICE]
    shackle_angle_deg: float = -15.0  # deg [CHOICE]
    front_roll_steer: float = 0.0  # rad/rad [CHOICE: independent front, neutral]
    #: [CHOICE] 50 mm total trail (about 25 mm caster trail + 25 mm pneumatic trail of a
    #: 195/70 R15C tyre in the linear range) and 20 kN*m/rad steering stiffness at the
    #: road wheels (a recirculating-ball box, long column and drag-link linkage of a van
    #: front end is softer than a car's rack): about 1.4 deg/g of compliance understeer.
    #: Steering compliance is the largest understeer contribution of trucks and vans
    #: (Gillespie, *Fundamentals of Vehicle Dynamics*, 1992, ch. 6). The earlier 30 mm and
    #: 30 kN*m/rad (0.57 deg/g) left the loaded reference oversteering from about 0.3 g.
    steering_trail: float = 0.050  # m
    steering_stiffness: float = 2.0e4  # N*m/rad

    def __post_init__(self) -> None:
        owner = "LeafAxleGeometry"
        positive(owner, "shackle_lateral_ratio", self.shackle_lateral_ratio)
        positive(owner, "steering_stiffness", self.steering_stiffness)
        angle = self.shackle_angle_deg
        number(owner, "shackle_angle_deg", angle, -80.0, 80.0, lo_open=True, hi_open=True)


DEFAULT_LEAF_GEOMETRY = LeafAxleGeometry()


@dataclass(frozen=True)
class HandlingParams:
    """Handling parameters of a batch of n vehicles (every field an array of shape (n,)).

    Masses kg; lengths m; inertias kg*m^2; roll stiffness N*m/rad. ``a``/``b``: total
    CoM to front/rear axle. ``fz_front``/``fz_rear``: static load per wheel, N.
    """

    m: np.ndarray  # total mass
    ms: np.ndarray  # sprung mass
    a: np.ndarray
    b: np.ndarray
    iz: np.ndarray  # yaw inertia of the whole vehicle about its CoM
    ixs: np.ndarray  # sprung roll inertia about the roll axis
    h_prime: np.ndarray  # sprung CoM height above the roll axis
    h_rc_front: np.ndarray
    h_rc_rear: np.ndarray
    ms_front: np.ndarray  # sprung mass share carried by the front axle
    ms_rear: np.ndarray
    mu_front: np.ndarray  # unsprung mass of the front axle (both sides)
    mu_rear: np.ndarray
    wheel_radius: np.ndarray
    track_front: np.ndarray
    track_rear: np.ndarray
    kphi_front: np.ndarray  # effective roll stiffness (suspension in series with tyres)
    kphi_rear: np.ndarray
    damper_scale_front: np.ndarray
    damper_scale_rear: np.ndarray
    fz_front: np.ndarray
    fz_rear: np.ndarray
    roll_steer_front: np.ndarray  # rad/rad
    force_steer_front: np.ndarray  # rad/N (steering compliance, < 0)
    roll_steer_rear: np.ndarray  # rad/rad, geometric + bush
    force_steer_rear: np.ndarray  # rad/N
    cornering_front: np.ndarray  # N/rad, axle's two tyres at the static wheel loads
    cornering_rear: np.ndarray  # N/rad
    #: per-row coefficients (n, 22) of the compiled handling loops
    #: (:mod:`suspenv.models.minibus.handling_kernel`), read-only: roll gradient (rad
    #: per m/s^2), axle roll stiffnesses (N m/rad), the lateral-acceleration moments of
    #: the roll centres and unsprung masses (kg m), tracks (m), static wheel loads (N),
    #: mass (kg), CoM distances and wheelbase (m), as :func:`wheel_loads` forms them at
    #: zero roll rate, the roll (rad/rad) and force (rad/N) steers front and rear, then
    #: yaw and roll inertias (kg m^2), ``ms h'`` (kg m), ``ms h' g - Kphi`` (N m/rad)
    #: and the roll damping (N m s/rad, :func:`roll_damping`); :func:`handling_parameters`
    #: forms them
    rows: np.ndarray
    vehicle: Minibus = REFERENCE_MINIBUS
    tyre: LateralTyre = LIGHT_TRUCK_TYRE

    @property
    def n(self) -> int:
        return len(self.rows)

    @property
    def wheelbase(self) -> np.ndarray:
        return self.a + self.b

    @property
    def kphi(self) -> np.ndarray:
        return self.kphi_front + self.kphi_rear

    def roll_gradient(self) -> np.ndarray:
        """Steady-state body roll per lateral acceleration, rad/(m/s^2) (closed form:
        ``ms h' / (Kphi - ms h' g)``, :attr:`rows`' first column)."""
        return np.ascontiguousarray(self.rows[:, 0])

    def axle_cornering_stiffness(self) -> tuple[np.ndarray, np.ndarray]:
        """Front and rear axle cornering stiffness at static load, N/rad (two tyres each)."""
        return self.cornering_front, self.cornering_rear

    def understeer_gradient(self) -> np.ndarray:
        """Linear-range understeer gradient K, rad/(m/s^2): delta = L/R + K a_y (closed form).

        K = m/L (b/Cf - a/Cr) + (eps_r - eps_f) dphi/da_y + (c_F a - c_Ff b) m / L: the
        bicycle model's term plus the roll steer and lateral-force steer of the axles.
        """
        cf, cr = self.axle_cornering_stiffness()
        L, roll_gradient = self.rows[:, 12], self.rows[:, 0]
        m_L = self.m / L
        k = m_L * (self.b / cf - self.a / cr)
        k = k + (self.roll_steer_rear - self.roll_steer_front) * roll_gradient
        return k + (self.force_steer_rear * self.a - self.force_steer_front * self.b) * m_L


def roll_centre_heights(vehicle: Minibus = REFERENCE_MINIBUS) -> tuple[float, float]:
    """Front and rear roll-centre heights above ground, m.

    Front (independent): the line from the contact patch through the swing-arm instant
    centre crosses the centre line at ``h_ic (t/2) / d_ic``. Rear (leaf axle): the stated
    leaf-seat height.
    """
    front = vehicle.front_ic_height * (vehicle.track_front / 2.0) / vehicle.front_ic_inboard
    return float(front), float(vehicle.rear_roll_centre_height)


def handling_parameters(
    X: np.ndarray,
    load_case: str | LoadCase | Sequence[str | LoadCase] = "no_load",
    vehicle: Minibus = REFERENCE_MINIBUS,
    tyre: LateralTyre = LIGHT_TRUCK_TYRE,
    leaf: LeafAxleGeometry = DEFAULT_LEAF_GEOMETRY,
    params: Sequence[VehicleParams] | None = None,
) -> HandlingParams:
    """Handling parameters for designs X (n, 8; the study's units) in one load case, or
    in each of a sequence of them (rows stacked in its order: k n rows); ``params``:
    :func:`stacked_vehicle_parameters` of X in those load cases, if already at hand."""
    cases = [load_case] if isinstance(load_case, str | LoadCase) else list(load_case)
    vps = stacked_vehicle_parameters(X, cases, vehicle) if params is None else params
    d = vps[0].design
    # the design-independent parameters of each load case, on their rows
    table, constant_rows = _case_table(vps, leaf, tyre)
    case = table.repeat(d.n, axis=1)
    msh, msh_g = case[23], case[24]
    # the per-design values, on the rows of every load case
    rates = np.array(
        [d.front_wheel_rate, d.front_roll_arb, d.rear_roll_arb, d.leaf_bush_radial,
         d.front_damper_scale, d.rear_damper_scale]
    )  # fmt: skip
    wheel_rate, arb_f, arb_r, k3, c_front, c_rear = np.concatenate(len(cases) * [rates], axis=1)
    rear_rate = np.concatenate([vp.rear_static_rate for vp in vps])
    kphi_f, kphi_r = _roll_stiffness(vehicle, wheel_rate, rear_rate, arb_f, arb_r)
    eps_r, c_force = _rear_axle_steer(vehicle, leaf, rear_rate, k3)
    kphi = kphi_f + kphi_r
    # (n, 22): the load cases' rows of constant columns, then the design's columns
    rows = constant_rows.repeat(d.n, axis=0)
    rows[:, 0], rows[:, 1], rows[:, 2] = msh / (kphi - msh_g), kphi_f, kphi_r
    rows[:, 15], rows[:, 16], rows[:, 20] = eps_r, c_force, msh_g - kphi
    rows[:, 21] = roll_damping(vehicle, c_front, c_rear)
    rows.flags.writeable = False
    return HandlingParams(
        **dict(zip(_CASE_FIELDS, case[: len(_CASE_FIELDS)], strict=True)),
        kphi_front=kphi_f,
        kphi_rear=kphi_r,
        damper_scale_front=c_front,
        damper_scale_rear=c_rear,
        roll_steer_rear=eps_r,
        force_steer_rear=c_force,
        cornering_front=case[25],
        cornering_rear=case[26],
        rows=rows,
        vehicle=vehicle,
        tyre=tyre,
    )


def _roll_stiffness(
    vehicle: Minibus,
    wheel_rate: np.ndarray,
    rear_rate: np.ndarray,
    arb_front: np.ndarray,
    arb_rear: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Effective roll stiffness of the front and rear axle (N m/rad): springs (front
    wheel rates, rear leaf rates at rest; N/m each) plus stabiliser (N m/rad), in series
    with the axle's two tyres."""
    kt_f = spring_pair_roll_stiffness(vehicle.tyre_vertical_stiffness, vehicle.track_front)
    kt_r = spring_pair_roll_stiffness(vehicle.tyre_vertical_stiffness, vehicle.track_rear)
    ks_f = spring_pair_roll_stiffness(wheel_rate, vehicle.track_front) + arb_front
    ks_r = spring_pair_roll_stiffness(rear_rate, vehicle.leaf_spacing) + arb_rear
    return ks_f * kt_f / (ks_f + kt_f), ks_r * kt_r / (ks_r + kt_r)


def _rear_axle_steer(
    vehicle: Minibus, leaf: LeafAxleGeometry, rear_rate: np.ndarray, k3: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The leaf axle's roll steer (rad/rad: geometric plus the bushes' ``eps_bush``)
    and lateral-force steer ``c_F`` (rad/N) of the module docstring, from the leaf rates
    at rest (N/m) and the bushes' radial stiffness K3 (N/m)."""
    Ls = vehicle.leaf_length
    l1 = leaf.axle_from_front_eye
    l2 = Ls - l1
    # the geometry's factors as plain floats: one array operation each for a design
    # alone (eps_bush = K_rate (l1/Ls) tan(shackle) / K3, c_F = (l2 - l1/r) / (2 Ls^2 K3))
    bush = l1 / Ls * math.tan(math.radians(leaf.shackle_angle_deg))
    force = (l2 - l1 / leaf.shackle_lateral_ratio) / (2.0 * Ls**2)
    return vehicle.rear_roll_steer + rear_rate * bush / k3, force / k3


#: :func:`_case_table`'s cache
_CASE_TABLES: IdentityCache[tuple[np.ndarray, np.ndarray]] = IdentityCache()
#: the columns of :attr:`HandlingParams.rows` that no design variable changes, and the
#: rows of :func:`_case_terms` they take
_CONSTANT_COLUMNS = [3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 17, 18, 19]
_CONSTANT_TERMS = [20, 21, 16, 17, 9, 10, 0, 2, 3, 22, 18, 19, 4, 5, 23]
#: the :class:`HandlingParams` fields of the first rows of :func:`_case_table`
_CASE_FIELDS = (
    "m", "ms", "a", "b", "iz", "ixs", "h_prime", "ms_front", "ms_rear", "fz_front", "fz_rear",
    "h_rc_front", "h_rc_rear", "mu_front", "mu_rear", "wheel_radius", "track_front",
    "track_rear", "roll_steer_front", "force_steer_front",
)  # fmt: skip


def _case_table(
    vps: Sequence[VehicleParams], leaf: LeafAxleGeometry, tyre: LateralTyre
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_case_terms` of each load case of ``vps``, then the axles' cornering
    stiffness at its static wheel loads (N/rad, front and rear, two tyres each), as the
    columns of a (27, k) array, and each load case's row of :attr:`HandlingParams.rows`
    with its constant columns set (the others 0), (k, 22); read-only, kept per vehicle,
    load case, leaf geometry and tyre (frozen) and CoM distances ``a``, ``b``: what the
    terms depend on. An evaluation repeats the same load cases, so it pays the lookup
    only."""
    held = [leaf, tyre] + [o for vp in vps for o in (vp.vehicle, vp.load)]
    values = tuple([x for vp in vps for x in (vp.a, vp.b)])
    return _CASE_TABLES.get(held, values, lambda: _new_case_table(vps, leaf, tyre))


def _new_case_table(
    vps: Sequence[VehicleParams], leaf: LeafAxleGeometry, tyre: LateralTyre
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_case_table`, built (read-only)."""
    terms = np.array([_case_terms(vp, leaf) for vp in vps]).T
    # the static wheel loads: terms 9, 10 (fz_front, fz_rear)
    table = np.vstack([terms, 2.0 * tyre.cornering_stiffness(terms[9:11])])
    rows = np.zeros((len(vps), 22))
    rows[:, _CONSTANT_COLUMNS] = table[_CONSTANT_TERMS].T
    for a in (table, rows):
        a.flags.writeable = False
    return table, rows


def _case_terms(vp: VehicleParams, leaf: LeafAxleGeometry) -> list[float]:
    """The handling parameters of load case ``vp`` that no design variable changes, in
    the order of :data:`_CASE_FIELDS` (the fields they fill): total mass (kg), sprung mass,
    total CoM to the axles (m), yaw and sprung roll inertias (kg m^2), sprung CoM above
    the roll axis (m), the axles' sprung mass shares (kg), static wheel loads (N),
    roll-centre heights (m), unsprung masses (kg), wheel radius and tracks (m), front
    roll (rad/rad) and force steer (rad/N), then for :attr:`HandlingParams.rows` the
    roll centres' and unsprung masses' moments per lateral acceleration (kg m), the
    wheelbase (m), ``ms h'`` (kg m) and ``ms h' g`` (N m). Plain floats: one design at
    a time pays no array calls for them."""
    v = vp.vehicle
    L = v.wheelbase
    ms, va, vb = vp.load.sprung_mass, vp.a, vp.b
    muf, mur = 2.0 * v.unsprung_front, 2.0 * v.unsprung_rear
    m = ms + muf + mur
    a = (ms * va + mur * L) / m  # total CoM behind the front axle
    b = L - a
    iz = vp.load.yaw_inertia + ms * ((va - a) * (va - a)) + muf * (a * a) + mur * (b * b)
    h_rf, h_rr = roll_centre_heights(v)
    h_axis = h_rf + (h_rr - h_rf) * va / L  # roll-axis height under the sprung CoM
    h_prime = vp.load.cg_z - h_axis
    if h_prime <= 0:
        raise ValidationError(
            f"the sprung CoM must lie above the roll axis, but got (cg_z={vp.load.cg_z}, "
            f"roll-axis height={h_axis:.3f})"
        )
    if not 0.0 < leaf.axle_from_front_eye < v.leaf_length:
        raise ValidationError(
            f"`0 < axle_from_front_eye < leaf_length` must hold, but got "
            f"(axle_from_front_eye={leaf.axle_from_front_eye}, leaf_length={v.leaf_length})"
        )
    ixs = vp.load.roll_inertia + ms * (h_prime * h_prime)
    w_front = (ms * G * vb / L) / 2.0 + v.unsprung_front * G
    w_rear = (ms * G * va / L) / 2.0 + v.unsprung_rear * G
    ms_front, ms_rear, radius = ms * vb / L, ms * va / L, v.tyre_loaded_radius
    msh = ms * h_prime
    return [
        m, ms, a, b, iz, ixs, h_prime, ms_front, ms_rear, w_front, w_rear,
        h_rf, h_rr, muf, mur, radius, v.track_front, v.track_rear,
        leaf.front_roll_steer, -leaf.steering_trail / leaf.steering_stiffness,
        ms_front * h_rf + muf * radius, ms_rear * h_rr + mur * radius, a + b, msh, msh * G,
    ]  # fmt: skip


# ------------------------------------------------------------------ equations of motion
@dataclass
class HandlingState:
    """Dynamic state of a batch, arrays of shape (n,). Positions in the ground frame."""

    x: np.ndarray  # m, ground-frame position of the CoM
    y: np.ndarray  # m
    psi: np.ndarray  # rad, heading
    v: np.ndarray  # m/s, lateral velocity in vehicle axes
    r: np.ndarray  # rad/s, yaw rate
    phi: np.ndarray  # rad, body roll
    p: np.ndarray  # rad/s, roll rate
    delta: np.ndarray  # rad, front road-wheel steer (after the steering lag)
    ay: np.ndarray  # m/s^2, lateral acceleration of the last step (load transfer input)
    fy_front: np.ndarray  # N, front axle force of the last step (compliance steer input)
    fy_rear: np.ndarray  # N, rear axle force of the last step (compliance steer input)

    @classmethod
    def zeros(cls, n: int) -> HandlingState:
        return cls(*(np.zeros(n) for _ in range(11)))


@dataclass
class HandlingRates:
    """Derivatives and outputs of one evaluation of the equations of motion."""

    v_dot: np.ndarray
    r_dot: np.ndarray
    p_dot: np.ndarray
    ay: np.ndarray  # m/s^2, v' + u r (lateral acceleration at the CoM)
    fy_front: np.ndarray
    fy_rear: np.ndarray
    fz: np.ndarray  # (4, n) wheel loads FL, FR, RL, RR


def wheel_loads(
    P: HandlingParams, phi: np.ndarray, p: np.ndarray | None, ay: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Wheel loads (FL, FR, RL, RR, N, >= 0) and damper roll moments (front, rear), N*m.

    Load moves to the right wheels for positive roll / positive a_y (a left turn).
    ``p=None``: zero roll rate (a steady state), no damper moments.
    """
    v = P.vehicle
    sf, sr = v.front_damper_spacing, v.rear_damper_spacing
    if p is None:
        md_f = md_r = np.zeros(())
    else:
        # roll-induced compression rate: right side +p s/2, left side -p s/2
        vf = 0.5 * sf * p
        vr = 0.5 * sr * p
        ff = damper_force(np.stack([vf, -vf]), v.damper_front, P.damper_scale_front)
        fr_ = damper_force(np.stack([vr, -vr]), v.damper_rear, P.damper_scale_rear)
        md_f = 0.5 * sf * (ff[0] - ff[1])
        md_r = 0.5 * sr * (fr_[0] - fr_[1])
    dfz_f = (
        P.kphi_front * phi + md_f + (P.ms_front * P.h_rc_front + P.mu_front * P.wheel_radius) * ay
    ) / P.track_front
    dfz_r = (
        P.kphi_rear * phi + md_r + (P.ms_rear * P.h_rc_rear + P.mu_rear * P.wheel_radius) * ay
    ) / P.track_rear
    fl, fr, rl, rr = axle_transfer(dfz_f, dfz_r, P.fz_front, P.fz_rear, P.track_front, P.track_rear)
    return fl, fr, rl, rr, md_f, md_r


def rates(P: HandlingParams, s: HandlingState, u: np.ndarray | float) -> HandlingRates:
    """Evaluate the equations of motion at state ``s`` and forward speed ``u`` (m/s).

    The load transfer uses the lateral acceleration and the compliance steers the
    axle forces stored in the state (their values one step earlier), which breaks the
    algebraic loops; the step is short against these loops' dynamics.
    """
    fl, fr, rl, rr, md_f, md_r = wheel_loads(P, s.phi, s.p, s.ay)
    tyre = P.tyre
    delta_f = s.delta + P.roll_steer_front * s.phi + P.force_steer_front * s.fy_front
    alpha_f = delta_f - (s.v + P.a * s.r) / u
    delta_r = P.roll_steer_rear * s.phi + P.force_steer_rear * s.fy_rear
    alpha_r = delta_r - (s.v - P.b * s.r) / u
    fz = np.stack([fl, fr, rl, rr])
    fy = tyre.lateral_force(np.stack([alpha_f, alpha_f, alpha_r, alpha_r]), fz)
    fyf = fy[0] + fy[1]
    fyr = fy[2] + fy[3]
    msh = P.ms * P.h_prime
    r1 = fyf + fyr - P.m * u * s.r
    r2 = msh * u * s.r + (msh * G - P.kphi) * s.phi - (md_f + md_r)
    det = P.m * P.ixs - msh**2
    v_dot = (P.ixs * r1 + msh * r2) / det
    p_dot = (msh * r1 + P.m * r2) / det
    r_dot = (P.a * fyf - P.b * fyr) / P.iz
    return HandlingRates(
        v_dot=v_dot,
        r_dot=r_dot,
        p_dot=p_dot,
        ay=v_dot + u * s.r,
        fy_front=fyf,
        fy_rear=fyr,
        fz=fz,
    )


def step(
    P: HandlingParams,
    s: HandlingState,
    u: np.ndarray | float,
    delta_command: np.ndarray,
    dt: float,
    steer_lag: float,
) -> HandlingRates:
    """Advance ``s`` in place by ``dt`` (semi-implicit Euler); returns the rates used.

    Velocities are updated first and the new velocities move the positions and angles
    (symplectic Euler, stable for the roll mode at the step sizes used by the rigs).
    The front steer follows the command through a first-order lag ``steer_lag`` (s),
    integrated exactly over the step.
    """
    k = rates(P, s, u)
    s.v = s.v + dt * k.v_dot
    s.r = s.r + dt * k.r_dot
    s.p = s.p + dt * k.p_dot
    s.phi = s.phi + dt * s.p
    cos_psi, sin_psi = np.cos(s.psi), np.sin(s.psi)
    s.x = s.x + dt * (u * cos_psi - s.v * sin_psi)
    s.y = s.y + dt * (u * sin_psi + s.v * cos_psi)
    s.psi = s.psi + dt * s.r
    blend = 1.0 - np.exp(-dt / steer_lag) if steer_lag > 0 else 1.0
    s.delta = s.delta + blend * (delta_command - s.delta)
    s.ay = k.ay
    s.fy_front = k.fy_front
    s.fy_rear = k.fy_rear
    return k


# ------------------------------------------------------------------ linear range
def roll_damping(vehicle: Minibus, scale_front: np.ndarray, scale_rear: np.ndarray) -> np.ndarray:
    """Roll damping (N*m*s/rad, (n,)) of the dampers' low-speed slopes (linear range),
    the damper curves scaled by ``scale_front``/``scale_rear`` (the designs' C1, C2).

    A roll rate p compresses one side at ``p s/2`` and extends the other, so an axle's
    damper roll moment is ``(s^2/4) (c_bump + c_rebound) C p`` (s the damper spacing, C
    the design's curve scale), the small-rate slope of :func:`wheel_loads`' damper moments;
    ``(c_bump + c_rebound) / 2`` is :func:`damper_mean_coefficient`.
    """
    v = vehicle
    front = 0.5 * v.front_damper_spacing**2 * damper_mean_coefficient(v.damper_front)
    rear = 0.5 * v.rear_damper_spacing**2 * damper_mean_coefficient(v.damper_rear)
    return front * scale_front + rear * scale_rear


def linear_system(
    P: HandlingParams,
    u: float | np.ndarray,
    axle_stiffness: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """State matrix A (n, 4, 4) and steer input B (n, 4) of the linearised handling model.

    State (v, r, phi, p), input the front road-wheel steer delta (rad), speed ``u``
    (m/s). The equations of :func:`rates` about straight running: tyres at their static
    loads' cornering stiffness (a symmetric load transfer changes no axle force to first
    order), the compliance steers solved into effective axle stiffnesses
    ``C' = C / (1 - C c_F)``, the dampers at their low-speed slopes
    (:func:`roll_damping`). Exact for this model in the limit of small amplitudes.

    ``axle_stiffness``: the axles' tyre cornering stiffnesses (front, rear; N/rad, (n,)
    each) to use instead, e.g. the quasi-steady secants at a manoeuvre's lateral
    acceleration (:func:`suspenv.rigs.handling.secant_axle_stiffness`), which carry the
    load transfer's effect on the axles. ``u`` and the stiffnesses may carry leading
    axes (several speeds and working points at once, e.g. u (k, 1) and stiffnesses
    (k, n)); A and B then carry them too.
    """
    cf, cr = axle_stiffness if axle_stiffness is not None else P.axle_cornering_stiffness()
    shape = np.broadcast(u, cf, cr).shape
    ucc = np.empty((3, *shape))  # u, cf, cr broadcast, each C-contiguous (k, n)
    ucc[0], ucc[1], ucc[2] = u, cf, cr
    u, cf, cr = ucc.reshape(3, -1, P.n)
    A, B = np.zeros((u.shape[0], P.n, 4, 4)), np.zeros((u.shape[0], P.n, 4))
    handling_kernel.linear_loop(P.rows, u, cf, cr, A, B)
    return A.reshape(*shape, 4, 4), B.reshape(*shape, 4)


@dataclass
class SteerResponse:
    """Linear frequency response per rad of front road-wheel steer, complex (n, Nf).

    Attributes: ay (m/s^2 per rad; v' + u r), yaw_rate (1/s), roll (rad/rad),
    sideslip (v/u, rad/rad); f: Hz (Nf,).
    """

    f: np.ndarray
    ay: np.ndarray
    yaw_rate: np.ndarray
    roll: np.ndarray
    sideslip: np.ndarray


def steer_response(
    P: HandlingParams,
    u: float,
    f: np.ndarray | float,
    system: tuple[np.ndarray, np.ndarray] | None = None,
) -> SteerResponse:
    """Frequency response of the linearised model (:func:`linear_system`) to front steer.

    ``H(f) = (i 2 pi f I - A)^-1 B`` at the frequencies ``f`` (Hz, >= 0; 0 gives the
    steady state), batched over the rows of ``P`` (the compiled
    :func:`suspenv.models.minibus.handling_kernel.response_loop`); ``system``: (A, B)
    of :func:`linear_system` if already at hand.
    """
    f = np.atleast_1d(np.asarray(f, dtype=float))
    A, B = system if system is not None else linear_system(P, u)
    s = 2j * np.pi * f
    X = np.empty((P.n, f.size, 4), dtype=complex)
    handling_kernel.response_loop(np.ascontiguousarray(A), np.ascontiguousarray(B), s, X)
    v, r, phi = X[..., 0], X[..., 1], X[..., 2]
    return SteerResponse(f=f, ay=s[None, :] * v + u * r, yaw_rate=r, roll=phi, sideslip=v / u)
