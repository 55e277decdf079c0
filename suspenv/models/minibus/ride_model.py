"""Full-vehicle ride model of the minibus, integrated for a whole batch of designs at once.

Frame and units: ISO 8855 (x forward, y left, z up), SI units (m, kg, N, s, rad).
Motions are small deviations from the static equilibrium of the load case.

Degrees of freedom (7, plus 2 with the seat-mount effect)::

    q = [z_f, z_r, phi, z_FL, z_FR, z_RL, z_RR, (z_seat_f, z_seat_r)]

- ``z_f``, ``z_r``: body vertical displacement above the front and rear axle on the
  centreline (m, + up). Heave and pitch follow: z_cg = (b z_f + a z_r)/L and pitch
  theta = (z_f - z_r)/L (+ nose down). Coordinates at the axles make the geometry
  matrices independent of the load case, so both load cases share one batch; the
  body mass matrix couples z_f and z_r (2x2 per design).
- ``phi``: body roll (rad, + = left side up, ISO 8855 right-hand rule about +x).
- ``z_FL .. z_RR``: wheel-centre vertical displacements (m). The rear rigid axle is two
  wheel-end masses joined by a rigid beam, so its heave and tramp (roll) are the mean
  and difference of z_RL, z_RR; the axle roll inertia is m_ur t_r^2 / 2.

Elements (all forces positive when they resist compression):
front torsion-bar springs and dampers at the front wheels (wheel rates); rear two-stage
leaves at the leaf seats (spacing ``leaf_spacing``) and rear dampers at
``rear_damper_spacing``; stabilisers as axle roll stiffness (moment per body-minus-axle
roll); point-contact tyres (spring + small damper) that can lift off.

Integration: classic fixed-step RK4; the whole batch is one state array (n_states, n)
with the batch on the last, contiguous axis (long inner loops for every operation).
Road inputs are sampled on the half-step grid. Body accelerations are recorded at each
step start (the RK4 first stage), so no extra right-hand-side evaluation is needed.
float64 models run the same scheme compiled, design by design (:mod:`.ride_kernel`,
effect parameters checked once at construction; :data:`COMPILED`); float32 models and
platforms without numba run the numpy loop.

Effects (off by default), element laws from :mod:`suspenv.models.effects`:
``dahl_hysteresis`` at location ``"rear_leaf"`` (interleaf friction, one Dahl state
per leaf); ``coulomb_friction`` at ``"front_damper"`` / ``"rear_damper"``;
``bump_stop`` / ``rebound_stop`` at ``"front_suspension"`` / ``"rear_suspension"``
(gaps measured from the static ride position). Model options: a seat (or cab) mount
:class:`SeatMount` above the measuring points, and tyre enveloping (the road is
averaged over the contact length, see :mod:`suspenv.rigs.ride`).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.core.identity_cache import IdentityCache
from suspenv.models.effects import friction, hysteresis, stiffness
from suspenv.models.effects.effect import Effect
from suspenv.models.minibus import ride_kernel
from suspenv.models.minibus.suspension import damper_mean_coefficient
from suspenv.models.minibus.vehicle import G, VehicleParams

N_BASE_DOF = 7
#: float64 models integrate by the compiled loop (:mod:`.ride_kernel`, design by design)
#: where numba is installed; False: the numpy loop (:meth:`RideModel.rhs`) always
COMPILED = True
#: element columns (position-type then velocity-type)
POS_ELEMENTS = ("s_FL", "s_FR", "s_RL", "s_RR", "arb_F", "arb_R", "t_FL", "t_FR", "t_RL", "t_RR")
VEL_ELEMENTS = ("d_FL", "d_FR", "d_RL", "d_RR", "tc_FL", "tc_FR", "tc_RL", "tc_RR")
SUPPORTED_EFFECTS = {
    ("dahl_hysteresis", "rear_leaf"),
    ("coulomb_friction", "front_damper"),
    ("coulomb_friction", "rear_damper"),
    ("bump_stop", "front_suspension"),
    ("bump_stop", "rear_suspension"),
    ("rebound_stop", "front_suspension"),
    ("rebound_stop", "rear_suspension"),
}


@dataclass(frozen=True)
class SeatMount:
    """A seat (or cab) as a mass on a spring-damper above each measuring point.

    Defaults [CHOICE]: 90 kg seat + occupant share, 4 Hz, damping ratio 0.25 (a
    typical bus passenger seat's vertical mode).
    """

    mass: float = 90.0  # kg
    frequency: float = 4.0  # Hz
    damping_ratio: float = 0.25  # -

    def __post_init__(self) -> None:
        if not (self.mass > 0 and self.frequency > 0 and self.damping_ratio >= 0):
            raise ValidationError(
                "seat mount needs `mass > 0`, `frequency > 0`, `damping_ratio >= 0`, but got "
                f"(mass={self.mass}, frequency={self.frequency}, "
                f"damping_ratio={self.damping_ratio})"
            )

    @property
    def stiffness(self) -> float:
        return self.mass * (2 * np.pi * self.frequency) ** 2

    @property
    def damping(self) -> float:
        return 2 * self.damping_ratio * np.sqrt(self.stiffness * self.mass)


@dataclass
class RideRecord:
    """Recorded channels of one run; time on axis -1.

    Attributes:
        dt: sample interval (s).
        body_acc: (n, 3, N) accelerations of [z_f, z_r, phi] (m/s^2, rad/s^2).
        acc_front, acc_rear: (n, N) vertical acceleration at the measuring points (m/s^2)
            (on the seat when a seat mount is modelled).
        states: (n, n_states, N) full state history when requested, else None.
        ok: (n,) False where a design's integration diverged (its channels are not finite;
            the other designs are unaffected: batch columns never mix).
    """

    dt: float
    body_acc: np.ndarray
    acc_front: np.ndarray
    acc_rear: np.ndarray
    states: np.ndarray | None = None
    ok: np.ndarray | None = None

    @property
    def t(self) -> np.ndarray:
        return self.dt * np.arange(self.acc_front.shape[-1])


#: the arrays of :meth:`RideModel.rhs` cast to a float32 model's type
_TYPED = (
    "Et",
    "Pt",
    "Vt",
    "Bt",
    "Kt",
    "minv_diag",
    "m12",
    "leaf_dk",
    "leaf_thr",
    "leaf_base",
    "d_bl",
    "d_bh",
    "d_rl",
    "d_rh",
    "knee_b",
    "knee_r",
    "f0_tyre",
)
#: the float types a model integrates in
_DTYPES = (np.dtype(np.float64), np.dtype(np.float32))
#: the rows of :meth:`RideModel._build_coefficients`' stacked design arrays that fill the
#: first six element rates (front wheel rate twice, leaf rate twice, stabilisers):
#: the leaf's primary rate, or in the linear model its rate at rest
_K_ROWS = {False: np.array([0, 0, 1, 1, 3, 4]), True: np.array([0, 0, 7, 7, 3, 4])}
#: :meth:`RideModel._build_geometry`'s cache
_GEOMETRY: IdentityCache[tuple] = IdentityCache()
#: :meth:`RideModel._inverse_blocks`' cache
_INVERSE: IdentityCache[np.ndarray] = IdentityCache()


class RideModel:
    """The full-vehicle ride model for one or more :class:`VehicleParams` batches.

    Several parameter batches (e.g. the two load cases) are stacked into one state
    array, so they are integrated together.

    Args:
        params: one VehicleParams or a sequence of them (rows are stacked in order).
        effects: effect instances (see module docstring for the supported kinds).
        seat: a :class:`SeatMount` above the measuring points, or None.
        linear: use the linearised model (leaf at its static rate, dampers linear with
            the mean low-speed bump/rebound coefficient, no tyre lift-off); effects are
            then rejected.
        measure_y: lateral offset (m, + left) of both measuring points from the
            centreline [CHOICE 0.35 m: the driver's seat rail of a left-hand-drive bus].
    """

    def __init__(
        self,
        params: VehicleParams | Sequence[VehicleParams],
        effects: Sequence[Effect] = (),
        seat: SeatMount | None = None,
        linear: bool = False,
        measure_y: float = 0.35,
        dtype: type = np.float64,
    ) -> None:
        plist = [params] if isinstance(params, VehicleParams) else list(params)
        if not plist:
            raise ValidationError("RideModel needs at least one VehicleParams batch, got 0")
        veh = plist[0].vehicle
        if any(p.vehicle is not veh and p.vehicle != veh for p in plist):
            raise ValidationError("stacked VehicleParams must share one vehicle definition")
        self.params = plist
        self.vehicle = veh
        self.linear = bool(linear)
        self.seat = seat
        self.measure_y = float(measure_y)
        self.dtype = np.dtype(dtype)
        if self.dtype not in _DTYPES:
            raise ValidationError(f"dtype must be float64 or float32, but got {self.dtype}")
        self.effects = tuple(effects)
        if self.linear and self.effects:
            raise ValidationError("the linearised ride model takes no effects, but got some")
        for e in self.effects:
            if (e.kind, e.location) not in SUPPORTED_EFFECTS:
                raise ValidationError(
                    f"ride model effect ({e.kind!r}, location={e.location!r}) is not "
                    f"supported; supported are {sorted(SUPPORTED_EFFECTS)}"
                )
        #: designs per parameter block (rows of each in order)
        self.counts = [p.n for p in plist]
        self.n = sum(self.counts)
        self.nq = N_BASE_DOF + (2 if seat else 0)
        self._build_geometry()
        self._build_coefficients()

    # -------------------------------------------------------------- assembly
    def _build_geometry(self) -> None:
        """The element geometry (:meth:`_geometry`), shared by the models of one vehicle
        object, seat or not and measuring point (read-only)."""
        key = (self.seat is not None, self.measure_y)
        geometry = _GEOMETRY.get([self.vehicle], key, self._geometry)
        self.n_pos, self.n_vel, self.E, self.Et, self.Pt, self.Vt, self.B, self.Bt = geometry[:8]
        # tyre_rates: the element rates the vehicle fixes (the tyres'; 0 in the others)
        self._damper_unit, self.knee_b, self.knee_r, self.tyre_rates = geometry[8:]

    def _geometry(self) -> tuple:
        """``(n_pos, n_vel, E, E^T, P^T, V^T, B, B^T, damper curves, knee_b, knee_r,
        tyre rates)``:
        element deflections of position and velocity type from the state, ``X @ E``,
        generalised forces from the element forces, ``Q = -F @ B`` (see :meth:`rhs`),
        the dampers' (FL, FR, RL, RR) slopes at scale 1 (N s/m; bump low, bump high,
        rebound low, rebound high rows) and their mean low-speed coefficient in every row
        (the linear model's slopes), their bump and (negative) rebound knees (m/s, (4, 1)),
        and the element rates of the tyres (N/m, N s/m; 0 in the other columns)."""
        v = self.vehicle
        tf, tr, s, sd = v.track_front, v.track_rear, v.leaf_spacing, v.rear_damper_spacing
        nq = self.nq
        pos = np.zeros((nq, len(POS_ELEMENTS) + (2 if self.seat else 0)))
        vel = np.zeros((nq, len(VEL_ELEMENTS) + (2 if self.seat else 0)))

        def rear_axle_at(y: float, track: float) -> np.ndarray:
            row = np.zeros(nq)
            row[5] = 0.5 + y / track
            row[6] = 0.5 - y / track
            return row

        def body_at(axle: int, y: float) -> np.ndarray:
            row = np.zeros(nq)
            row[axle] = 1.0
            row[2] = y
            return row

        # suspension compression = wheel/axle point - body point (+ = bump)
        for j, (axle, y, wheel) in enumerate(((0, tf / 2, 3), (0, -tf / 2, 4))):
            r = -body_at(axle, y)
            r[wheel] += 1.0
            pos[:, j] = r
            vel[:, j] = r
        for j, y in ((2, s / 2), (3, -s / 2)):
            pos[:, j] = rear_axle_at(y, tr) - body_at(1, y)
        for j, y in ((2, sd / 2), (3, -sd / 2)):
            vel[:, j] = rear_axle_at(y, tr) - body_at(1, y)
        # stabilisers: body roll minus axle roll
        pos[2, 4], pos[3, 4], pos[4, 4] = 1.0, -1.0 / tf, 1.0 / tf
        pos[2, 5], pos[5, 5], pos[6, 5] = 1.0, -1.0 / tr, 1.0 / tr
        # tyres: compression = road - wheel (road added at run time)
        for j in range(4):
            pos[3 + j, 6 + j] = -1.0
            vel[3 + j, 4 + j] = -1.0
        if self.seat:
            # seat mount compression = body point - seat (+ when the body rises)
            y = self.measure_y
            for j, axle in enumerate((0, 1)):
                r = body_at(axle, y)
                r[7 + j] -= 1.0
                pos[:, 10 + j] = r
                vel[:, 8 + j] = r
        n_pos, n_vel = pos.shape[1], vel.shape[1]
        # deflections of all elements from the state [q, qd]: X @ E
        E = np.zeros((2 * nq, n_pos + n_vel))
        E[:nq, :n_pos] = pos
        E[nq:, n_pos:] = vel
        # generalised forces from element forces: Q = -F @ B
        B = -np.vstack([pos.T, vel.T])
        curves = (v.damper_front,) * 2 + (v.damper_rear,) * 2
        slopes = [[c.bump_low, c.bump_high, c.rebound_low, c.rebound_high] for c in curves]
        mean = [damper_mean_coefficient(c) for c in curves]
        knees = np.array([[c.bump_knee, -c.rebound_knee] for c in curves]).T[:, :, None]
        out = tuple(np.ascontiguousarray(a) for a in (E, E.T, pos.T, vel.T, B, B.T, *knees))
        damper = (np.array(slopes).T, np.array([mean] * 4))
        # the element rates the vehicle fixes: the tyres' (the rest 0, set per design)
        tyres = np.zeros(n_pos + n_vel)
        tyres[6:10] = v.tyre_vertical_stiffness
        tyres[n_pos + 4 : n_pos + 8] = v.tyre_vertical_damping
        for a in (*out, *damper, tyres):
            a.flags.writeable = False
        return (n_pos, n_vel, *out[:6], damper, *out[6:], tyres)

    def _build_coefficients(self) -> None:
        v, ps, nq = self.vehicle, self.params, self.nq
        counts = self.counts
        # the per-design arrays of every block, stacked: front wheel rate, leaf primary
        # and composite rates, stabilisers, damper scales (C1, C2), leaf rate and
        # deflection at rest
        per = [
            [(d := p.design).front_wheel_rate, d.rear_primary_rate, d.rear_composite_rate,
             d.front_roll_arb, d.rear_roll_arb, d.front_damper_scale, d.rear_damper_scale,
             p.rear_static_rate, p.rear_static_deflection]
            for p in ps
        ]  # fmt: skip
        stacked = np.concatenate(per, axis=1)
        self.inverse_blocks = self._inverse_blocks()
        inverse = self.inverse_blocks.T.repeat(counts, axis=1)  # (nq + 1, n), C order
        # position-type stiffnesses (N/m, N*m/rad), then velocity-type (N s/m): the
        # vehicle's tyre columns, the seat's, then the design's
        K = np.empty((self.n, self.n_pos + self.n_vel))
        K[:] = self.tyre_rates
        if self.seat:
            K[:, 10:12] = self.seat.stiffness
            K[:, self.n_pos + 8 : self.n_pos + 10] = self.seat.damping
        K[:, :6] = stacked[_K_ROWS[self.linear]].T
        # damper curves scaled per design: (4 slopes, 4 dampers, n); the linear model's
        # slopes all the mean low-speed coefficient
        scale = stacked[5:7].repeat(2, axis=0)  # (4, n): C1 front twice, C2 rear twice
        curves, mean = self._damper_unit
        slopes = (mean if self.linear else curves)[:, :, None] * scale
        # the linearised model's rates, kept for either model (float64, batch first):
        # rear leaf rate at rest (N/m, left, right) and mean low-speed damper
        # coefficient (N s/m, FL, FR, RL, RR)
        self.leaf_static_rate = stacked[7][:, None].repeat(2, axis=1)
        self.damper_mean = np.multiply(scale.T, mean[0], order="C")
        # batch along the last axis (see rhs)
        self.K = K
        self.minv_diag, self.m12 = inverse[:nq], inverse[nq]
        # leaf knee relative to the static position: composite - primary rate (N/m) and
        # the helper's engagement from the static deflection (m), (1, n)
        self.leaf_dk = stacked[2:3] - stacked[1:2]
        self.leaf_thr = v.helper_engagement - stacked[8:9]
        #: damper slopes (N s/m; curve, damper FL FR RL RR, design), float64; d_* views
        self.damper_slopes = slopes
        self.d_bl, self.d_bh, self.d_rl, self.d_rh = slopes
        # float32 models: the integration's arrays in their type (float64: so already),
        # each formed in float64 first
        if self.dtype != np.float64:
            values = [np.ascontiguousarray(getattr(self, k), dtype=self.dtype) for k in _TYPED]
            for name, value in zip(_TYPED, values, strict=True):
                setattr(self, name, value)
        # effects
        self._hyst = None
        self._damper_friction: list[tuple[slice, Effect]] = []
        self._stops: list[tuple[slice, Effect]] = []
        for e in self.effects:
            cols = slice(0, 2) if e.location.startswith("front") else slice(2, 4)
            if e.kind == "dahl_hysteresis":
                self._hyst = e
            elif e.kind == "coulomb_friction":
                self._damper_friction.append((cols, e))
            else:
                self._stops.append((cols, e))
        self.n_hyst = 2 if self._hyst is not None else 0
        self.n_states = 2 * self.nq + self.n_hyst
        self._compiled = COMPILED and ride_kernel.AVAILABLE and self.dtype == np.float64
        # effect parameters checked once here (packed for the compiled loop; without
        # effects there is nothing to check and the empty pack waits for a simulation)
        self._effect_pack = ride_kernel.pack_effects(self.effects, self.n) if self.effects else None

    def _inverse_blocks(self) -> np.ndarray:
        """Per parameter block (k, nq + 1): the inverse mass matrix of q's diagonal, then
        its (z_f, z_r) coupling (1/kg, 1/(kg m^2)); the body's in (z_f, z_r) from the KE
        of heave (b zf + a zr)/L and pitch (zf - zr)/L. No design variable changes them:
        read-only, kept per vehicle, seat, load case and CoM distances."""
        held = [self.vehicle, self.seat, *[p.load for p in self.params]]
        values = tuple([x for p in self.params for x in (p.a, p.b)])
        return _INVERSE.get(held, values, self._new_inverse_blocks)

    def _new_inverse_blocks(self) -> np.ndarray:
        """:meth:`_inverse_blocks`, built (read-only)."""
        v, ps, L = self.vehicle, self.params, self.vehicle.wheelbase
        seat = 2 * (1.0 / self.seat.mass,) if self.seat else ()
        wheels = (*(2 * (1.0 / v.unsprung_front,)), *(2 * (1.0 / v.unsprung_rear,)), *seat)
        terms = []
        for p in ps:
            m, I_pitch, I_roll = p.load.sprung_mass, p.load.pitch_inertia, p.load.roll_inertia
            M11 = (m * p.b**2 + I_pitch) / L**2
            M22 = (m * p.a**2 + I_pitch) / L**2
            M12 = (m * p.a * p.b - I_pitch) / L**2
            det = M11 * M22 - M12**2
            terms.append((M22 / det, M11 / det, 1.0 / I_roll, *wheels, -M12 / det))
        inverse = np.array(terms)
        inverse.flags.writeable = False
        return inverse

    # the arrays only a simulation reads (:meth:`rhs`, :attr:`_packed`), formed at its
    # first use: the spectral methods never need them
    @functools.cached_property
    def Kt(self) -> np.ndarray:
        """Element rates (n_elements, n), batch along the last axis (see :meth:`rhs`)."""
        return np.ascontiguousarray(self.K.T)

    @functools.cached_property
    def leaf_base(self) -> np.ndarray:
        """(1, n) composite-rate force of the leaf at rest (N; 0 below the helper knee)."""
        return self.leaf_dk * np.maximum(-self.leaf_thr, 0.0)

    @functools.cached_property
    def f0_tyre(self) -> np.ndarray:
        """(4, n) static tyre loads FL, FR, RL, RR (N): sprung share plus the unsprung
        weight."""
        v = self.vehicle
        loads = [
            (p.front_static_load + v.unsprung_front * G, p.rear_static_load + v.unsprung_rear * G)
            for p in self.params
        ]
        front, rear = np.array(loads).T.repeat(self.counts, axis=1)
        f0 = np.empty((4, self.n))
        f0[0:2], f0[2:4] = front, rear
        return f0

    @functools.cached_property
    def _packed(self) -> tuple | None:
        """The coefficients and effects as the compiled loop takes them (float64), at
        the first simulation (the spectral methods never need them); None: the numpy
        loop runs."""
        if not self._compiled:
            return None
        n = self.n
        pv = np.ascontiguousarray(np.vstack([self.Pt, self.Vt]), dtype=float)
        minv = np.ascontiguousarray(self.minv_diag.T, dtype=float)
        leaf = np.stack(
            [np.broadcast_to(a[0], (n,)) for a in (self.leaf_dk, self.leaf_thr, self.leaf_base)], 1
        )
        damp = np.ascontiguousarray(self.damper_slopes.transpose(2, 0, 1))
        knees = np.ascontiguousarray(np.vstack([self.knee_b[:, 0], self.knee_r[:, 0]]), dtype=float)
        f0 = np.ascontiguousarray(self.f0_tyre.T, dtype=float)
        coeffs = (pv, self.Bt, np.ascontiguousarray(self.K, dtype=float), minv, self.m12)
        shapes = (np.ascontiguousarray(leaf, dtype=float), damp, knees, f0, self.linear)
        pack = self._effect_pack or ride_kernel.pack_effects((), n)
        return (*coeffs, *shapes, *pack)

    # -------------------------------------------------------------- dynamics
    def road_vector(self, z: np.ndarray, zd: np.ndarray) -> np.ndarray:
        """Element offsets (M, n_elements) from wheel road inputs z, zd (M, 4)."""
        R = np.zeros((z.shape[0], self.n_pos + self.n_vel))
        R[:, 6:10] = z
        R[:, self.n_pos + 4 : self.n_pos + 8] = zd
        return R

    def rhs(self, X: np.ndarray, r: np.ndarray, out: np.ndarray) -> np.ndarray:
        """State derivative of X (n_states, n) with element road offsets r; written to out.

        The batch runs along the last (contiguous) axis so every elementwise operation
        has a long inner loop.
        """
        nq, npos = self.nq, self.n_pos
        e = np.empty((self.n_pos + self.n_vel, X.shape[1]), dtype=X.dtype)
        np.matmul(self.Pt, X[:nq], out=e[:npos])
        np.matmul(self.Vt, X[nq : 2 * nq], out=e[npos:])
        e += r[:, None]
        F = self.Kt * e
        if not self.linear:
            # two-stage leaf: extra composite rate beyond the helper knee
            F[2:4] += self.leaf_dk * np.maximum(e[2:4] - self.leaf_thr, 0.0) - self.leaf_base
            # asymmetric digressive dampers
            v = e[npos : npos + 4]
            vc = np.minimum(np.maximum(v, self.knee_r), self.knee_b)
            bump = v > 0
            F[npos : npos + 4] = np.where(bump, self.d_bl, self.d_rl) * vc + np.where(
                bump, self.d_bh, self.d_rh
            ) * (v - vc)
            # tyres cannot pull: total tyre force >= 0
            ft = F[6:10] + F[npos + 4 : npos + 8]
            F[6:10] += np.maximum(ft, -self.f0_tyre) - ft
            if self.effects:
                self._effect_forces(X, e, F, out)
        else:
            F[npos : npos + 4] = self.d_bl * e[npos : npos + 4]
        Q = self.Bt @ F
        acc = out[nq : 2 * nq]
        np.multiply(Q, self.minv_diag, out=acc)
        acc[0] += self.m12 * Q[1]
        acc[1] += self.m12 * Q[0]
        out[:nq] = X[nq : 2 * nq]
        return out

    def _effect_forces(self, X: np.ndarray, e: np.ndarray, F: np.ndarray, out: np.ndarray) -> None:
        npos, nq = self.n_pos, self.nq
        for rows, eff in self._stops:
            fn = stiffness.bump_stop if eff.kind == "bump_stop" else stiffness.rebound_stop
            F[rows] += fn(e[rows], eff.params["gap"], eff.params["k_stop"], eff.params["p"])
        for rows, eff in self._damper_friction:
            vrows = slice(npos + rows.start, npos + rows.stop)
            F[vrows] += friction.coulomb_smooth(e[vrows], eff.params["f_c"], eff.params["v_eps"])
        if self._hyst is not None:
            z = X[2 * nq : 2 * nq + 2]
            # leaf compression rate at the seats = time derivative of e[2:4]
            v_leaf = self.Et[2:4, :nq] @ X[nq : 2 * nq]
            F[2:4] += z
            out[2 * nq :] = hysteresis.dahl_dzdt(
                z, v_leaf, self._hyst.params["sigma"], self._hyst.params["f_c"]
            )

    # -------------------------------------------------------------- integration
    def simulate(
        self,
        z_road: np.ndarray,
        zd_road: np.ndarray,
        dt: float,
        record_states: bool = False,
        discard: int = 0,
    ) -> RideRecord:
        """Integrate from static equilibrium with wheel road inputs on the half-step grid.

        Args:
            z_road, zd_road: (2 N + 1, 4) road elevation (m) and its rate (m/s) under
                FL, FR, RL, RR at times 0, dt/2, dt, ..., N dt (shared by the batch).
            dt: step (s).
            record_states: keep the full state history (memory n x states x N).
            discard: leading steps not recorded (settling).
        """
        R = self._road_offsets(z_road, zd_road, discard)
        run = self._run_numpy if self._packed is None else self._run_compiled
        rec, states, final = run(R, float(dt), record_states, discard)
        return self._record(dt, rec, states, final)

    def _road_offsets(self, z_road: np.ndarray, zd_road: np.ndarray, discard: int) -> np.ndarray:
        """Element road offsets (2 N + 1, n_elements) of :meth:`simulate`'s road inputs,
        in the model's float type, once their shapes and ``discard`` are checked."""
        z_road, zd_road = np.asarray(z_road, float), np.asarray(zd_road, float)
        if z_road.ndim != 2 or z_road.shape[1] != 4 or z_road.shape[0] % 2 != 1:
            raise ValidationError(
                f"road inputs must have shape (2N+1, 4) on the half-step grid, but got "
                f"{z_road.shape}"
            )
        if zd_road.shape != z_road.shape:
            raise ValidationError(
                f"road rate must match road shape {z_road.shape}, but got {zd_road.shape}"
            )
        n_steps = (z_road.shape[0] - 1) // 2
        if not 0 <= discard < n_steps:
            raise ValidationError(
                f"`0 <= discard < steps` must hold, but got ({discard}, {n_steps})"
            )
        return self.road_vector(z_road, zd_road).astype(self.dtype)

    @property
    def _recorded_rows(self) -> np.ndarray:
        """Rows of the state derivative a run records: the body accelerations of
        [z_f, z_r, phi], then the seats' (with a seat mount)."""
        nq = self.nq
        return np.array([nq, nq + 1, nq + 2] + ([nq + 7, nq + 8] if self.seat else []))

    def _run_numpy(
        self, R: np.ndarray, dt: float, record_states: bool, discard: int
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """:meth:`simulate`'s RK4 loop in numpy over the whole batch: the recorded
        accelerations (n, channels, N) (:attr:`_recorded_rows`, at each step start: the
        RK4 first stage), the state history (n, n_states, N) or None, the final state
        (n, n_states)."""
        n, S, rows = self.n, self.n_states, self._recorded_rows
        dt_ = self.dtype
        X = np.zeros((S, n), dt_)
        k1 = np.zeros((S, n), dt_)
        work = tuple(np.zeros((S, n), dt_) for _ in range(3)) + (np.empty((S, n), dt_),)
        n_steps = (R.shape[0] - 1) // 2
        rec = np.empty((rows.size, n_steps - discard, n), dt_)
        states = np.empty((n_steps - discard, S, n), dt_) if record_states else None
        # a diverging design overflows in its own column only; it is reported via `ok`
        with np.errstate(over="ignore", invalid="ignore"):
            for k in range(n_steps):
                self.rhs(X, R[2 * k], k1)
                j = k - discard
                if j >= 0:
                    rec[:, j] = k1[rows]
                    if states is not None:
                        states[j] = X
                self._rk4_advance(X, k1, R[2 * k + 1], R[2 * k + 2], dt, work)
        history = None if states is None else np.moveaxis(states, (0, 1, 2), (2, 1, 0))
        return np.moveaxis(rec, -1, 0), history, X.T

    def _rk4_advance(
        self,
        X: np.ndarray,
        k1: np.ndarray,
        r_mid: np.ndarray,
        r_end: np.ndarray,
        h: float,
        work: tuple[np.ndarray, ...],
    ) -> None:
        """One classic RK4 step of X (n_states, n) in place, from its first stage ``k1``
        and the road offsets at the half and the full step; ``work``: four scratch
        arrays like X."""
        k2, k3, k4, tmp = work
        np.multiply(k1, h / 2, out=tmp)
        tmp += X
        self.rhs(tmp, r_mid, k2)
        np.multiply(k2, h / 2, out=tmp)
        tmp += X
        self.rhs(tmp, r_mid, k3)
        np.multiply(k3, h, out=tmp)
        tmp += X
        self.rhs(tmp, r_end, k4)
        k2 += k3
        k2 *= 2.0
        k2 += k1
        k2 += k4
        k2 *= h / 6
        X += k2

    def _run_compiled(
        self, R: np.ndarray, dt: float, record_states: bool, discard: int
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """:meth:`_run_numpy` by the compiled loop (:mod:`.ride_kernel`), design by design."""
        assert self._packed is not None  # invariant: set where the compiled loop runs
        n, S, rows = self.n, self.n_states, self._recorded_rows
        n_rec = (R.shape[0] - 1) // 2 - discard
        rec = np.empty((n, rows.size, n_rec))
        states = np.empty((n, S, n_rec if record_states else 0))
        final = np.empty((n, S))
        ride_kernel.run(R, dt, int(discard), self.nq, self.n_pos, *self._packed, rows, rec,
                        states, final)  # fmt: skip
        return rec, states if record_states else None, final

    def _record(
        self, dt: float, rec: np.ndarray, states: np.ndarray | None, final: np.ndarray
    ) -> RideRecord:
        """The :class:`RideRecord` of a run's recorded accelerations ``rec`` (n, channels,
        N), state history and final state (n, n_states); every design diverged: an
        :class:`EvaluationError`."""
        ok = np.asarray(np.isfinite(final).all(axis=1) & np.isfinite(rec).all(axis=(1, 2)))
        if not ok.any():
            raise EvaluationError(
                "ride model integration diverged (non-finite state) for every design; step "
                f"too large for the stiffest element? dt={dt}"
            )
        body = rec[:, :3]
        if self.seat:
            a_f, a_r = rec[:, 3], rec[:, 4]
        else:
            a_f = body[:, 0] + self.measure_y * body[:, 2]
            a_r = body[:, 1] + self.measure_y * body[:, 2]
        return RideRecord(dt, body, a_f, a_r, states, ok)

    # -------------------------------------------------------------- linear algebra
    def linear_system(
        self,
        damper_c: np.ndarray | None = None,
        leaf_k: np.ndarray | None = None,
        front_k: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Mass, damping, stiffness (n, nq, nq) and road input matrices (n, nq, 4).

        ``M qdd + C qd + K q = Kin u + Cin ud`` with u the wheel road inputs (FL, FR, RL,
        RR). ``damper_c`` (n, 4), ``leaf_k`` (n, 2) and ``front_k`` (n, 2) override the
        damper coefficients, the rear leaf rates and the front wheel rates
        (equivalent-linear values); by default the linearised model's (mean low-speed
        damping, static leaf rate, front wheel rate). Valid for ``linear=True``.
        """
        if not self.linear:
            raise ValidationError("linear_system needs a model built with linear=True")
        npos, nq = self.n_pos, self.nq
        pos, vel = self.E[:nq, :npos], self.E[nq:, npos:]
        Kel, Cel = self.K[:, :npos].copy(), self.K[:, npos:].copy()
        Cel[:, :4] = self.d_bl.T if damper_c is None else damper_c
        if leaf_k is not None:
            Kel[:, 2:4] = leaf_k
        if front_k is not None:
            Kel[:, 0:2] = front_k
        Kmat = np.einsum("ie,ne,je->nij", pos, Kel, pos)
        Cmat = np.einsum("ie,ne,je->nij", vel, Cel, vel)
        Minv = np.zeros((self.n, nq, nq))
        idx = np.arange(nq)
        Minv[:, idx, idx] = self.minv_diag.T
        Minv[:, 0, 1] = Minv[:, 1, 0] = self.m12
        # road enters through the tyre elements: compression = road - wheel
        Kin = -pos[None, :, 6:10] * Kel[:, None, 6:10]
        Cin = -vel[None, :, 4:8] * Cel[:, None, 4:8]
        return np.linalg.inv(Minv), Cmat, Kmat, Kin, Cin
