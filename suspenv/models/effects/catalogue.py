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

import re
from collections.abc import Callable
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

#: the domain marks of :data:`_PARAMETERS`: a law needs the value above 0, at least 0,
#: at least 1 (``EffectKind.domain``: bound, strict)
_DOMAIN_MARKS = {">0": (0.0, True), ">=0": (0.0, False), ">=1": (1.0, False)}


def _parameter_table(
    text: str,
) -> tuple[dict[str, tuple[Parameter, ...]], dict[str, dict[str, tuple[float, bool]]]]:
    """The parameters and domains of every kind from a table: a line ``[kind]``, then one
    line per parameter, ``name low high default [log] [domain] [unit]: description``
    (``log``: the unit interval maps to the range logarithmically; ``domain``: a mark of
    :data:`_DOMAIN_MARKS` where the law needs one; no unit: dimensionless), the
    description continued on indented lines."""
    tables: dict[str, list[Parameter]] = {}
    domains: dict[str, dict[str, tuple[float, bool]]] = {}
    for row in re.split(r"\n(?=\S)", text.strip()):
        line = " ".join(row.split())
        if line.startswith("["):
            kind = tables.setdefault(line.strip("[]"), [])
            domain = domains.setdefault(line.strip("[]"), {})
            continue
        head, _, description = line.partition(": ")
        name, low, high, default, *unit = head.split()
        log = unit[:1] == ["log"]
        unit = unit[1:] if log else unit
        if unit[:1] and unit[0] in _DOMAIN_MARKS:
            domain[name] = _DOMAIN_MARKS[unit.pop(0)]
        lo, hi, ref = (float(v) for v in (low, high, default))
        kind.append(Parameter(name, lo, hi, " ".join(unit), log, ref, description))
    return {k: tuple(v) for k, v in tables.items()}, domains


