"""Nonlinear stiffness elements: cubic (Duffing) and progressive springs, end stops.

Units SI: deflection x [m], force [N]. Sign convention: ``x`` positive = compression
(bump); the force is the force the element transmits, positive when it resists
positive deflection. All functions are pointwise (numpy broadcasting).

* Cubic stiffness: ``F = k3 x^3`` (``k3`` [N/m^3]), added to a linear base spring.
  Under ``x = A sin(wt)`` it produces a third harmonic of amplitude ``k3 A^3 / 4``.
* Progressive spring beyond a free range: ``F = k_p sign(x) max(|x| - x0, 0)^2``
  (``k_p`` [N/m^2], ``x0`` [m]); symmetric, stiffening with amplitude.
* End stops, one-sided: a bump stop acts only when ``x > gap_bump``, a rebound stop
  only when ``x < -gap_rebound``::

      F_bump    =  k_stop * max(x - gap, 0)^p
      F_rebound = -k_stop * max(-x - gap, 0)^p

  ``gap`` [m] >= 0 is the free travel, ``k_stop`` [N/m^p], ``p >= 1`` (1 linear,
  2 a typical progressive elastomer stop).
* Bump and rebound stops as one element (a strut's travel limited both ways), each side
  with its own free travel and stiffness and one exponent::

      F = k_bump max(x - gap_bump, 0)^p - k_rebound max(-x - gap_rebound, 0)^p

  With equal gaps and stiffnesses and ``p = 2`` this is the progressive spring above;
  with ``p = 1`` it is linear beyond each gap.
"""

from __future__ import annotations

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.effects._util import Value, require_positive


def cubic_stiffness(x: Value, k3: Value) -> np.ndarray:
    """Cubic spring force ``k3 x^3`` [N]."""
    x = np.asarray(x, dtype=float)
    return np.asarray(k3, dtype=float) * (x * x * x)  # x**3 would take numpy's slow pow


def progressive_spring(x: Value, k_p: Value, x0: Value = 0.0) -> np.ndarray:
    """Symmetric progressive force ``k_p sign(x) max(|x| - x0, 0)^2`` [N]."""
    require_positive("x0", x0, strict=False)
    x = np.asarray(x, dtype=float)
    return np.asarray(k_p, dtype=float) * np.sign(x) * np.maximum(np.abs(x) - x0, 0.0) ** 2


def _check_stop(
    gap: Value, k_stop: Value, p: Value, names: tuple[str, str] = ("gap", "k_stop")
) -> None:
    require_positive(names[0], gap, strict=False)
    require_positive(names[1], k_stop, strict=False)
    if np.any(np.asarray(p, dtype=float) < 1.0):
        raise ValidationError(f"`p >= 1` must hold, but got p={p!r}")


def bump_stop(x: Value, gap: Value, k_stop: Value, p: Value = 1.0) -> np.ndarray:
    """One-sided bump (compression) stop force [N]: zero until ``x > gap``."""
    _check_stop(gap, k_stop, p)
    x = np.asarray(x, dtype=float)
    return k_stop * np.maximum(x - gap, 0.0) ** p


def rebound_stop(x: Value, gap: Value, k_stop: Value, p: Value = 1.0) -> np.ndarray:
    """One-sided rebound (extension) stop force [N]: zero until ``x < -gap``; negative."""
    _check_stop(gap, k_stop, p)
    x = np.asarray(x, dtype=float)
    return -k_stop * np.maximum(-x - gap, 0.0) ** p


def bump_and_rebound_stops(
    x: Value, gap_bump: Value, k_bump: Value, gap_rebound: Value, k_rebound: Value, p: Value = 1.0
) -> np.ndarray:
    """Bump stop plus rebound stop [N]: positive beyond ``x > gap_bump``, negative beyond
    ``x < -gap_rebound``, zero between."""
    _check_stop(gap_bump, k_bump, p, ("gap_bump", "k_bump"))
    _check_stop(gap_rebound, k_rebound, p, ("gap_rebound", "k_rebound"))
    x = np.asarray(x, dtype=float)
    return (
        k_bump * np.maximum(x - gap_bump, 0.0) ** p
        - k_rebound * np.maximum(-x - gap_rebound, 0.0) ** p
    )
