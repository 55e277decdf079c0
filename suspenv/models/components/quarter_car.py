"""Quarter car on a four-poster-type rig: 2-DOF response to an imposed road input.

Frame and signs (ISO 8855 z up): ``road`` z_r [m] is the imposed wheel-pan
displacement (input); body z_s and wheel z_u [m] are measured from static
equilibrium (gravity balanced by the static spring force, so it does not appear).
Suspension deflection ``x = z_u - z_s`` [m] is positive in compression (bump);
the suspension force ``F_s`` [N] pushes body up and wheel down::

    m_s z_s'' = F_s + F_a
    m_u z_u'' = -F_s - F_a + k_t (z_r - z_u)
    F_s = k_s x + c_s x' + sum of effect forces(x, x')

``F_a`` [N] is an optional known input ``actuator_force`` (an active rig's actuator
between body and wheel, positive pushing them apart; exact integrator only).

Outputs: ``body_acceleration`` z_s'' [m/s^2] and ``suspension_deflection`` [m]: ``x``
times the known option ``deflection_ratio`` (default 1; a transducer across the damper
of a suspension with motion ratio ``r`` reads ``r x``).
The tyre stays in contact (linear point-contact tyre). Masses are known options
(they cannot be told apart from a common scaling of all stiffnesses otherwise);
fitted base parameters are ``k_s``, ``c_s``, ``k_t``, less those the rig states as known
(option ``known_base``, e.g. a measured tyre rate ``{"k_t": 2.3e5}``).

Effects act on the suspension force; hysteresis (Dahl, Bouc-Wen), Maxwell and LuGre
elements carry a state integrated with the body and wheel. Two integrators
(option ``integrator``):

* ``"exact"`` (default, :mod:`suspenv.models.components.rig_integrator`): the linear
  2-DOF part advanced exactly (matrix exponential, road and element force linear over
  a step of at most ``dt_max``), the element force solved implicitly at the end of
  each step, element states stepped exactly along the deflection. Stable for any
  element stiffness (narrow friction steps, LuGre bristles); about 1.5 % error in
  the body acceleration for 1 cm/s-wide Coulomb friction at a 2 ms step, 0.5 % at the
  default 1 ms. Bouc-Wen (no exact state step) is integrated by RK4.
* ``"rk4"``: classical RK4 with a fixed sub-step small enough for the stiffest
  element (road held linear between samples); parameters that would need more than
  ``max_substeps`` sub-steps per sample are refused with an :class:`EvaluationError`
  (a fit treats them as a failed point); LuGre friction is refused. A batch of
  parameter sets is integrated at once (state arrays over the batch).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from scipy.signal import lfilter

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.core.options import choice, integer, positive
from suspenv.core.space import Parameter
from suspenv.measurements import Recording, RecordingError, smooth_derivative
from suspenv.models.components import rig_integrator
from suspenv.models.components.base import ComponentModel, linear_lstsq, robust_amplitude
from suspenv.models.effects import Effect, PointwiseElement

#: "exact": exact linear step with the element force implicit (:mod:`.rig_integrator`);
#: "rk4": classical RK4 with sub-steps (reference; also used for Bouc-Wen hysteresis)
INTEGRATORS = ("exact", "rk4")


#: window [s] of the cubic Savitzky-Golay derivative of the measured deflection: the
#: deflection carries the body and wheel modes (below about 20 Hz), so a 40 ms window
#: keeps them while cutting the differentiated sensor noise several times (a 5-sample
#: window left about a third of the velocity as noise at 2 % deflection noise)
RATE_WINDOW_S = 0.04


#: the vector operations of :func:`_rk4` on a state of plain floats (one design) ...
_FLOATS = (
    lambda s, c, k: [a + c * b for a, b in zip(s, k, strict=True)],
    lambda k1, k2, k3, k4: [
        a + 2.0 * (b + c) + d for a, b, c, d in zip(k1, k2, k3, k4, strict=True)
    ],
)
#: ... and on a (n_states, B) array (a batch of designs)
_ARRAYS = (lambda s, c, k: s + c * k, lambda k1, k2, k3, k4: k1 + 2.0 * (k2 + k3) + k4)


def _rk4(
    deriv: Callable[[Any, float], Any],
    ops: tuple[Callable[..., Any], Callable[..., Any]],
    observe: Callable[[Any, int], tuple[Any, Any]],
    state: Any,
    t: np.ndarray,
    road: np.ndarray,
    nsub: int,
) -> tuple[list[Any], list[Any]]:
    """Classical fixed-step RK4 of ``deriv(state, road height)`` over the samples ``t``
    [s], ``nsub`` equal sub-steps per sample, the road [m] linear between samples.

    ``ops``: ``(axpy, mix)`` of the state's representation (:data:`_FLOATS`,
    :data:`_ARRAYS`): ``axpy(s, c, k) = s + c k`` and ``mix(k1..k4) = k1 + 2 (k2 + k3) + k4``.
    Returns the two lists of ``observe(state, k)`` after each sample ``k + 1``, led by 0
    for the first sample (the system starts at rest)."""
    axpy, mix = ops
    first, second = [0.0 * state[0]], [0.0 * state[0]]  # zeros shaped as one state entry
    road_l, dts_l = road.tolist(), np.diff(t).tolist()
    for k in range(t.size - 1):
        h = dts_l[k] / nsub
        rk, slope = road_l[k], (road_l[k + 1] - road_l[k]) / dts_l[k]
        for j in range(nsub):
            s0 = j * h
            mid = rk + slope * (s0 + 0.5 * h)
            k1 = deriv(state, rk + slope * s0)
            k2 = deriv(axpy(state, 0.5 * h, k1), mid)
            k3 = deriv(axpy(state, 0.5 * h, k2), mid)
            k4 = deriv(axpy(state, h, k3), rk + slope * (s0 + h))
            state = axpy(state, h / 6.0, mix(k1, k2, k3, k4))
        a, b = observe(state, k)
        first.append(a)
        second.append(b)
    return first, second


def _elements(effects: Sequence[Effect]) -> tuple[list[PointwiseElement], list[PointwiseElement]]:
    """The pointwise forms of the force effects: (stateless, with one state)."""
    elements = [PointwiseElement(e) for e in effects]
    return [el for el in elements if el.n_states == 0], [el for el in elements if el.n_states == 1]


def _row(flat_base: dict, flat_eff: list[dict], effects: Sequence[Effect], i: int) -> tuple:
    """Row ``i`` of a flattened batch as plain floats: (base values, effects)."""
    return {n: float(v[i]) for n, v in flat_base.items()}, [
        e.with_params({p: float(v[i]) for p, v in fe.items()})
        for e, fe in zip(effects, flat_eff, strict=True)
    ]


def _rate(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Smoothed derivative of ``x`` [unit/s]; plain central differences on gapped time."""
    dt = float(np.median(np.diff(t)))
    try:
        return smooth_derivative(x, t, window_s=max(RATE_WINDOW_S, 5 * dt))
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
    optional_inputs = ("actuator_force",)
    output_channels = ("body_acceleration", "suspension_deflection")
    channel_units = {"road": "m", "body_acceleration": "m/s^2", "suspension_deflection": "m"}
    candidate_effects = (
        "coulomb_friction",
        "stribeck_friction",
        "bump_stop",
        "rebound_stop",
        "bump_and_rebound_stops",
        "cubic_stiffness",
        "progressive_stiffness",
        "damper_asymmetry",
        "digressive_damping",
        "dahl_hysteresis",
        "maxwell_viscoelastic",
        "sensor_offset",
        "sensor_gain",
        "sensor_lag",
    )
    location = "suspension"
    viscous_parameter = "c_s"
    #: element constants this model uses for effects it adds (friction regularised over
    #: 1 cm/s: a width of 1 mm/s would need about ten times more RK4 sub-steps)
    effect_defaults: ClassVar[dict[str, dict[str, float]]] = {
        "coulomb_friction": {"v_eps": 0.01},
        "stribeck_friction": {"v_eps": 0.01},
        "directional_friction": {"v_eps": 0.01},
    }

    def __init__(
        self,
        effects: Sequence[Effect] = (),
        m_s: float = 300.0,
        m_u: float = 40.0,
        dt_max: float = 1e-3,
        max_substeps: int = 20,
        integrator: str = "exact",
        scales: Mapping[str, float] | None = None,
        deflection_ratio: float = 1.0,
        known_base: Mapping[str, float] | None = None,
    ):
        owner = self.family
        deflection_ratio = positive(owner, "deflection_ratio", deflection_ratio)
        super().__init__(
            effects,
            m_s=positive(owner, "m_s", m_s),
            m_u=positive(owner, "m_u", m_u),
            dt_max=positive(owner, "dt_max", dt_max),
            max_substeps=integer(owner, "max_substeps", max_substeps, lo=1),
            integrator=choice(owner, "integrator", integrator, INTEGRATORS),
            **({"scales": dict(scales)} if scales else {}),
            **({"deflection_ratio": float(deflection_ratio)} if deflection_ratio != 1.0 else {}),
            **({"known_base": {k: float(v) for k, v in known_base.items()}} if known_base else {}),
        )

    @property
    def deflection_ratio(self) -> float:
        """Travel of the deflection transducer per unit of suspension deflection ``x``
        (1: it reads ``x``; a transducer across the damper of a suspension with motion
        ratio 0.6 reads ``0.6 x``); the recorded channel is this times ``x``."""
        return float(self.options.get("deflection_ratio", 1.0))

    def _check_effect(self, effect: Effect) -> None:
        if effect.kind == "berg_hysteresis":
            raise ValidationError(
                f"{self.family}: effect kind 'berg_hysteresis' cannot be integrated by the rig "
                "model (Berg: path memory only, use 'dahl_hysteresis')"
            )
        if effect.kind == "lugre_friction" and self.options.get("integrator") == "rk4":
            raise ValidationError(
                f"{self.family}: effect kind 'lugre_friction' cannot be integrated by the rig "
                "model with integrator='rk4' (LuGre: too stiff for the explicit scheme; use "
                "integrator='exact', or 'coulomb_friction' / 'stribeck_friction')"
            )

    # ------------------------------------------------------------------ physics
    def _substeps(self, base, effects, t: np.ndarray, road: np.ndarray) -> int:
        """Sub-steps per sample so that ``h * rate <= 1.5`` for the stiffest element.

        ``v_max`` [m/s] bounds the deflection rate (hysteresis state equations are
        as fast as ``v_max`` over their transition displacement): the relative velocity
        rarely exceeds 3x the road velocity (wheel hop included).
        """
        dts = np.diff(t)
        dt = float(np.max(dts))
        v_max = 3.0 * float(np.max(np.abs(np.diff(road)) / dts)) + 1e-3
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
            elif e.kind == "bump_and_rebound_stops":
                k_max = max(float(np.max(p["k_bump"])), float(np.max(p["k_rebound"])))
                rate = max(rate, np.sqrt(k_max / m_u) * 2.0)
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
        n = max(n_rate, n_dt, 1)
        if n > self.options["max_substeps"]:
            raise EvaluationError(
                f"{self.family}: an element is too stiff for the fixed-step integrator: "
                f"{n} sub-steps per sample needed, but `max_substeps` = "
                f"{self.options['max_substeps']}"
            )
        return int(n)

    def _predict(self, base, effects, rec):
        t, road = rec.time, rec.inputs["road"]
        names = ("k_s", "c_s", "k_t")
        batch = np.broadcast_shapes(
            *(np.shape(base[n]) for n in names),
            *(np.shape(v) for e in effects for v in e.params.values()),
        )
        rows = int(np.prod(batch, dtype=int))

        def flat(values: Mapping[str, Any]) -> dict[str, np.ndarray]:  # each as (rows,)
            return {
                k: np.broadcast_to(np.asarray(v, float), batch).reshape(-1)
                for k, v in values.items()
            }

        flat_base = flat({n: base[n] for n in names})
        flat_eff = [flat(e.params) for e in effects]
        actuator = rec.inputs.get("actuator_force")
        exact = self.options["integrator"] == "exact" and rig_integrator.supports(effects)
        if actuator is not None and not exact:
            raise ValidationError(
                f"{self.family}: an actuator_force input is integrated by the exact scheme "
                "only, which does not support the effects "
                f"{[e.kind for e in effects if not rig_integrator.supports([e])]}"
            )
        if exact:
            acc, defl = self._integrate_exact(flat_base, flat_eff, effects, t, road, rows, actuator)
        elif rows == 1:
            row_base, row_effects = _row(flat_base, flat_eff, effects, 0)
            acc, defl = (a[None, :] for a in self._integrate(row_base, row_effects, t, road))
        else:
            batch_effects = [e.with_params(fe) for e, fe in zip(effects, flat_eff, strict=True)]
            acc, defl = self._integrate_batch(flat_base, batch_effects, t, road)
        shape = batch + (t.size,)
        return {
            "body_acceleration": acc.reshape(shape),
            "suspension_deflection": self.deflection_ratio * defl.reshape(shape),
        }

    def jacobian_model(self) -> QuarterCarRigModel:
        """The same model stepping once per sample (``dt_max`` at least the recording
        step) for finite-difference Jacobians: about half the cost; its outputs differ
        from the default step's by at most about 1.5 % (1 cm/s-wide friction), so its
        difference quotients are close to the default step's (the fit's residuals and
        its optimum stay those of the default step)."""
        if self.options["integrator"] != "exact":
            return self
        return type(self)(
            self.effects, **{**self.options, "dt_max": max(self.options["dt_max"], 1.0)}
        )

    def _integrate_exact(
        self,
        flat_base: dict[str, np.ndarray],
        flat_eff: list[dict[str, np.ndarray]],
        effects: Sequence[Effect],
        t: np.ndarray,
        road: np.ndarray,
        rows: int,
        actuator: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The exact-linear, implicit-element scheme, row by row; ``(rows, T)`` outputs.

        Rows with the same dynamic parameters (base and force elements) are integrated
        once: a finite-difference Jacobian's columns of the sensor elements (offsets,
        drifts), which act on the recorded channels after the simulation, repeat the
        dynamics of its first row. A row that diverges becomes NaN (the fit treats it
        as a large residual) unless every row diverges."""
        m_s, m_u = self.options["m_s"], self.options["m_u"]
        nsub = max(int(np.ceil(float(np.max(np.diff(t))) / self.options["dt_max"] - 1e-9)), 1)
        acc = np.full((rows, t.size), np.nan)
        defl = np.full((rows, t.size), np.nan)
        failure = None
        first_row: dict[tuple[float, ...], int] = {}
        for i in range(rows):
            key = tuple(float(v[i]) for v in flat_base.values()) + tuple(
                float(v[i]) for fe in flat_eff for v in fe.values()
            )
            if key in first_row:
                acc[i], defl[i] = acc[first_row[key]], defl[first_row[key]]
                continue
            first_row[key] = i
            row_base, row_eff = _row(flat_base, flat_eff, effects, i)
            try:
                acc[i], defl[i] = rig_integrator.integrate(
                    m_s, m_u, row_base, row_eff, t, road, nsub, actuator=actuator
                )
            except (EvaluationError, OverflowError, ZeroDivisionError, ValueError) as exc:
                failure = exc
        if failure is not None and (rows == 1 or not np.any(np.isfinite(acc[:, -1]))):
            raise EvaluationError(f"{self.family}: simulation failed ({failure})") from None
        return acc, defl

    def _equations(
        self,
        k_s: Any,
        c_s: Any,
        k_t: Any,
        stateless: list[PointwiseElement],
        stateful: list[PointwiseElement],
        pack: Callable[[list[Any]], Any],
    ) -> tuple[Callable[[Any], Any], Callable[[Any, float], Any]]:
        """The equations of motion (module docstring) of both RK4 paths:
        ``(susp_force(s), deriv(s, z_r))`` for a state ``s = (z_s, v_s, z_u, v_u, element
        states...)`` whose entries are plain floats (one design, ``pack=list``) or
        ``(B,)`` arrays (a batch, ``pack=np.array``: a ``(4 + n_states, B)`` array).
        ``susp_force`` is ``F_s`` [N] (no actuator: the exact scheme's input only);
        ``deriv`` the state's time derivative with the road at ``z_r`` [m]."""
        m_s, m_u = self.options["m_s"], self.options["m_u"]

        def susp_force(s: Any) -> Any:
            x, v = s[2] - s[0], s[3] - s[1]
            f = k_s * x + c_s * v
            for el in stateless:
                f = f + el.force(x, v)
            for i, el in enumerate(stateful):
                f = f + el.force(x, v, s[4 + i])
            return f

        def deriv(s: Any, zr: float) -> Any:
            x, v = s[2] - s[0], s[3] - s[1]
            f = susp_force(s)
            dz = [el.dzdt(x, v, s[4 + i]) for i, el in enumerate(stateful)]
            return pack([s[1], f / m_s, s[3], (k_t * (zr - s[2]) - f) / m_u, *dz])

        return susp_force, deriv

    def _integrate(
        self, base: dict[str, float], effects: list[Effect], t: np.ndarray, road: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """RK4 for one parameter set, in plain floats (fast for a single design)."""
        m_s = self.options["m_s"]
        k_s, c_s, k_t = base["k_s"], base["c_s"], base["k_t"]
        stateless, stateful = _elements(effects)
        susp_force, deriv = self._equations(k_s, c_s, k_t, stateless, stateful, list)

        # start at rest on the initial road height (static equilibrium)
        r0 = float(road[0])
        state = [r0, 0.0, r0, 0.0] + [0.0] * len(stateful)
        nsub = self._substeps(base, effects, t, road)

        def observe(state: list[float], k: int) -> tuple[float, float]:
            if not all(math.isfinite(s) for s in state):
                raise EvaluationError(
                    f"{self.family}: simulation diverged at t={t[k + 1]:.4g} s (sub-steps {nsub})"
                )
            return susp_force(state) / m_s, state[2] - state[0]

        try:
            acc, defl = _rk4(deriv, _FLOATS, observe, state, t, road, nsub)
            return np.array(acc, dtype=float), np.array(defl, dtype=float)
        except (OverflowError, ZeroDivisionError) as exc:
            raise EvaluationError(
                f"{self.family}: simulation diverged ({exc}; sub-steps {nsub})"
            ) from None

    def _integrate_batch(
        self,
        base: dict[str, np.ndarray],
        effects: list[Effect],
        t: np.ndarray,
        road: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """RK4 for a batch of ``B`` parameter sets at once (same scheme as :meth:`_integrate`).

        ``base`` values and effect parameters are ``(B,)`` arrays; the state is a
        ``(4 + n_states, B)`` array, so one RK4 stage is a handful of array operations
        whatever ``B`` is (a finite-difference Jacobian costs about one simulation).
        The sub-step count is the largest any row needs. Returns ``(B, T)`` arrays.
        """
        m_s = self.options["m_s"]
        k_s, c_s, k_t = (np.asarray(base[n], float) for n in ("k_s", "c_s", "k_t"))
        n_rows = k_s.size
        stateless, stateful = _elements(effects)
        # rows whose hysteresis level is zero carry no Dahl element (its law divides by f_c)
        for el in stateful:
            if el.effect.kind == "dahl_hysteresis":
                f_c = np.broadcast_to(np.asarray(el.params["f_c"], float), (n_rows,))
                present = f_c > 0.0
                el.params["f_c"] = np.where(present, f_c, 1.0)
                el.params["sigma"] = np.where(present, el.params["sigma"], 0.0)
        n_states = 4 + len(stateful)
        susp_force, deriv = self._equations(k_s, c_s, k_t, stateless, stateful, np.array)

        r0 = float(road[0])
        state = np.zeros((n_states, n_rows))
        state[0] = state[2] = r0
        nsub = self._substeps(base, effects, t, road)

        def observe(s: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
            return susp_force(s) / m_s, s[2] - s[0]

        with np.errstate(all="ignore"):  # a diverging row becomes NaN, checked below
            acc, defl = (np.array(o) for o in _rk4(deriv, _ARRAYS, observe, state, t, road, nsub))
        bad = ~np.isfinite(acc[-1]) | ~np.isfinite(defl[-1])
        if np.all(bad):
            raise EvaluationError(
                f"{self.family}: simulation diverged for every row of the batch (sub-steps {nsub})"
            )
        # a diverged row becomes NaN (the fit treats non-finite residuals as large)
        acc[:, bad] = np.nan
        defl[:, bad] = np.nan
        return acc.T.copy(), defl.T.copy()

    # ------------------------------------------------------------------ force view
    def force_view(self, theta: np.ndarray, rec: Recording) -> dict[str, np.ndarray] | None:
        """The suspension force seen through the body equation, for residual signatures.

        ``measured`` = ``m_s * body_acceleration`` [N]; ``predicted`` = the model's
        suspension force ``k_s x + c_s x' + effects`` [N] along the *measured*
        deflection ``x`` [m] and its smoothed rate [m/s] (``x``, ``v``); ``jacobian``
        ``(T, p)`` is d(predicted)/d(theta) [N per unit] (zero for the tyre rate and sensor
        parameters). In this view a missing element leaves its own force signature
        (a loop, a step, a one-sided ramp), which the simulated channels smear through
        the body and wheel dynamics. None when ``rec`` lacks either channel.
        """
        if not {"body_acceleration", "suspension_deflection"} <= set(rec.outputs):
            return None
        x, v, measured = self._body_view(np.asarray(theta, float), rec)

        def predicted(th: np.ndarray) -> np.ndarray:
            return np.asarray(self._suspension_force(th, x, v, rec.time), float)

        theta = np.asarray(theta, float)
        f0 = predicted(theta)
        lo, hi = self.bounds()
        jac = np.zeros((x.size, theta.size))
        for i in range(theta.size):
            h = 1e-6 * max(abs(theta[i]), 1.0)
            h = h if theta[i] + h <= hi[i] else -h
            th = theta.copy()
            th[i] += h
            jac[:, i] = (predicted(th) - f0) / h
        return {"measured": measured, "predicted": f0, "x": x, "v": v, "jacobian": jac}

    def _body_view(self, theta: np.ndarray, rec: Recording) -> tuple[np.ndarray, ...]:
        """The body equation's view of ``rec``, the sensor elements of ``theta`` undone:
        deflection ``x`` [m], its smoothed rate [m/s], ``m_s z_s''`` less the actuator [N]."""
        _, sensed = self.unpack(theta)
        x = self._undo_sensors(sensed, "suspension_deflection", rec) / self.deflection_ratio
        f = self.options["m_s"] * self._undo_sensors(sensed, "body_acceleration", rec)
        return x, _rate(x, rec.time), f - self._actuator(rec)

    def _suspension_force(self, theta: np.ndarray, x: np.ndarray, v: np.ndarray, t: np.ndarray):
        """Suspension force ``k_s x + c_s v + force effects`` [N] at ``theta`` along the
        deflection ``x`` [m] and its rate ``v`` [m/s]."""
        base, effects = self.unpack(theta)
        f = base["k_s"] * x + base["c_s"] * v
        for e in effects:
            if e.spec.role == "force":
                f = f + e.force(x, v, t)
        return f

    @staticmethod
    def _actuator(rec: Recording) -> np.ndarray | float:
        """The known actuator force [N] between body and wheel (positive pushing them
        apart), or 0 when the recording has none."""
        act = rec.inputs.get("actuator_force")
        return 0.0 if act is None else np.asarray(act, float)

    def _undo_sensors(self, effects: Sequence[Effect], channel: str, rec: Recording) -> np.ndarray:
        """The recorded ``channel`` with the zero, drift and gain elements on it undone
        (the true signal the force view needs); a sensor lag is left in place."""
        y = np.asarray(rec.outputs[channel], float)
        t = np.asarray(rec.time, float)
        for e in reversed([e for e in effects if e.spec.role == "sensor"]):
            if self._sensor_channel(e) != channel:
                continue
            p = {k: float(np.ravel(v)[0]) for k, v in e.params.items()}
            if e.kind == "sensor_offset":
                y = y - p["offset"]
            elif e.kind == "zero_drift":
                y = y - p["rate"] * np.minimum(t, p["span"])  # held past its span
            elif e.kind == "sensor_gain":
                y = y / p["gain"]
        return y

    # ------------------------------------------------------------------ fast start
    def refine_start(
        self,
        theta0: np.ndarray,
        recordings: Sequence[Recording],
        masks: Sequence[np.ndarray | None] | None = None,
    ) -> np.ndarray | None:
        """A start for the simulation (output-error) fit from an equation-error fit.

        The body equation ``m_s z_s'' = F_s(x, x')`` holds sample by sample, and the rig
        records both ``z_s''`` and the deflection ``x`` (``m_s`` is known): the
        suspension force parameters (``k_s``, ``c_s`` and every force effect) are fitted
        to ``m_s * body_acceleration`` along the measured deflection and its smoothed
        rate by least squares, without simulating (milliseconds per evaluation). The
        tyre rate and sensor effects keep their start values. Returns None (no
        refinement) when no recording has both channels or the equation-error fit fails.
        """
        from scipy.optimize import least_squares

        theta0 = np.asarray(theta0, float)
        views = []
        for i, rec in enumerate(recordings):
            if not {"body_acceleration", "suspension_deflection"} <= set(rec.outputs):
                continue
            m = None if masks is None else masks[i]
            x, v, f = self._body_view(theta0, rec)
            views.append((x, v, rec.time, f, np.ones(x.size, bool) if m is None else m))
        if not views:
            return None
        names = self.parameter_names
        sensor = {
            f"{e.name}.{q}" for e in self.effects if e.spec.role == "sensor" for q in self._free(e)
        }
        free = np.array([n != "k_t" and n not in sensor for n in names])
        lo, hi = self.bounds()
        scale = float(np.std(np.concatenate([f[m] for *_, f, m in views]))) or 1.0

        def residual(sub: np.ndarray) -> np.ndarray:
            th = theta0.copy()
            th[free] = sub
            r = np.concatenate(
                [(f - self._suspension_force(th, x, v, t))[m] / scale for x, v, t, f, m in views]
            )
            return np.where(np.isfinite(r), r, 1e3)

        x0 = np.clip(theta0[free], lo[free], hi[free])
        span = hi[free] - lo[free]
        x0 = np.clip(x0, lo[free] + 1e-6 * span, hi[free] - 1e-6 * span)
        try:
            sol = least_squares(
                residual, x0, bounds=(lo[free], hi[free]), x_scale="jac", max_nfev=200
            )
        except (ValueError, EvaluationError, ValidationError):
            return None
        out = theta0.copy()
        out[free] = sol.x
        return out

    # ------------------------------------------------------------------ guesses
    def _base_guess(self, rec):
        guess = super()._base_guess(rec)
        if {"body_acceleration", "suspension_deflection"} <= set(rec.outputs):
            x = rec.outputs["suspension_deflection"] / self.deflection_ratio
            v = _rate(x, rec.time)
            k_s, c_s = linear_lstsq([x, v], self.options["m_s"] * rec.outputs["body_acceleration"])
            lo, hi = self.bounds()
            names = self.parameter_names
            for name, value in (("k_s", k_s), ("c_s", c_s)):
                if name in names:  # fitted, not known
                    i = names.index(name)
                    guess[name] = float(np.clip(value, lo[i], hi[i]))
        guess.update(self.known_base)
        return guess

    def _scales(self, rec):
        if "suspension_deflection" in rec.outputs:
            xd = rec.outputs["suspension_deflection"] / self.deflection_ratio
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
