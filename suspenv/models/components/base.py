"""Component models as "base + effects", with one interface for fitting and diagnosis.

A :class:`ComponentModel` predicts the output channels of a :class:`Recording`
from its input channels and a parameter vector ``theta``: the base model's
parameters first, then the free parameters of each effect in order, named
``"<effect name>.<parameter>"``. Effect parameters listed in the kind's
``fit_fixed`` (regularisation widths, exponents) are not in ``theta``; they keep
the value stored in the :class:`Effect`.

``theta`` may be one vector ``(p,)`` or a batch ``(B, p)``; predictions are then
``(N,)`` or ``(B, N)`` per channel. Units SI; each subclass states its frame and
sign conventions.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, Self

import numpy as np
from scipy.signal import butter, sosfiltfilt

from suspenv.core.errors import ValidationError
from suspenv.core.options import positive
from suspenv.core.space import Parameter
from suspenv.measurements import Recording
from suspenv.models.effects import Effect
from suspenv.models.effects._util import batch_param as bp

#: the friction kinds whose velocity width ``v_eps`` a component model fits
#: (:attr:`ComponentModel.freed_parameters`)
FRICTION_WIDTHS: Mapping[str, tuple[str, ...]] = {
    "coulomb_friction": ("v_eps",),
    "stribeck_friction": ("v_eps",),
    "directional_friction": ("v_eps",),
}

#: LuGre's bristles, where a model fits them (a guide's contact, a damper's seal): the
#: stiffness ``sigma0`` [N/m] sets the pre-sliding displacement ``f_c / sigma0``, and the
#: damping ``sigma1`` [N s/m] is fitted with it (the library's fixed 300 N s/m belongs to
#: its default 1e5 N/m: beside a fitted stiffness of 1e4 N/m it is a bristle time
#: ``sigma1 / sigma0`` of 30 ms, where a contact's is under a millisecond)
LUGRE_BRISTLES: tuple[str, ...] = ("sigma0", "sigma1")


#: meta key of a recording whose output channels were low-passed (zero phase, at this
#: cut-off [Hz]) together with its motion channels; the prediction is then low-passed
#: alike (:meth:`ComponentModel.simulate`)
OUTPUT_LOWPASS_KEY = "output_lowpass_hz"
#: order of the zero-phase Butterworth low-pass (each way)
LOWPASS_ORDER = 4
#: length [periods of the cut-off] by which :func:`lowpass` extends each end of a record
#: before filtering: the filter's response to the extension's far end has died out long
#: before the record starts
LOWPASS_PAD_PERIODS = 3.0
#: samples [periods of the cut-off] at each end of a record that give :func:`lowpass` the
#: end's value and curvature (a least-squares quadratic: on a noisy channel its value is
#: the mean of many samples, not the last one's noise)
LOWPASS_END_PERIODS = 0.5


@functools.lru_cache(maxsize=64)
def butterworth(fc: float, fs: float) -> np.ndarray:
    """Second-order sections (read-only) of the :data:`LOWPASS_ORDER` Butterworth
    low-pass at ``fc`` [Hz] for sampling at ``fs`` [Hz] (a diagnosis filters thousands of
    predictions with one cut-off: designed once)."""
    sos = np.asarray(butter(LOWPASS_ORDER, float(fc), fs=float(fs), output="sos"))
    sos.flags.writeable = False
    return sos


def lowpass(y: np.ndarray, fs: float, fc: float) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``y`` along its last axis at ``fc`` [Hz],
    sampled at ``fs`` [Hz] (order :data:`LOWPASS_ORDER` each way).

    Each end is extended by :data:`LOWPASS_PAD_PERIODS` periods of the cut-off before
    filtering: the record reflected through the end's value with the end's curvature
    kept, both from a quadratic fitted to the last :data:`LOWPASS_END_PERIODS` periods
    (``q(j) + q(-j) - y(-j)`` at ``j`` samples beyond the end, ``q`` that quadratic),
    its departure from the end value tapered to nothing at the far end
    (:func:`_end_taper`), where the filter starts from rest at that value. A motion
    curved at the record's end and the noise of its last sample then start no
    transient; the plain odd extension through the end sample starts both (on a guide's
    noisy acceleration channel, a transient of the whole mass's force for half a second
    at either end). Linear in ``y``, like the filter.
    """
    y = np.asarray(y, float)
    sos = butterworth(float(fc), float(fs)).copy()  # scipy's filter takes a writeable array
    n = y.shape[-1]
    if n < 8:
        return np.asarray(sosfiltfilt(sos, y, axis=-1))
    pad = min(n - 1, int(np.ceil(LOWPASS_PAD_PERIODS * float(fs) / float(fc))))
    w = max(5, min(n, int(np.ceil(LOWPASS_END_PERIODS * float(fs) / float(fc)))))
    fit = _end_quadratic(w)  # (3, w): value, slope, curvature at the end sample
    j = np.arange(1, pad + 1, dtype=float)
    taper = _end_taper(pad)

    def beyond(inward: np.ndarray) -> np.ndarray:  # the samples from an end inwards
        coef = inward[..., :w] @ fit.T
        away = coef[..., :1] + 2.0 * coef[..., 2:3] * j * j - inward[..., 1 : pad + 1]
        return coef[..., :1] + taper * away

    ext = np.concatenate([beyond(y)[..., ::-1], y, beyond(y[..., ::-1])], axis=-1)
    return np.asarray(sosfiltfilt(sos, ext, axis=-1, padtype=None)[..., pad : pad + n])


