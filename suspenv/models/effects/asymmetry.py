"""Left/right manufacturing asymmetry helpers.

A symmetric model uses one value for a left/right pair (hard point coordinate,
bushing rate, spring rate...). Real parts differ within a tolerance. These helpers
draw reproducible left/right pairs from a nominal value and a relative (or
absolute) tolerance with a seed; units are those of the nominal value.

Convention: left = side with y > 0 (ISO 8855), keys ending ``_left``/``_right``
(or ``.left``/``.right``) name the two sides of a pair.
"""

from __future__ import annotations

import numpy as np

from suspenv.core.errors import ValidationError


def perturb_pair(
    nominal: float,
    tolerance: float,
    seed: int | np.random.Generator | None = None,
    relative: bool = True,
) -> tuple[float, float]:
    """Return ``(left, right)``, each the nominal value moved uniformly within ``±tolerance``.

    ``relative=True``: ``value = nominal (1 + e)``, ``e ~ U(-tolerance, tolerance)``;
    otherwise ``value = nominal + e`` in the nominal's unit.
    """
    if not tolerance >= 0:
        raise ValidationError(f"`tolerance >= 0` must hold, but got tolerance={tolerance!r}")
    e = np.random.default_rng(seed).uniform(-tolerance, tolerance, size=2)
    if relative:
        return float(nominal * (1.0 + e[0])), float(nominal * (1.0 + e[1]))
    return float(nominal + e[0]), float(nominal + e[1])


def split_pair(nominal: float, delta: float, relative: bool = True) -> tuple[float, float]:
    """Deterministic pair with right minus left = ``delta`` (relative to nominal if ``relative``).

    Left and right sit symmetrically about the nominal value:
    ``left = nominal (1 - delta/2)``, ``right = nominal (1 + delta/2)``.
    """
    if relative:
        return float(nominal * (1.0 - 0.5 * delta)), float(nominal * (1.0 + 0.5 * delta))
    return float(nominal - 0.5 * delta), float(nominal + 0.5 * delta)
