"""Non-Gaussian closure of a linear end stop on a spring, tabulated, and the stop's
Hermite remainder.

A stop ``F = k_stop max(x - gap, 0)`` (p = 1; a rebound stop is its mirror image) on a
spring of rate K, deflection x of mean m and RMS s. The closure takes x's density as
the exact stationary one of a one-degree-of-freedom oscillator with that spring and
stop under white noise (Caughey): ``p(x) ∝ exp(-(K (x - c)^2/2 + k_stop max(x - gap,
0)^2/2)/(K s0^2))``, its centre c and scale s0 set so that its mean is m and its RMS s.
In the units of s0 about c (``u = (x - c)/s0``, ``beta = (gap - c)/s0``) the density is
``∝ exp(-(u^2 + kappa max(u - beta, 0)^2)/2)``: two dimensionless numbers, the stiffness
ratio ``kappa = k_stop/K`` and the normalised gap ``a = (gap - m)/s``, fix the stop's
mean force ``k_stop s mu(kappa, a)``, its gain (least-squares rate about the mean, as
Stein's lemma gives for a Gaussian) ``E[F y]/E[y^2] = k_stop g(kappa, a)`` and its
remainder's variance ``Var(F - E[F] - gain y) = (k_stop s)^2 v(kappa, a)`` (y = x - m).

:func:`closure_statistics` computes them by summing the density on a uniform grid
(:data:`QUAD_POINTS` points), parameterised by (kappa, beta); :func:`closure_table`
re-grids them onto (log(1 + kappa), a) once (cached) and :func:`closure_moments`
interpolates (bicubic splines). Outside the table's a range the Gaussian closed forms
serve (the closure tends to them: a -> -inf, the stop always in contact, a linear
spring; a -> +inf, never); kappa above :data:`KAPPA_MAX` is taken as ``KAPPA_MAX``.

The remainder's spectrum: its Hermite expansion for a Gaussian deflection
(:func:`hermite_remainder`), scaled to the closure's variance; cross-covariances of
the remainders by Mehler's formula (used by :func:`suspenv.metrics.ride.ride_spectral`).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np
from scipy.interpolate import CubicSpline, RectBivariateSpline
from scipy.special import ndtr

#: table domain: stiffness ratio k_stop/K up to KAPPA_MAX, normalised gap a in A_RANGE
KAPPA_MAX = 100.0
A_RANGE = (-3.0, 6.0)
#: table nodes: log(1 + kappa) and a
_X_NODES = np.linspace(0.0, np.log1p(KAPPA_MAX), 31)
_A_NODES = np.linspace(*A_RANGE, 91)
#: Gauss-Legendre points per side of the stop's contact point in the closure's
#: density, and the points of its beta family per kappa
QUAD_POINTS = 256
_GL_X, _GL_W = np.polynomial.legendre.leggauss(QUAD_POINTS)
_BETA_POINTS = 160
#: Hermite orders of the remainder (2..ORDERS; at 40 the series carries over 99 % of
#: its variance for a <= 3, 94 % at a = 6)
ORDERS = 40


def _nodes(beta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature nodes and weights (..., 2 QUAD_POINTS) of the closure's density in u:
    Gauss-Legendre on each side of the contact point beta (the density's kink, so each
    piece is smooth), from 8 units below the lower of 0 and beta to 8 above the
    higher (the density's tails there below e^-32 of its peak)."""
    lo, hi = np.minimum(beta, 0.0) - 8.0, np.maximum(beta, 0.0) + 8.0
    parts = [
        (0.5 * (a + b))[..., None] + (0.5 * (b - a))[..., None] * _GL_X
        for a, b in ((lo, beta), (beta, hi))
    ]
    weights = [(0.5 * (b - a))[..., None] * _GL_W for a, b in ((lo, beta), (beta, hi))]
    return np.concatenate(parts, -1), np.concatenate(weights, -1)


def closure_statistics(kappa: np.ndarray, beta: np.ndarray) -> tuple[np.ndarray, ...]:
    """``(a, mu, g, v)`` of the closure's density ``∝ exp(-(u^2 + kappa max(u - beta,
    0)^2)/2)`` (broadcast arrays, -): normalised gap ``a = (beta - E u)/sd u``, mean
    force ``E[max(u - beta, 0)]/sd u``, gain ``E[max(u - beta, 0) (u - E u)]/Var u``
    and remainder variance ``(Var max(u - beta, 0) - gain^2 Var u)/Var u`` (per unit
    k_stop s, k_stop, (k_stop s)^2), by the quadrature of :func:`_nodes`."""
    kappa, beta = np.broadcast_arrays(np.asarray(kappa, float), np.asarray(beta, float))
    u, wq = _nodes(beta)
    pen = np.maximum(u - beta[..., None], 0.0)
    expo = 0.5 * (u * u + kappa[..., None] * pen * pen)
    w = wq * np.exp(expo.min(-1, keepdims=True) - expo)  # peak 1: no underflow
    w /= w.sum(-1, keepdims=True)
    mean_u = (w * u).sum(-1)
    y = u - mean_u[..., None]
    var = (w * y * y).sum(-1)
    force = (w * pen).sum(-1)
    fy = (w * pen * y).sum(-1)
    var_f = (w * (pen - force[..., None]) ** 2).sum(-1)
    sd = np.sqrt(var)
    gain = fy / var
    return (beta - mean_u) / sd, force / sd, gain, np.maximum(var_f - gain * fy, 0.0) / var


