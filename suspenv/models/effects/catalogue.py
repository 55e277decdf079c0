"""The effect kinds shipped with suspenv, registered at import.

Bounds are generic (component to vehicle scale); a model that knows its scale
should narrow them. Parameters are in SI units.

Some elements sit beside a linear stiffness of their host (a bushing): there the
host gives their stiffness relative to its own, ``sigma_ratio`` (Dahl) and ``ratio``
at ``x_ref`` (cubic), in place of the absolute ``sigma`` and ``k3`` of an element on
its own. Coulomb friction has two forms: rate-dependent (``tanh(v / v_eps)``) in time
integration and rate-independent (Dahl, pre-sliding stiffness ``sigma``) in a
quasi-static sweep, where there is no velocity.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from suspenv.core.space import Parameter
from suspenv.models.effects import (
    asymmetry,
    friction,
    hysteresis,
    laws,
    sensor,
    viscoelastic,
)
from suspenv.models.effects._util import batch_param as bp
from suspenv.models.effects.effect import EffectKind, register_kind


def _p(
    name: str, low: float, high: float, unit: str, default: float, desc: str, log: bool = False
) -> Parameter:
    return Parameter(name, low, high, unit=unit, log=log, default=default, description=desc)


#: the domains of the laws' parameters (``EffectKind.domain``): above 0, at least 0, at least 1
_POSITIVE, _NONNEGATIVE, _AT_LEAST_ONE = (0.0, True), (0.0, False), (1.0, False)


def _law(kind: str) -> Callable[..., Any]:
    """The force of a stateless kind: its law (:data:`.laws.STATELESS`), batch-shaped."""
    law, inputs, names = laws.STATELESS[kind]
    return lambda x, v, t, **p: law(
        *{"x": (x,), "v": (v,), "xv": (x, v)}[inputs], *(bp(p[n]) for n in names)
    )


def _force(
    kind: str,
    words: str,
    parameters: tuple[Parameter, ...],
    signature: str,
    apply: Callable[..., Any] | None = None,
    *,
    needs_time: bool = False,
    fit_fixed: tuple[str, ...] = (),
    domain: Mapping[str, tuple[float, bool]] | None = None,
) -> EffectKind:
    """A force-role kind; its force is the stateless law of the same key (:func:`_law`)
    unless ``apply`` is given."""
    return EffectKind(
        kind,
        words,
        "force",
        parameters,
        signature,
        apply or _law(kind),
        needs_time=needs_time,
        fit_fixed=fit_fixed,
        domain=domain or {},
    )


V_EPS = _p("v_eps", 1e-5, 0.1, "m/s", 1e-3, "velocity width of the regularised step", log=True)

KINDS = (
    _force(
        "coulomb_friction",
        "Coulomb friction",
        (
            _p("f_c", 0.0, 5000.0, "N", 20.0, "Coulomb friction force level"),
            V_EPS,
            _p(
                "sigma",
                1e2,
                1e9,
                "N/m",
                2e6,
                "pre-sliding stiffness of the rate-independent (Dahl) form in quasi-static sweeps",
                log=True,
            ),
        ),
        "step at every velocity reversal; loop width independent of amplitude and rate",
        domain={"v_eps": _POSITIVE},
        fit_fixed=("v_eps", "sigma"),
    ),
    _force(
        "directional_friction",
        "direction-dependent Coulomb friction",
        (
            _p("f_pos", 0.0, 5000.0, "N", 20.0, "friction level sliding in +x"),
            _p("f_neg", 0.0, 5000.0, "N", 20.0, "friction level sliding in -x"),
            V_EPS,
        ),
        "reversal steps of different size in each direction; indistinguishable from a "
        "constant offset plus symmetric friction unless the test holds each direction",
        domain={"v_eps": _POSITIVE},
        fit_fixed=("v_eps",),
    ),
    _force(
        "stribeck_friction",
        "stiction with Stribeck decay",
        (
            _p("f_c", 0.0, 5000.0, "N", 20.0, "Coulomb (sliding) friction level"),
            _p("f_s", 0.0, 10000.0, "N", 30.0, "static (breakaway) friction level"),
            _p("v_s", 1e-4, 1.0, "m/s", 0.01, "Stribeck velocity", log=True),
            V_EPS,
        ),
        "reversal step with an overshoot at low speed that decays with velocity",
        domain={"v_s": _POSITIVE, "v_eps": _POSITIVE},
        fit_fixed=("v_eps",),
    ),
    _force(
        "lugre_friction",
        "LuGre dynamic friction (pre-sliding and stiction)",
        (
            _p("sigma0", 1e2, 1e9, "N/m", 1e5, "bristle stiffness", log=True),
            _p("sigma1", 0.0, 1e5, "N s/m", 300.0, "bristle damping"),
            _p("f_c", 0.0, 5000.0, "N", 20.0, "Coulomb friction level"),
            _p("f_s", 0.0, 10000.0, "N", 30.0, "static friction level"),
            _p("v_s", 1e-4, 1.0, "m/s", 0.01, "Stribeck velocity", log=True),
        ),
        "reversal step with finite pre-sliding stiffness and stiction overshoot",
        lambda x, v, t, sigma0, sigma1, f_c, f_s, v_s: friction.lugre_series(
            v, t, sigma0, sigma1, f_c, f_s, v_s
        ),
        needs_time=True,
        fit_fixed=("sigma0", "sigma1"),
    ),
    _force(
        "dahl_hysteresis",
        "rubber bushing hysteresis (Dahl)",
        (
            _p("f_c", 0.0, 5000.0, "N", 50.0, "saturation hysteretic force"),
            _p("sigma", 1e2, 1e9, "N/m", 1e5, "initial stiffness after a reversal", log=True),
            _p(
                "sigma_ratio",
                1e-2,
                1e2,
                "",
                1.0,
                "initial stiffness after a reversal over the host's linear stiffness "
                "(used by a host with one, e.g. a bushing, in place of sigma)",
                log=True,
            ),
        ),
        "loop between loading and unloading branches; width roughly independent of rate, "
        "rounded (not stepped) at reversals",
        lambda x, v, t, f_c, sigma, sigma_ratio: hysteresis.dahl_path(x, sigma, f_c),
        fit_fixed=("sigma_ratio",),
    ),
    _force(
        "bouc_wen_hysteresis",
        "hysteresis (Bouc-Wen)",
        (
            _p("f_y", 0.0, 5000.0, "N", 50.0, "asymptotic hysteretic force"),
            _p("x_y", 1e-6, 0.05, "m", 1e-3, "yield displacement", log=True),
            _p("shape", 0.0, 1.0, "", 0.5, "loop shape b = beta/(beta+gamma)"),
            _p("n", 1.0, 5.0, "", 1.0, "knee sharpness"),
        ),
        "loop between loading and unloading branches; width roughly independent of rate",
        lambda x, v, t, f_y, x_y, shape, n: hysteresis.bouc_wen_force_path(x, f_y, x_y, shape, n),
        fit_fixed=("n",),
    ),
    _force(
        "berg_hysteresis",
        "rubber bushing hysteresis (Berg friction)",
        (
            _p("f_max", 0.0, 5000.0, "N", 50.0, "limit friction force"),
            _p("x2", 1e-6, 0.05, "m", 1e-3, "travel to half the limit force", log=True),
        ),
        "loop between loading and unloading branches; width roughly independent of rate, "
        "hyperbolic (not exponential) approach after a reversal",
        lambda x, v, t, f_max, x2: hysteresis.berg_path(x, f_max, x2),
    ),
    _force(
        "cubic_stiffness",
        "progressive (cubic) stiffness",
        (
            _p("k3", -1e12, 1e12, "N/m^3", 1e6, "cubic stiffness coefficient"),
            _p(
                "ratio",
                0.0,
                10.0,
                "",
                0.1,
                "cubic over linear force at x_ref beside the host's linear stiffness k, "
                "k3 = ratio k / x_ref^2 (used by a host with one, e.g. a bushing, in place "
                "of k3)",
            ),
            _p("x_ref", 1e-5, 0.1, "m", 1e-3, "reference deflection of ratio", log=True),
            _p(
                "x_0",
                -10.0,
                10.0,
                "m",
                0.0,
                "neutral position: the deflection at which the cubic force is zero (a host "
                "whose deflection is not measured from it, e.g. a guide's position, fits it)",
            ),
        ),
        "odd-symmetric residual growing with the cube of amplitude; 3rd harmonic",
        fit_fixed=("ratio", "x_ref", "x_0"),
    ),
    _force(
        "progressive_stiffness",
        "progressive stiffness beyond a free range",
        (
            _p("k_p", 0.0, 1e10, "N/m^2", 1e6, "quadratic stiffening coefficient"),
            _p("x0", 0.0, 0.2, "m", 0.0, "free range before stiffening"),
        ),
        "odd-symmetric residual beyond |x| > x0 growing with amplitude",
        domain={"x0": _NONNEGATIVE},
    ),
    _force(
        "bump_stop",
        "bump stop contact",
        (
            _p("gap", 0.0, 0.3, "m", 0.03, "free travel before contact (compression)"),
            _p("k_stop", 0.0, 1e8, "N/m^p", 1e5, "stop stiffness"),
            _p("p", 1.0, 3.0, "", 1.0, "stop force exponent"),
        ),
        "residual only beyond a compression travel threshold; one-sided",
        domain={"gap": _NONNEGATIVE, "k_stop": _NONNEGATIVE, "p": _AT_LEAST_ONE},
        fit_fixed=("p",),
    ),
    _force(
        "rebound_stop",
        "rebound stop contact",
        (
            _p("gap", 0.0, 0.3, "m", 0.05, "free travel before contact (extension)"),
            _p("k_stop", 0.0, 1e8, "N/m^p", 1e5, "stop stiffness"),
            _p("p", 1.0, 3.0, "", 1.0, "stop force exponent"),
        ),
        "residual only beyond an extension travel threshold; one-sided",
        domain={"gap": _NONNEGATIVE, "k_stop": _NONNEGATIVE, "p": _AT_LEAST_ONE},
        fit_fixed=("p",),
    ),
    _force(
        "bump_and_rebound_stops",
        "bump and rebound stop contact",
        (
            _p("gap_bump", 0.0, 0.3, "m", 0.03, "free travel before bump contact"),
            _p("k_bump", 0.0, 1e8, "N/m^p", 1e5, "bump stop stiffness"),
            _p("gap_rebound", 0.0, 0.3, "m", 0.05, "free travel before rebound contact"),
            _p("k_rebound", 0.0, 1e8, "N/m^p", 1e5, "rebound stop stiffness"),
            _p("p", 1.0, 3.0, "", 1.0, "stop force exponent (both stops)"),
        ),
        "residual only beyond a compression threshold and beyond an extension threshold, "
        "each side with its own onset and slope",
        domain={
            "gap_bump": _NONNEGATIVE,
            "k_bump": _NONNEGATIVE,
            "gap_rebound": _NONNEGATIVE,
            "k_rebound": _NONNEGATIVE,
            "p": _AT_LEAST_ONE,
        },
        fit_fixed=("p",),
    ),
    _force(
        "digressive_damping",
        "digressive damper curve (blow-off)",
        (
            _p("c_low", 0.0, 1e6, "N s/m", 2000.0, "extra low-speed damping below the knee"),
            _p("v_knee", 1e-3, 5.0, "m/s", 0.1, "knee velocity", log=True),
        ),
        "residual odd in velocity, large at low speed, saturating above the knee",
        domain={"v_knee": _POSITIVE},
    ),
    _force(
        "asymmetric_digressive_damping",
        "asymmetric digressive damper curve (separate bump and rebound valve stacks)",
        (
            _p("c_bump", 0.0, 1e6, "N s/m", 2000.0, "extra low-speed damping in bump (v > 0)"),
            _p("v_knee_bump", 1e-3, 5.0, "m/s", 0.1, "knee velocity in bump", log=True),
            _p("c_rebound", 0.0, 1e6, "N s/m", 2000.0, "extra low-speed damping in rebound"),
            _p("v_knee_rebound", 1e-3, 5.0, "m/s", 0.1, "knee velocity in rebound", log=True),
        ),
        "residual depending on the sign and size of velocity: a digressive curve with a "
        "different slope or knee in bump and in rebound",
        domain={"v_knee_bump": _POSITIVE, "v_knee_rebound": _POSITIVE},
    ),
    _force(
        "damper_asymmetry",
        "damper bump/rebound asymmetry",
        (_p("dc_rebound", -1e6, 1e6, "N s/m", 1000.0, "extra damping in rebound (v < 0)"),),
        "residual correlated with the sign of velocity: present in rebound only",
    ),
    _force(
        "maxwell_viscoelastic",
        "viscoelastic lag (Maxwell element)",
        (
            _p("k_m", 1.0, 1e9, "N/m", 1e5, "series spring stiffness", log=True),
            _p("c_m", 1e-2, 1e8, "N s/m", 1e3, "series dashpot coefficient", log=True),
        ),
        "rate-dependent loop width; phase lead atan(1/(w tau)) changing with frequency",
        lambda x, v, t, k_m, c_m: viscoelastic.maxwell_series(x, t, k_m, c_m),
        needs_time=True,
    ),
    _force(
        "low_speed_deficit",
        "force missing around zero speed (a velocity dead band)",
        (
            _p("f_d", 0.0, 5000.0, "N", 20.0, "force missing beyond the band"),
            _p("v_band", 1e-4, 10.0, "m/s", 0.05, "speed over which it goes missing", log=True),
        ),
        "a step against the motion at every reversal, spread over a band of speed: the "
        "force a friction step would add, missing (a probe of the component diagnosis, "
        "fitted after its last named element; not a candidate: friction cannot be negative)",
        domain={"v_band": _POSITIVE},
    ),
    _force(
        "kelvin_voigt",
        "parallel spring and dashpot (Kelvin-Voigt)",
        (
            _p("k", -1e9, 1e9, "N/m", 0.0, "parallel stiffness"),
            _p("c", -1e6, 1e6, "N s/m", 0.0, "parallel damping"),
        ),
        "residual in phase with displacement and/or velocity",
    ),
    _force(
        "gas_spring",
        "gas spring force (preload plus stiffness)",
        (
            _p("f_0", -1e5, 1e5, "N", 100.0, "force at zero deflection (preload)"),
            _p("k_gas", -1e7, 1e7, "N/m", 1000.0, "gas stiffness"),
        ),
        "residual constant plus proportional to displacement, no loop",
    ),
    _force(
        "force_offset",
        "constant force offset",
        (_p("offset", -1e5, 1e5, "N", 0.0, "constant force"),),
        "constant residual independent of motion",
    ),
    EffectKind(
        "sensor_offset",
        "sensor offset (zero error)",
        "sensor",
        (_p("offset", -1e6, 1e6, "", 0.0, "offset in the channel's unit"),),
        "constant residual",
        lambda y, t, offset: sensor.sensor_offset_gain(y, bp(offset), 1.0),
    ),
    EffectKind(
        "sensor_gain",
        "sensor gain (calibration) error",
        "sensor",
        (_p("gain", 0.1, 10.0, "", 1.0, "gain factor", log=True),),
        "residual proportional to the signal",
        lambda y, t, gain: sensor.sensor_offset_gain(y, 0.0, bp(gain)),
    ),
    EffectKind(
        "sensor_lag",
        "sensor lag (first-order filter)",
        "sensor",
        (_p("tau", 0.0, 1.0, "s", 0.005, "time constant"),),
        "residual proportional to the signal's derivative; phase lag atan(w tau)",
        lambda y, t, tau: sensor.sensor_lag(y, t, tau),
        needs_time=True,
    ),
    EffectKind(
        "sensor_delay",
        "pure time delay of the sensor (transport or digital-filter delay)",
        "sensor",
        (_p("delay", 0.0, 1.0, "s", 0.005, "delay"),),
        "residual proportional to the signal's derivative at small delays; phase lag "
        "w delay at unit gain",
        lambda y, t, delay: sensor.sensor_delay(y, t, delay),
        needs_time=True,
    ),
    EffectKind(
        "zero_drift",
        "sensor zero drift (slow, smooth in time)",
        "sensor",
        (
            _p("rate", -1e6, 1e6, "", 0.0, "drift rate, in the channel's unit per second"),
            _p("bow", -1e6, 1e6, "", 0.0, "quadratic part over the span, in the channel's unit"),
            _p("wave", -1e6, 1e6, "", 0.0, "cubic part over the span, in the channel's unit"),
            _p("span", 1e-3, 1e7, "s", 1.0, "time span the drift shape is defined over"),
        ),
        "slow trend in time, independent of the motion",
        lambda y, t, rate, bow, wave, span: sensor.sensor_drift(
            y, t, bp(rate), bp(bow), bp(wave), bp(span)
        ),
        fit_fixed=("span",),
        needs_time=True,
    ),
    EffectKind(
        "lr_asymmetry",
        "left/right manufacturing asymmetry",
        "pair",
        (),
        "left minus right differs; opposite-travel curves not antisymmetric",
        lambda nominal, delta, relative=True: asymmetry.split_pair(nominal, delta, relative),
        host_parameters="d_",
    ),
)

for _kind in KINDS:
    register_kind(_kind, replace=True)
