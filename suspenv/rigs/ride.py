"""Ride rigs for the minibus: random-road run (ISO 8608) and pulse bump (GB/T 4970).

Frame and units: ISO 8855 (x forward, y left, z up), SI inside; speeds at the edge in
km/h. Road inputs are shared by every design in a batch (common random numbers: one
seeded road realisation), so differences between designs are not road noise.

Random road (defaults are the study's case): class B at 80 km/h; left and right
tracks ``track_front`` apart with the isotropic-road coherency; the rear wheels run on
the same tracks ``wheelbase`` later (exact periodic delay). Fixed RK4 step at 100 Hz
(wheel hop near 12 Hz is resolved with ~8 steps per cycle; Wk is applied in the
frequency domain, so no 200+ Hz rate is needed for the weighting filters), 1 s of
settling discarded, then 10 s recorded. The recorded window is exactly one period of
the periodic road profile (no FFT leakage). From road seed to road seed the 10 s
weighted RMS of a design scatters by 2.4-9.8 % (coefficient of variation over 20 seeds,
five designs; most at the rear with full load, whose body mode is lightly damped; see
``docs/benchmarks/ride_noise.json``); the same road serves every design of a batch, and
designs rank like in a 60 s run on another road with Spearman 0.96-0.99 front and
0.64-0.99 rear at no load; 20 s gives 0.95-0.99 everywhere at twice the cost. The
minibus problem's default ride objectives avoid the record altogether (the spectral
method, :func:`suspenv.metrics.ride.ride_spectral`).

Pulse bump: one triangular bump (400 mm base, 60 mm high by default) across both
wheel tracks on a smooth road, at constant speed (20 and 50 km/h in the study). The
profile is averaged over the tyre contact length (a point contact over-predicts a
short obstacle); step 1 ms.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.effects.effect import Effect
from suspenv.models.minibus.ride_model import RideModel, RideRecord, SeatMount
from suspenv.models.minibus.vehicle import (
    LOAD_CASES,
    REFERENCE_MINIBUS,
    Minibus,
    stacked_vehicle_parameters,
)
from suspenv.models.road import (
    RandomRoad,
    contact_length_filter,
    generate_profile,
    profile_inputs,
    triangular_bump,
)


def random_road_inputs(
    road: RandomRoad, vehicle: Minibus = REFERENCE_MINIBUS
) -> tuple[np.ndarray, np.ndarray]:
    """Wheel inputs (2 N + 1, 4) on the half-step grid: elevation (m) and rate (m/s).

    Columns FL, FR, RL, RR; the rear columns are the front tracks delayed by L/v.
    """
    if abs(vehicle.track_front - vehicle.track_rear) > 1e-9:
        raise ValidationError(
            "random road inputs assume equal front and rear tracks, but got "
            f"({vehicle.track_front}, {vehicle.track_rear})"
        )
    v = road.speed
    m = 2 * road.n_steps + 1
    dx = v * road.dt / 2.0
    # one period of the (periodic) profile spans exactly the recorded window, so the
    # record is one period of the steady state: no leakage in the FFT weighting and
    # the recorded power per road line is fixed by the line amplitudes
    period = 2 * (road.n_steps - road.n_settle)
    prof = generate_profile(period * dx, dx, road.road_class, road.seed, vehicle.track_front)
    if road.enveloping:
        prof = prof.enveloped(road.enveloping)
    return profile_inputs(prof, v, m, road.n_settle, vehicle.wheelbase)


def _model(
    X: np.ndarray, load_cases: str | Sequence[str], vehicle: Minibus, **options: Any
) -> RideModel:
    """The ride model of designs X (n, 8; study units) in the load cases, stacked in
    order (rows: load case 0 designs 0..n-1, then load case 1, ...)."""
    cases = [load_cases] if isinstance(load_cases, str) else list(load_cases)
    return RideModel(stacked_vehicle_parameters(X, cases, vehicle), **options)


def random_road_run(
    X: np.ndarray,
    load_cases: str | Sequence[str] = LOAD_CASES,
    road: RandomRoad | None = None,
    vehicle: Minibus = REFERENCE_MINIBUS,
    effects: Sequence[Effect] = (),
    seat: SeatMount | None = None,
    linear: bool = False,
    record_states: bool = False,
    dtype: type = np.float64,
) -> RideRecord:
    """Run designs X (n, 8; study units) over a random road; load cases stacked in order.

    Rows of the record: load case 0 designs 0..n-1, then load case 1, ...
    """
    road = road or RandomRoad()
    model = _model(X, load_cases, vehicle, effects=effects, seat=seat, linear=linear, dtype=dtype)
    z, zd = random_road_inputs(road, vehicle)
    return model.simulate(z, zd, road.dt, record_states=record_states, discard=road.n_settle)


# ------------------------------------------------------------------ pulse bump
@dataclass(frozen=True)
class PulseBump:
    """Settings of the pulse (single triangular bump) test."""

    speed_kmh: float = 50.0
    base: float = 0.4  # m
    height: float = 0.06  # m
    lead_in: float = 0.5  # s of smooth road before the front wheels reach the bump
    duration_s: float = 3.0  # s recorded after the start
    sample_rate: float = 1000.0  # Hz
    #: tyre contact length (m) to average the profile over; 0 = point contact
    contact_length: float | None = field(default=None)

    @property
    def speed(self) -> float:
        return self.speed_kmh / 3.6


@dataclass
class PulseResult:
    """Time histories and peaks of a pulse run (n designs x load cases stacked)."""

    record: RideRecord
    t: np.ndarray
    peak_front: np.ndarray
    peak_rear: np.ndarray


def pulse_inputs(
    pulse: PulseBump, vehicle: Minibus = REFERENCE_MINIBUS
) -> tuple[np.ndarray, np.ndarray]:
    """Wheel inputs (2 N + 1, 4) for the bump across both tracks, rear delayed by L/v."""
    v, dt = pulse.speed, 1.0 / pulse.sample_rate
    n_steps = int(round(pulse.duration_s * pulse.sample_rate))
    m = 2 * n_steps + 1
    dx = v * dt / 2.0
    lc = vehicle.tyre_contact_length if pulse.contact_length is None else pulse.contact_length
    # distance travelled on the half-step grid; the front axle starts lead_in*v before it
    x = dx * np.arange(m + int(np.ceil(vehicle.wheelbase / dx)) + 2)
    start = pulse.lead_in * v
    prof = contact_length_filter(triangular_bump(x, start, pulse.base, pulse.height), dx, lc)

    def wheels(y: np.ndarray) -> np.ndarray:  # (m, 4): y under the front, delayed at the rear
        rear = np.interp(x[:m] - vehicle.wheelbase, x, y, left=0.0)
        return np.stack([y[:m], y[:m], rear, rear], axis=1)

    return wheels(prof), v * wheels(np.gradient(prof, dx))


def pulse_run(
    X: np.ndarray,
    load_cases: str | Sequence[str] = LOAD_CASES,
    pulse: PulseBump | None = None,
    vehicle: Minibus = REFERENCE_MINIBUS,
    effects: Sequence[Effect] = (),
    seat: SeatMount | None = None,
) -> PulseResult:
    """Pulse test: peak |vertical acceleration| (m/s^2) above front and rear suspension."""
    pulse = pulse or PulseBump()
    model = _model(X, load_cases, vehicle, effects=effects, seat=seat)
    z, zd = pulse_inputs(pulse, vehicle)
    rec = model.simulate(z, zd, 1.0 / pulse.sample_rate)
    return PulseResult(
        record=rec,
        t=rec.t,
        peak_front=np.max(np.abs(rec.acc_front), axis=-1),
        peak_rear=np.max(np.abs(rec.acc_rear), axis=-1),
    )
