"""Design spaces: named, bounded, unit-carrying parameters and the unit-cube map.

Strategies only ever see the unit cube [0, 1]^d; problems only ever see physical
values. :class:`DesignSpace` is the single place where one becomes the other.
Linear parameters map ``x = low + u (high - low)``; log-scale parameters map
``x = low (high / low)^u`` (both bounds must be > 0).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import did_you_mean


@dataclass(frozen=True)
class Parameter:
    """One design variable.

    Attributes:
        name: unique identifier (``snake_case`` or dotted).
        low, high: physical bounds, ``low < high``.
        unit: unit string shown to users (e.g. ``"mm"``, ``"N/mm"``).
        log: map the unit interval logarithmically (needs ``low > 0``).
        default: reference value (inside the bounds); centre of the range if None.
        description: one line for tables and docs.
    """

    name: str
    low: float
    high: float
    unit: str = ""
    log: bool = False
    default: float | None = None
    description: str = ""

    def __post_init__(self) -> None:
        if not self.name:
            raise ValidationError("parameter `name` must be a non-empty string")
        lo, hi = float(self.low), float(self.high)
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise ValidationError(
                f"parameter {self.name!r}: bounds must be finite, but got (low={lo}, high={hi})"
            )
        if not lo < hi:
            raise ValidationError(
                f"parameter {self.name!r}: `low < high` must hold, but got (low={lo}, high={hi})"
            )
        if self.log and lo <= 0:
            raise ValidationError(
                f"parameter {self.name!r}: log scale needs `low > 0`, but got low={lo}"
            )
        if self.default is not None and not lo <= float(self.default) <= hi:
            raise ValidationError(
                f"parameter {self.name!r}: `low <= default <= high` must hold, but got "
                f"(low={lo}, default={self.default}, high={hi})"
            )

    @property
    def reference(self) -> float:
        """The default value, or the centre of the range (geometric centre on log scale)."""
        if self.default is not None:
            return float(self.default)
        if self.log:
            return math.sqrt(self.low * self.high)
        return 0.5 * (self.low + self.high)


class DesignSpace:
    """An ordered set of :class:`Parameter` with vectorised unit-cube maps."""

    def __init__(self, parameters: Iterable[Parameter]):
        self.parameters: tuple[Parameter, ...] = tuple(parameters)
        if not self.parameters:
            raise ValidationError("a design space needs at least one parameter, got 0")
        names = [p.name for p in self.parameters]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ValidationError(f"parameter names must be unique, but got duplicates {dupes}")
        self.names: tuple[str, ...] = tuple(names)
        self._index = {n: i for i, n in enumerate(names)}
        self.lower = np.array([p.low for p in self.parameters], dtype=float)
        self.upper = np.array([p.high for p in self.parameters], dtype=float)
        self.units: tuple[str, ...] = tuple(p.unit for p in self.parameters)
        self._log = np.array([p.log for p in self.parameters], dtype=bool)
        self._log_lo = np.log(np.where(self._log, self.lower, 1.0))
        self._log_hi = np.log(np.where(self._log, self.upper, 1.0))

    # ------------------------------------------------------------------ basics
    @property
    def dim(self) -> int:
        return len(self.parameters)

    def __len__(self) -> int:
        return self.dim

    def __repr__(self) -> str:
        more = "..." if self.dim > 4 else ""
        return f"DesignSpace(dim={self.dim}, names={list(self.names)[:4]}{more})"

    def index(self, name: str) -> int:
        """Column of parameter ``name``; unknown names suggest the nearest valid ones."""
        try:
            return self._index[name]
        except KeyError:
            hint = did_you_mean(name, self.names)
            raise ValidationError(f"unknown parameter {name!r}{hint}") from None

    # -------------------------------------------------------------- validation
    def check_batch(self, X: np.ndarray, *, what: str = "design batch") -> np.ndarray:
        """Return ``X`` as float (n, d); reject wrong shapes and NaN/inf with a clear message."""
        arr = np.asarray(X, dtype=float)
        if arr.ndim == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != self.dim:
            raise ValidationError(f"{what} must have shape (n, {self.dim}), but got {np.shape(X)}")
        bad = ~np.isfinite(arr)
        if bad.any():
            r, c = np.argwhere(bad)[0]
            raise ValidationError(
                f"{what} must be finite, but row {r} parameter {self.names[c]!r} is {arr[r, c]}"
                f" ({int(bad.any(axis=1).sum())} bad row(s))"
            )
        return arr

    # -------------------------------------------------------------------- maps
    def to_physical(self, U: np.ndarray) -> np.ndarray:
        """Map unit-cube designs (n, d) to physical values. Values are clipped to [0, 1]."""
        U = np.clip(self.check_batch(U, what="unit design batch"), 0.0, 1.0)
        lin = self.lower + U * (self.upper - self.lower)
        if self._log.any():
            logv = np.exp(self._log_lo + U * (self._log_hi - self._log_lo))
            lin = np.where(self._log, logv, lin)
        return lin

    def to_unit(self, X: np.ndarray) -> np.ndarray:
        """Map physical designs (n, d) to the unit cube (not clipped: outside bounds > 1 or < 0)."""
        X = self.check_batch(X)
        U = (X - self.lower) / (self.upper - self.lower)
        if self._log.any():
            with np.errstate(divide="ignore", invalid="ignore"):
                ulog = (np.log(np.where(self._log, X, 1.0)) - self._log_lo) / (
                    self._log_hi - self._log_lo
                )
            U = np.where(self._log, ulog, U)
        return U

    def slope(self, u: np.ndarray) -> np.ndarray:
        """``dx/du`` (d,) of the unit-cube map at the unit point ``u`` (d,), clipped to
        [0, 1]: ``high - low`` on a linear scale, ``x ln(high / low)`` on a log scale
        (physical units per unit)."""
        x = self.to_physical(np.clip(u, 0, 1)[None])[0]
        log, lo, hi = self._log, self.lower, self.upper
        with np.errstate(divide="ignore", invalid="ignore"):
            lg = x * np.log(np.where(log, hi / np.where(log, lo, 1.0), 1.0))
        return np.where(log, lg, hi - lo)

    def reference(self) -> np.ndarray:
        """Physical reference design (1-D, length d)."""
        return np.array([p.reference for p in self.parameters], dtype=float)

    def outside_bounds(self, X: np.ndarray) -> list[str]:
        """Messages for every physical value of a single design outside its bounds."""
        x = np.asarray(X, dtype=float).reshape(-1)
        out = []
        for p, v in zip(self.parameters, x, strict=True):
            if not p.low <= v <= p.high:
                out.append(f"{p.name}={v:g} outside [{p.low:g}, {p.high:g}] {p.unit}".rstrip())
        return out

    # ------------------------------------------------------------- dict views
    def as_dict(self, x: Sequence[float] | np.ndarray) -> dict[str, float]:
        """One physical design as ``{name: value}``."""
        arr = np.asarray(x, dtype=float).reshape(-1)
        if arr.size != self.dim:
            raise ValidationError(f"design must have {self.dim} values, but got {arr.size}")
        return {n: float(v) for n, v in zip(self.names, arr, strict=True)}

    def from_dict(self, values: Mapping[str, float], *, fill_reference: bool = True) -> np.ndarray:
        """A physical design from ``{name: value}``; unknown names are an error."""
        x = self.reference() if fill_reference else np.full(self.dim, np.nan)
        for name, v in values.items():
            x[self.index(name)] = float(v)
        return x

    def table(self) -> str:
        """A plain-text table of the parameters."""
        w = max(len(n) for n in self.names)
        rows = [f"{'name':<{w}}  {'low':>10}  {'high':>10}  {'default':>10}  unit"]
        for p in self.parameters:
            rows.append(
                f"{p.name:<{w}}  {p.low:>10.4g}  {p.high:>10.4g}  {p.reference:>10.4g}  {p.unit}"
                + ("  (log)" if p.log else "")
            )
        return "\n".join(rows)
