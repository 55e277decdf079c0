"""Option checks shared by every problem, strategy and file reader.

Each checker takes the *owner* (who the option belongs to: a problem or strategy name, a
file), the option's *name* and the *value* as given, and returns the value converted to
its plain Python type, or raises :class:`~suspenv.core.errors.ValidationError` whose
message names the owner, the broken rule and the value::

    cmaes: `0 < sigma0 <= 1` must hold, but got sigma0=1.5
    MinibusRideHandling: `speed_kmh` must be a finite number with `speed_kmh > 0`, but
        got speed_kmh=inf
    problem 'Sphere': unknown option 'dimm' (did you mean 'dim'?); valid options: delay_s, dim

Rules for the kinds of value:

- number (:func:`number`, :func:`positive`, :func:`numbers`): an ``int``, a ``float`` or a
  numpy number, finite (no NaN, no infinity), optionally within a range (each end
  inclusive or open). ``bool`` is refused (``True`` is not a number of anything), and so
  are strings: ``"1.5"`` is a text, not a number.
- integer (:func:`integer`): an ``int`` or numpy integer, or a float whose value is
  integral (``3.0``, as JSON and some TOML writers produce); refused: ``2.5`` (it is not
  truncated to 2), NaN, infinities, ``bool`` and strings.
- choice (:func:`choice`, :func:`texts`): a string from a fixed set, optionally compared
  without regard to case (the canonical spelling is returned); a near miss is suggested.
- keywords (:func:`check_keywords`): names outside the allowed set are refused with the
  nearest allowed name and the full list; :func:`option_names` reads the allowed set off
  a constructor's signature.

Only the standard library and :mod:`suspenv.core.errors` are used, so every layer may
import this module.
"""

from __future__ import annotations

import difflib
import inspect
import math
import numbers as _numbers
from collections.abc import Callable, Iterable, Sequence
from typing import Any

from suspenv.core.errors import ValidationError

__all__ = [
    "check_keywords",
    "choice",
    "did_you_mean",
    "flag",
    "integer",
    "near_names",
    "nearest",
    "number",
    "numbers",
    "option_names",
    "optional",
    "positive",
    "text",
    "texts",
]


def _show(value: Any) -> str:
    """``repr`` of a value, numpy scalars shown as the plain number (``1.5``, not
    ``np.float64(1.5)``)."""
    item = getattr(value, "item", None)
    if callable(item) and getattr(value, "ndim", None) == 0:
        value = item()
    return repr(value)


def _bound(x: float) -> str:
    return f"{x:g}"


def near_names(name: Any, known: Iterable[str], n: int = 1, cutoff: float = 0.6) -> list[str]:
    """Up to ``n`` known names nearest to ``name``: the one that differs only in case
    alone, else difflib's closest with a ratio >= ``cutoff`` ([] when nothing is near)."""
    known = list(known)
    lowered = {k.lower(): k for k in known}
    if str(name).lower() in lowered:
        return [lowered[str(name).lower()]]
    return difflib.get_close_matches(str(name), known, n=n, cutoff=cutoff)


def nearest(name: Any, known: Iterable[str]) -> str | None:
    """The known name nearest to ``name`` (:func:`near_names`), or None."""
    near = near_names(name, known)
    return near[0] if near else None


def did_you_mean(name: Any, known: Iterable[str], n: int = 3, cutoff: float = 0.6) -> str:
    """``"; did you mean 'a', 'b'?"`` naming :func:`near_names`, or "" when none is near:
    the hint every "unknown name" error ends with."""
    near = near_names(name, known, n, cutoff)
    return f"; did you mean {', '.join(map(repr, near))}?" if near else ""


def optional(
    check: Callable[..., Any], owner: str, name: str, value: Any, *args: Any, **rules: Any
) -> Any:
    """None for a value of None, else ``check(owner, name, value, *args, **rules)``: an
    option whose None means "the default"."""
    return None if value is None else check(owner, name, value, *args, **rules)


