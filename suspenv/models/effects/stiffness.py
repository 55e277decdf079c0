"""Nonlinear stiffness elements: cubic (Duffing) and progressive springs, end stops.

Units SI: deflection x [m], force [N]. Sign convention: ``x`` positive = compression
(bump); the force is the force the element transmits, positive when it resists
positive deflection. All functions are pointwise (numpy broadcasting).

* Cubic stiffness: ``F = k3 (x - x_0)^3`` (``k3`` [N/m^3], neutral position ``x_0`` [m]),
  added to a linear base spring.
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
* Gas spring ``F = f_0 + k_gas x`` (preload ``f_0`` [N], stiffness ``k_gas`` [N/m]) and a
  constant force ``offset`` [N].
"""

from __future__ import annotations

import numpy as np

from suspenv.models.effects._util import Value


def cubic_stiffness(x: Value, k3: Value, x_0: Value = 0.0) -> Value:
    """Cubic spring force ``k3 (x - x_0)^3`` [N] about the neutral position ``x_0`` [m]."""
    d = x - x_0
    return k3 * (d * d * d)  # d**3 would take numpy's slow pow


def progressive_spring(x: Value, k_p: Value, x0: Value = 0.0) -> np.ndarray:
    """Symmetric progressive force ``k_p sign(x) max(|x| - x0, 0)^2`` [N]."""
    return k_p * np.sign(x) * np.maximum(np.abs(x) - x0, 0.0) ** 2


def bump_stop(x: Value, gap: Value, k_stop: Value, p: Value = 1.0) -> np.ndarray:
    """One-sided bump (compression) stop force [N]: zero until ``x > gap``."""
    return k_stop * np.maximum(x - gap, 0.0) ** p


def rebound_stop(x: Value, gap: Value, k_stop: Value, p: Value = 1.0) -> np.ndarray:
    """One-sided rebound (extension) stop force [N]: zero until ``x < -gap``; negative."""
    return -k_stop * np.maximum(-x - gap, 0.0) ** p


def bump_and_rebound_stops(
    x: Value, gap_bump: Value, k_bump: Value, gap_rebound: Value, k_rebound: Value, p: Value = 1.0
) -> np.ndarray:
    """Bump stop plus rebound stop [N]: positive beyond ``x > gap_bump``, negative beyond
    ``x < -gap_rebound``, zero between."""
    bump = k_bump * np.maximum(x - gap_bump, 0.0) ** p
    return bump - k_rebound * np.maximum(-x - gap_rebound, 0.0) ** p


def gas_spring(x: Value, f_0: Value, k_gas: Value) -> Value:
    """Gas spring force ``f_0 + k_gas x`` [N]: preload plus stiffness."""
    return f_0 + k_gas * x


def force_offset(x: Value, offset: Value) -> Value:
    """Constant force ``offset`` [N], shaped as ``x``."""
    return offset + 0.0 * x
