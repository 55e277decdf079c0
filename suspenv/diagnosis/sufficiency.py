"""Data sufficiency: the recordings a diagnosis refuses before any fitting, and why.

:func:`check_setup` runs once the family has split the data and built the model
(:meth:`~suspenv.diagnosis.family.DiagnosisFamily.prepare`) and before the baseline
fit. Each failure raises :class:`~suspenv.core.errors.ValidationError` whose message
names the recording, what it has and what the diagnosis needs. The rules, in order:

1. **Values** (every fitted and held-out recording, every channel and the time): finite;
   a unit the diagnosis knows (:data:`PLAUSIBLE`, SI) and, for a channel the model
   reads, the model's own unit (force in lbf is never read as N); a magnitude below the
   channel's physical limit (:data:`PLAUSIBLE`, in SI after the reader's conversion; for
   the time, its span). A value past the limit means the declared unit or a scale factor
   is wrong (mm read as m, data multiplied by 1e300), not a component to diagnose.
2. **Samples** against the model's size: the fitted part must hold at least
   :data:`OBS_PER_PARAMETER` observations (samples x predicted channels) per parameter
   of the largest model the search may reach (base parameters plus the
   ``max_effects`` largest candidate elements), and the held-out part at least
   :data:`MIN_HELDOUT_OBS`. With fewer, the likelihood-ratio test's chi-square
   approximation and the held-out comparison rest on a handful of samples, and a
   verdict would be confident about noise.
3. **The family's own rules** (its optional ``check_data(setup)``): a component's
   motion cycles (:func:`suspenv.diagnosis.component.motion.check_cycles`), a K&C
   recording's whole loop (:func:`suspenv.diagnosis.knc.family.check_loop`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.family import Setup
from suspenv.diagnosis.fitting import sample_counts
from suspenv.diagnosis.hypothesis import split_candidate
from suspenv.diagnosis.protocols import RecordingLike
from suspenv.diagnosis.split import Split

#: SI unit -> (largest plausible magnitude, quantity, why). Limits of a road vehicle's
#: suspension, its rigs and its sensors, each about ten times the largest real value.
PLAUSIBLE: dict[str, tuple[float, str, str]] = {
    "N": (
        1e6,
        "force",
        "wheel, damper and bushing forces of road vehicles stay below about 1e5 N (a 40 t "
        "truck axle's static load)",
    ),
    "m": (
        10.0,
        "length",
        "strokes, wheel travel, rig and contact-point positions stay below about 1 m",
    ),
    "m/s": (
        100.0,
        "velocity",
        "damper and rig velocities stay below about 10 m/s (racing dampers peak near 5 m/s)",
    ),
    "m/s^2": (
        1e4,
        "acceleration",
        "wheel accelerations on a pothole reach about 100 g (1e3 m/s^2)",
    ),
    "rad": (
        20.0 * math.pi,
        "angle",
        "suspension and steering angles stay below about two turns of the steering wheel",
    ),
    "rad/s": (1e4, "angular velocity", "wheel and steering speeds stay below about 1e3 rad/s"),
    "V": (1e3, "voltage", "drive commands and sensor signals stay below about 100 V"),
    "A": (1e3, "electric current", "coil and actuator drive currents stay below about 100 A"),
    "s": (
        1e7,
        "time span",
        "a rig or road test lasts at most days (1e6 s); a longer span is not in seconds",
    ),
    "1": (1e6, "dimensionless value", "indices and ratios (loop steps, gains) stay small"),
    "-": (1e6, "dimensionless value", "indices and ratios (loop steps, gains) stay small"),
}
#: fitted observations needed per parameter of the largest model (the customary minimum
#: of a regression; the chi-square approximation of the likelihood-ratio test)
OBS_PER_PARAMETER = 10
#: held-out observations needed (a held-out RMS of fewer values rests on a handful of
#: samples; 30 is the customary minimum for a mean to be near-normal)
MIN_HELDOUT_OBS = 30
#: parameters counted for an element whose host declares them (the McPherson axle's
#: left/right asymmetry fits five right-minus-left differences)
HOST_ELEMENT_PARAMETERS = 5
#: parameters counted for a candidate the effects library does not know
DEFAULT_ELEMENT_PARAMETERS = 4


def check_setup(setup: Setup, family: Any) -> None:
    """Refuse data the diagnosis cannot judge (see the module docstring for the rules).

    Args:
        setup: the family's split, model and candidates.
        family: the diagnosis family (its ``max_effects``: most elements the search adds
            in turn; its optional ``check_data(setup)``: the family's own rules).
    """
    sp = setup.split
    model_units = getattr(setup.model, "channel_units", None)
    units = dict(model_units) if isinstance(model_units, Mapping) else {}
    for rec in sp.recordings():
        check_values(rec, units, str(setup.model.family))
    _check_samples(setup, family.max_effects)
    if (own := getattr(family, "check_data", None)) is not None:
        own(setup)


# ------------------------------------------------------------------ values
def check_values(rec: RecordingLike, model_units: Mapping[str, str], model: str = "") -> None:
    """Every channel (and the time) of ``rec`` finite, in a known SI unit (the model's
    own for the channels it reads) and below its plausible magnitude (:data:`PLAUSIBLE`)."""
    where = f"recording {rec.name!r}"
    t = np.asarray(rec.time, float)
    channels: list[tuple[str, str, np.ndarray]] = [("time", "time", t)]
    channels += [("input", k, np.asarray(v, float)) for k, v in rec.inputs.items()]
    channels += [("output", k, np.asarray(v, float)) for k, v in rec.outputs.items()]
    for kind, name, values in channels:
        what = "the time" if kind == "time" else f"{kind} channel {name!r}"
        unit = rec.units.get(name, "s" if kind == "time" else None)
        if unit is None:
            raise ValidationError(f"{where}: {what} has no unit")
        bad = ~np.isfinite(values)
        if bad.any():
            i = int(np.argmax(bad))
            raise ValidationError(
                f"{where}: {what} has {int(bad.sum())} non-finite sample(s), the first at "
                f"index {i} (value {values.flat[i]}); a diagnosis needs finite data"
            )
        if unit not in PLAUSIBLE:
            raise ValidationError(
                f"{where}: {what} is in {unit!r}, a unit a diagnosis does not read; "
                f"convert it to SI ({sorted(PLAUSIBLE)})"
            )
        expected = model_units.get(name)
        if expected is not None and unit != expected:
            raise ValidationError(
                f"{where}: {what} is in {unit!r}, but the {model or 'model'} model reads it "
                f"in {expected!r}; convert it (suspenv.measurements.to_si)"
            )
        limit, quantity, why = PLAUSIBLE[unit]
        if kind == "time":  # a clock may start anywhere (an epoch); its span may not
            span = float(values[-1] - values[0]) if values.size else 0.0
            if span > limit:
                raise ValidationError(
                    f"{where}: the time spans {span:.6g} s, an implausible duration: the "
                    f"limit is {limit:.6g} s ({why}); check the time unit and any scale "
                    "factor"
                )
            continue
        peak = float(np.max(np.abs(values))) if values.size else 0.0
        if peak > limit:
            i = int(np.argmax(np.abs(values)))
            at = f" at t={t[i]:.6g} s" if values.shape == t.shape else ""
            raise ValidationError(
                f"{where}: {what} reaches {values.flat[i]:.6g} {unit}{at}, an implausible "
                f"{quantity}: the limit is {limit:.6g} {unit} ({why}); check the declared "
                "unit and any scale factor"
            )


# ------------------------------------------------------------------ samples
def _fitted_channels(model: Any, rec: RecordingLike) -> list[str]:
    return [c for c in model.output_channels if c in rec.outputs]


def _counts(
    model: Any, recs: Sequence[RecordingLike], masks: Sequence[np.ndarray | None] | None
) -> tuple[int, int, int]:
    """(samples, observations, fewest channels per recording) of one part of the split."""
    counts = sample_counts(recs, masks)
    chans = [len(_fitted_channels(model, rec)) for rec in recs]
    obs = sum(n * c for n, c in zip(counts, chans, strict=True))
    return sum(counts), obs, min(chans, default=0)


def element_parameters(candidate: str) -> int:
    """Free parameters an element of ``candidate`` (``kind`` or ``kind@location``) adds."""
    from suspenv.models.effects.effect import effect_kinds

    if (spec := effect_kinds().get(split_candidate(candidate)[0])) is None:
        return DEFAULT_ELEMENT_PARAMETERS
    extra = HOST_ELEMENT_PARAMETERS if spec.host_parameters else 0
    return len(spec.free_parameter_names) + extra


def largest_model(setup: Setup, max_effects: int) -> tuple[int, int, int]:
    """(base parameters, parameters the ``max_effects`` largest candidates add, total)."""
    base = len(setup.model.parameter_names)
    sizes = sorted((element_parameters(c) for c in setup.candidates), reverse=True)
    added = sum(sizes[: max(int(max_effects), 0)])
    return base, added, base + added


def recording_names(sp: Split) -> str:
    """The split's recordings for a message: ``recording 'a'`` or ``recordings 'a', 'b'``."""
    names = list(dict.fromkeys(str(r.name) for r in sp.recordings()))
    head = "recording" if len(names) == 1 else "recordings"
    return f"{head} " + ", ".join(repr(n) for n in names)


def _check_samples(setup: Setup, max_effects: int) -> None:
    sp, model = setup.split, setup.model
    for rec in sp.fit_recordings:
        if not _fitted_channels(model, rec):
            raise ValidationError(
                f"recording {rec.name!r}: none of the channels the {model.family} model "
                f"predicts ({list(model.output_channels)}) is among its outputs "
                f"({sorted(rec.outputs)}); there is nothing to fit"
            )
    n_fit, obs_fit, c_fit = _counts(model, sp.fit_recordings, sp.fit_masks)
    n_held, obs_held, c_held = _counts(model, sp.heldout_recordings, sp.heldout_masks)
    base, added, p_max = largest_model(setup, max_effects)
    need_fit = OBS_PER_PARAMETER * p_max
    if obs_fit >= need_fit and obs_held >= MIN_HELDOUT_OBS:
        return
    total = sum(len(r.time) for r in sp.recordings())
    fit_samples = math.ceil(need_fit / max(c_fit, 1))
    held_samples = math.ceil(MIN_HELDOUT_OBS / max(c_held, 1))
    shared = sp.fit_masks is not None and sp.heldout_masks is not None
    if shared and n_fit > 0 and n_held > 0:
        frac = n_fit / (n_fit + n_held)
        n_min = max(math.ceil(fit_samples / frac), math.ceil(held_samples / (1 - frac)))
        need = f"about {n_min} samples"
    else:
        need = f"{fit_samples} fitted and {held_samples} held-out samples"
    raise ValidationError(
        f"{recording_names(sp)}: {plural(total, 'sample')}; a diagnosis of the "
        f"{model.family} model needs at least {need} ({n_fit} fitted and {n_held} held out here: "
        f"{sp.description}). The fit needs {OBS_PER_PARAMETER} observations (samples x "
        f"predicted channels) per parameter of the largest model the search may reach "
        f"({base} base + {added} for up to {max_effects} element(s) = {p_max} parameters), "
        f"{need_fit} in all, and the held-out part {MIN_HELDOUT_OBS}; these data give "
        f"{obs_fit} and {obs_held}"
    )


def plural(n: int, word: str) -> str:
    """``n word`` or ``n words``."""
    return f"{n} {word}" + ("" if n == 1 else "s")
