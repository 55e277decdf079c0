"""Minibus suspension elements: two-stage leaf, torsion-bar wheel rate, stabilisers, dampers.

Frame and units: ISO 8855 (x forward, y left, z up), SI units (m, N, s, rad).
Sign conventions: spring/leaf deflection ``d`` is positive in compression (bump) and
measured from the free (unloaded) spring; element forces are positive when they push
body and wheel apart (they resist compression). Damper velocity ``v`` is the
compression rate (+ = bump); damper force is positive when it resists bump motion,
so the absorbed power is ``F * v >= 0``. Roll angles are positive right-side-down
about +x; a stabiliser moment is positive when it resists positive body-minus-axle
roll.

Every function is vectorised: arguments broadcast with numpy rules, so a batch of
designs (arrays of shape (n,)) and a batch of states (n, ...) work alike.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from suspenv.core.errors import ValidationError

#: a rate: one float, or a float array
RateT = TypeVar("RateT", float, np.ndarray)


# ------------------------------------------------------------------ two-stage leaf
def leaf_force(
    d: np.ndarray, k1: np.ndarray | float, k2: np.ndarray | float, d_helper: float
) -> np.ndarray:
    """Two-stage leaf spring force (N) at deflection d (m, from free, + = compression).

    ``F = k1 d`` up to the helper-contact deflection ``d_helper``, then slope ``k2``
    (the composite rate of primary + helper): ``F = k1 d + (k2 - k1) max(d - d_helper, 0)``.
    Continuous at the knee; below zero deflection the primary leaf keeps its rate.
    """
    d = np.asarray(d, dtype=float)
    k1 = np.asarray(k1, dtype=float)
    return k1 * d + (np.asarray(k2, dtype=float) - k1) * np.maximum(d - d_helper, 0.0)


def leaf_static_deflection(
    load: np.ndarray | float, k1: np.ndarray, k2: np.ndarray, d_helper: float
) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`leaf_force`: deflection (m) and helper-engaged flag at a load
    (N) >= 0, for rates k1, k2 > 0 (not checked: a checked design's rates are)."""
    knee = k1 * d_helper
    on_helper = load > knee
    d = np.where(on_helper, d_helper + (load - knee) / k2, load / k1)
    return d, on_helper


# ------------------------------------------------------------------ torsion bar / bars
def torsion_bar_wheel_rate(bar_stiffness: np.ndarray | float, lever: float) -> np.ndarray:
    """Vertical wheel rate (N/m) of a torsion bar (N*m/rad) acting through a lever (m).

    Small-angle lever perpendicular to the wheel's vertical travel: a wheel travel dz
    twists the bar by dz/l and the moment K dz/l gives a wheel force K dz/l^2.
    """
    if lever <= 0:
        raise ValidationError(f"`lever > 0` must hold, but got lever={lever}")
    return np.asarray(bar_stiffness, dtype=float) / lever**2


def spring_pair_roll_stiffness(rate: RateT, spacing: float) -> RateT:
    """Roll stiffness (N*m/rad) of two vertical springs (N/m each, float or float
    array) ``spacing`` (m) apart."""
    return rate * (spacing**2 / 2.0)  # (halving is exact: the same as (rate s^2) / 2)


# ------------------------------------------------------------------ dampers
@dataclass(frozen=True)
class DamperCurve:
    """Nonlinear, asymmetric, digressive damper characteristic at the wheel (scale 1).

    Force (N, resisting motion) vs suspension velocity v (m/s, + = bump):
    ``c_low * v`` up to the knee speed, then slope ``c_high`` beyond it, with separate
    values in bump and rebound. The design scale C multiplies the whole curve.
    """

    bump_low: float  # N*s/m
    bump_high: float  # N*s/m
    bump_knee: float  # m/s
    rebound_low: float  # N*s/m
    rebound_high: float  # N*s/m
    rebound_knee: float  # m/s


def damper_force(v: np.ndarray, curve: DamperCurve, scale: np.ndarray | float = 1.0) -> np.ndarray:
    """Damper force (N, + resists bump) at compression rate v (m/s), curve scaled by ``scale``.

    Piecewise-linear, digressive and asymmetric: slope ``*_low`` up to the knee speed,
    ``*_high`` beyond, bump values for v > 0 and rebound values for v < 0. The scale
    (the study's C1/C2) multiplies the force at every velocity.
    """
    v = np.asarray(v, dtype=float)
    vb = np.clip(v, 0.0, curve.bump_knee)
    vr = np.clip(v, -curve.rebound_knee, 0.0)
    f = (
        curve.bump_low * vb
        + curve.bump_high * np.maximum(v - curve.bump_knee, 0.0)
        + curve.rebound_low * vr
        + curve.rebound_high * np.minimum(v + curve.rebound_knee, 0.0)
    )
    return np.asarray(scale, dtype=float) * f


def damper_mean_coefficient(curve: DamperCurve) -> float:
    """Low-speed damping coefficient (N*s/m), mean of bump and rebound (scale 1).

    The conventional single number for damping-ratio checks of an asymmetric damper.
    """
    return 0.5 * (curve.bump_low + curve.rebound_low)