@functools.lru_cache(maxsize=16)
def _end_taper(pad: int) -> np.ndarray:
    """Weights (pad,) of the extension's departure from the end value: 1 over the first
    third, then a half cosine down to 0 at the far end, where the extension is the
    constant end value that the filter's initial state assumes."""
    u = np.clip((np.arange(1, pad + 1) / pad - 1.0 / 3.0) * 1.5, 0.0, 1.0)
    out = 0.5 * (1.0 + np.cos(np.pi * u))
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=16)
def _end_quadratic(w: int) -> np.ndarray:
    """Least-squares map (3, w) from ``w`` samples, the first at the end, to the
    coefficients of ``a + b j + c j^2`` (``j`` samples from the end)."""
    out = np.linalg.pinv(np.polynomial.polynomial.polyvander(np.arange(w, dtype=float), 2))
    out.flags.writeable = False
    return out


class FitDefaults:
    """The defaults of the members a diagnosis reads
    (``suspenv.diagnosis.protocols.DiagnosableModel``) that a model may lack: no
    shape constants of its own, no cheap start, the model itself as its Jacobian's
    twin, no force view; subclasses override what they have. Also the one map between
    ``theta`` and base values plus effects (:meth:`theta_from`, :meth:`unpack`), over a
    subclass's :attr:`base_names` and each effect's entries (:meth:`_free`)."""

    family: ClassVar[str] = ""
    effect_defaults: ClassVar[Mapping[str, Mapping[str, float]]] = {}
    effects: tuple[Effect, ...]

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the entries of ``theta``."""
        raise NotImplementedError

    @property
    def base_names(self) -> tuple[str, ...]:
        """Names of the fitted base parameters (the first entries of ``theta``)."""
        raise NotImplementedError

    @property
    def known_base(self) -> dict[str, float]:
        """Base parameters held at known values, not in ``theta``: none here."""
        return {}

    def _free(self, e: Effect) -> tuple[str, ...]:
        """Names of the parameters of effect ``e`` in ``theta``, in order."""
        raise NotImplementedError

    # ------------------------------------------------------------------ theta <-> values
    def theta_from(
        self, base: Mapping[str, float], effects: Sequence[Effect] | None = None
    ) -> np.ndarray:
        """``theta`` from base values and the effects' stored parameters (default: own effects)."""
        missing = [n for n in self.base_names if n not in base]
        if missing:
            raise ValidationError(f"{self.family}: base values missing {missing}")
        effs = self.effects if effects is None else tuple(effects)
        vals = [float(base[n]) for n in self.base_names]
        for e in effs:
            vals += [float(e.params[p]) for p in self._free(e)]
        return np.array(vals)

    def unpack(self, theta: np.ndarray) -> tuple[dict[str, np.ndarray], list[Effect]]:
        """Split ``theta`` ``(p,)`` or ``(B, p)`` into base values and effects with values set."""
        cols = np.moveaxis(self._checked_theta(theta), -1, 0)
        nb = len(self.base_names)
        base = {n: cols[i] for i, n in enumerate(self.base_names)}
        base.update({n: np.full(cols.shape[1:], v) for n, v in self.known_base.items()})
        effects, k = [], nb
        for e in self.effects:
            free = self._free(e)
            effects.append(e.with_params({q: cols[k + j] for j, q in enumerate(free)}))
            k += len(free)
        return base, effects

    def _checked_theta(self, theta: np.ndarray) -> np.ndarray:
        """``theta`` as floats, refused unless it is ``(p,)`` or ``(B, p)`` and finite."""
        th = np.asarray(theta, dtype=float)
        p = len(self.parameter_names)
        if th.shape[-1:] != (p,) or th.ndim > 2:
            raise ValidationError(
                f"{self.family}: theta must have shape ({p},) or (B, {p}) for parameters "
                f"{self.parameter_names}, but got {th.shape}"
            )
        if not np.all(np.isfinite(th)):
            raise ValidationError(f"{self.family}: theta must be finite, but got {th}")
        return th

    def refine_start(
        self,
        theta0: np.ndarray,
        recordings: Sequence[Recording],
        masks: Sequence[np.ndarray | None] | None = None,
    ) -> np.ndarray | None:
        """A cheap improvement of the fit's start point; None: this model has none."""
        return None

    def jacobian_model(self) -> Self:
        """A cheaper twin for finite-difference Jacobians; the model itself here."""
        return self

    def force_view(self, theta: np.ndarray, rec: Recording) -> dict[str, np.ndarray] | None:
        """The internal force seen through a measured equation; None: no such view."""
        return None


