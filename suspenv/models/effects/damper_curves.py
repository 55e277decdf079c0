"""Damper force-velocity curves: digressive, asymmetric digressive, extra rebound.

Units SI: velocity v [m/s] (positive = compression / bump, negative = extension /
rebound), force [N], positive when it resists positive velocity (power absorbed
``F v >= 0`` for positive coefficients). Pointwise functions (numpy broadcasting).

* Digressive (rational knee)::

      F = c_low v / (1 + |v| / v_knee)

  slope ``c_low`` at rest, force saturating towards ``c_low v_knee`` at high speed.
  With a linear base ``c_high v`` in parallel, the total curve has slope
  ``c_low + c_high`` at low speed and ``c_high`` above the knee (a blow-off damper).
* Asymmetric digressive (separate bump and rebound valve stacks)::

      F = c_bump v / (1 + v / v_knee_bump)              for v >= 0
      F = c_rebound v / (1 + |v| / v_knee_rebound)      for v < 0

  the digressive curve with its own low-speed slope and knee in each direction;
  equal coefficients give the symmetric curve.
* Extra rebound damping (the effect form of asymmetry, added to a linear base):
  ``F = dc_rebound * min(v, 0)``.
"""

from __future__ import annotations

import numpy as np

from suspenv.models.effects._util import Value


def extra_rebound_damping(v: Value, dc_rebound: Value) -> np.ndarray:
    """Additional rebound-only damping force ``dc_rebound * min(v, 0)`` [N]."""
    return dc_rebound * np.minimum(v, 0.0)


def damper_digressive(v: Value, c_low: Value, v_knee: Value) -> np.ndarray:
    """Digressive damper force ``c_low v / (1 + |v|/v_knee)`` [N]."""
    return c_low * v / (1.0 + np.abs(v) / v_knee)


def damper_digressive_asymmetric(
    v: Value, c_bump: Value, v_knee_bump: Value, c_rebound: Value, v_knee_rebound: Value
) -> np.ndarray:
    """Digressive damper force [N] with bump (v >= 0) and rebound (v < 0) coefficients.

    ``c_*`` [N s/m] is the low-speed slope and ``v_knee_*`` [m/s] the knee velocity of
    each branch (see the module docstring); continuous at ``v = 0``. The sum of the two
    one-sided curves (one of them zero): a form numba compiles for scalars too.
    """
    bump, rebound = np.maximum(v, 0.0), np.minimum(v, 0.0)
    f_bump = c_bump * bump / (1.0 + bump / v_knee_bump)
    return f_bump + c_rebound * rebound / (1.0 - rebound / v_knee_rebound)
