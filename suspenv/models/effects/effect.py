"""The ``Effect`` descriptor and the registry of effect kinds.

An :class:`Effect` names one piece of optional physics added to a base model:
its ``kind`` (a key of the registry, e.g. ``"coulomb_friction"``), a ``name``
unique within the model, its parameter values (SI units) and an optional
``location`` (where it lives, e.g. ``"strut"``, ``"lower_arm_front_bush"``, or
the channel name for sensor effects).

Each :class:`EffectKind` carries the engineering words a report uses ("Coulomb
friction"), its parameters with bounds and units (:class:`suspenv.core.Parameter`),
its residual signature and a ``role``:

* ``"force"``: an additive force element ``F(x, v, t)`` acting on a deflection
  ``x[..., T]`` [m] with velocity ``v`` [m/s] at times ``t[T]`` [s]; force positive
  when it resists positive deflection;
* ``"sensor"``: maps a true channel ``y[..., T]`` to the recorded one;
* ``"pair"``: a left/right parameter-pair perturbation (see
  :mod:`suspenv.models.effects.asymmetry`).

A kind may leave some parameters to the host model (``host_parameters``, a name
prefix): a left/right asymmetry perturbs the host's own parameter pairs, one
right-minus-left difference ``d_<host parameter>`` each, whose unit and bounds only
the host knows. An effect then carries those values too; the host checks their names.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import did_you_mean
from suspenv.core.space import Parameter
from suspenv.models.effects._util import require_positive

ROLES = ("force", "sensor", "pair")


@dataclass(frozen=True)
class EffectKind:
    """One family member of the effect library, with its parameters and words.

    Attributes:
        kind: registry key (``snake_case``).
        words: engineering name used in reports, e.g. ``"rubber bushing hysteresis (Dahl)"``.
        role: ``"force"``, ``"sensor"`` or ``"pair"``.
        parameters: the element's parameters (bounds, unit, default, description).
        signature: the residual signature a missing instance of this effect leaves.
        apply: force role ``apply(x, v, t, **params) -> F``; sensor role
            ``apply(y, t, **params) -> y_rec``; pair role
            ``apply(nominal, delta, relative) -> (l, r)`` for one of the host's pairs.
        needs_time: True when the element is rate dependent (``t`` required).
        fit_fixed: parameters a fit holds at the effect's stored value by default
            (regularisation widths, exponents, pre-sliding constants that recordings
            of macroscopic motion barely inform).
        host_parameters: name prefix of further parameters the host model declares
            (unit, bounds, default), e.g. ``"d_"`` for the per-pair differences of
            ``lr_asymmetry``; empty when the kind's parameters are all it takes.
        domain: parameters whose laws need a domain: name -> (bound, strict), each value
            ``> bound`` (strict) or ``>= bound`` (:meth:`Effect.check`).
        shift: a sensor-role kind that only adds to the channel a signal independent of
            it, ``y_rec = y + s(t)`` (a zero offset, a zero drift): its linear response is
            the identity.
    """

    kind: str
    words: str
    role: str
    parameters: tuple[Parameter, ...]
    signature: str
    apply: Callable[..., Any]
    needs_time: bool = False
    fit_fixed: tuple[str, ...] = ()
    host_parameters: str = ""
    domain: Mapping[str, tuple[float, bool]] = field(default_factory=dict)
    shift: bool = False

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise ValidationError(
                f"effect kind {self.kind!r}: `role in {ROLES}` must hold, but got {self.role!r}"
            )

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def free_parameter_names(self) -> tuple[str, ...]:
        """Parameters a fit adjusts by default (all but ``fit_fixed``)."""
        return tuple(p.name for p in self.parameters if p.name not in self.fit_fixed)

    def parameter(self, name: str) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise ValidationError(
            f"effect kind {self.kind!r} has no parameter {name!r}; "
            f"its parameters are {self.parameter_names}"
        )

    def defaults(self) -> dict[str, float]:
        return {p.name: p.reference for p in self.parameters}

    def accepts(self, name: str) -> bool:
        """True for one of the kind's parameters or a host-declared one (``host_parameters``)."""
        if name in self.parameter_names:
            return True
        prefix = self.host_parameters
        return bool(prefix) and name.startswith(prefix) and len(name) > len(prefix)


#: the registry: filled by :mod:`suspenv.models.effects.catalogue`, which the package
#: imports first (so every import of this module finds the shipped kinds registered)
_KINDS: dict[str, EffectKind] = {}


def register_kind(kind: EffectKind, replace: bool = False) -> EffectKind:
    """Add ``kind`` to the registry (``replace=True`` to overwrite an existing key)."""
    if kind.kind in _KINDS and not replace:
        raise ValidationError(f"effect kind {kind.kind!r} is already registered")
    _KINDS[kind.kind] = kind
    return kind


def get_kind(kind: str) -> EffectKind:
    """Look up an effect kind by key; unknown keys raise with close matches."""
    try:
        return _KINDS[kind]
    except KeyError:
        raise ValidationError(
            f"unknown effect kind {kind!r}{did_you_mean(kind, _KINDS)} (known kinds: "
            f"{sorted(_KINDS)})"
        ) from None


def effect_kinds() -> dict[str, EffectKind]:
    """All registered effect kinds, by key (a copy)."""
    return dict(_KINDS)