class ComponentModel(FitDefaults):
    """Base class: subclasses set the class attributes and implement ``_predict``.

    Class attributes:
        family: ``"damper"``, ``"mr_damper"``, ``"friction_guide"``, ``"quarter_car_rig"``.
        description: one line for reports.
        base_parameters: the base model's parameters (bounds, units).
        input_channels / output_channels: channel names read / predicted.
        channel_units: unit of every input and output channel.
        candidate_effects: effect kinds that make sense for this family.
        location: default location words of force effects (e.g. ``"damper"``).
        effect_defaults: per effect kind, shape constants this model fixes for the
            effects a diagnosis adds (empty: the effects library's defaults).
        device_words: per effect kind, the words of this device for it (a controllable
            damper's yield force is not "friction in the damper"); empty: the library's.
        freed_parameters: per effect kind, parameters the library holds fixed that this
            model fits: a friction step's velocity width ``v_eps`` [m/s] (a real step is
            not 1 mm/s wide by decree), LuGre's bristle stiffness ``sigma0`` [N/m] (the
            pre-sliding displacement ``f_c / sigma0`` of a guide's contact or a damper's
            seal) and bristle damping ``sigma1`` [N s/m] (:data:`LUGRE_BRISTLES`), a cubic
            spring's neutral position ``x_0`` [m] (a guide's position is not measured
            from it).
        viscous_parameter: the base parameter that is the component's viscous
            coefficient [N s/m] ("" when it has none); a Maxwell branch fitted to carry
            all of it is a lag of the whole force, not a parallel branch.
        output_lowpass: where the diagnosis low-passes the motion channels, also compare
            the outputs low-passed by the same filter (needs :meth:`linear_part`): the
            recorded outputs are low-passed, and so is the prediction's part that is not
            linear in the motion, while the linear part is computed from the low-passed
            motion, which carries the filter through it exactly.
        dwells_between_moves: the family's test holds the part still between moves (a
            guide's trajectory), where a hysteresis loop holds its force and friction
            does not: a small loop and friction's pre-sliding then compete on the data
            (``suspenv.diagnosis.component.plausible.check_loop_or_step``); on a test that
            keeps moving (a dyno's sines) the loop's width decides.
        optional_inputs: input channels read where a recording carries them (a quarter
            car rig's ``actuator_force``); :attr:`reads_inputs` lists every channel read.

    The members the diagnosis reads (``suspenv.diagnosis.protocols.DiagnosableModel``)
    are all defined here or in :class:`FitDefaults` with their defaults:
    ``difference_step`` (finite-difference step) and the others there.
    """

    description: ClassVar[str] = ""
    base_parameters: ClassVar[tuple[Parameter, ...]] = ()
    input_channels: ClassVar[tuple[str, ...]] = ()
    output_channels: ClassVar[tuple[str, ...]] = ()
    channel_units: ClassVar[dict[str, str]] = {}
    candidate_effects: ClassVar[tuple[str, ...]] = ()
    location: ClassVar[str] = ""
    freed_parameters: ClassVar[Mapping[str, tuple[str, ...]]] = {}
    device_words: ClassVar[Mapping[str, str]] = {}
    viscous_parameter: ClassVar[str] = ""
    output_lowpass: ClassVar[bool] = False
    dwells_between_moves: ClassVar[bool] = False
    optional_inputs: ClassVar[tuple[str, ...]] = ()

    def __init__(self, effects: Sequence[Effect] = (), **options: Any):
        self.effects: tuple[Effect, ...] = tuple(effects)
        self.options: dict[str, Any] = dict(options)
        all_base = [p.name for p in self.base_parameters]
        for name, value in dict(self.options.get("known_base", {})).items():
            if name not in all_base:
                raise ValidationError(
                    f"{self.family}: known base parameter {name!r} is not one of its base "
                    f"parameters {all_base}"
                )
            positive(self.family, f"known_base[{name!r}]", value)
        for e in self.effects:
            if not isinstance(e, Effect):
                raise ValidationError(
                    f"effects must be Effect instances, but got {type(e).__name__}"
                )
        names = [e.name for e in self.effects]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValidationError(f"effect names must be unique in a model, but got repeats {dup}")
        for e in self.effects:
            role = e.spec.role
            if role == "pair":
                raise ValidationError(
                    f"effect {e.name!r} ({e.kind}) is a left/right pair effect; "
                    f"{self.family} models have no left/right pair"
                )
            if role == "sensor" and self._sensor_channel(e) not in self.output_channels:
                raise ValidationError(
                    f"sensor effect {e.name!r} must be located on an output channel "
                    f"{self.output_channels}, but got location={e.location!r}"
                )
            self._check_effect(e)

    @property
    def reads_inputs(self) -> tuple[str, ...]:
        """Every input channel this model reads (required, then optional)."""
        return (*self.input_channels, *self.optional_inputs)

    # ------------------------------------------------------------------ hooks
    def _check_effect(self, effect: Effect) -> None:
        """Subclasses reject effects they cannot simulate."""

    def _predict(
        self, base: dict[str, np.ndarray], effects: Sequence[Effect], rec: Recording
    ) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def _base_guess(self, rec: Recording) -> dict[str, float]:
        return {p.name: p.reference for p in self.base_parameters}

    def _scales(self, rec: Recording) -> dict[str, float]:
        """Typical force [N], deflection [m] and velocity [m/s] amplitudes in ``rec``."""
        raise NotImplementedError

    # ------------------------------------------------------------------ names and bounds
    def _sensor_channel(self, e: Effect) -> str:
        return e.location or self.output_channels[0]

    @property
    def known_base(self) -> dict[str, float]:
        """Base parameters the user knows (option ``known_base``: name -> value, SI);
        they are held at their values and are not in ``theta``."""
        return dict(self.options.get("known_base", {}))

    @property
    def fitted_base_parameters(self) -> tuple[Parameter, ...]:
        """The base parameters in ``theta``: all but the known ones."""
        known = self.options.get("known_base", {})
        return tuple(p for p in self.base_parameters if p.name not in known)

    @property
    def base_names(self) -> tuple[str, ...]:
        """Names of the fitted base parameters (the first entries of ``theta``)."""
        return tuple(p.name for p in self.fitted_base_parameters)

    def _free(self, e: Effect) -> tuple[str, ...]:
        """The library's free parameters of ``e``, then those this model frees."""
        names = e.spec.free_parameter_names
        freed = self.freed_parameters.get(e.kind, ())
        return (*names, *(p for p in e.spec.parameter_names if p in freed and p not in names))

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Base parameter names, then ``"<effect>.<param>"`` for each effect's free parameters."""
        names = list(self.base_names)
        for e in self.effects:
            names += [f"{e.name}.{p}" for p in self._free(e)]
        return tuple(names)

    @property
    def parameter_units(self) -> tuple[str, ...]:
        units = [p.unit for p in self.fitted_base_parameters]
        for e in self.effects:
            units += [e.spec.parameter(p).unit for p in self._free(e)]
        return tuple(units)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of ``theta``.

        With the option ``scales`` (``{"force": F [N], "deflection": X [m], "velocity":
        V [m/s]}``, the recording's amplitudes) every bound is widened, never narrowed,
        to follow the data's scale (:func:`scaled_bound`): a 20 kN damper is not held
        under a 5 kN friction cap, a soft spring not over a 1 kN/m floor."""
        specs = list(self.fitted_base_parameters)
        for e in self.effects:
            specs += [e.spec.parameter(p) for p in self._free(e)]
        sc = self.options.get("scales")
        lo, hi = [], []
        for spec in specs:
            a, b = float(spec.low), float(spec.high)
            if sc:
                a, b = scaled_bound(a, b, spec.unit, sc)
            lo.append(a)
            hi.append(b)
        return np.array(lo, dtype=float), np.array(hi, dtype=float)

    # ------------------------------------------------------------------ guesses
    def initial_guess(self, rec: Recording) -> np.ndarray:
        """A start for fitting ``rec``: base values from a linear fit, effects from scales."""
        rec.require(self.input_channels, units=self._input_units())
        base = self._base_guess(rec)
        sc = self._scales(rec)
        guessed = [e.with_params(self._effect_guess(e, sc)) for e in self.effects]
        th = self.theta_from(base, guessed)
        lo, hi = self.bounds()
        return np.clip(th, lo, hi)

    def _effect_guess(self, e: Effect, sc: Mapping[str, float]) -> dict[str, float]:
        """Generic starting values by parameter meaning, from force/deflection/velocity scales."""
        f, x, v = sc["force"], sc["deflection"], sc["velocity"]
        g = {
            "f_c": 0.05 * f,
            "f_s": 0.07 * f,
            "f_pos": 0.05 * f,
            "f_neg": 0.05 * f,
            "f_y": 0.05 * f,
            "sigma": 0.05 * f / (0.1 * x),
            "x_y": 0.1 * x,
            "v_s": 0.1 * v,
            "k3": 0.0,
            "k_p": 0.0,
            "x0": 0.5 * x,
            "gap": 0.8 * x,
            "k_stop": 10.0 * f / x,
            "c_low": 0.2 * f / v,
            "v_knee": 0.3 * v,
            "dc_rebound": 0.0,
            "k_m": f / x,
            "c_m": 0.1 * f / v,
            "k": 0.0,
            "c": 0.0,
            "f_0": 0.0,
            "k_gas": 0.0,
            "offset": 0.0,
            "gain": 1.0,
            "tau": 0.005,
            "f_d": 0.05 * f,
            "v_band": 0.1 * v,
            # a pre-sliding displacement of 0.1 % of the stroke amplitude
            "sigma0": 0.05 * f / (1e-3 * x),
            # the middle of the travel where the model's scales give one (a guide's)
            "x_0": sc.get("centre", 0.0),
        }
        return {p: g[p] for p in self._free(e) if p in g}

    # ------------------------------------------------------------------ simulation
    def _input_units(self) -> dict[str, str]:
        return {c: self.channel_units[c] for c in self.input_channels}

    def simulate(self, theta: np.ndarray, rec: Recording) -> dict[str, np.ndarray]:
        """Predicted output channels (same names and units as the model's outputs)."""
        rec.require(self.input_channels, units=self._input_units())
        base, effects = self.unpack(theta)
        force_effects = [e for e in effects if e.spec.role == "force"]
        out = self._predict(base, force_effects, rec)
        fc = rec.meta.get(OUTPUT_LOWPASS_KEY) if isinstance(rec.meta, Mapping) else None
        linear = self.linear_part(base, rec) if fc else None
        if linear is not None and fc is not None:
            # outputs compared low-passed: the linear part is exact from the low-passed
            # motion; the rest (the elements' forces) is low-passed by the same filter
            fs = 1.0 / float(np.median(np.diff(np.asarray(rec.time, float))))
            for ch, part in linear.items():
                out[ch] = part + lowpass(out[ch] - part, fs, float(fc))
        for e in effects:
            if e.spec.role == "sensor":
                ch = self._sensor_channel(e)
                out[ch] = e.sensor(out[ch], rec.time)
        return out

    def sensed(self, theta: np.ndarray, y: np.ndarray, rec: Recording, channel: str) -> np.ndarray:
        """A true ``channel`` signal ``y`` (the channel's unit) as the model's sensor
        elements on that channel record it, less what they record of zero: their linear
        response (a gain scales it, a lag filters it), in the order :meth:`simulate`
        applies them. A zero offset or drift (``EffectKind.shift``) adds nothing and is
        skipped: ``y`` itself (not broadcast to a batch of designs) where nothing else is
        on the channel."""
        _, effects = self.unpack(theta)
        y = np.asarray(y, float)
        shaping = [
            e
            for e in effects
            if e.spec.role == "sensor" and not e.spec.shift and self._sensor_channel(e) == channel
        ]
        if not shaping:
            return y
        zero = np.zeros(len(rec.time))
        for e in shaping:
            y, zero = e.sensor(y, rec.time), e.sensor(zero, rec.time)
        return y - zero

    def linear_part(self, base: Mapping[str, Any], rec: Recording) -> dict[str, np.ndarray] | None:
        """The part of the predicted outputs that is linear in the motion channels (a
        guide's ``m a + c v`` [N]), by output channel; None: none is separated (the
        outputs are not compared low-passed, :attr:`output_lowpass`)."""
        return None

    def effect_force(
        self, effects: Sequence[Effect], x: np.ndarray, v: np.ndarray, t: np.ndarray
    ) -> np.ndarray | float:
        """Sum of the force effects along deflection ``x`` and velocity ``v`` [N]."""
        total: np.ndarray | float = 0.0
        for e in effects:
            total = total + e.force(x, v, t)
        return total

    # ------------------------------------------------------------------ composition
    def with_effects(self, effects: Sequence[Effect]) -> ComponentModel:
        """The same model (same options) with another list of effects."""
        return type(self)(effects, **self.options)

    # ------------------------------------------------------------------ fit interface
    def difference_step(self, theta: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Forward-difference step per parameter: ``1e-6 * max(|theta|, 1)`` (the
        simulations are smooth in ``theta`` to round-off; ``lo``/``hi`` unused)."""
        return 1e-6 * np.maximum(np.abs(np.asarray(theta, dtype=float)), 1.0)

    def effect_words(self, effect: Effect) -> str:
        """Engineering words for ``effect`` in this model, e.g. "Coulomb friction in the guide"
        (the device's own words, ``device_words``, first; an effect placed elsewhere, e.g.
        on a bushing, keeps its own)."""
        elsewhere = bool(effect.location) and effect.location != self.location
        if effect.kind in self.device_words and not elsewhere:
            return str(self.device_words[effect.kind])
        if effect.location or not self.location:
            return effect.words
        # a loop in the device itself is not a bushing's (a friction device's pre-sliding,
        # a damper's mounts or fluid): the mechanism-neutral words
        words = effect.spec.words.replace(
            "rubber bushing hysteresis", "rate-independent hysteresis"
        )
        return f"{words} in the {self.location}"

    def __repr__(self) -> str:
        effs = ", ".join(f"{e.kind}:{e.name}" for e in self.effects)
        return f"{type(self).__name__}(effects=[{effs}], options={self.options})"

    def example_recording(self, seed: int = 0) -> Recording:
        """A synthetic recording with this family's typical inputs (no outputs)."""
        raise NotImplementedError


class LinearForceModel(ComponentModel):
    """A component whose output ``force`` [N] is linear in its base parameters,
    ``F = sum_i p_i u_i`` over :attr:`regressors`, plus the effects' forces along the
    first input channel (deflection or position [m]) and ``velocity`` [m/s]."""

    #: (base parameter, input channel it multiplies ("": a constant 1), lower limit
    #: of its least-squares start value or None), in the order of the sum
    regressors: ClassVar[tuple[tuple[str, str, float | None], ...]] = ()

    def _linear_force(self, base: Mapping[str, Any], rec: Recording) -> np.ndarray:
        """The base force ``sum_i p_i u_i`` [N], summed in :attr:`regressors` order."""
        terms = [bp(base[p]) * (rec.inputs[ch] if ch else 1.0) for p, ch, _ in self.regressors]
        return functools.reduce(np.add, terms)

    def _predict(self, base, effects, rec):
        x, v = rec.inputs[self.input_channels[0]], rec.inputs["velocity"]
        f = self._linear_force(base, rec) + self.effect_force(effects, x, v, rec.time)
        return {"force": np.broadcast_to(f, np.broadcast_shapes(np.shape(f), v.shape)).copy()}

    def _base_guess(self, rec):
        """Least squares of the recorded force on the regressors (each start value at
        least its lower limit); the references without a recorded force."""
        if "force" not in rec.outputs:
            return super()._base_guess(rec)
        ones = np.ones_like(rec.inputs["velocity"])
        cols = [rec.inputs[ch] if ch else ones for _, ch, _ in self.regressors]
        coef = linear_lstsq(cols, rec.outputs["force"])
        return {
            p: float(c if low is None else max(c, low))
            for (p, _, low), c in zip(self.regressors, coef, strict=True)
        }

    def _scales(self, rec):
        """Amplitudes of the first input, the velocity and the force (without a recorded
        force: the viscous parameter's default times the velocity's)."""
        x = robust_amplitude(rec.inputs[self.input_channels[0]])
        v = robust_amplitude(rec.inputs["velocity"])
        if "force" in rec.outputs:
            f = robust_amplitude(rec.outputs["force"])
        else:
            c = next(p for p in self.base_parameters if p.name == self.viscous_parameter)
            f = c.reference * v
        return {"force": f, "deflection": x, "velocity": v}


def linear_lstsq(columns: Sequence[np.ndarray], y: np.ndarray) -> np.ndarray:
    """Least-squares coefficients of ``y ~ sum_i a_i columns[i]``."""
    A = np.column_stack(columns)
    return np.linalg.lstsq(A, y, rcond=None)[0]


def robust_amplitude(x: np.ndarray) -> float:
    """98th percentile of ``|x - median(x)|`` (a stroke amplitude robust to spikes)."""
    x = np.asarray(x, dtype=float)
    a = float(np.percentile(np.abs(x - np.median(x)), 98))
    return a if a > 0 else 1.0


#: unit -> (force exponent, deflection exponent, velocity exponent) of its scale
UNIT_SCALE = {
    "N": (1, 0, 0),
    "N/m": (1, -1, 0),
    "N s/m": (1, 0, -1),
    "N/m^3": (1, -3, 0),
    "N/m^2": (1, -2, 0),
    "m": (0, 1, 0),
    "m/s": (0, 0, 1),
}
#: a bound is widened to this many times the data's scale (upper) or below its inverse
#: (a positive lower bound)
SCALE_SPAN = 1e3


def scaled_bound(
    low: float, high: float, unit: str, scales: Mapping[str, float]
) -> tuple[float, float]:
    """``(low, high)`` widened to the data's scale for parameters in ``unit``.

    The scale is ``F^a X^b V^c`` (:data:`UNIT_SCALE`) from the recording's force ``F``
    [N], deflection ``X`` [m] and velocity ``V`` [m/s] amplitudes: the upper bound
    reaches at least ``SCALE_SPAN`` x the scale, a negative lower bound at least minus
    that, a positive lower bound at most the scale / ``SCALE_SPAN``. Other units
    (dimensionless, seconds) keep their bounds.
    """
    exps = UNIT_SCALE.get(unit)
    if exps is None:
        return low, high
    f, x, v = (float(scales.get(k, 0.0)) for k in ("force", "deflection", "velocity"))
    if not all(np.isfinite(q) and q > 0 for q, e in zip((f, x, v), exps, strict=True) if e):
        return low, high
    scale = (f ** exps[0]) * (x ** exps[1]) * (v ** exps[2])
    high = max(high, SCALE_SPAN * scale)
    if low < 0:
        low = min(low, -SCALE_SPAN * scale)
    elif low > 0:
        low = min(low, scale / SCALE_SPAN)
    return low, high
