"""Quarter car on a four-poster-type rig: 2-DOF response to an imposed road input.

Frame and signs (ISO 8855 z up): ``road`` z_r [m] is the imposed wheel-pan
displacement (input); body z_s and wheel z_u [m] are measured from static
equilibrium (gravity balanced by the static spring force, so it does not appear).
Suspension deflection ``x = z_u - z_s`` [m] is positive in compression (bump);
the suspension force ``F_s`` [N] pushes body up and wheel down::

    m_s z_s'' = F_s
    m_u z_u'' = -F_s + k_t (z_r - z_u)
    F_s = k_s x + c_s x' + sum of effect forces(x, x')

Outputs: ``body_acceleration`` z_s'' [m/s^2] and ``suspension_deflection`` x [m].
The tyre stays in contact (linear point-contact tyre). Masses are known options
(they cannot be told apart from a common scaling of all stiffnesses otherwise);
fitted base parameters are ``k_s``, ``c_s``, ``k_t``.

Effects act on the suspension force. Rate-independent hysteresis (Dahl,
Bouc-Wen) and the Maxwell element carry a state integrated with the body and
wheel; LuGre friction is too stiff for the fixed-step integrator and is refused
(use smooth Coulomb or Stribeck friction). Integration: classical RK4 with a
fixed sub-step small enough for the stiffest element (road held linear between
samples).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.signal import lfilter

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.core.space import Parameter
from suspenv.models.components.base import ComponentModel, linear_lstsq, robust_amplitude
from suspenv.models.effects import Effect, pointwise
from suspenv.recordings import Recording, RecordingError, smooth_derivative

UNSUPPORTED = ("lugre_friction", "berg_hysteresis")


def _rate(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Smoothed derivative of ``x`` [unit/s]; plain central differences on gapped time."""
    try:
        return smooth_derivative(x, t, window_s=5 * float(np.median(np.diff(t))))
    except RecordingError:
        return np.gradient(x, t)