@dataclass(frozen=True)
class Effect:
    """One effect instance in a model: kind, unique name, parameter values, location.

    Parameters missing from ``params`` take the kind's defaults; unknown names raise.
    Values may be scalars or batch-shaped arrays (broadcast against a series'
    leading axes).
    """

    kind: str
    name: str
    params: dict[str, Any] = field(default_factory=dict)
    location: str = ""

    def __post_init__(self) -> None:
        spec = get_kind(self.kind)
        if not self.name:
            raise ValidationError(f"effect of kind {self.kind!r}: `name` must be non-empty")
        unknown = [k for k in self.params if not spec.accepts(k)]
        if unknown:
            host = (
                f" and host parameters named {spec.host_parameters}<name>"
                if spec.host_parameters
                else ""
            )
            raise ValidationError(
                f"effect {self.name!r} ({self.kind}): unknown parameter(s) {unknown}; "
                f"allowed are {spec.parameter_names}{host}"
            )
        full = spec.defaults()
        full.update(self.params)
        object.__setattr__(self, "params", full)

    def __hash__(self) -> int:
        vals = tuple(
            (k, float(v) if np.ndim(v) == 0 else np.asarray(v).tobytes())
            for k, v in sorted(self.params.items())
        )
        return hash((self.kind, self.name, self.location, vals))

    # ----------------------------------------------------------------- descriptors
    @property
    def spec(self) -> EffectKind:
        return get_kind(self.kind)

    @property
    def words(self) -> str:
        """Engineering description, e.g. ``"Coulomb friction in the strut"``."""
        where = f" in the {self.location}" if self.location else ""
        return f"{self.spec.words}{where}"

    @property
    def host_parameter_names(self) -> tuple[str, ...]:
        """Host-declared parameters this effect carries (see ``EffectKind.host_parameters``)."""
        own = self.spec.parameter_names
        return tuple(k for k in self.params if k not in own)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the parameters in registry order; the host knows
        those of host-declared parameters (here unbounded)."""
        ps = self.spec.parameters
        extra = len(self.host_parameter_names)
        return (
            np.array([p.low for p in ps] + [-np.inf] * extra),
            np.array([p.high for p in ps] + [np.inf] * extra),
        )

    def with_params(self, values: Mapping[str, Any]) -> Effect:
        """A copy with the parameters named in ``values`` replaced."""
        return Effect(self.kind, self.name, {**self.params, **values}, self.location)

    def describe(self) -> str:
        """One line: words and parameter values with units."""
        parts = []
        for p in self.spec.parameters:
            val = self.params[p.name]
            txt = f"{float(val):.4g}" if np.ndim(val) == 0 else "array"
            parts.append(f"{p.name}={txt}{(' ' + p.unit) if p.unit else ''}")
        for name in self.host_parameter_names:
            val = self.params[name]
            parts.append(f"{name}={float(val):.4g}" if np.ndim(val) == 0 else f"{name}=array")
        return f"{self.words} ({', '.join(parts)})"

    # ----------------------------------------------------------------- evaluation
    def check(self) -> Effect:
        """The effect itself, once its parameters are in their laws' domain (else a
        :class:`ValidationError` naming the rule and the value)."""
        for name, (bound, strict) in self.spec.domain.items():
            require_positive(name, self.params[name], strict, bound)
        return self

    def _spec_of_role(self, role: str) -> EffectKind:
        """The kind's spec; a :class:`ValidationError` unless its role is ``role``."""
        spec = self.spec
        if spec.role != role:
            raise ValidationError(
                f"effect {self.name!r} ({self.kind}) has role {spec.role!r}, not {role!r}"
            )
        return spec

    def force(
        self, x: np.ndarray, v: np.ndarray | None = None, t: np.ndarray | None = None
    ) -> np.ndarray:
        """Force [N] of a force-role effect along ``x[..., T]`` [m] (``v`` [m/s], ``t`` [s]).

        When ``v`` is omitted it is the central-difference derivative of ``x``
        over ``t`` (which is then required).
        """
        spec = self._spec_of_role("force")
        x = np.asarray(x, dtype=float)
        if (v is None or spec.needs_time) and t is None:
            raise ValidationError(
                f"effect {self.name!r} ({self.kind}) needs the time vector `t` "
                "(rate-dependent element or velocity not given)"
            )
        if v is None:
            v = np.gradient(x, np.asarray(t, dtype=float), axis=-1)
        return spec.apply(x, np.asarray(v, dtype=float), t, **self.check().params)

    def sensor(self, y: np.ndarray, t: np.ndarray | None = None) -> np.ndarray:
        """Recorded version of a true channel ``y[..., T]`` for a sensor-role effect."""
        spec = self._spec_of_role("sensor")
        if spec.needs_time and t is None:
            raise ValidationError(f"effect {self.name!r} ({self.kind}) needs the time vector `t`")
        return spec.apply(np.asarray(y, dtype=float), t, **self.params)

    # ----------------------------------------------------------------- persistence
    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "name": self.name,
            "location": self.location,
            "params": {k: float(v) for k, v in self.params.items()},
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Effect:
        missing = [k for k in ("kind", "name") if k not in d]
        if missing:
            raise ValidationError(f"effect dict must contain 'kind' and 'name', missing {missing}")
        return cls(d["kind"], d["name"], dict(d.get("params", {})), d.get("location", ""))


def make_effect(kind: str, name: str | None = None, location: str = "", **params: Any) -> Effect:
    """Shorthand: ``make_effect("coulomb_friction", f_c=20.0)`` (name defaults to the kind)."""
    return Effect(kind, name or kind, params, location)
