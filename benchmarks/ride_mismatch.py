"""Out-of-library truths for the blind ride cases: physics no candidate element describes.

Frame and units: ISO 8855 (z up), SI; suspension velocity + in bump (compression);
accelerations m/s^2, + up; delays s.

Each truth is physical and cheap to simulate with the same 7-DOF ride model:

* ``damper_asymmetry``: one axle's dampers (front or rear) with a stronger rebound
  side (rebound branch x 1.4-1.8; bump unchanged), e.g. a replacement damper valved
  differently from the model's 3:1 curve;
* ``damper_digressive``: one axle's dampers more digressive than the model's curve
  (knee 0.05-0.08 m/s instead of 0.13, high-speed slope 20-28 % of the low-speed one
  instead of 40 %);
* ``tyre_stiffness``: all four tyres softer (x 0.70-0.80) or stiffer (x 1.25-1.40)
  than the model's 223 kN/m: the front wheel-hop resonance moves by -9 to -13 % or
  +10 to +15 %;
* ``seat_sensor_gain``: the seat-rail accelerometer reads x 0.85-0.92 or x 1.08-1.15;
* ``seat_sensor_lag``: the seat-rail accelerometer lags by 5-10 ms (an exact delay,
  applied in the frequency domain to the noise-free signal);
* ``seat_sensor_sign``: the seat-rail accelerometer mounted upside down (a sign the
  recording does not declare);
* ``payload``: an undeclared payload of 150-300 kg on the floor (1.0 m high), 0.8-2.4 m
  behind the front axle: the sprung mass, its centre and pitch and roll inertia change
  (the recording still says "no_load");
* ``tyre_nonuniformity``: each tyre has a radial run-out of 0.5-1.5 mm (once per
  revolution, its own phase): an input the recording does not carry, added to the
  road under that wheel in the truth's simulation only.

None of these is a candidate of :data:`~suspenv.diagnosis.ride.model.RIDE_CANDIDATES`
(the damper curve scales C1, C2 the fit adjusts scale a curve, they cannot change
its shape). The right diagnosis is "nothing significant", or a candidate flagged
as leaving a residual unexplained (:mod:`suspenv.diagnosis.ride.residual`).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.minibus import REFERENCE_MINIBUS
from suspenv.models.minibus.vehicle import DamperCurve, LoadCase, Minibus

#: truth kinds whose extra physics is outside the candidate list
OUT_OF_LIBRARY_KINDS = (
    "damper_asymmetry",
    "damper_digressive",
    "tyre_stiffness",
    "seat_sensor_gain",
    "seat_sensor_lag",
    "seat_sensor_sign",
    "payload",
    "tyre_nonuniformity",
)


def _axle_curve(vehicle: Minibus, axle: str) -> DamperCurve:
    return vehicle.damper_front if axle == "front" else vehicle.damper_rear


def _with_curve(vehicle: Minibus, axle: str, curve: DamperCurve) -> Minibus:
    return vehicle.with_(**{f"damper_{axle}": curve})


def draw_mismatch(kind: str, rng: np.random.Generator) -> dict[str, Any]:
    """Seeded description of one out-of-library truth (JSON-friendly, SI)."""
    if kind == "damper_asymmetry":
        axle = str(rng.choice(["front", "rear"]))
        return {"kind": kind, "axle": axle, "rebound_factor": float(rng.uniform(1.4, 1.8))}
    if kind == "damper_digressive":
        axle = str(rng.choice(["front", "rear"]))
        return {
            "kind": kind,
            "axle": axle,
            "knee": float(rng.uniform(0.05, 0.08)),
            "high_over_low": float(rng.uniform(0.20, 0.28)),
        }
    if kind == "tyre_stiffness":
        factor = rng.uniform(0.70, 0.80) if rng.random() < 0.5 else rng.uniform(1.25, 1.40)
        return {"kind": kind, "factor": float(factor)}
    if kind == "seat_sensor_gain":
        gain = rng.uniform(0.85, 0.92) if rng.random() < 0.5 else rng.uniform(1.08, 1.15)
        return {"kind": kind, "channel": "acc_seat", "gain": float(gain)}
    if kind == "seat_sensor_lag":
        return {"kind": kind, "channel": "acc_seat", "delay_s": float(rng.uniform(0.005, 0.010))}
    if kind == "seat_sensor_sign":
        return {"kind": kind, "channel": "acc_seat", "gain": -1.0}
    if kind == "payload":
        return {"kind": kind, "mass": rng.uniform(150.0, 300.0), "x": rng.uniform(0.8, 2.4)}
    if kind == "tyre_nonuniformity":
        return {
            "kind": kind,
            "runout_m": rng.uniform(0.5e-3, 1.5e-3, 4).tolist(),
            "phase": rng.uniform(0.0, 2 * np.pi, 4).tolist(),
        }
    raise ValidationError(
        f"out-of-library kind must be one of {OUT_OF_LIBRARY_KINDS}, but got {kind!r}"
    )


def mismatch_vehicle(mismatch: dict[str, Any], vehicle: Minibus = REFERENCE_MINIBUS) -> Minibus:
    """The truth vehicle of a mismatch (the reference one for sensor kinds)."""
    kind = mismatch["kind"]
    if kind == "damper_asymmetry":
        axle, f = mismatch["axle"], float(mismatch["rebound_factor"])
        c = _axle_curve(vehicle, axle)
        stronger = replace(c, rebound_low=c.rebound_low * f, rebound_high=c.rebound_high * f)
        return _with_curve(vehicle, axle, stronger)
    if kind == "damper_digressive":
        axle, knee = mismatch["axle"], float(mismatch["knee"])
        ratio = float(mismatch["high_over_low"])
        c = _axle_curve(vehicle, axle)
        return _with_curve(
            vehicle,
            axle,
            replace(
                c,
                bump_knee=knee,
                rebound_knee=knee,
                bump_high=c.bump_low * ratio,
                rebound_high=c.rebound_low * ratio,
            ),
        )
    if kind == "tyre_stiffness":
        return vehicle.with_(
            tyre_vertical_stiffness=vehicle.tyre_vertical_stiffness * float(mismatch["factor"])
        )
    if kind == "payload":
        return vehicle.with_(no_load=with_payload(vehicle.no_load, mismatch["mass"], mismatch["x"]))
    return vehicle


#: height of an undeclared payload's centre above the ground (m) [CHOICE: on the floor]
PAYLOAD_HEIGHT = 1.0


def with_payload(load: LoadCase, mass: float, x: float) -> LoadCase:
    """``load`` with a point payload of ``mass`` [kg] at ``x`` [m] behind the front axle on
    the centreline, :data:`PAYLOAD_HEIGHT` high: the new sprung mass, its centre, and the
    radii of gyration about it (parallel-axis theorem; the yaw radius kept)."""
    m0, m = load.sprung_mass, load.sprung_mass + mass
    cx = (m0 * load.cg_x + mass * x) / m
    cz = (m0 * load.cg_z + mass * PAYLOAD_HEIGHT) / m
    pitch = (
        m0 * (load.pitch_gyration**2 + (load.cg_x - cx) ** 2 + (load.cg_z - cz) ** 2)
        + mass * ((x - cx) ** 2 + (PAYLOAD_HEIGHT - cz) ** 2)
    ) / m
    roll = (
        m0 * (load.roll_gyration**2 + (load.cg_z - cz) ** 2) + mass * (PAYLOAD_HEIGHT - cz) ** 2
    ) / m
    return replace(
        load,
        sprung_mass=m,
        cg_x=cx,
        cg_z=cz,
        roll_gyration=np.sqrt(roll),
        pitch_gyration=np.sqrt(pitch),
    )


def felt_inputs(
    mismatch: dict[str, Any] | None, road: dict[str, np.ndarray], t: np.ndarray, speed_kmh: float
) -> dict[str, np.ndarray]:
    """The road each wheel of the truth feels [m]: the recorded ``road`` (channel ->
    elevation at times ``t`` [s]), plus each tyre's radial run-out for
    ``tyre_nonuniformity`` (a sine once per revolution of the loaded radius at
    ``speed_kmh``); the recorded road otherwise."""
    if mismatch is None or mismatch["kind"] != "tyre_nonuniformity":
        return road
    turns = speed_kmh / 3.6 * t / (2 * np.pi * REFERENCE_MINIBUS.tyre_loaded_radius)
    out = {}
    for i, (c, z) in enumerate(road.items()):
        run = mismatch["runout_m"][i] * np.sin(2 * np.pi * turns + mismatch["phase"][i])
        out[c] = np.asarray(z, float) + run
    return out


def delay_signal(y: np.ndarray, delay_s: float, dt: float) -> np.ndarray:
    """``y(t - delay_s)`` for a signal at rest before its first sample: exact
    (band-limited) fractional delay by a linear phase on the zero-padded spectrum."""
    y = np.asarray(y, float)
    if delay_s < 0:
        raise ValidationError(f"`delay_s >= 0` must hold, but got {delay_s}")
    n = y.size
    m = 2 * n
    f = np.fft.rfftfreq(m, dt)
    ys = np.fft.rfft(np.concatenate([y, np.zeros(n)]))
    return np.fft.irfft(ys * np.exp(-2j * np.pi * f * delay_s), m)[:n]


def apply_sensor(mismatch: dict[str, Any], outputs: dict[str, np.ndarray], dt: float) -> None:
    """Apply a sensor mismatch (gain or lag) in place to the noise-free ``outputs``."""
    kind = mismatch["kind"]
    if kind in ("seat_sensor_gain", "seat_sensor_sign"):
        ch = mismatch["channel"]
        outputs[ch] = outputs[ch] * float(mismatch["gain"])
    elif kind == "seat_sensor_lag":
        ch = mismatch["channel"]
        outputs[ch] = delay_signal(outputs[ch], float(mismatch["delay_s"]), dt)


def mismatch_words(mismatch: dict[str, Any]) -> str:
    """One line for tables: what the out-of-library truth is."""
    k = mismatch["kind"]
    if k == "damper_asymmetry":
        return f"{mismatch['axle']} dampers: rebound x {mismatch['rebound_factor']:.2f}"
    if k == "damper_digressive":
        return (
            f"{mismatch['axle']} dampers digressive: knee {mismatch['knee']:.3f} m/s, "
            f"high/low slope {mismatch['high_over_low']:.2f}"
        )
    if k == "tyre_stiffness":
        return f"tyre vertical stiffness x {mismatch['factor']:.2f}"
    if k == "seat_sensor_gain":
        return f"seat accelerometer gain {mismatch['gain']:.3f}"
    if k == "seat_sensor_lag":
        return f"seat accelerometer lag {1e3 * mismatch['delay_s']:.1f} ms"
    if k == "seat_sensor_sign":
        return "seat accelerometer upside down"
    if k == "payload":
        return f"payload {mismatch['mass']:.0f} kg at {mismatch['x']:.2f} m, not declared"
    if k == "tyre_nonuniformity":
        return f"tyre radial run-out {1e3 * max(mismatch['runout_m']):.1f} mm at most"
    return k