#: the parameters of every kind, SI units, and the domains their laws need
#: (:func:`_parameter_table`)
_PARAMETERS, _DOMAINS = _parameter_table("""
[coulomb_friction]
f_c               0.0  5000.0    20.0  N: Coulomb friction force level
v_eps            1e-5     0.1    1e-3  log >0 m/s: velocity width of the regularised step
sigma             1e2     1e9     2e6  log N/m: pre-sliding stiffness of the rate-independent
    (Dahl) form in quasi-static sweeps
[directional_friction]
f_pos             0.0  5000.0    20.0  N: friction level sliding in +x
f_neg             0.0  5000.0    20.0  N: friction level sliding in -x
v_eps            1e-5     0.1    1e-3  log >0 m/s: velocity width of the regularised step
[stribeck_friction]
f_c               0.0  5000.0    20.0  N: Coulomb (sliding) friction level
f_s               0.0 10000.0    30.0  N: static (breakaway) friction level
v_s              1e-4     1.0    0.01  log >0 m/s: Stribeck velocity
v_eps            1e-5     0.1    1e-3  log >0 m/s: velocity width of the regularised step
[lugre_friction]
sigma0            1e2     1e9     1e5  log N/m: bristle stiffness
sigma1            0.0     1e5   300.0  N s/m: bristle damping
f_c               0.0  5000.0    20.0  N: Coulomb friction level
f_s               0.0 10000.0    30.0  N: static friction level
v_s              1e-4     1.0    0.01  log m/s: Stribeck velocity
[dahl_hysteresis]
f_c               0.0  5000.0    50.0  N: saturation hysteretic force
sigma             1e2     1e9     1e5  log N/m: initial stiffness after a reversal
sigma_ratio      1e-2     1e2     1.0  log: initial stiffness after a reversal over the host's
    linear stiffness (used by a host with one, e.g. a bushing, in place of sigma)
[bouc_wen_hysteresis]
f_y               0.0  5000.0    50.0  N: asymptotic hysteretic force
x_y              1e-6    0.05    1e-3  log m: yield displacement
shape             0.0     1.0     0.5: loop shape b = beta/(beta+gamma)
n                 1.0     5.0     1.0: knee sharpness
[berg_hysteresis]
f_max             0.0  5000.0    50.0  N: limit friction force
x2               1e-6    0.05    1e-3  log m: travel to half the limit force
[cubic_stiffness]
k3              -1e12    1e12     1e6  N/m^3: cubic stiffness coefficient
ratio             0.0    10.0     0.1: cubic over linear force at x_ref beside the host's
    linear stiffness k, k3 = ratio k / x_ref^2 (used by a host with one, e.g. a bushing, in
    place of k3)
x_ref            1e-5     0.1    1e-3  log m: reference deflection of ratio
x_0             -10.0    10.0     0.0  m: neutral position: the deflection at which the cubic
    force is zero (a host whose deflection is not measured from it, e.g. a guide's position,
    fits it)
[progressive_stiffness]
k_p               0.0    1e10     1e6  N/m^2: quadratic stiffening coefficient
x0                0.0     0.2     0.0  >=0 m: free range before stiffening
[bump_stop]
gap               0.0     0.3    0.03  >=0 m: free travel before contact (compression)
k_stop            0.0     1e8     1e5  >=0 N/m^p: stop stiffness
p                 1.0     3.0     1.0  >=1: stop force exponent
[rebound_stop]
gap               0.0     0.3    0.05  >=0 m: free travel before contact (extension)
k_stop            0.0     1e8     1e5  >=0 N/m^p: stop stiffness
p                 1.0     3.0     1.0  >=1: stop force exponent
[bump_and_rebound_stops]
gap_bump          0.0     0.3    0.03  >=0 m: free travel before bump contact
k_bump            0.0     1e8     1e5  >=0 N/m^p: bump stop stiffness
gap_rebound       0.0     0.3    0.05  >=0 m: free travel before rebound contact
k_rebound         0.0     1e8     1e5  >=0 N/m^p: rebound stop stiffness
p                 1.0     3.0     1.0  >=1: stop force exponent (both stops)
[digressive_damping]
c_low             0.0     1e6  2000.0  N s/m: extra low-speed damping below the knee
v_knee           1e-3     5.0     0.1  log >0 m/s: knee velocity
[asymmetric_digressive_damping]
c_bump            0.0     1e6  2000.0  N s/m: extra low-speed damping in bump (v > 0)
v_knee_bump      1e-3     5.0     0.1  log >0 m/s: knee velocity in bump
c_rebound         0.0     1e6  2000.0  N s/m: extra low-speed damping in rebound
v_knee_rebound   1e-3     5.0     0.1  log >0 m/s: knee velocity in rebound
[damper_asymmetry]
dc_rebound       -1e6     1e6  1000.0  N s/m: extra damping in rebound (v < 0)
[maxwell_viscoelastic]
k_m               1.0     1e9     1e5  log N/m: series spring stiffness
c_m              1e-2     1e8     1e3  log N s/m: series dashpot coefficient
[low_speed_deficit]
f_d               0.0  5000.0    20.0  N: force missing beyond the band
v_band           1e-4    10.0    0.05  log >0 m/s: speed over which it goes missing
[kelvin_voigt]
k                -1e9     1e9     0.0  N/m: parallel stiffness
c                -1e6     1e6     0.0  N s/m: parallel damping
[gas_spring]
f_0              -1e5     1e5   100.0  N: force at zero deflection (preload)
k_gas            -1e7     1e7  1000.0  N/m: gas stiffness
[force_offset]
offset           -1e5     1e5     0.0  N: constant force
[sensor_offset]
offset           -1e6     1e6     0.0: offset in the channel's unit
[sensor_gain]
gain              0.1    10.0     1.0  log: gain factor
[sensor_lag]
tau               0.0     1.0   0.005  s: time constant
[sensor_delay]
delay             0.0     1.0   0.005  s: delay
[zero_drift]
rate             -1e6     1e6     0.0: drift rate, in the channel's unit per second
bow              -1e6     1e6     0.0: quadratic part over the span, in the channel's unit
wave             -1e6     1e6     0.0: cubic part over the span, in the channel's unit
span             1e-3     1e7     1.0  s: time span the drift shape is defined over
[lr_asymmetry]
""")


