"""The minibus ride model behind the component-model interface the diagnosis uses.

Frame and units: ISO 8855 (x forward, y left, z up), SI inside; the design values
keep the study's units at the edge (C1, C2 dimensionless, T1 N*mm/deg, K1 N/mm).
Suspension deflection positive in compression (bump); accelerations m/s^2, + up.

A ride recording (:func:`pulse_inputs_recording`; sampled at :data:`SAMPLE_RATE`) has
the road elevation under each wheel as inputs ``road_FL``, ``road_FR``, ``road_RL``,
``road_RR`` [m] on the recording's uniform time grid, and measures the vertical
acceleration of the body above the front and rear suspension (``acc_front``,
``acc_rear``, at the measuring points of :class:`RideModel`) and on the seat rail of
a mid-cabin seat (``acc_seat``) [m/s^2].

Fitted parameters (small and identifiable from pulse tests): the front/rear damper
curve scales C1, C2, the front torsion-bar rate T1 and the rear leaf primary rate
K1; the other design values stay at the study's pick. Effects (each a physical
element with its own parameters, simulated inside the 7-DOF model):

* ``bump_stop`` at ``front_suspension`` / ``rear_suspension`` (gap from the static
  ride position);
* ``dahl_hysteresis`` at ``rear_leaf`` (leaf interleaf friction);
* ``coulomb_friction`` at ``front_damper`` / ``rear_damper`` (seal friction);
* ``kelvin_voigt`` at ``seat_mount``: the seat frame on a compliant mount (stiffness
  ``k`` [N/m], damping ``c`` [N s/m], seat mass :data:`SEAT_MASS`); without it the
  seat rail moves with the floor. The seat is light against the body, so its
  reaction on the body is left out: the mount acts as a base-excited oscillator
  on the floor acceleration at the seat.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from scipy import signal

from suspenv.core.errors import ValidationError
from suspenv.core.space import Parameter
from suspenv.diagnosis.hypothesis import candidate_name
from suspenv.measurements import Recording
from suspenv.models.components.base import ComponentModel
from suspenv.models.effects import Effect, make_effect
from suspenv.models.minibus import DESIGN_NAMES, REFERENCE_MINIBUS, STUDY_PICK, vehicle_parameters
from suspenv.models.minibus.ride_model import SUPPORTED_EFFECTS, RideModel
from suspenv.models.minibus.vehicle import Minibus
from suspenv.rigs.ride import PulseBump, pulse_inputs

WHEELS = ("FL", "FR", "RL", "RR")
ROAD_CHANNELS = tuple(f"road_{w}" for w in WHEELS)
OUTPUT_CHANNELS = ("acc_front", "acc_rear", "acc_seat")
SAMPLE_RATE = 200.0  # Hz
UNITS = {**{c: "m" for c in ROAD_CHANNELS}, **{c: "m/s^2" for c in OUTPUT_CHANNELS}}
#: seat + occupant share on the mount (kg) [CHOICE: a bus passenger seat, as SeatMount]
SEAT_MASS = 90.0
#: seat position: fraction of the wheelbase behind the front axle, lateral offset (m)
SEAT_FRACTION, SEAT_Y = 0.5, -0.35

#: velocity width (m/s) of the smoothed damper friction step [CHOICE: a sharper step
#: acts as a damping of f_c / v_eps at rest, too stiff for RK4 at 200 Hz on a 45 kg wheel]
FRICTION_V_EPS = 0.03

#: (kind, location) -> engineering words
RIDE_EFFECT_WORDS: dict[tuple[str, str], str] = {
    ("bump_stop", "front_suspension"): "bump stop contact in the front suspension",
    ("bump_stop", "rear_suspension"): "bump stop contact in the rear suspension",
    ("rebound_stop", "front_suspension"): "rebound stop contact in the front suspension",
    ("rebound_stop", "rear_suspension"): "rebound stop contact in the rear suspension",
    ("dahl_hysteresis", "rear_leaf"): "leaf-spring interleaf friction (Dahl) in the rear leaves",
    ("coulomb_friction", "front_damper"): "Coulomb friction in the front dampers",
    ("coulomb_friction", "rear_damper"): "Coulomb friction in the rear dampers",
    ("kelvin_voigt", "seat_mount"): "a compliant seat mount (spring and damper under the seat)",
}
#: candidate (kind, location) pairs the ride diagnosis tries: every ride element but the
#: rebound stops
RIDE_CANDIDATES = tuple(k for k in RIDE_EFFECT_WORDS if k[0] != "rebound_stop")
#: fit bounds tighter than the effect library's generic ones: they keep every
#: element integrable by RK4 at the recordings' 200 Hz (stiffest mode well inside
#: the stability limit) and physically meaningful (a seat mount has k, c > 0)
RIDE_BOUNDS: dict[tuple[str, str], tuple[float, float]] = {
    ("bump_stop", "gap"): (0.0, 0.15),
    ("bump_stop", "k_stop"): (0.0, 2.0e6),
    ("rebound_stop", "gap"): (0.0, 0.15),
    ("rebound_stop", "k_stop"): (0.0, 2.0e6),
    ("dahl_hysteresis", "f_c"): (0.0, 3000.0),
    ("dahl_hysteresis", "sigma"): (1.0e4, 1.0e6),
    ("coulomb_friction", "f_c"): (0.0, 600.0),
    ("kelvin_voigt", "k"): (2.0e4, 2.0e6),
    ("kelvin_voigt", "c"): (50.0, 2.0e4),
}


def ride_effect(kind: str, location: str, **params: float) -> Effect:
    """An effect named ``"<kind>@<location>"`` placed at ``location`` of the ride model."""
    if (kind, location) not in RIDE_EFFECT_WORDS:
        raise ValidationError(
            f"ride effect (kind, location) must be one of {sorted(RIDE_EFFECT_WORDS)}, but got "
            f"({kind!r}, {location!r})"
        )
    if kind == "coulomb_friction":
        params.setdefault("v_eps", FRICTION_V_EPS)
    return make_effect(kind, name=f"{kind}@{location}", location=location, **params)


def effect_words(effect: Effect) -> str:
    return RIDE_EFFECT_WORDS.get((effect.kind, effect.location), effect.words)


def half_step_inputs(rec: Recording) -> tuple[np.ndarray, np.ndarray, float]:
    """Road elevation (2N+1, 4) [m] and rate [m/s] on the half-step grid of ``rec``'s N
    samples (midpoints interpolated linearly, the last sample held), and the step [s]."""
    t = rec.time
    dt = float(np.median(np.diff(t)))
    if np.ptp(np.diff(t)) > 1e-6 * dt:
        raise ValidationError(f"recording {rec.name!r}: ride recordings need a uniform time grid")
    z = np.stack([rec.inputs[c] for c in ROAD_CHANNELS], axis=1)
    z_ext = np.vstack([z, z[-1:]])
    zh = np.empty((2 * z.shape[0] + 1, 4))
    zh[0::2] = z_ext
    zh[1::2] = 0.5 * (z_ext[:-1] + z_ext[1:])
    zd = np.gradient(zh, dt / 2.0, axis=0)
    return zh, zd, dt


class MinibusRideAdapter(ComponentModel):
    """7-DOF minibus ride model as a diagnosable component model (family ``minibus_ride``).

    Options: ``load_case`` ("no_load"/"full_load"; a recording's ``meta["load_case"]``
    wins), ``design`` (the 8 study values the fit does not touch; default study pick),
    ``vehicle`` (the :class:`~suspenv.models.minibus.vehicle.Minibus` definition: damper
    curve shapes, tyres, masses; default the reference minibus; the blind generator's
    out-of-library truths change it).
    """

    family: ClassVar[str] = "minibus_ride"
    description: ClassVar[str] = (
        "7-DOF minibus ride model (pulse bump and random road), damper scales and spring rates"
    )
    base_parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter("C1", 0.4, 2.5, "-", default=1.12, description="front damper curve scale"),
        Parameter("C2", 0.4, 2.5, "-", default=0.88, description="rear damper curve scale"),
        Parameter("T1", 4.0e4, 2.0e5, "N*mm/deg", default=8.8e4, description="front torsion bar"),
        Parameter("K1", 40.0, 140.0, "N/mm", default=73.5, description="rear leaf primary rate"),
    )
    input_channels: ClassVar[tuple[str, ...]] = ROAD_CHANNELS
    output_channels: ClassVar[tuple[str, ...]] = OUTPUT_CHANNELS
    channel_units: ClassVar[dict[str, str]] = dict(UNITS)
    candidate_effects: ClassVar[tuple[str, ...]] = tuple(
        candidate_name(kind, loc) for kind, loc in RIDE_CANDIDATES
    )
    location: ClassVar[str] = ""

    def __init__(self, effects: Sequence[Effect] = (), **options: Any):
        super().__init__(effects, **options)
        design = np.asarray(options.get("design", STUDY_PICK), float)
        if design.shape != (len(DESIGN_NAMES),):
            raise ValidationError(
                f"design must hold the {len(DESIGN_NAMES)} study values {DESIGN_NAMES}, but got "
                f"shape {design.shape}"
            )
        self._design = design
        vehicle = options.get("vehicle", REFERENCE_MINIBUS)
        if not isinstance(vehicle, Minibus):
            raise ValidationError(
                f"vehicle must be a Minibus definition, but got {type(vehicle).__name__}"
            )
        self._vehicle = vehicle

    def _check_effect(self, effect: Effect) -> None:
        key = (effect.kind, effect.location)
        if key not in RIDE_EFFECT_WORDS:
            raise ValidationError(
                f"minibus_ride: effect (kind, location) must be one of "
                f"{sorted(RIDE_EFFECT_WORDS)}, but got {key}"
            )
        if effect.kind != "kelvin_voigt" and key not in SUPPORTED_EFFECTS:
            raise ValidationError(f"minibus_ride: the ride model does not support {key}")

    # ------------------------------------------------------------------ fit interface
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = super().bounds()
        k = len(self.base_parameters)
        for e in self.effects:
            for p in self._free(e):
                if (b := RIDE_BOUNDS.get((e.kind, p))) is not None:
                    lo[k], hi[k] = b
                k += 1
        return lo, hi

    def _scales(self, rec: Recording) -> dict[str, float]:
        """Unit scales: the ride elements' starting values (:meth:`_effect_guess`) are
        physical sizes that read none."""
        return {"force": 1.0, "deflection": 1.0, "velocity": 1.0}

    def _effect_guess(self, e: Effect, sc: Mapping[str, float]) -> dict[str, float]:
        """Physical starting values of the ride elements (SI)."""
        k_seat = SEAT_MASS * (2 * np.pi * 8.0) ** 2
        g = {
            "bump_stop": {"gap": 0.03, "k_stop": 2.0e5},
            "rebound_stop": {"gap": 0.05, "k_stop": 2.0e5},
            "dahl_hysteresis": {"f_c": 300.0, "sigma": 7.5e4},
            "coulomb_friction": {"f_c": 150.0},
            "kelvin_voigt": {"k": k_seat, "c": 2 * 0.2 * np.sqrt(k_seat * SEAT_MASS)},
        }[e.kind]
        return {p: v for p, v in g.items() if p in self._free(e)}

    # ------------------------------------------------------------------ simulation
    def _predict(
        self, base: dict[str, np.ndarray], effects: Sequence[Effect], rec: Recording
    ) -> dict[str, np.ndarray]:
        batched = np.ndim(base["C1"]) > 0
        B = int(np.size(base["C1"]))
        X = np.tile(self._design, (B, 1))
        for name in ("C1", "C2", "T1", "K1"):
            X[:, DESIGN_NAMES.index(name)] = np.atleast_1d(base[name])
        load_case = str(rec.meta.get("load_case", self.options.get("load_case", "no_load")))
        params = vehicle_parameters(X, load_case, self._vehicle)
        ride_effects = [_batch(e, B) for e in effects if e.kind != "kelvin_voigt"]
        seat = [e for e in effects if e.kind == "kelvin_voigt"]
        model = RideModel(params, effects=ride_effects)
        zh, zd, dt = half_step_inputs(rec)
        out = model.simulate(zh, zd, dt)
        body = out.body_acc  # (B, 3, N): z_f, z_r, phi accelerations
        seat_floor = (
            (1 - SEAT_FRACTION) * body[:, 0] + SEAT_FRACTION * body[:, 1] + SEAT_Y * body[:, 2]
        )
        acc_seat = seat_floor
        if seat:
            k, c = (np.broadcast_to(np.atleast_1d(seat[0].params[p]), (B,)) for p in ("k", "c"))
            acc_seat = np.vstack(
                [seat_mount_response(seat_floor[i], dt, k[i], c[i]) for i in range(B)]
            )
        res = {"acc_front": out.acc_front, "acc_rear": out.acc_rear, "acc_seat": acc_seat}
        bad = ~np.asarray(out.ok, bool) if out.ok is not None else np.zeros(B, bool)
        for key in res:
            arr = np.array(res[key], dtype=float)
            arr[bad] = np.nan
            res[key] = arr if batched else arr[0]
        return res

    def example_recording(self, seed: int = 0) -> Recording:
        return pulse_inputs_recording(50.0)


def _batch(e: Effect, B: int) -> Effect:
    """Effect with (B,) parameter arrays (the ride model's batch axis) or scalars."""
    vals = {
        k: (np.broadcast_to(np.asarray(v, float), (B,)) if np.ndim(v) else v)
        for k, v in e.params.items()
    }
    return Effect(e.kind, e.name, vals, e.location)


def seat_mount_response(a_floor: np.ndarray, dt: float, k: float, c: float) -> np.ndarray:
    """Absolute seat acceleration [m/s^2] on a mount (k [N/m], c [N s/m], SEAT_MASS) driven
    by the floor acceleration: H(s) = (c s + k) / (m s^2 + c s + k), bilinear at ``dt``
    with the mount's natural frequency pre-warped (the discrete resonance sits at wn).

    The bilinear map s = K (1 - 1/z) / (1 + 1/z), K = 2 / (dt warp), written out for
    this second-order H (the coefficients ``scipy.signal.bilinear`` gives)."""
    m = SEAT_MASS
    wn = np.sqrt(k / m)
    warp = np.tan(wn * dt / 2.0) / (wn * dt / 2.0) if wn * dt < 1.0 else 1.0
    K = 2.0 / (dt * warp)
    b = np.array([c * K + k, 2.0 * k, k - c * K])
    a = np.array([m * K**2 + c * K + k, 2.0 * (k - m * K**2), m * K**2 - c * K + k])
    return signal.lfilter(b / a[0], a / a[0], a_floor)


def half_grid_recording(z: np.ndarray, name: str, test: str, meta: dict[str, Any]) -> Recording:
    """Inputs-only recording of wheel inputs ``z`` [m], (2N + 1, 4) on the ride model's
    half-step grid: its N full-step samples at :data:`SAMPLE_RATE`."""
    zs = z[0::2][:-1]  # the N full-step samples (the half grid has 2N + 1 points)
    t = np.arange(zs.shape[0]) / SAMPLE_RATE
    return Recording(
        name=name,
        test=test,
        time=t,
        inputs={c: zs[:, i] for i, c in enumerate(ROAD_CHANNELS)},
        outputs={},
        units=dict(UNITS),
        meta=meta,
    )


def pulse_inputs_recording(
    speed_kmh: float, duration_s: float | None = None, name: str | None = None
) -> Recording:
    """Inputs-only recording of a pulse run (bump under the front wheels at 0.3 s)."""
    if not speed_kmh > 0:
        raise ValidationError(f"`speed_kmh > 0` must hold, but got {speed_kmh}")
    if duration_s is None:
        # front and rear passes, then 1 s of decay
        duration_s = 0.3 + REFERENCE_MINIBUS.wheelbase / (speed_kmh / 3.6) + 1.0
    pulse = PulseBump(
        speed_kmh=speed_kmh, lead_in=0.3, duration_s=duration_s, sample_rate=SAMPLE_RATE
    )
    z, _ = pulse_inputs(pulse, REFERENCE_MINIBUS)
    meta = {
        "speed_kmh": float(speed_kmh),
        "bump_time_s": 0.3,
        "load_case": "no_load",
        "wheelbase_delay_s": REFERENCE_MINIBUS.wheelbase / pulse.speed,
    }
    return half_grid_recording(z, name or f"pulse_{speed_kmh:g}kmh", "pulse", meta)
