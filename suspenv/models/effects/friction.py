"""Friction elements: smooth Coulomb, Stribeck/stiction, direction-dependent, LuGre.

Units SI: velocity v [m/s], force [N], time [s]. Sign convention: the returned
force is the friction force the element transmits, positive when it opposes
positive sliding velocity (power absorbed ``F v >= 0``).

* Smooth Coulomb: ``F = f_c tanh(v / v_eps)``; ``v_eps`` [m/s] is the width of the
  regularised step (``v_eps -> 0`` gives the ideal ``f_c sign(v)``).
* Stribeck curve (static friction ``f_s >= f_c`` decaying to Coulomb ``f_c`` over
  the Stribeck velocity ``v_s``)::

      g(v) = f_c + (f_s - f_c) exp(-(v / v_s)^2),   F = g(v) tanh(v / v_eps)

* Force missing around zero speed (a velocity dead band): ``F = -f_d tanh(v / v_band)``.
* Direction-dependent Coulomb: ``f_pos`` when sliding positive, ``f_neg`` when
  negative: ``F = (f_pos + f_neg)/2 tanh(v/v_eps) + (f_pos - f_neg)/2 * |tanh(v/v_eps)|``.
  Note that over a test in which the sliding direction is rarely held, the
  asymmetric part is hard to tell from a constant force offset.
* LuGre (Canudas de Wit et al., 1995), bristle deflection ``z`` [m]::

      dz/dt = v - sigma0 |v| z / g(v)
      F = sigma0 z + sigma1 dz/dt

  ``sigma0`` [N/m] bristle stiffness, ``sigma1`` [N s/m] bristle damping; the
  viscous term ``sigma2 v`` of the original model belongs to the base model here.
"""

from __future__ import annotations

import numpy as np

from suspenv.models.effects._util import (
    Value,
    batch_param,
    linear_recurrence,
    require_positive,
    series,
    time_steps,
)


def coulomb_smooth(v: Value, f_c: Value, v_eps: Value = 1e-3) -> np.ndarray:
    """Regularised Coulomb friction force [N] at sliding velocity ``v`` [m/s]."""
    return f_c * np.tanh(v / v_eps)


def low_speed_deficit(v: Value, f_d: Value, v_band: Value) -> np.ndarray:
    """Force [N] missing around zero speed: ``-f_d tanh(v / v_band)``."""
    return -coulomb_smooth(v, f_d, v_band)


def coulomb_directional(v: Value, f_pos: Value, f_neg: Value, v_eps: Value = 1e-3) -> np.ndarray:
    """Coulomb friction [N] of level ``f_pos`` for ``v > 0`` and ``f_neg`` for ``v < 0``."""
    th = np.tanh(v / v_eps)
    return 0.5 * (f_pos + f_neg) * th + 0.5 * (f_pos - f_neg) * np.abs(th)


def stribeck_level(v: Value, f_c: Value, f_s: Value, v_s: Value) -> np.ndarray:
    """Stribeck friction level g(v) [N] (positive, even in ``v``)."""
    return f_c + (f_s - f_c) * np.exp(-((v / v_s) ** 2))


def stribeck_friction(
    v: Value, f_c: Value, f_s: Value, v_s: Value, v_eps: Value = 1e-3
) -> np.ndarray:
    """Static friction force [N] with stiction and Stribeck decay: ``g(v) tanh(v/v_eps)``."""
    return stribeck_level(v, f_c, f_s, v_s) * np.tanh(v / v_eps)


def lugre_dzdt(z: Value, v: Value, sigma0: Value, f_c: Value, f_s: Value, v_s: Value) -> np.ndarray:
    """LuGre bristle-deflection derivative dz/dt [m/s] (the level floored at 1e-12 N: the
    zero-friction limit)."""
    return v - sigma0 * np.abs(v) * z / np.maximum(stribeck_level(v, f_c, f_s, v_s), 1e-12)


def lugre_force(
    z: Value, v: Value, sigma0: Value, sigma1: Value, f_c: Value, f_s: Value, v_s: Value
) -> np.ndarray:
    """LuGre friction force [N] from state ``z`` [m] and velocity ``v`` [m/s]."""
    return sigma0 * z + sigma1 * lugre_dzdt(z, v, sigma0, f_c, f_s, v_s)


def lugre_series(
    v: np.ndarray,
    t: np.ndarray,
    sigma0: Value,
    sigma1: Value,
    f_c: Value,
    f_s: Value,
    v_s: Value,
    z0: Value = 0.0,
) -> np.ndarray:
    """LuGre friction force [N] for a velocity history ``v[..., T]`` sampled at ``t[T]``.

    Velocity is held constant over each interval, where the bristle equation is
    linear in ``z`` and is stepped exactly (exponential), so stiff bristles are stable
    at any sample rate. Parameters are batch-shaped.
    """
    v = series(v, "v")
    dt = time_steps(t, v.shape[-1])
    require_positive("sigma0", sigma0)
    require_positive("v_s", v_s)
    s0, s1, fc, fs, vs = (batch_param(p) for p in (sigma0, sigma1, f_c, f_s, v_s))
    vk = v[..., :-1]
    # a zero friction level (the "no effect" limit) is floored to keep the step finite
    rate = s0 * np.abs(vk) / np.maximum(stribeck_level(vk, fc, fs, vs), 1e-12)
    decay = np.exp(-rate * dt)
    # exact solution of dz/dt = vk - rate z over the interval; rate -> 0 limit is z + vk dt
    moving = rate > 1e-300
    safe = np.where(moving, rate, 1.0)
    a = np.where(moving, vk / safe * (1.0 - decay), vk * dt)
    z = linear_recurrence(a, np.where(moving, decay, 1.0), z0)
    return lugre_force(z, v, s0, s1, fc, fs, vs)