class QuarterCarRigModel(ComponentModel):
    """Quarter car on a rig; base linear spring, damper and tyre."""

    family = "quarter_car_rig"
    description = "quarter car on a rig, 2-DOF (base: linear spring k_s, damper c_s, tyre k_t)"
    base_parameters = (
        Parameter("k_s", 1e3, 1e6, unit="N/m", default=2e4, log=True, description="spring rate"),
        Parameter("c_s", 0.0, 1e5, unit="N s/m", default=1500.0, description="damping"),
        Parameter("k_t", 1e4, 2e6, unit="N/m", default=2e5, log=True, description="tyre rate"),
    )
    input_channels = ("road",)
    output_channels = ("body_acceleration", "suspension_deflection")
    channel_units = {"road": "m", "body_acceleration": "m/s^2", "suspension_deflection": "m"}
    candidate_effects = (
        "coulomb_friction",
        "stribeck_friction",
        "bump_stop",
        "rebound_stop",
        "cubic_stiffness",
        "progressive_stiffness",
        "damper_asymmetry",
        "digressive_damping",
        "dahl_hysteresis",
        "sensor_offset",
        "sensor_gain",
    )
    location = "suspension"

    def __init__(
        self,
        effects: Sequence[Effect] = (),
        m_s: float = 300.0,
        m_u: float = 40.0,
        dt_max: float = 2e-3,
    ):
        if not (m_s > 0 and m_u > 0 and dt_max > 0):
            raise ValidationError(
                f"`m_s > 0, m_u > 0, dt_max > 0` must hold, but got (m_s={m_s}, m_u={m_u}, "
                f"dt_max={dt_max})"
            )
        super().__init__(effects, m_s=float(m_s), m_u=float(m_u), dt_max=float(dt_max))

    def _check_effect(self, effect: Effect) -> None:
        if effect.kind in UNSUPPORTED:
            raise ValidationError(
                f"{self.family}: effect kind {effect.kind!r} cannot be integrated by the rig "
                "model (LuGre: too stiff, use 'coulomb_friction' or 'stribeck_friction'; "
                "Berg: path memory only, use 'dahl_hysteresis')"
            )

    # ------------------------------------------------------------------ physics
    def _substeps(self, base, effects, dt: float, v_max: float) -> int:
        """Sub-steps per sample so that ``h * rate <= 1.5`` for the stiffest element.

        ``v_max`` [m/s] bounds the deflection rate (hysteresis state equations are
        as fast as ``v_max`` over their transition displacement).
        """
        m_u = self.options["m_u"]
        rate = np.sqrt(np.max((np.asarray(base["k_s"]) + np.asarray(base["k_t"])) / m_u))
        rate = max(rate, float(np.max(np.asarray(base["c_s"]) / m_u)))
        for e in effects:
            p = e.params
            if e.kind in ("coulomb_friction", "stribeck_friction", "directional_friction"):
                level = max(
                    np.max(np.abs(np.asarray(p.get(k, 0.0))))
                    for k in ("f_c", "f_s", "f_pos", "f_neg")
                )
                rate = max(rate, level / (float(np.min(p["v_eps"])) * m_u))
            elif e.kind in ("bump_stop", "rebound_stop"):
                rate = max(rate, np.sqrt(float(np.max(p["k_stop"])) / m_u) * 2.0)
            elif e.kind == "dahl_hysteresis":
                rate = max(
                    rate,
                    np.sqrt(float(np.max(p["sigma"])) / m_u),
                    float(np.max(p["sigma"] / np.maximum(p["f_c"], 1e-3))) * v_max,
                )
            elif e.kind == "bouc_wen_hysteresis":
                rate = max(
                    rate,
                    np.sqrt(float(np.max(p["f_y"] / p["x_y"])) / m_u),
                    float(np.max(1.0 / p["x_y"])) * v_max,
                )
            elif e.kind == "maxwell_viscoelastic":
                rate = max(
                    rate, float(np.max(p["k_m"] / p["c_m"])), np.sqrt(float(np.max(p["k_m"])) / m_u)
                )
            elif e.kind == "digressive_damping":
                rate = max(rate, float(np.max(p["c_low"])) / m_u)
            elif e.kind == "damper_asymmetry":
                rate = max(rate, float(np.max(np.abs(p["dc_rebound"]))) / m_u)
        n_rate = int(np.ceil(dt * rate / 1.5))
        n_dt = int(np.ceil(dt / self.options["dt_max"] - 1e-9))
        return int(np.clip(max(n_rate, n_dt, 1), 1, 2000))

    def _predict(self, base, effects, rec):
        t, road = rec.time, rec.inputs["road"]
        names = ("k_s", "c_s", "k_t")
        batch = np.broadcast_shapes(
            *(np.shape(base[n]) for n in names),
            *(np.shape(v) for e in effects for v in e.params.values()),
        )
        rows = int(np.prod(batch, dtype=int))
        flat_base = {
            n: np.broadcast_to(np.asarray(base[n], float), batch).reshape(-1) for n in names
        }
        flat_eff = [
            {
                p: np.broadcast_to(np.asarray(v, float), batch).reshape(-1)
                for p, v in e.params.items()
            }
            for e in effects
        ]
        acc = np.empty((rows, t.size))
        defl = np.empty((rows, t.size))
        for r in range(rows):
            row_base = {n: float(v[r]) for n, v in flat_base.items()}
            row_effects = [
                e.with_params({p: float(v[r]) for p, v in fe.items()})
                for e, fe in zip(effects, flat_eff, strict=True)
            ]
            acc[r], defl[r] = self._integrate(row_base, row_effects, t, road)
        shape = batch + (t.size,)
        return {
            "body_acceleration": acc.reshape(shape),
            "suspension_deflection": defl.reshape(shape),
        }

    def _integrate(
        self, base: dict[str, float], effects: list[Effect], t: np.ndarray, road: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """RK4 for one parameter set, in plain floats (fast for a single design)."""
        m_s, m_u = self.options["m_s"], self.options["m_u"]
        k_s, c_s, k_t = base["k_s"], base["c_s"], base["k_t"]
        elements = [pointwise(e) for e in effects]
        stateless = [el for el in elements if el.n_states == 0]
        stateful = [el for el in elements if el.n_states == 1]

        def susp_force(x, v, zs):
            f = k_s * x + c_s * v
            for el in stateless:
                f += el.force(x, v)
            for el, z in zip(stateful, zs, strict=True):
                f += el.force(x, v, z)
            return f

        def deriv(state, zr):
            z_s, v_s, z_u, v_u, *zs = state
            x, v = z_u - z_s, v_u - v_s
            f = susp_force(x, v, zs)
            dz = [el.dzdt(x, v, z) for el, z in zip(stateful, zs, strict=True)]
            return [v_s, f / m_s, v_u, (-f + k_t * (zr - z_u)) / m_u, *dz]

        # start at rest on the initial road height (static equilibrium)
        r0 = float(road[0])
        state = [r0, 0.0, r0, 0.0] + [0.0] * len(stateful)
        acc, defl = [0.0], [0.0]
        dts = np.diff(t)
        # relative velocity rarely exceeds 3x the road velocity (wheel hop included)
        v_max = 3.0 * float(np.max(np.abs(np.diff(road)) / dts)) + 1e-3
        nsub = self._substeps(base, effects, float(np.max(dts)), v_max)
        road_l, dts_l = road.tolist(), dts.tolist()
        for k in range(t.size - 1):
            h = dts_l[k] / nsub
            rk, slope = road_l[k], (road_l[k + 1] - road_l[k]) / dts_l[k]
            for j in range(nsub):
                s0 = j * h
                mid = rk + slope * (s0 + 0.5 * h)
                k1 = deriv(state, rk + slope * s0)
                k2 = deriv([a + 0.5 * h * b for a, b in zip(state, k1, strict=True)], mid)
                k3 = deriv([a + 0.5 * h * b for a, b in zip(state, k2, strict=True)], mid)
                k4 = deriv(
                    [a + h * b for a, b in zip(state, k3, strict=True)], rk + slope * (s0 + h)
                )
                state = [
                    a + h / 6.0 * (b + 2 * c + 2 * d + e)
                    for a, b, c, d, e in zip(state, k1, k2, k3, k4, strict=True)
                ]
            if not all(math.isfinite(s) for s in state):
                raise EvaluationError(
                    f"{self.family}: simulation diverged at t={t[k + 1]:.4g} s (sub-steps {nsub})"
                )
            z_s, v_s, z_u, v_u, *zs = state
            acc.append(susp_force(z_u - z_s, v_u - v_s, zs) / m_s)
            defl.append(z_u - z_s)
        return np.array(acc, dtype=float), np.array(defl, dtype=float)

    # ------------------------------------------------------------------ guesses
    def _base_guess(self, rec):
        guess = {p.name: p.reference for p in self.base_parameters}
        if {"body_acceleration", "suspension_deflection"} <= set(rec.outputs):
            x = rec.outputs["suspension_deflection"]
            v = _rate(x, rec.time)
            k_s, c_s = linear_lstsq([x, v], self.options["m_s"] * rec.outputs["body_acceleration"])
            lo, hi = self.bounds()
            guess["k_s"] = float(np.clip(k_s, lo[0], hi[0]))
            guess["c_s"] = float(np.clip(c_s, lo[1], hi[1]))
        return guess

    def _scales(self, rec):
        if "suspension_deflection" in rec.outputs:
            xd = rec.outputs["suspension_deflection"]
            x = robust_amplitude(xd)
            v = robust_amplitude(_rate(xd, rec.time))
        else:
            x = robust_amplitude(rec.inputs["road"])
            v = robust_amplitude(np.gradient(rec.inputs["road"], rec.time))
        if "body_acceleration" in rec.outputs:
            f = self.options["m_s"] * robust_amplitude(rec.outputs["body_acceleration"])
        else:
            f = 2e4 * x
        return {"force": f, "deflection": x, "velocity": v}

    def example_recording(
        self, seed: int = 0, duration: float = 4.0, dt: float = 0.002
    ) -> Recording:
        """Rig road input: band-limited random road (about 1 cm) plus a 3 cm bump."""
        rng = np.random.default_rng(seed)
        t = np.arange(0.0, duration, dt)
        white = rng.standard_normal(t.size)
        # first-order low pass at ~4 Hz applied twice, then scaled to 8 mm RMS
        alpha = np.exp(-2 * np.pi * 4.0 * dt)
        road = lfilter([1 - alpha], [1, -alpha], lfilter([1 - alpha], [1, -alpha], white))
        road *= 0.008 / np.std(road)
        t0, width = 0.35 * duration, 0.12
        bump = np.where(
            (t >= t0) & (t < t0 + width), 0.03 * np.sin(np.pi * (t - t0) / width) ** 2, 0.0
        )
        road = road - road[0] + bump
        return Recording(
            f"quarter_car_example_{seed}",
            "rig_road",
            t,
            {"road": road},
            {},
            dict(self.channel_units),
            {"source": "synthetic", "sampling": {"dt_s": dt}},
        )