class ClosureTable(NamedTuple):
    """Bicubic splines of mu, g and v over (log(1 + kappa), a)."""

    mu: RectBivariateSpline
    g: RectBivariateSpline
    v: RectBivariateSpline


@functools.cache
def closure_table() -> ClosureTable:
    """The closure's quantities on the nodes ``_X_NODES`` x ``_A_NODES``: per kappa,
    :func:`closure_statistics` on ``_BETA_POINTS`` values of beta whose a spans
    :data:`A_RANGE` (a rises with beta), re-gridded onto a by cubic splines in a;
    built once per process (about 1 s)."""
    kappa = np.expm1(_X_NODES)[:, None]
    # a ~ beta for beta >> 0 and beta/sqrt(1 + kappa) for beta << 0
    lo = (A_RANGE[0] - 0.5) * np.sqrt(1.0 + kappa)
    beta = lo + (A_RANGE[1] + 0.5 - lo) * np.linspace(0.0, 1.0, _BETA_POINTS)[None, :]
    a, *values = closure_statistics(kappa, beta)
    grids = [np.empty((_X_NODES.size, _A_NODES.size)) for _ in values]
    for i in range(_X_NODES.size):
        if not (np.all(np.diff(a[i]) > 0) and a[i, 0] < A_RANGE[0] < A_RANGE[1] < a[i, -1]):
            raise ArithmeticError(f"closure table: a(beta) not rising over the range at {i}")
        for grid, val in zip(grids, values, strict=True):
            grid[i] = CubicSpline(a[i], val[i])(_A_NODES)
    splines = (RectBivariateSpline(_X_NODES, _A_NODES, grid) for grid in grids)
    return ClosureTable(*splines)


def gaussian_excess(a: np.ndarray) -> np.ndarray:
    """``T(a) = E[max(t - a, 0)] = phi(a) - a (1 - Phi(a))`` (-), t standard normal."""
    return np.exp(-0.5 * a * a) / np.sqrt(2.0 * np.pi) - a * ndtr(-a)


def gaussian_remainder_variance(a: np.ndarray) -> np.ndarray:
    """The remainder's variance per unit ``(k_stop s)^2`` for a Gaussian deflection:
    ``Var F - (E[F'] s)^2 = E[max(t - a, 0)^2] - T(a)^2 - (1 - Phi(a))^2``, with
    ``E[max(t - a, 0)^2] = (1 + a^2)(1 - Phi(a)) - a phi(a)``."""
    q, t1 = ndtr(-a), gaussian_excess(a)
    t2 = (1.0 + a * a) * q - a * np.exp(-0.5 * a * a) / np.sqrt(2.0 * np.pi)
    return np.maximum(t2 - t1 * t1 - q * q, 0.0)


def closure_moments(
    kappa: np.ndarray, a: np.ndarray, names: str = "mu dmu g v"
) -> list[np.ndarray]:
    """The closure's quantities ``names`` (from mu, dmu = dmu/da, g, v; -) at
    stiffness ratios ``kappa`` >= 0 and normalised gaps ``a`` (broadcast) from
    :func:`closure_table`; outside :data:`A_RANGE` the Gaussian closed forms (``mu =
    T(a)``, ``dmu/da = -(1 - Phi(a))``, ``g = 1 - Phi(a)``, v of
    :func:`gaussian_remainder_variance`)."""
    kappa, a = np.broadcast_arrays(np.asarray(kappa, float), np.asarray(a, float))
    x = np.log1p(np.minimum(kappa, KAPPA_MAX)).ravel()
    a_in = np.clip(a, *A_RANGE).ravel()
    table = closure_table()
    laws = {"mu": (table.mu, 0), "dmu": (table.mu, 1), "g": (table.g, 0), "v": (table.v, 0)}
    out = [laws[q][0].ev(x, a_in, dy=laws[q][1]).reshape(a.shape) for q in names.split()]
    outside = (a < A_RANGE[0]) | (a > A_RANGE[1])
    if outside.any():
        tail = ndtr(-a)
        gauss = {
            "mu": lambda: gaussian_excess(a),
            "dmu": lambda: -tail,
            "g": lambda: tail,
            "v": lambda: gaussian_remainder_variance(a),
        }
        out = [np.where(outside, gauss[q](), v) for q, v in zip(names.split(), out, strict=True)]
    if "v" in names.split():
        k = names.split().index("v")
        out[k] = np.maximum(out[k], 0.0)
    return out