def _law(kind: str) -> Callable[..., Any]:
    """The force of a stateless kind: its law (:data:`.laws.STATELESS`), batch-shaped."""
    law, inputs, names = laws.STATELESS[kind]
    return lambda x, v, t, **p: law(
        *{"x": (x,), "v": (v,), "xv": (x, v)}[inputs], *(bp(p[n]) for n in names)
    )


def _force(
    kind: str,
    words: str,
    signature: str,
    apply: Callable[..., Any] | None = None,
    *,
    needs_time: bool = False,
    fit_fixed: tuple[str, ...] = (),
) -> EffectKind:
    """A force-role kind with the parameters and domains of :data:`_PARAMETERS`; its force
    is the stateless law of the same key (:func:`_law`) unless ``apply`` is given."""
    return EffectKind(
        kind,
        words,
        "force",
        _PARAMETERS[kind],
        signature,
        apply or _law(kind),
        needs_time=needs_time,
        fit_fixed=fit_fixed,
        domain=_DOMAINS[kind],
    )


KINDS = (
    _force(
        "coulomb_friction",
        "Coulomb friction",
        "step at every velocity reversal; loop width independent of amplitude and rate",
        fit_fixed=("v_eps", "sigma"),
    ),
    _force(
        "directional_friction",
        "direction-dependent Coulomb friction",
        "reversal steps of different size in each direction; indistinguishable from a "
        "constant offset plus symmetric friction unless the test holds each direction",
        fit_fixed=("v_eps",),
    ),
    _force(
        "stribeck_friction",
        "stiction with Stribeck decay",
        "reversal step with an overshoot at low speed that decays with velocity",
        fit_fixed=("v_eps",),
    ),
    _force(
        "lugre_friction",
        "LuGre dynamic friction (pre-sliding and stiction)",
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
        "loop between loading and unloading branches; width roughly independent of rate, "
        "rounded (not stepped) at reversals",
        lambda x, v, t, f_c, sigma, sigma_ratio: hysteresis.dahl_path(x, sigma, f_c),
        fit_fixed=("sigma_ratio",),
    ),
    _force(
        "bouc_wen_hysteresis",
        "hysteresis (Bouc-Wen)",
        "loop between loading and unloading branches; width roughly independent of rate",
        lambda x, v, t, f_y, x_y, shape, n: hysteresis.bouc_wen_force_path(x, f_y, x_y, shape, n),
        fit_fixed=("n",),
    ),
    _force(
        "berg_hysteresis",
        "rubber bushing hysteresis (Berg friction)",
        "loop between loading and unloading branches; width roughly independent of rate, "
        "hyperbolic (not exponential) approach after a reversal",
        lambda x, v, t, f_max, x2: hysteresis.berg_path(x, f_max, x2),
    ),
    _force(
        "cubic_stiffness",
        "progressive (cubic) stiffness",
        "odd-symmetric residual growing with the cube of amplitude; 3rd harmonic",
        fit_fixed=("ratio", "x_ref", "x_0"),
    ),
    _force(
        "progressive_stiffness",
        "progressive stiffness beyond a free range",
        "odd-symmetric residual beyond |x| > x0 growing with amplitude",
    ),
    _force(
        "bump_stop",
        "bump stop contact",
        "residual only beyond a compression travel threshold; one-sided",
        fit_fixed=("p",),
    ),
    _force(
        "rebound_stop",
        "rebound stop contact",
        "residual only beyond an extension travel threshold; one-sided",
        fit_fixed=("p",),
    ),
    _force(
        "bump_and_rebound_stops",
        "bump and rebound stop contact",
        "residual only beyond a compression threshold and beyond an extension threshold, "
        "each side with its own onset and slope",
        fit_fixed=("p",),
    ),
    _force(
        "digressive_damping",
        "digressive damper curve (blow-off)",
        "residual odd in velocity, large at low speed, saturating above the knee",
    ),
    _force(
        "asymmetric_digressive_damping",
        "asymmetric digressive damper curve (separate bump and rebound valve stacks)",
        "residual depending on the sign and size of velocity: a digressive curve with a "
        "different slope or knee in bump and in rebound",
    ),
    _force(
        "damper_asymmetry",
        "damper bump/rebound asymmetry",
        "residual correlated with the sign of velocity: present in rebound only",
    ),
    _force(
        "maxwell_viscoelastic",
        "viscoelastic lag (Maxwell element)",
        "rate-dependent loop width; phase lead atan(1/(w tau)) changing with frequency",
        lambda x, v, t, k_m, c_m: viscoelastic.maxwell_series(x, t, k_m, c_m),
        needs_time=True,
    ),
    _force(
        "low_speed_deficit",
        "force missing around zero speed (a velocity dead band)",
        "a step against the motion at every reversal, spread over a band of speed: the "
        "force a friction step would add, missing (a probe of the component diagnosis, "
        "fitted after its last named element; not a candidate: friction cannot be negative)",
    ),
    _force(
        "kelvin_voigt",
        "parallel spring and dashpot (Kelvin-Voigt)",
        "residual in phase with displacement and/or velocity",
    ),
    _force(
        "gas_spring",
        "gas spring force (preload plus stiffness)",
        "residual constant plus proportional to displacement, no loop",
    ),
    _force(
        "force_offset",
        "constant force offset",
        "constant residual independent of motion",
    ),
    EffectKind(
        "sensor_offset",
        "sensor offset (zero error)",
        "sensor",
        _PARAMETERS["sensor_offset"],
        "constant residual",
        lambda y, t, offset: sensor.sensor_offset_gain(y, bp(offset), 1.0),
        shift=True,
    ),
    EffectKind(
        "sensor_gain",
        "sensor gain (calibration) error",
        "sensor",
        _PARAMETERS["sensor_gain"],
        "residual proportional to the signal",
        lambda y, t, gain: sensor.sensor_offset_gain(y, 0.0, bp(gain)),
    ),
    EffectKind(
        "sensor_lag",
        "sensor lag (first-order filter)",
        "sensor",
        _PARAMETERS["sensor_lag"],
        "residual proportional to the signal's derivative; phase lag atan(w tau)",
        sensor.sensor_lag,
        needs_time=True,
    ),
    EffectKind(
        "sensor_delay",
        "pure time delay of the sensor (transport or digital-filter delay)",
        "sensor",
        _PARAMETERS["sensor_delay"],
        "residual proportional to the signal's derivative at small delays; phase lag "
        "w delay at unit gain",
        sensor.sensor_delay,
        needs_time=True,
    ),
    EffectKind(
        "zero_drift",
        "sensor zero drift (slow, smooth in time)",
        "sensor",
        _PARAMETERS["zero_drift"],
        "slow trend in time, independent of the motion",
        lambda y, t, rate, bow, wave, span: sensor.sensor_drift(
            y, t, bp(rate), bp(bow), bp(wave), bp(span)
        ),
        fit_fixed=("span",),
        needs_time=True,
        shift=True,
    ),
    EffectKind(
        "lr_asymmetry",
        "left/right manufacturing asymmetry",
        "pair",
        _PARAMETERS["lr_asymmetry"],
        "left minus right differs; opposite-travel curves not antisymmetric",
        lambda nominal, delta, relative=True: asymmetry.split_pair(nominal, delta, relative),
        host_parameters="d_",
    ),
)

for _kind in KINDS:
    register_kind(_kind, replace=True)
