"""Rate-independent hysteresis elements: Dahl and Bouc-Wen.

Units SI: displacement x [m], velocity v [m/s], force [N]. Sign convention (every
force element in :mod:`suspenv.models.effects`): ``x`` is the element's deflection
(positive = compression / bump), and the returned force is the force the element
transmits, positive when it resists positive deflection, so the power it absorbs is
``F * v`` and the energy it dissipates over a closed cycle is ``∮ F dx >= 0``.

Two forms of each element:

* state-derivative form for time integration, ``*_dzdt(z, v, ...)`` (pointwise,
  numpy broadcasting);
* path form for quasi-static sweeps, ``*_path(x[..., T], ...)``: the state is
  integrated along the displacement path, so the loop depends on the path only,
  never on how fast it is travelled (rate independence).

Dahl (P. R. Dahl, 1968), with the hysteretic force ``z`` [N] as the state::

    dz/dt = sigma * v * (1 - z / f_c * sign(v))

``sigma`` [N/m] is the initial stiffness after a reversal and ``f_c`` [N] the
saturation force. Along a monotone stretch of the path the exact solution is
``z = s f_c + (z0 - s f_c) exp(-sigma |Δx| / f_c)``, ``s = sign(Δx)``; the path
form uses it segment by segment, so it is exact for piecewise-linear paths.

Bouc-Wen (Bouc 1967, Wen 1976), canonical form with dimension-free shape::

    dz/dt = A v - beta |v| |z|^(n-1) z - gamma v |z|^n

The engineering form used by the effect registry has ``z`` dimensionless with
ultimate value 1 and ``F = f_y z``: ``A = 1/x_y``, ``beta = b/x_y``,
``gamma = (1-b)/x_y``; ``f_y`` [N] is the asymptotic hysteretic force, ``x_y`` [m]
the yield displacement (initial stiffness ``f_y/x_y``), ``b`` in [0, 1] the loop
shape and ``n >= 1`` the sharpness of the knee.

Berg (M. Berg, 1998), the friction part of a rubber bushing model, path form only
(its memory is the last reversal point ``(x_s, F_s)``, not a smooth state)::

    x > x_s:  F = F_s + (x - x_s) / (x2 (1 - a) + (x - x_s)) (f_max - F_s)
    x < x_s:  F = F_s + (x - x_s) / (x2 (1 + a) - (x - x_s)) (f_max + F_s),   a = F_s / f_max

``f_max`` [N] is the limit friction force and ``x2`` [m] the travel from the
unloaded state to half of it (``F(x2) = f_max / 2`` on the virgin curve).
"""

from __future__ import annotations

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.effects import kernels
from suspenv.models.effects._util import (
    Value,
    batch_param,
    linear_recurrence,
    require_positive,
    series,
)


def dahl_dzdt(z: Value, v: Value, sigma: Value, f_c: Value) -> np.ndarray:
    """Dahl state derivative dz/dt [N/s]; ``z`` hysteretic force [N], ``v`` [m/s]."""
    return sigma * v * (1.0 - z / f_c * np.sign(v))


def dahl_segment(dx: Value, sigma: Value, f_c: Value) -> tuple[np.ndarray, np.ndarray]:
    """The exact Dahl step over a monotone increment ``dx`` [m] as the coefficients
    ``(a [N], decay)`` of ``z_new = a + decay z_old``: ``decay = exp(-sigma |dx| / f_c)``,
    ``a = sign(dx) f_c (1 - decay)``. ``sigma`` [N/m], ``f_c`` [N] ``>= 0`` (not checked);
    ``f_c = 0`` is the "no effect" limit: the force relaxes to zero at once."""
    with np.errstate(divide="ignore"):
        decay = np.where(f_c > 0, np.exp(-sigma * np.abs(dx) / np.where(f_c > 0, f_c, 1.0)), 0.0)
    return np.sign(dx) * f_c * (1.0 - decay), decay