def check_keywords(
    owner: str, given: Iterable[str], allowed: Iterable[str], what: str = "option"
) -> None:
    """Refuse every name of ``given`` (e.g. a mapping's keys) that is not in ``allowed``.

    The message names each unknown name with the nearest allowed one and lists them all:
    ``"problem 'Sphere': unknown option 'dimm' (did you mean 'dim'?); valid options:
    delay_s, dim"``. ``what`` is the word for one name ("option", "key", "point", ...).
    """
    allowed = list(allowed)
    unknown = [str(k) for k in given if k not in allowed]
    if not unknown:
        return
    parts = []
    for k in unknown:
        near = nearest(k, allowed)
        parts.append(f"{k!r}" + (f" (did you mean {near!r}?)" if near else ""))
    plural = "s" if len(unknown) > 1 else ""
    valid = ", ".join(sorted(allowed)) if allowed else "none"
    raise ValidationError(
        f"{owner}: unknown {what}{plural} {', '.join(parts)}; valid {what}s: {valid}"
    )


def option_names(target: Callable[..., Any], reserved: Iterable[str] = ()) -> list[str] | None:
    """The keyword options a class (its ``__init__``) or a function takes, without ``self``
    and the names in ``reserved``; None when it takes any keyword (``**kwargs``)."""
    params = inspect.signature(target).parameters
    if any(p.kind is p.VAR_KEYWORD for p in params.values()):
        return None
    skip = {"self", *reserved}
    keyword = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return [k for k, p in params.items() if k not in skip and p.kind in keyword]


def _range_rule(name: str, lo: float | None, hi: float | None, lo_open: bool, hi_open: bool) -> str:
    lo_op, hi_op = ("<" if lo_open else "<="), ("<" if hi_open else "<=")
    if lo is not None and hi is not None:
        return f"`{_bound(lo)} {lo_op} {name} {hi_op} {_bound(hi)}`"
    if lo is not None:
        return f"`{name} {'>' if lo_open else '>='} {_bound(lo)}`"
    if hi is not None:
        return f"`{name} {hi_op} {_bound(hi)}`"
    return ""


def _in_range(x: float, lo: float | None, hi: float | None, lo_open: bool, hi_open: bool) -> bool:
    if lo is not None and not (x > lo if lo_open else x >= lo):
        return False
    return hi is None or (x < hi if hi_open else x <= hi)


def number(
    owner: str,
    name: str,
    value: Any,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
) -> float:
    """A finite real number, within ``[lo, hi]`` when given (``lo_open``/``hi_open``
    exclude that end). Returns it as a ``float``."""
    rule = _range_rule(name, lo, hi, lo_open, hi_open)
    with_rule = f" with {rule}" if rule else ""
    if isinstance(value, bool) or not isinstance(value, _numbers.Real):
        kind = f" ({type(value).__name__})"
        raise ValidationError(
            f"{owner}: `{name}` must be a number{with_rule}, but got {name}={_show(value)}{kind}"
        )
    try:
        x = float(value)
    except OverflowError:  # an int beyond the float range
        x = math.inf
    if not math.isfinite(x):
        raise ValidationError(
            f"{owner}: `{name}` must be a finite number{with_rule}, but got {name}={_show(value)}"
        )
    if not _in_range(x, lo, hi, lo_open, hi_open):
        raise ValidationError(f"{owner}: {rule} must hold, but got {name}={_show(value)}")
    return x


def positive(owner: str, name: str, value: Any) -> float:
    """A finite number ``> 0`` (a length, a speed, a scale ...), as a ``float``."""
    return number(owner, name, value, lo=0.0, lo_open=True)


def integer(owner: str, name: str, value: Any, lo: int | None = None, hi: int | None = None) -> int:
    """An integer within ``[lo, hi]`` (both inclusive) when given, as an ``int``.

    Accepted: ``int``, numpy integers, floats with an integral value (``3.0``). Refused:
    ``bool``, ``2.5`` (never truncated), NaN, infinities, strings.
    """
    rule = _range_rule(name, lo, hi, False, False)
    integral = isinstance(value, _numbers.Integral) and not isinstance(value, bool)
    if not integral and not (
        isinstance(value, _numbers.Real)
        and not isinstance(value, bool)
        and math.isfinite(float(value))
        and float(value).is_integer()
    ):
        plain = isinstance(value, _numbers.Real) and not isinstance(value, bool)
        kind = "" if plain else f" ({type(value).__name__})"
        with_rule = f" with {rule}" if rule else ""
        raise ValidationError(
            f"{owner}: `{name}` must be an integer{with_rule}, but got {name}={_show(value)}{kind}"
        )
    n = int(value)
    if not _in_range(n, lo, hi, False, False):
        raise ValidationError(f"{owner}: {rule} must hold, but got {name}={_show(value)}")
    return n


