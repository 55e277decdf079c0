"""A generator of "measured" minibus ride recordings with concealed effects (benchmarks).

Frame and units: ISO 8855 (z up), SI; speeds at the edge in km/h. Channels (see
:mod:`suspenv.diagnosis.ride.model`): inputs ``road_FL .. road_RR`` [m] (road
elevation under each wheel), outputs ``acc_front``, ``acc_rear``, ``acc_seat``
[m/s^2] (vertical acceleration above the front and rear suspension and on a seat
rail). Uniform sampling at :data:`~suspenv.diagnosis.ride.model.SAMPLE_RATE`.

Tests (GB/T 4970 style, see ``spec/ride_standards.md``):

* pulse: one triangular bump (400 x 60 mm) across both tracks at 20 and 50 km/h,
  profile averaged over the tyre contact length; each speed is run twice (the
  second run at a slightly different speed with fresh sensor noise), as a real test
  repeats runs;
* random road: an ISO 8608 road (two coherent tracks, rear delayed by L/v) at a
  given speed; reports show its acceleration PSDs.

The generator (:func:`make_ride_case`) draws a truth minibus (design values spread
around the study's pick) with zero or one concealed effect of seeded random
magnitude and location, simulates every test with the same ride model code as the
fit (only the effect list differs) and adds white sensor noise of a seeded level.
The case's recordings do not say what was added; the :class:`RideTruth` is kept
apart (:func:`write_ride_case` writes it to a separate folder).

Out-of-library truths (:data:`~benchmarks.ride_mismatch.OUT_OF_LIBRARY_KINDS`:
a damper curve of another shape, other tyres, a seat accelerometer with a gain error,
a lag or upside down, an undeclared payload, tyre run-out the recordings do not carry)
put physics into the truth that no candidate element describes; see
:mod:`benchmarks.ride_mismatch`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.ride_mismatch import (
    OUT_OF_LIBRARY_KINDS,
    apply_sensor,
    draw_mismatch,
    felt_inputs,
    mismatch_vehicle,
)
from suspenv.core.errors import ValidationError
from suspenv.diagnosis.ride.model import (
    OUTPUT_CHANNELS,
    SAMPLE_RATE,
    MinibusRideAdapter,
    half_grid_recording,
    pulse_inputs_recording,
    ride_effect,
)
from suspenv.measurements import Recording, save_recording
from suspenv.models.effects import Effect
from suspenv.models.minibus import REFERENCE_MINIBUS
from suspenv.models.road import RandomRoad
from suspenv.rigs.ride import random_road_inputs

#: concealed-effect kinds the generator draws from (None = no effect)
TRUTH_KINDS = ("bump_stop", "leaf_friction", "damper_friction", "seat_mount")


# ------------------------------------------------------------------ truth and cases
@dataclass
class RideTruth:
    """What the generator put in (kept apart from the recordings)."""

    base: dict[str, float]
    effects: list[Effect]
    noise_fraction: float
    seed: int
    #: out-of-library physics (see :mod:`benchmarks.ride_mismatch`), or None
    mismatch: dict[str, Any] | None = None

    @property
    def in_library(self) -> bool:
        """False when the truth holds physics outside the candidate list."""
        return self.mismatch is None

    @property
    def kinds(self) -> list[str]:
        return [e.kind for e in self.effects]

    def to_dict(self) -> dict[str, Any]:
        return {
            "base": self.base,
            "effects": [e.to_dict() for e in self.effects],
            "noise_fraction": self.noise_fraction,
            "seed": self.seed,
            "mismatch": self.mismatch,
        }


@dataclass
class RideCase:
    """A blind case: fit recordings, held-out recordings, and the truth (apart)."""

    name: str
    fit: list[Recording]
    heldout: list[Recording]
    truth: RideTruth = field(repr=False)


def draw_truth_effect(kind: str | None, rng: np.random.Generator) -> list[Effect]:
    """One concealed effect of ``kind`` with random magnitude and location (SI)."""
    if kind is None:
        return []
    if kind == "bump_stop":
        loc = str(rng.choice(["front_suspension", "rear_suspension"]))
        return [
            ride_effect(
                "bump_stop",
                loc,
                gap=float(rng.uniform(0.012, 0.022)),
                k_stop=float(rng.uniform(2e5, 5e5)),
            )
        ]
    if kind == "leaf_friction":
        f_c = float(rng.uniform(400.0, 900.0))
        delta = float(rng.uniform(2.5e-3, 5e-3))  # m, travel to build up the friction
        return [ride_effect("dahl_hysteresis", "rear_leaf", f_c=f_c, sigma=f_c / delta)]
    if kind == "damper_friction":
        loc = str(rng.choice(["front_damper", "rear_damper"]))
        return [ride_effect("coulomb_friction", loc, f_c=float(rng.uniform(150.0, 400.0)))]
    if kind == "seat_mount":
        from suspenv.diagnosis.ride.model import SEAT_MASS

        f = float(rng.uniform(6.0, 10.0))
        zeta = float(rng.uniform(0.1, 0.3))
        k = SEAT_MASS * (2 * np.pi * f) ** 2
        return [ride_effect("kelvin_voigt", "seat_mount", k=k, c=2 * zeta * np.sqrt(k * SEAT_MASS))]
    raise ValidationError(
        f"truth effect kind must be one of {TRUTH_KINDS + OUT_OF_LIBRARY_KINDS} or None, "
        f"got {kind!r}"
    )


def measure(
    rec: Recording,
    model: MinibusRideAdapter,
    theta: np.ndarray,
    noise: float,
    rng,
    mismatch: dict[str, Any] | None = None,
) -> Recording:
    """``rec`` with the model's outputs (on the road the truth feels, through a mismatched
    sensor, if any) plus white noise of ``noise`` x channel RMS."""
    road = felt_inputs(mismatch, rec.inputs, rec.time, float(rec.meta.get("speed_kmh", 0.0)))
    felt = replace(rec, inputs=road) if road is not rec.inputs else rec
    pred = {c: np.asarray(v, float) for c, v in model.simulate(theta, felt).items()}
    if mismatch is not None:
        apply_sensor(mismatch, pred, rec.sample_interval)
    outs = {}
    for c in OUTPUT_CHANNELS:
        y = pred[c]
        sd = noise * float(np.sqrt(np.mean(y**2)))
        outs[c] = y + rng.normal(0.0, sd, y.shape)
    return rec.with_outputs(outs)


def make_ride_case(
    seed: int,
    kind: str | None,
    speeds_kmh: tuple[float, float] = (20.0, 50.0),
    random_road: bool = True,
) -> RideCase:
    """A blind ride case: truth with ``kind`` (or none), pulse runs x2 and a random road.

    ``kind``: one of :data:`TRUTH_KINDS` (a candidate element), one of
    :data:`~benchmarks.ride_mismatch.OUT_OF_LIBRARY_KINDS` (physics outside the
    candidate list), or None.

    Fit recordings: the first pulse run at each speed. Held-out recordings: the
    second pulse runs (speed within +-3 %, fresh noise) and, with ``random_road``, a
    class C road at 60 km/h.
    """
    rng = np.random.default_rng(seed)
    base = {
        "C1": 1.12 * float(rng.uniform(0.85, 1.15)),
        "C2": 0.88 * float(rng.uniform(0.85, 1.15)),
        "T1": 8.8e4 * float(rng.uniform(0.9, 1.1)),
        "K1": 73.5 * float(rng.uniform(0.9, 1.1)),
    }
    mismatch = None
    if kind in OUT_OF_LIBRARY_KINDS:
        effects, mismatch = [], draw_mismatch(str(kind), rng)
    else:
        effects = draw_truth_effect(kind, rng)
    noise = float(rng.uniform(0.02, 0.04))
    truth_model = (
        MinibusRideAdapter(effects, vehicle=mismatch_vehicle(mismatch))
        if mismatch
        else MinibusRideAdapter(effects)
    )
    theta = truth_model.theta_from(base)
    fit, held = [], []
    for v in speeds_kmh:
        fit.append(
            measure(
                pulse_inputs_recording(v, name=f"pulse_{v:g}_run1"),
                truth_model,
                theta,
                noise,
                rng,
                mismatch,
            )
        )
    for v in speeds_kmh:
        v2 = v * float(rng.uniform(0.97, 1.03))
        rec = pulse_inputs_recording(v2, name=f"pulse_{v:g}_run2")
        held.append(measure(rec, truth_model, theta, noise, rng, mismatch))
    if random_road:
        rr = random_road_inputs_recording(
            60.0, "C", 6.0, seed=int(rng.integers(1 << 30)), name="random_C_60_run1"
        )
        held.append(measure(rr, truth_model, theta, noise, rng, mismatch))
    name = f"ride_case_{seed}"
    return RideCase(name, fit, held, RideTruth(base, effects, noise, seed, mismatch))


def write_ride_case(case: RideCase, case_dir: str | Path, truth_dir: str | Path) -> list[Path]:
    """Recordings (``.npz``) into ``case_dir``; the truth (JSON) into a separate ``truth_dir``."""
    case_dir, truth_dir = Path(case_dir), Path(truth_dir)
    if case_dir.resolve() == truth_dir.resolve():
        raise ValidationError(
            f"the truth must be kept apart, but case_dir == truth_dir ({case_dir})"
        )
    paths = [save_recording(r, case_dir / f"{r.name}.npz") for r in case.fit + case.heldout]
    truth_dir.mkdir(parents=True, exist_ok=True)
    tp = truth_dir / f"{case.name}.truth.json"
    tp.write_text(json.dumps(case.truth.to_dict(), indent=2))
    return [*paths, tp]


def random_road_inputs_recording(
    speed_kmh: float = 60.0,
    road_class: str = "C",
    duration_s: float = 6.0,
    seed: int = 0,
    name: str | None = None,
) -> Recording:
    """Inputs-only recording of a random-road run (1 s settling included at the start)."""
    road = RandomRoad(
        road_class=road_class,
        speed_kmh=speed_kmh,
        duration_s=duration_s,
        settle_s=1.0,
        sample_rate=SAMPLE_RATE,
        seed=seed,
    )
    z, _ = random_road_inputs(road, REFERENCE_MINIBUS)
    z = z - z[0]  # start from rest on the local road level
    meta = {
        "speed_kmh": float(speed_kmh),
        "road_class": road_class,
        "load_case": "no_load",
        "road_seed": int(seed),
        "settle_s": 1.0,
    }
    return half_grid_recording(
        z, name or f"random_{road_class}_{speed_kmh:g}kmh", "random_road", meta
    )
