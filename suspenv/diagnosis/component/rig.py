"""The rig a component was tested on: baseline physics, known parameters, signs, inputs.

A component diagnosis compares a recording with a *baseline*: the base law of the
model family plus the standard physics an engineer would include before looking for
anything missing. "Missing physics" is only what lies beyond it.

Standard baselines (:data:`STANDARD_BASELINE`; every family also gets
:data:`DRIFT` on each output channel, a slowly drifting sensor zero):

======================  =====================================================
family                  baseline
======================  =====================================================
``damper``              ``F = c v`` + gas force ``f_0 + k_gas x`` (gas damper)
``mr_damper``           ``F = c v + k x + f_0`` (its base holds the accumulator)
``friction_guide``      ``F = m a + c v`` + a constant force offset
``quarter_car_rig``     linear spring, damper and tyre (masses from the rig) + a
                        zero offset on each sensor
======================  =====================================================

Where the description comes from, later entries overriding earlier ones:

1. the recording's metadata ``meta["rig"]`` (see ``docs/recordings.md``)::

       {"device": "quarter_car_rig",
        "known": {"m_s": 287.0, "m_u": 41.5, "k_t": 2.3e5, "deflection_ratio": 1.0},
        "positive_stroke": "compression", "positive_force": "compression",
        "extra_inputs": {"actuator_force": "..."}, "baseline": ["gas_spring"],
        "velocity_source": "auto"}

2. a model file (``--model rig.toml``; TOML with the same keys, ``family`` in place of
   ``device``);
3. the model text ``FAMILY[+KIND...][-KIND...]``: ``damper`` is the standard baseline,
   ``damper+maxwell_viscoelastic`` adds an element to it, ``damper-gas_spring`` removes
   one (``damper-gas_spring-zero_drift`` is the bare law ``F = c v``).

Signs: inside suspenv a positive stroke (displacement, velocity, suspension deflection)
is compression (bump) and a positive damper force pushes back against compression. A
recording whose ``positive_stroke`` is ``"extension"`` has its stroke channels negated,
one whose ``positive_force`` is ``"tension"`` its force channel, before anything else
(the report says so).

Extra inputs (:data:`EXTRA_INPUTS`): a channel a family reads beyond its motion, declared
in ``extra_inputs`` or, where none is declared, recorded in every recording under its
own name (its unit checked by the model; :func:`check_extra_inputs`). An MR damper's
``coil_current`` [A] or ``coil_voltage`` [V] that varies (:func:`field_input`) makes its
baseline the field-dependent law
(:class:`~suspenv.models.components.mr_damper.MRFieldDamperModel`).
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.component.motion_inputs import VELOCITY_SOURCES
from suspenv.diagnosis.hypothesis import family_of
from suspenv.diagnosis.protocols import RecordingLike
from suspenv.models.components import FAMILIES, make_component
from suspenv.models.components.base import ComponentModel
from suspenv.models.components.mr_damper import FIELD_INPUTS
from suspenv.models.effects import Effect, effect_kinds, make_effect

#: sensor-zero drift, in every family's standard baseline on every output channel
DRIFT = "zero_drift"

#: baseline elements beyond each family's base law (the drift comes on top): a constant
#: force or zero in every family (the damper's gas preload, the MR damper's own f_0, the
#: guide's force offset, the quarter car's sensor zeros)
STANDARD_BASELINE: dict[str, tuple[str, ...]] = {
    "damper": ("gas_spring",),
    "mr_damper": (),
    "friction_guide": ("force_offset",),
    "quarter_car_rig": ("sensor_offset",),
}
#: sensor elements of the baseline placed on every output channel (others: the first)
EVERY_CHANNEL = (DRIFT, "sensor_offset")

#: rig parameters a user may declare as known, per family (model options, SI units)
KNOWN_PARAMETERS: dict[str, dict[str, str]] = {
    "quarter_car_rig": {
        "m_s": "kg",
        "m_u": "kg",
        "deflection_ratio": "-",
        "k_s": "N/m",
        "c_s": "N s/m",
        "k_t": "N/m",
    },
}

#: extra input channels a family reads when declared, and what it does with them
EXTRA_INPUTS: dict[str, dict[str, str]] = {
    "mr_damper": {
        name: f"the field ({unit}): the yield force and the viscous damping grow linearly "
        "with it (Spencer et al. 1997 Bouc-Wen)"
        for name, unit in FIELD_INPUTS.items()
    },
    "quarter_car_rig": {
        "actuator_force": "a known force between body and wheel, positive pushing them apart"
    },
}

STROKE_SIGNS = ("compression", "extension")
FORCE_SIGNS = ("compression", "tension")
#: channels negated when a recording's positive stroke is extension
STROKE_CHANNELS = (
    "displacement",
    "velocity",
    "deflection",
    "stroke",
    "travel",
    "suspension_deflection",
)
FORCE_CHANNELS = ("force",)
#: relative spread above which an MR damper's field input counts as varying
FIELD_SPREAD = 0.02


@dataclass(frozen=True)
class RigDescription:
    """What the user states about the test, merged from metadata, model file and text.

    Attributes:
        family: model family (``"damper"``, ...).
        baseline: effect kinds added to the base law before any search.
        known: known rig parameters (model options, SI), e.g. ``{"m_s": 287.0}``.
        positive_stroke: ``"compression"`` or ``"extension"``: what a positive stroke
            channel means in the recording.
        positive_force: ``"compression"`` or ``"tension"``: what a positive force means.
        extra_inputs: declared extra input channels -> the user's description.
        velocity_source: ``"auto"``, ``"displacement"`` or ``"channel"``: where the
            velocity driving the component comes from
            (:mod:`suspenv.diagnosis.component.motion_inputs`).
        sources: where each entry came from, in words, for the report.
    """

    family: str
    baseline: tuple[str, ...]
    known: Mapping[str, float] = field(default_factory=dict)
    positive_stroke: str = "compression"
    positive_force: str = "compression"
    extra_inputs: Mapping[str, str] = field(default_factory=dict)
    velocity_source: str = "auto"
    sources: tuple[str, ...] = ()
    #: the entries the user declared (metadata or model file); the others are defaults
    declared: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        out = asdict(self)
        return out | {k: list(v) for k, v in out.items() if isinstance(v, tuple)}


def parse_model_text(text: str) -> tuple[str, list[str], list[str]]:
    """``FAMILY[+KIND...][-KIND...]`` -> (family, kinds added, kinds removed)."""
    family, *rest = re.split(r"([+-])", text.strip())
    if not family:
        raise ValidationError(f"a model must read FAMILY[+KIND...][-KIND...], but got {text!r}")
    signed = list(zip(rest[0::2], rest[1::2], strict=True))
    return family, [w for s, w in signed if s == "+"], [w for s, w in signed if s == "-"]


def _check_family(family: str, where: str) -> None:
    if family not in FAMILIES:
        raise ValidationError(
            f"{where}: unknown component family {family!r}; known families are {sorted(FAMILIES)}"
        )


def _check_kinds(kinds: Sequence[str], where: str) -> None:
    known = effect_kinds()
    if bad := [k for k in kinds if k not in known]:
        raise ValidationError(
            f"{where}: unknown effect kind(s) {bad}; known kinds are {sorted(known)}"
        )


def _known(known: Any, where: str) -> dict[str, float]:
    """The validated ``known`` table of a rig: positive numbers by parameter name."""
    if not isinstance(known, Mapping):
        raise ValidationError(f"{where}: 'known' must be a table, but got {known!r}")
    vals: dict[str, float] = {}
    for k, v in known.items():
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise ValidationError(f"{where}: known.{k} must be a number, but got {v!r}") from None
        if not (np.isfinite(x) and x > 0):
            raise ValidationError(f"{where}: `known.{k} > 0` must hold, but got {x}")
        vals[str(k)] = x
    return vals


def _entries(raw: Mapping[str, Any], where: str) -> dict[str, Any]:
    """Validated entries of a metadata ``rig`` table or a model file."""
    allowed = {
        "device",
        "family",
        "known",
        "positive_stroke",
        "positive_force",
        "extra_inputs",
        "baseline",
        "velocity_source",
    }
    if unknown := sorted(set(raw) - allowed):
        raise ValidationError(
            f"{where}: unknown rig entr(ies) {unknown}; the entries are {sorted(allowed)}"
        )
    out: dict[str, Any] = {}
    if (fam := raw.get("family", raw.get("device"))) is not None:
        _check_family(str(fam), where)
        out["family"] = str(fam)
    for key, choices in (
        ("positive_stroke", STROKE_SIGNS),
        ("positive_force", FORCE_SIGNS),
        ("velocity_source", VELOCITY_SOURCES),
    ):
        if key in raw:
            if raw[key] not in choices:
                raise ValidationError(
                    f"{where}: `{key} in {choices}` must hold, but got {raw[key]!r}"
                )
            out[key] = str(raw[key])
    if "known" in raw:
        out["known"] = _known(raw["known"], where)
    if "extra_inputs" in raw:
        extra = raw["extra_inputs"]
        if not isinstance(extra, Mapping):
            raise ValidationError(f"{where}: 'extra_inputs' must be a table, but got {extra!r}")
        out["extra_inputs"] = {str(k): str(v) for k, v in extra.items()}
    if "baseline" in raw:
        base = raw["baseline"]
        if isinstance(base, str) or not isinstance(base, Sequence):
            raise ValidationError(
                f"{where}: 'baseline' must be a list of effect kinds, but got {base!r}"
            )
        _check_kinds([str(b) for b in base], where)
        out["baseline"] = tuple(str(b) for b in base)
    return out


def read_model_file(path: str | Path) -> dict[str, Any]:
    """The entries of a model file (TOML; see the module docstring)."""
    p = Path(path)
    try:
        raw = tomllib.loads(p.read_text())
    except FileNotFoundError:
        raise ValidationError(f"model file {str(p)!r} does not exist") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValidationError(f"model file {str(p)!r} is not valid TOML: {exc}") from None
    return _entries(raw, f"model file {p.name}")


def _meta_entries(recordings: Sequence[RecordingLike]) -> dict[str, Any]:
    """The ``meta["rig"]`` entries of the recordings (they must agree)."""
    found: dict[str, Any] | None = None
    first = ""
    for rec in recordings:
        meta = getattr(rec, "meta", None) or {}
        if (raw := meta.get("rig")) is None:
            continue
        if not isinstance(raw, Mapping):
            raise ValidationError(
                f"recording {rec.name!r}: meta['rig'] must be a table, but got {raw!r}"
            )
        entries = _entries(raw, f"recording {rec.name!r} meta['rig']")
        if found is None:
            found, first = entries, str(rec.name)
        elif entries != found:
            raise ValidationError(
                f"recordings {first!r} and {rec.name!r} describe different rigs in "
                f"meta['rig'] ({found} and {entries}); diagnose them separately"
            )
    return found or {}


def describe_rig(
    model: str | Path | ComponentModel | None,
    recordings: Sequence[RecordingLike],
) -> RigDescription:
    """Merge recording metadata, a model file and the model text (see module docstring).

    ``model``: the model text, a model file path (``.toml``), or None (family from the
    metadata).
    """
    entries = _meta_entries(recordings)
    sources = ["recording metadata"] if entries else []
    added: list[str] = []
    removed: list[str] = []
    if isinstance(model, Path) or (isinstance(model, str) and model.endswith(".toml")):
        entries.update(read_model_file(model))
        sources.append(f"model file {Path(model).name}")
    elif isinstance(model, str):
        family, added, removed = parse_model_text(model)
        _check_family(family, f"model {model!r}")
        if "family" in entries and entries["family"] != family:
            sources.append(
                f"model {family!r} given (the recording metadata says {entries['family']!r})"
            )
        entries["family"] = family
        _check_kinds(added + removed, f"model {model!r}")
    if (chosen := entries.get("family")) is None:
        raise ValidationError(
            "the model family is unknown: give one (--model damper | mr_damper | "
            "friction_guide | quarter_car_rig) or declare meta['rig']['device']"
        )
    family = str(chosen)  # checked where it was read
    base = list(entries.get("baseline", (*STANDARD_BASELINE.get(family, ()), DRIFT)))
    base = list(dict.fromkeys(k for k in base + added if k not in removed))
    known = dict(entries.get("known", {}))
    allowed = KNOWN_PARAMETERS.get(family, {})
    if bad := sorted(set(known) - set(allowed)):
        raise ValidationError(
            f"known rig parameter(s) {bad} are not read by {family}; it reads "
            f"{sorted(allowed) or 'none'}"
        )
    extra = dict(entries.get("extra_inputs", {}))
    if not extra and recordings:
        # a channel the family reads, recorded under its own name and unit, declares itself
        recorded = set.intersection(*(set(r.inputs) for r in recordings))
        extra = {k: "recorded" for k in EXTRA_INPUTS.get(family, {}) if k in recorded}
    return RigDescription(
        family=family,
        baseline=tuple(base),
        known=known,
        positive_stroke=entries.get("positive_stroke", "compression"),
        positive_force=entries.get("positive_force", "compression"),
        extra_inputs=extra,
        sources=tuple(sources),
        velocity_source=entries.get("velocity_source", "auto"),
        declared=tuple(sorted(entries)),
    )


def data_scales(model: ComponentModel, recordings: Sequence[RecordingLike]) -> dict[str, float]:
    """The largest force [N], deflection [m] and velocity [m/s] amplitudes the model
    reads in ``recordings`` (its ``_scales``): the parameter bounds follow them."""
    out: dict[str, float] = {}
    for rec in recordings:
        try:
            sc = model._scales(rec)  # type: ignore[arg-type]  # the model's own reading
        except (KeyError, ValueError, NotImplementedError):
            continue
        for k in ("force", "deflection", "velocity"):
            val = float(sc.get(k, 0.0))
            if np.isfinite(val) and val > out.get(k, 0.0):
                out[k] = val
    return out


def baseline_model(rig: RigDescription, recordings: Sequence[RecordingLike] = ()) -> ComponentModel:
    """The family's model with the baseline elements and the known rig parameters; with
    ``recordings``, its parameter bounds follow their scale (:func:`data_scales`)."""
    known: dict[str, Any] = dict(rig.known)
    # known base-law parameters (a measured tyre rate) are held, not fitted
    base_names = {p.name for p in FAMILIES[rig.family].base_parameters}
    if held := {k: known.pop(k) for k in list(known) if k in base_names}:
        known["known_base"] = held
    if field := field_input(rig, recordings):
        known["field"] = field
    if recordings:
        known["scales"] = data_scales(make_component(rig.family, (), **known), recordings)
    probe = make_component(rig.family, (), **known)
    effects: list[Effect] = []
    for kind in rig.baseline:
        e = make_effect(kind)
        if e.spec.role == "sensor":
            channels = probe.output_channels if kind in EVERY_CHANNEL else probe.output_channels[:1]
            for ch in channels:
                name = kind if len(channels) == 1 else f"{kind}_{ch}"
                effects.append(make_effect(kind, name=name, location=ch))
        else:
            effects.append(make_effect(kind, location=str(probe.location or "")))
    effects = [e.with_params(probe.effect_defaults.get(e.kind, {})) for e in effects]
    if recordings:
        # the drift's shape is defined over the longest recording's duration
        span = max(float(np.ptp(np.asarray(r.time, float))) for r in recordings) or 1.0
        effects = [e.with_params({"span": span}) if e.kind == DRIFT else e for e in effects]
    return make_component(rig.family, effects, **known)


def drift_over_fit(model: ComponentModel, sp: Any) -> ComponentModel:
    """``model`` with its zero drift's shape defined over the time the split ``sp``
    fits (the latest fitted sample's time from the recording's origin [s]): past it the
    drift holds its last value (:func:`~suspenv.models.effects.sensor.sensor_drift`), so
    a held-out stretch after the fitted one is predicted without extrapolating a cubic
    in time. Unchanged without a drift."""
    if not any(e.kind == DRIFT for e in model.effects):
        return model
    ends = [
        float(np.asarray(r.time, float)[m][-1] - r.time[0])
        for r, m in zip(sp.fit_recordings, sp.fit_selections(), strict=True)
        if np.any(m)
    ]
    span = max(ends, default=0.0) or 1.0
    effects = [e.with_params({"span": span}) if e.kind == DRIFT else e for e in model.effects]
    return model.with_effects(effects)


def baseline_families(model: ComponentModel) -> set[str]:
    """Signature families the baseline already holds (not searched for again)."""
    return {family_of(e.kind) for e in model.effects}


def oriented(recordings: Sequence[RecordingLike], rig: RigDescription) -> list[RecordingLike]:
    """The recordings in suspenv's signs (positive stroke = compression, positive force
    pushes back against compression); unchanged when they already are."""
    flip_stroke = rig.positive_stroke == "extension"
    flip_force = rig.positive_force == "tension"
    if not (flip_stroke or flip_force):
        return list(recordings)
    negated = (STROKE_CHANNELS if flip_stroke else ()) + (FORCE_CHANNELS if flip_force else ())

    def turn(chs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {k: -np.asarray(y, float) if k in negated else y for k, y in chs.items()}

    said = {"stroke_negated": flip_stroke, "force_negated": flip_force}
    return [
        replace(  # type: ignore[type-var]
            rec,
            inputs=turn(rec.inputs),
            outputs=turn(rec.outputs),
            meta={**(getattr(rec, "meta", {}) or {}), "oriented": dict(said)},
        )
        for rec in recordings
    ]


def check_extra_inputs(recordings: Sequence[RecordingLike], rig: RigDescription) -> list[str]:
    """Sentences on the declared extra inputs; refuses one the family cannot use.

    A declared channel must be in every recording's inputs; a family that reads no such
    input refuses it rather than ignore it (its effect would be named as missing
    physics).
    """
    reads = EXTRA_INPUTS.get(rig.family, {})
    words: list[str] = []
    for name, desc in rig.extra_inputs.items():
        for rec in recordings:
            if name not in rec.inputs:
                raise ValidationError(
                    f"recording {rec.name!r}: declared extra input {name!r} is not among its "
                    f"inputs {sorted(rec.inputs)}"
                )
        if name not in reads:
            raise ValidationError(
                f"{rig.family} does not model the declared extra input {name!r} ({desc}); "
                f"it reads {sorted(reads) or 'no extra input'}; a model that ignored it "
                "would name its effect as missing physics"
            )
        if name in FIELD_INPUTS and field_input(rig, recordings) is None:
            values = ", ".join(f"{float(np.mean(r.inputs[name])):.3g}" for r in recordings)
            words.append(f"{name} constant ({values} {FIELD_INPUTS[name]})")
        else:
            words.append(f"extra input {name}: {reads[name]}")
    return words


def field_input(rig: RigDescription, recordings: Sequence[RecordingLike] = ()) -> str | None:
    """The coil channel an MR damper's field-dependent law reads: the declared one, where
    it varies over the recordings (within one, or from one to another) by more than
    :data:`FIELD_SPREAD` (one constant field is the passive law's, fitted for that
    field); None otherwise."""
    if rig.family != "mr_damper":
        return None
    found = [k for k in rig.extra_inputs if k in FIELD_INPUTS]
    if len(found) > 1:
        raise ValidationError(
            f"mr_damper reads one field input, but {found} are declared; declare the one "
            "that drives the coil (the current where both are recorded)"
        )
    if not found or not recordings:
        return None
    u = np.concatenate([np.asarray(r.inputs.get(found[0], [0.0]), float) for r in recordings])
    # range over mean magnitude (at least 0.05 of the channel's unit)
    spread = float(np.ptp(u)) / max(float(np.mean(np.abs(u))), 0.05)
    return found[0] if spread > FIELD_SPREAD else None


def baseline_words(model: ComponentModel) -> str:
    """The baseline in words, e.g. "linear viscous F = c v; gas spring force ..."."""
    desc = model.description
    parts = [desc.split("(base: ")[-1][:-1] if "(base: " in desc else desc]
    for kind in dict.fromkeys(e.kind for e in model.effects):
        spec = next(e.spec for e in model.effects if e.kind == kind)
        chans = [x.location for x in model.effects if x.kind == kind and x.location]
        where = f" on {', '.join(chans)}" if spec.role == "sensor" and chans else ""
        parts.append(f"{spec.words}{where}")
    return "; ".join(parts)