def numbers(
    owner: str,
    name: str,
    value: Any,
    length: int | None = None,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
) -> list[float]:
    """A sequence (list, tuple, 1-D array) of finite numbers, each checked like
    :func:`number` (named ``name[i]``), of ``length`` items when given."""
    items = _as_list(value)
    if items is None:
        raise ValidationError(
            f"{owner}: `{name}` must be a list of numbers, but got {name}={_show(value)} "
            f"({type(value).__name__})"
        )
    if length is not None and len(items) != length:
        raise ValidationError(
            f"{owner}: `len({name}) == {length}` must hold, but got len({name})={len(items)} "
            f"({name}={_show(items)})"
        )
    return [
        number(owner, f"{name}[{i}]", v, lo, hi, lo_open=lo_open, hi_open=hi_open)
        for i, v in enumerate(items)
    ]


def _as_list(value: Any) -> list[Any] | None:
    """The items of a list, a tuple or a 1-D array; None for anything else (a string or a
    mapping is not a list of values)."""
    if isinstance(value, list | tuple):
        return list(value)
    if getattr(value, "ndim", None) == 1 and hasattr(value, "tolist"):
        return list(value)
    return None


def flag(owner: str, name: str, value: Any, allow_none: bool = False) -> bool | None:
    """A bool or a numpy bool scalar (None too when ``allow_none``); 0/1 and strings are
    refused."""
    numpy_bool = getattr(value, "shape", None) == () and getattr(value, "dtype", None) == "bool"
    if isinstance(value, bool) or numpy_bool or (allow_none and value is None):
        return None if value is None else bool(value)
    kinds = "True, False or None" if allow_none else "True or False"
    raise ValidationError(
        f"{owner}: `{name}` must be {kinds}, but got {name}={_show(value)} ({type(value).__name__})"
    )


def text(owner: str, name: str, value: Any, empty: bool = False) -> str:
    """A string (a name, a path), non-empty unless ``empty``."""
    if not isinstance(value, str):
        raise ValidationError(
            f"{owner}: `{name}` must be a string, but got {name}={_show(value)} "
            f"({type(value).__name__})"
        )
    if not empty and not value.strip():
        raise ValidationError(f"{owner}: `{name}` must not be empty, but got {name}={value!r}")
    return value


def choice(
    owner: str, name: str, value: Any, allowed: Sequence[str], *, ignore_case: bool = False
) -> str:
    """One of ``allowed`` (compared without case when ``ignore_case``; the allowed spelling
    is returned). The message lists the allowed values and suggests the nearest."""
    if isinstance(value, str):
        if value in allowed:
            return value
        if ignore_case:
            lowered = {a.lower(): a for a in allowed}
            if value.strip().lower() in lowered:
                return lowered[value.strip().lower()]
    hint = did_you_mean(value, allowed, n=1) if isinstance(value, str) else ""
    raise ValidationError(
        f"{owner}: `{name}` must be one of {list(allowed)}, but got {_show(value)}{hint}"
    )


def texts(
    owner: str,
    name: str,
    value: Any,
    allowed: Sequence[str] | None = None,
    *,
    empty: bool = True,
) -> tuple[str, ...]:
    """A list of strings (a single string is refused: it is not a list of names), each one
    of ``allowed`` when given (checked like :func:`choice`, named ``name[i]``); an empty
    list only when ``empty``."""
    items = _as_list(value)
    if items is None:
        raise ValidationError(
            f"{owner}: `{name}` must be a list of strings, but got {name}={_show(value)} "
            f"({type(value).__name__})"
        )
    if not items and not empty:
        raise ValidationError(f"{owner}: `{name}` must not be empty, but got {name}=[]")
    if allowed is None:
        return tuple(text(owner, f"{name}[{i}]", v) for i, v in enumerate(items))
    return tuple(choice(owner, f"{name}[{i}]", v, allowed) for i, v in enumerate(items))