def dahl_path(x: np.ndarray, sigma: Value, f_c: Value, z0: Value = 0.0) -> np.ndarray:
    """Dahl hysteretic force [N] along a displacement path ``x[..., T]`` [m].

    Exact for piecewise-linear paths (:func:`dahl_segment` on each segment, a linear
    recurrence in z). ``sigma`` [N/m], ``f_c`` [N] (``>= 0``; zero gives zero force)
    and ``z0`` [N] are batch-shaped.
    """
    x = series(x)
    require_positive("sigma", sigma)
    require_positive("f_c", f_c, strict=False)
    a, decay = dahl_segment(np.diff(x, axis=-1), batch_param(sigma), batch_param(f_c))
    return linear_recurrence(a, decay, z0)


def bouc_wen_dzdt(z: Value, v: Value, A: Value, beta: Value, gamma: Value, n: Value) -> np.ndarray:
    """Canonical Bouc-Wen state derivative dz/dt (units of ``A v``)."""
    az = np.abs(z)
    return A * v - beta * np.abs(v) * az ** (n - 1.0) * z - gamma * v * az**n


def bouc_wen_ultimate(A: Value, beta: Value, gamma: Value, n: Value) -> np.ndarray:
    """Ultimate state ``z_u = (A / (beta + gamma))^(1/n)`` reached on long monotone loading."""
    bg = np.asarray(beta, dtype=float) + np.asarray(gamma, dtype=float)
    require_positive("beta + gamma", bg)
    return (np.asarray(A, dtype=float) / bg) ** (1.0 / np.asarray(n, dtype=float))


def bouc_wen_path(
    x: np.ndarray,
    A: Value,
    beta: Value,
    gamma: Value,
    n: Value = 1.0,
    z0: Value = 0.0,
    max_step_ratio: float = 0.25,
) -> np.ndarray:
    """Canonical Bouc-Wen state along a displacement path ``x[..., T]``.

    Integrates ``dz/dx = A - (beta sign(Δx) sign(z) + gamma) |z|^n``. For ``n = 1``
    (every batch member) the equation is linear in ``z`` on each side of ``z = 0``
    and is solved exactly per segment (splitting at the zero crossing); otherwise
    RK4 with sub-steps of at most ``max_step_ratio`` of the yield displacement
    ``z_u / A``. Needs ``n >= 1``, ``A > 0`` and ``beta + gamma > 0``. Parameters
    are batch-shaped.
    """
    x = series(x)
    require_positive("A", A)
    if np.any(np.asarray(n, dtype=float) < 1.0):
        raise ValidationError(f"`n >= 1` must hold, but got n={n!r}")
    a, b, g, nn = (batch_param(p)[..., 0] for p in (A, beta, gamma, n))
    zu = bouc_wen_ultimate(a, b, g, nn)
    batch = np.broadcast_shapes(x.shape[:-1], a.shape, b.shape, g.shape, nn.shape, np.shape(z0))
    dx = np.diff(x, axis=-1)
    x_yield = np.min(zu / a)
    nsub = int(
        np.clip(np.ceil(np.max(np.abs(dx), initial=0.0) / (max_step_ratio * x_yield)), 1, 2000)
    )
    if np.all(nn == 1.0):
        return _bouc_wen_path_linear(x, a, b, g, z0, batch)
    out = np.empty(batch + x.shape[-1:])
    z = np.broadcast_to(np.asarray(z0, dtype=float), batch).copy()
    out[..., 0] = z

    def rhs(zz: np.ndarray, s: np.ndarray) -> np.ndarray:
        return a - (b * s * np.sign(zz) + g) * np.abs(zz) ** nn

    for k in range(dx.shape[-1]):
        h = dx[..., k] / nsub
        s = np.sign(h)
        for _ in range(nsub):
            k1 = rhs(z, s)
            k2 = rhs(z + 0.5 * h * k1, s)
            k3 = rhs(z + 0.5 * h * k2, s)
            k4 = rhs(z + h * k3, s)
            z = z + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[..., k + 1] = z
    return out


