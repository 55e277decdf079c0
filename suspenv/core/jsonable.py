"""Plain JSON values from numpy results (every ``*.json`` suspenv writes, every
configuration hashed)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np


def to_jsonable(obj: Any, finite: bool = True) -> Any:
    """``obj`` with numpy scalars and arrays as Python values, paths as text and, when
    ``finite``, non-finite floats (NaN, inf) as None (else kept: ``json.dumps`` writes
    them as ``NaN`` / ``Infinity``, which ``json.loads`` reads back); dict keys become
    text."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v, finite) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [to_jsonable(v, finite) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist(), finite)
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item(), finite)
    if isinstance(obj, float):
        return obj if np.isfinite(obj) or not finite else None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def json_default(obj: Any) -> Any:
    """``json.dumps``'s ``default``: numpy arrays and scalars as Python values, sets as
    sorted lists, anything else (a path, an enum, a class) as its ``str``."""
    if isinstance(obj, np.ndarray | np.generic):
        return obj.tolist()
    if isinstance(obj, set | frozenset):
        return sorted(obj)
    return str(obj)


def json_text(obj: Any) -> str:
    """``obj`` as indented, standard JSON text with a final newline: numpy values as
    Python values and non-finite floats as ``null`` (:func:`to_jsonable`)."""
    return json.dumps(to_jsonable(obj), indent=2) + "\n"
