"""The one check of a sampled time vector: strictly increasing, with a named error."""

from __future__ import annotations

import numpy as np

from suspenv.core.errors import ValidationError


def increasing_steps(
    t: np.ndarray, where: str = "", name: str = "t", error: type[ValidationError] = ValidationError
) -> np.ndarray:
    """Sample intervals ``np.diff(t)`` [s] of the time vector ``t`` [s], all > 0.

    Raises ``error`` naming the first pair out of order as ``{where}time must be strictly
    increasing, but {name}[i]=... s and {name}[i+1]=... s``; ``where`` prefixes the source
    (``"run.csv: "``), ``name`` is the vector's name in the message.
    """
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.argmax(dt <= 0))
        raise error(
            f"{where}time must be strictly increasing, but {name}[{i}]={float(t[i])!r} s and "
            f"{name}[{i + 1}]={float(t[i + 1])!r} s"
        )
    return dt