def _bouc_wen_path_linear(x, a, b, g, z0, batch) -> np.ndarray:
    """Exact n = 1 Bouc-Wen along a piecewise-linear path.

    With ``w = sign(Δx) z`` and travel ``u = |Δx|``: ``dw/du = A - (beta + gamma) w``
    for ``w >= 0`` and ``dw/du = A - (beta - gamma) w`` for ``w < 0``; ``w`` only
    crosses zero upwards (``dw/du = A > 0`` there), so each segment is at most
    two exponential relaxations. Runs compiled (:func:`.kernels.bouc_wen_rows`).
    """
    dx = np.broadcast_to(np.diff(x, axis=-1), batch + (x.shape[-1] - 1,)).reshape(
        -1, x.shape[-1] - 1
    )
    a_, b_, g_, z0_ = (
        np.broadcast_to(np.asarray(p, dtype=float), batch).reshape(-1) for p in (a, b, g, z0)
    )
    out = np.empty((dx.shape[0], dx.shape[1] + 1))
    args = (np.ascontiguousarray(v, dtype=float) for v in (dx, a_, b_, g_, z0_))
    kernels.bouc_wen_rows(*args, out)
    return out.reshape(batch + (x.shape[-1],))


def bouc_wen_force_path(
    x: np.ndarray, f_y: Value, x_y: Value, shape: Value = 0.5, n: Value = 1.0, z0: Value = 0.0
) -> np.ndarray:
    """Bouc-Wen hysteretic force [N] in engineering form along ``x[..., T]`` [m].

    ``f_y`` [N] asymptotic force, ``x_y`` [m] yield displacement, ``shape`` = b in
    [0, 1], ``n >= 1``; ``z0`` is the dimensionless initial state (``F0 = f_y z0``).
    """
    require_positive("x_y", x_y)
    sh = np.asarray(shape, dtype=float)
    if np.any((sh < 0) | (sh > 1)):
        raise ValidationError(f"`0 <= shape <= 1` must hold, but got shape={shape!r}")
    xy = np.asarray(x_y, dtype=float)
    z = bouc_wen_path(x, 1.0 / xy, sh / xy, (1.0 - sh) / xy, n, z0)
    return batch_param(f_y) * z


def berg_path(x: np.ndarray, f_max: Value, x2: Value) -> np.ndarray:
    """Berg friction force [N] along a displacement path ``x[..., T]`` [m], from rest at ``x[0]``.

    A reversal (change of the direction of travel) moves the reference point to the
    previous sample. ``f_max`` [N] and ``x2`` [m] are batch-shaped.
    """
    x = series(x)
    require_positive("f_max", f_max, strict=False)
    require_positive("x2", x2)
    fm, xx = batch_param(f_max)[..., 0], batch_param(x2)[..., 0]
    batch = np.broadcast_shapes(x.shape[:-1], fm.shape, xx.shape)
    rows = np.broadcast_to(x, batch + x.shape[-1:]).reshape(-1, x.shape[-1])
    fm_r = np.broadcast_to(fm, batch).reshape(-1)
    x2_r = np.broadcast_to(xx, batch).reshape(-1)
    out = np.empty(rows.shape)
    for r in range(rows.shape[0]):
        out[r] = _berg_row(rows[r].tolist(), float(fm_r[r]), float(x2_r[r]))
    return out.reshape(batch + x.shape[-1:])


def _berg_row(xs: list[float], f_max: float, x2: float) -> list[float]:
    if f_max <= 0.0:
        return [0.0] * len(xs)
    x_s, f_s = xs[0], 0.0
    f = 0.0
    direction = 0.0
    out = [0.0]
    prev = xs[0]
    for x in xs[1:]:
        d = x - prev
        if d != 0.0:
            s = 1.0 if d > 0 else -1.0
            if direction != 0.0 and s != direction:
                x_s, f_s = prev, f  # reversal: new reference point
            direction = s
            a = f_s / f_max
            u = x - x_s
            if u >= 0.0:
                f = f_s + u / (x2 * (1.0 - a) + u) * (f_max - f_s)
            else:
                f = f_s + u / (x2 * (1.0 + a) - u) * (f_max + f_s)
        out.append(f)
        prev = x
    return out