def skew_ratios(gamma: np.ndarray, a: np.ndarray, names: str = "mu g v") -> list[np.ndarray]:
    """Ratios (-) ``names`` (from mu, g, v) of a p = 1 stop's mean force ``E[F]``, gain
    ``E[F y]`` and remainder variance ``Var F - E[F y]^2`` (``F = max(y - a, 0)``, per
    unit k_stop and RMS) for the unit Cornish-Fisher deflection ``y = (u + gamma (u^2 -
    1)/6)/sqrt(1 + gamma^2/18)`` (u standard normal; zero mean, unit variance, skewness
    gamma to first order, + towards the stop) to those for a Gaussian one at the same
    normalised gap ``a`` (broadcast; :func:`gaussian_excess`, ``1 - Phi(a)``,
    :func:`gaussian_remainder_variance`); 1 where the Gaussian value underflows.

    F is a quadratic ``p0 + c u + y2 u^2`` beyond the root u* of ``y(u) = a`` on y's
    rising branch (the falling one lies beyond ``|u| = 3/|gamma|``: ignored; no root,
    F = 0, where y stays below a), so each
    moment is a sum of the truncated moments ``M_k = E[u^k; u > u*] = u*^(k-1) phi(u*)
    + (k - 1) M_(k-2)``."""
    gamma, a = np.broadcast_arrays(np.asarray(gamma, float), np.asarray(a, float))
    c = 1.0 / np.sqrt(1.0 + gamma * gamma / 18.0)
    y2 = c * gamma / 6.0  # y = y2 u^2 + c u - y2
    b = (y2 + a) / c  # y(u) = a: (y2/c) u^2 + u - b = 0
    # disc < 0: y stays below a (gamma < 0), F = 0: u* = 40, where phi underflows to 0
    disc = 1.0 + 4.0 * y2 / c * b
    u0 = np.where(disc < 0.0, 40.0, 2.0 * b / (1.0 + np.sqrt(np.maximum(disc, 0.0))))
    phi = np.exp(-0.5 * u0 * u0) / np.sqrt(2.0 * np.pi)
    m = [ndtr(-u0), phi]  # M_k, k = 0.. (as far as the names need)
    for k in range(2, 3 if names.split() == ["mu"] else 5):
        m.append(u0 ** (k - 1) * phi + (k - 1) * m[k - 2])
    p0 = -y2 - a
    mu = p0 * m[0] + c * m[1] + y2 * m[2]
    phi_a, q_a = np.exp(-0.5 * a * a) / np.sqrt(2.0 * np.pi), ndtr(-a)
    t_a = phi_a - a * q_a
    out = {"mu": (mu, t_a)}
    if names.split() != ["mu"]:
        gain = -y2 * p0 * m[0] + (c * p0 - y2 * c) * m[1] + (y2 * p0 + c * c - y2 * y2) * m[2]
        gain = gain + 2.0 * c * y2 * m[3] + y2 * y2 * m[4]
        out["g"] = (gain, q_a)
        if "v" in names.split():
            sq = p0 * p0 * m[0] + 2.0 * p0 * c * m[1] + (c * c + 2.0 * p0 * y2) * m[2]
            sq = sq + 2.0 * c * y2 * m[3] + y2 * y2 * m[4]
            var = np.maximum(sq - mu * mu - gain * gain, 0.0)
            tv = (1.0 + a * a) * q_a - a * phi_a - t_a * t_a - q_a * q_a
            out["v"] = (var, np.maximum(tv, 0.0))
    return [
        np.where(g > 1e-300, x / np.maximum(g, 1e-300), 1.0)
        for x, g in (out[q] for q in names.split())
    ]


def hermite_remainder(a: np.ndarray, orders: int = ORDERS) -> np.ndarray:
    """``sqrt(n!) c_n`` (n = 2..orders, first axis; per unit ``k_stop s``) of a p = 1
    stop's force in Hermite polynomials of the standardised deflection u (mean m, RMS
    s, ``a = (gap - m)/s``): ``F(m + s u) = sum c_n He_n(u)`` with ``c_n = k_stop s
    He_(n-2)(a) phi(a)/n!`` (Stein's lemma n times, ``E[F He_n(u)] = E[F^(n)(u)]``,
    and ``E[delta^(k)(u - a)] = He_k(a) phi(a)``); c_1 is the Gaussian gain's term, so
    the orders from 2 are the remainder ``F - E[F] - E[F'] s u``. For deflections of
    correlation rho the remainders' covariance is ``sum_n (sqrt(n!) c_n)(sqrt(n!)
    c_n') rho^n`` (Mehler's formula). Recursion on ``He_k/sqrt(k!)``."""
    a = np.asarray(a, dtype=float)
    phi = np.exp(-0.5 * a * a) / np.sqrt(2.0 * np.pi)
    prev, he = np.zeros_like(a), np.ones_like(a)
    out = []
    for n in range(2, orders + 1):
        out.append(he * phi / np.sqrt(n * (n - 1.0)))
        prev, he = he, (a * he - np.sqrt(n - 2.0) * prev) / np.sqrt(n - 1.0)
    return np.array(out)
