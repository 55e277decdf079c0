"""Gaussian equivalent-linear rates of the minibus ride model's nonlinear elements.

Statistical linearisation (Roberts & Spanos, *Random Vibration and Statistical
Linearization*, ch. 5-6; Kazakov; Atalik & Utku 1976): an element force F(x) of a
zero-mean Gaussian element deflection or velocity x of RMS s is replaced by the
mean-square-optimal linear rate ``k_eq = E[F'(x)]`` (Stein's lemma: ``E[F x] / s^2``).
The spectral ride method (:func:`suspenv.metrics.ride.ride_spectral`) takes the RMS
values from the linear model built with these rates and iterates to consistency. The
springs' rates (two-stage leaf, end stops) are taken about their mean deflection,
which the asymmetric dampers' and the stops' mean forces move from rest
(:meth:`ElementLinearisation.spring_mean`).

Signs and units as :mod:`suspenv.models.minibus.ride_model`: deflections and
velocities positive in compression (m, m/s), forces positive when they resist
compression (N); rates in N/m and N s/m. Laws (the ride model's):

- asymmetric digressive damper: slopes ``c_bl``/``c_bh`` (bump, below/above the knee
  ``k_b``), ``c_rl``/``c_rh`` (rebound, knee ``k_r > 0``):
  ``c_eq = c_bl (Phi(k_b/s) - 1/2) + c_bh (1 - Phi(k_b/s)) + (same for rebound)``;
- two-stage leaf, extra rate ``dk`` beyond the knee ``e_k`` from rest, about its mean
  compression m: ``k_eq = K_1 + dk (1 - Phi((e_k - m)/s))``;
- end stop ``F = k_stop max(x - gap, 0)^p`` (bump; rebound mirrored) about the
  spring's mean deflection m: for p = 1 the non-Gaussian closure's gain ``E[F y]/
  E[y^2]`` and mean force (:mod:`suspenv.models.minibus.stop_closure`: the density of
  a spring with the stop under white noise; its remainder is
  :meth:`ElementLinearisation.remainder_coefficients`, added by the spectral method as
  a second excitation), else the Gaussian ``k_eq = p k_stop E[max(m + x - gap, 0)^(p -
  1)]``, the stop's stiffness times the Gaussian probability of contact for p = 1, and
  mean force ``k_stop E[max(m + x - gap, 0)^p]`` (:func:`stop_moments`);
- smoothed Coulomb friction ``F = f_c tanh(v / v_eps)``:
  ``c_eq = E[F'(v)]``, which tends to ``f_c sqrt(2/pi) / s`` for ``v_eps << s``
  (:func:`coulomb_rate`);
- Dahl hysteresis (interleaf friction) ``dz/dt = sigma v (1 - z/f_c sign(v))``, the
  force z a state: Wen's linearisation of the Bouc-Wen element (Wen 1980, J. Appl.
  Mech. 47:150; Dahl = Bouc-Wen with n = 1, A = sigma, beta = sigma/f_c, gamma = 0)
  ``dz/dt = c_z v - k_z z`` with ``c_z = sigma (1 - sqrt(2/pi) E[v z] / (f_c s_v))`` and
  ``k_z = sigma/f_c sqrt(2/pi) s_v``, jointly Gaussian (v, z) (:func:`dahl_rates`);
  the force's part no linear map of the deflection carries from the exact Dahl loop
  of a narrow-band deflection (:func:`dahl_incoherent_variance`), added by the
  spectral method as a second excitation like the stops' remainder
  (:meth:`ElementLinearisation.dahl_remainder_coefficients`).
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from scipy.special import gamma, i0e, i1e, ndtr, pbdv

from suspenv.models.minibus import spectral_kernel, stop_closure
from suspenv.models.minibus.ride_model import RideModel
from suspenv.models.minibus.stop_closure import gaussian_excess as _excess

SQRT_2_PI = float(np.sqrt(2.0 / np.pi))
#: Gauss-Legendre nodes for the Coulomb law's Gaussian expectation
_GL_X, _GL_W = np.polynomial.legendre.leggauss(96)
#: Gauss-Legendre points of the Dahl loop's Rayleigh amplitude averages (relative
#: error under 4e-6 for RMS deflections of 0.05-50 pre-sliding travels)
_DAHL_GL = 48
_GL_A, _GL_AW = np.polynomial.legendre.leggauss(_DAHL_GL)

#: columns of the rate vector (n, n_rates) the spectral method iterates: damper
#: coefficients FL, FR, RL, RR (N s/m), rear leaf rates L, R (N/m); with effects also
#: the front spring rates FL, FR (N/m) and the linearised Dahl coefficients c_z (N/m)
#: and k_z (1/s) of the left and right leaf
DAMPER = slice(0, 4)
LEAF = slice(4, 6)
FRONT = slice(6, 8)
DAHL_C = slice(8, 10)
DAHL_K = slice(10, 12)
#: columns of the RMS vector (n, n_sig) the rates are computed from: damper velocities
#: (m/s), leaf deflections (m); with effects also the front spring deflections (m), the
#: leaf deflection rates (m/s) and the Dahl forces (N)
SIG_DAMPER = slice(0, 4)
SIG_LEAF = slice(4, 6)
SIG_FRONT = slice(6, 8)
SIG_LEAF_V = slice(8, 10)
SIG_DAHL = slice(10, 12)


def tail_moment(a: np.ndarray, m: np.ndarray | float) -> np.ndarray:
    """``E[max(t - a, 0)^m]`` (-) for a standard normal t, m >= 0:
    ``Gamma(m + 1) exp(-a^2/4) D_{-m-1}(a) / sqrt(2 pi)`` with D the parabolic cylinder
    function (the integral representation of D_{-nu}; Abramowitz & Stegun 19.5.1);
    m = 0 gives ``1 - Phi(a)``, m = 1 ``phi(a) - a (1 - Phi(a))``."""
    a = np.asarray(a, dtype=float)
    m = np.asarray(m, dtype=float)
    d = pbdv(-m - 1.0, a)[0]
    return gamma(m + 1.0) * np.exp(-0.25 * a * a) * d / np.sqrt(2.0 * np.pi)


def stop_moments(
    gap: float, k_stop: float, p: float, sigma: np.ndarray, shift: np.ndarray | float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Mean force magnitude (N) and equivalent stiffness (N/m) of a bump or a rebound
    stop (mirror images) for a Gaussian deflection of RMS ``sigma`` (m) whose mean lies
    ``shift`` (m) towards the stop: with ``a = (gap - shift)/sigma``,
    ``k_stop sigma^p E[max(t - a, 0)^p]`` and ``p k_stop sigma^(p-1) E[max(t - a,
    0)^(p-1)]`` (t standard normal; :func:`tail_moment`, for p = 1 ``sigma T(a)`` and
    ``1 - Phi(a)``, the stiffness times the probability of contact)."""
    s = np.maximum(np.asarray(sigma, dtype=float), 1e-12)
    a = (gap - np.asarray(shift, dtype=float)) / s
    if p == 1.0:
        return k_stop * s * _excess(a), k_stop * ndtr(-a)
    mean = k_stop * s**p * tail_moment(a, p)
    return mean, p * k_stop * s ** (p - 1.0) * tail_moment(a, p - 1.0)


def coulomb_rate(f_c: float, v_eps: float, sigma: np.ndarray) -> np.ndarray:
    """Equivalent viscous coefficient (N s/m) of ``f_c tanh(v / v_eps)`` for a zero-mean
    Gaussian velocity of RMS ``sigma`` (m/s): ``E[f_c/v_eps sech^2(v/v_eps)]``, by
    96-point Gauss-Legendre quadrature over ``|v| <= min(12 v_eps, 10 sigma)`` (the
    narrower factor's width; beyond, sech^2 < 2e-10 or the density < 2e-22 of its
    peak); ``-> f_c sqrt(2/pi)/sigma`` as ``v_eps/sigma -> 0``."""
    s = np.maximum(np.asarray(sigma, dtype=float), 1e-12)[..., None]
    half = np.minimum(12.0 * v_eps, 10.0 * s)
    v = half * _GL_X
    sech2 = 1.0 / np.cosh(v / v_eps) ** 2
    dens = np.exp(-0.5 * (v / s) ** 2) / (np.sqrt(2.0 * np.pi) * s)
    return f_c / v_eps * half[..., 0] * ((sech2 * dens) @ _GL_W)


def dahl_rates(
    sigma: float,
    f_c: float,
    s_v: np.ndarray,
    s_z: np.ndarray,
    c_z: np.ndarray,
    k_z: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Wen's equivalent-linear Dahl element ``dz/dt = c_z v - k_z z``: new ``(c_z
    (N/m), k_z (1/s))`` from the RMS element velocity ``s_v`` (m/s) and force ``s_z``
    (N) of the linear model built with the current ``c_z``, ``k_z``.

    The cross-moment comes from that model's stationarity, ``E[z dz/dt] = 0``, so
    ``E[v z] = k_z s_z^2 / c_z`` (no cross-spectrum needed)."""
    s_v = np.maximum(s_v, 1e-12)
    evz = k_z * s_z * s_z / np.maximum(c_z, 1e-9 * sigma)
    c_new = sigma * (1.0 - SQRT_2_PI * evz / (f_c * s_v))
    k_new = sigma / f_c * SQRT_2_PI * s_v
    return np.maximum(c_new, 1e-3 * sigma), k_new


def dahl_loop(a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The steady Dahl loop of a sinusoidal deflection of amplitude ``a`` (-, in units
    of ``delta = f_c/sigma``), per unit f_c: the force's mean square and its
    fundamental's parts in phase with the deflection (``a1``) and with its rate
    (``b1``), closed forms of :func:`dahl_incoherent_variance` (exponentially scaled
    Bessel functions)."""
    a = np.asarray(a, dtype=float)
    c = 1.0 + np.tanh(a)  # C e^a
    ms = 1.0 - 2.0 * c * i0e(a) + c * c * i0e(2.0 * a)
    a1 = 2.0 * c * i1e(a)
    b1 = (4.0 / np.pi) * (1.0 - c * -np.expm1(-2.0 * a) / (2.0 * np.maximum(a, 1e-300)))
    return ms, a1, b1


def dahl_incoherent_variance(f_c: float, sigma: float, s_x: np.ndarray) -> np.ndarray:
    """Variance (N^2) of the Dahl force ``dz/dt = sigma v (1 - z/f_c sgn v)`` that no
    linear map of the deflection x carries, for a narrow-band Gaussian deflection of RMS
    ``s_x`` (m): ``x = A cos(w t + p)``, A Rayleigh (``E[A^2] = 2 s_x^2``), the Dahl
    loop exact per amplitude.

    Per amplitude (``a = A/delta``, ``delta = f_c/sigma``) the loop's rising branch is
    ``z = f_c (1 - (1 + tanh a) e^(-(x + A)/delta))`` (peak ``f_c tanh a``), the falling
    one its mirror image; with ``C = (1 + tanh a) e^(-a)`` and the Fourier series of
    ``e^(a cos t)`` (modified Bessel functions I_k) its mean square is ``f_c^2 (1 - 2 C
    I_0(a) + C^2 I_0(2a))`` and its fundamental ``f_c (a1 cos + b1 sin)`` (in phase with
    x and with its rate) ``a1 = 2 C I_1(a)``, ``b1 = (4/pi)(1 - C sinh(a)/a)``. Over the
    amplitudes the linear map (one rate in phase, one in quadrature, as the equivalent
    element) carries ``f_c^2 (E[A a1]^2 + E[A b1]^2)/(2 E[A^2])``; the rest of ``E[z^2]``
    (the harmonics, and the fundamental's part not proportional to A) is returned
    (:func:`dahl_loop`). Exact in both limits: nothing in the stick (``a -> 0``: ``z =
    sigma x``); ``f_c^2 (1 - 2/pi)`` in the Coulomb limit (``a -> inf``: ``z = f_c sgn
    v``, whose variance f_c^2 its Gaussian gain ``f_c sqrt(2/pi)/s_v`` carries ``2/pi``
    of). Rayleigh averages by
    ``_DAHL_GL``-point Gauss-Legendre over ``A <= 8 s_x`` (beyond, the density is below
    e^-32 of its peak); exponentially scaled Bessel functions (no overflow)."""
    delta = f_c / sigma
    s = np.maximum(np.asarray(s_x, dtype=float), 1e-12)[..., None]
    A = 4.0 * s * (1.0 + _GL_A)  # Gauss-Legendre on [0, 8 s]
    wA = 4.0 * s * _GL_AW * A / s**2 * np.exp(-0.5 * (A / s) ** 2)  # Rayleigh weights
    ms, a1, b1 = dahl_loop(A / delta)
    coherent = ((wA * A * a1).sum(-1) ** 2 + (wA * A * b1).sum(-1) ** 2) / (4.0 * s[..., 0] ** 2)
    return f_c * f_c * np.maximum((wA * ms).sum(-1) - coherent, 0.0)


@functools.cache
def _sign_series() -> np.ndarray:
    """``sqrt(n!) b_n`` (n = 2..``stop_closure.ORDERS``, orders - 1) of the sign law
    ``sgn u = sum b_n He_n(u)`` (u standard normal) beyond its linear term, scaled to
    unit variance: ``b_n = 2 He_(n-1)(0) phi(0)/n!`` (Stein's lemma, ``sgn' = 2
    delta``), i.e. ``2 (n + 1)`` times the order ``n + 1`` of a unit stop at its
    contact point (:func:`stop_closure.hermite_remainder` at a = 0); odd orders only.
    Read-only, cached."""
    ramp = stop_closure.hermite_remainder(np.zeros(1))[:, 0]  # orders 2..ORDERS
    n = np.arange(2, stop_closure.ORDERS)
    out = np.zeros(stop_closure.ORDERS - 1)
    out[:-1] = 2.0 * np.sqrt(n + 1.0) * ramp[1:]
    out /= np.sqrt(np.sum(out * out))
    out.flags.writeable = False
    return out


def deflection_compliances(stiff: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The body's and the wheels' parts ``(A, C)`` (m/N, (n,) each) of the static
    compliance ``e^T K^-1 e = A + C`` of an element deflection ``x = e^T q`` in the
    ride model's coordinates q = [z_f, z_r, phi, z_FL, z_FR, z_RL, z_RR, seat...]
    (stiffness K (n, nq, nq); the body's: all but the wheels'). With the wheels at
    their static positions given the body, ``w = -S b`` (``S = K_ww^-1 K_wb``),
    ``A = d^T K_c^-1 d`` (``K_c = K_bb - K_bw S`` the body's condensed stiffness,
    ``d = e_b - S^T e_w`` the deflection per body coordinate), and the wheels' scatter
    about those positions ``C = e_w^T K_ww^-1 e_w`` (block inversion of K). In a
    density ``exp(-(b^T K_c b/T_b + w'^T K_ww w'/T_w)/2)`` the deflection's variance is
    ``T_b A + T_w C``."""
    wheel = np.arange(3, 7)
    body = np.setdiff1d(np.arange(stiff.shape[1]), wheel)  # with a seat, its masses too
    kbw, kww = stiff[:, body][:, :, wheel], stiff[:, wheel][:, :, wheel]
    s = np.linalg.solve(kww, kbw.transpose(0, 2, 1))  # (n, 4, nb)
    kc = stiff[:, body][:, :, body] - kbw @ s
    d = e[body][None, :] - np.einsum("w,nwb->nb", e[wheel], s)
    a = np.einsum("nb,nb->n", d, np.linalg.solve(kc, d[..., None])[..., 0])
    ew = np.broadcast_to(e[wheel], (stiff.shape[0], 4))
    c = np.einsum("nw,nw->n", ew, np.linalg.solve(kww, ew[..., None])[..., 0])
    return a, c


def temperature_ratio(
    var_t: np.ndarray, cov: np.ndarray, k: np.ndarray, k_tyre: np.ndarray
) -> np.ndarray:
    """The ratio r (-, >= 0) of the wheel's temperature about its position given the
    body to the body's at a corner of spring rate ``k`` and tyre rate ``k_tyre`` (N/m)
    from the tyre deflection's variance ``var_t`` (m^2) and its covariance ``cov`` with
    the spring deflection (m^2): in the corner's two-temperature density (body b at
    temperature T, wheel about its static position ``k b/(k + k_tyre)`` at r T)
    ``var_t = T (k/k_tyre + r)/(k + k_tyre)`` and ``cov = T (1 - r)/(k + k_tyre)``, so
    ``r = (1 - c k/k_tyre)/(1 + c)`` with ``c = cov/var_t``."""
    c = cov / np.maximum(var_t, 1e-300)
    return np.maximum((1.0 - c * k / k_tyre) / (1.0 + c), 0.0)


#: Newton steps of a spring's mean deflection (:meth:`ElementLinearisation.spring_mean`)
NEWTON_STEPS = 6
#: starting guess of the leaf deflection rate's RMS (m/s) for the first Dahl rates
_DAHL_START_SV = 0.05


class ElementLinearisation:
    """The nonlinear elements of a (nonlinear) :class:`RideModel`'s designs and their
    Gaussian equivalent-linear rates as one vector per design (columns ``DAMPER``,
    ``LEAF`` and, when the model has effects, ``FRONT``, ``DAHL_C``, ``DAHL_K``)."""

    def __init__(self, nl: RideModel):
        # float64 (a float32 model's typed arrays cast back)
        slopes = nl.damper_slopes  # (4 slopes, 4 dampers, n)
        self.d_bl, self.d_bh, self.d_rl, self.d_rh = slopes.transpose(0, 2, 1)
        self.kb = np.asarray(nl.knee_b, float).T  # (1, 4) bump knee (m/s)
        self.kr = -np.asarray(nl.knee_r, float).T  # (1, 4) rebound knee (> 0, m/s)
        self.k1 = nl.K[:, 2:4]  # primary leaf rate (N/m)
        self.k_front = nl.K[:, 0:2]  # front wheel rate (N/m)
        self.dk = np.asarray(nl.leaf_dk, float).T  # composite - primary rate (N/m)
        self.thr = np.asarray(nl.leaf_thr, float).T  # helper knee from static (m)
        self.leaf_static = nl.leaf_static_rate
        self.damper_mean = nl.damper_mean
        self.effects = nl.effects
        self.dahl: dict[str, Any] | None = None
        #: end stops per end (front, rear): (+1 bump / -1 rebound, gap, k_stop, p)
        self.stops: tuple[list[tuple[float, float, float, float]], ...] = ([], [])
        for e in nl.effects:
            if e.kind == "dahl_hysteresis" and self.dahl is None:
                self.dahl = e.params
            elif e.kind in ("bump_stop", "rebound_stop"):
                sign = 1.0 if e.kind == "bump_stop" else -1.0
                end = self.stops[0 if e.location.startswith("front") else 1]
                end.append((sign, e.params["gap"], e.params["k_stop"], e.params["p"]))
        #: per stop of ``stops`` with p = 1: the whole vehicle's static compliances of
        #: its spring's deflection (:func:`deflection_compliances`) and the corner's
        #: spring rate at its contact point, else None
        self._compliances = tuple(
            [self._compliance(nl, end, *s) for s in self.stops[end]] for end in (0, 1)
        )
        self.k_tyre = nl.K[:, 6:9:2]  # front-left and rear-left tyre rates (N/m)
        #: per stop of ``stops`` with p = 1: the closure's stiffness ratio kappa (n, 2),
        #: at equal temperatures (r = 1) until :meth:`set_corners`, else None
        self.kappa: tuple[list[np.ndarray | None], ...] = ([], [])
        #: skewness (n, 2) of the left-hand front spring's and rear leaf's deflection
        #: (+ towards compression; 0 until :meth:`set_corners`)
        self.skew = np.zeros((self.k1.shape[0], 2))
        self.set_corners(None)
        self.n_rates = 12 if self.effects else 6
        #: damper slopes (n, 4, 4), knees (4, 2), leaf K_1, dk, e_k (n, 2, 3) of the
        #: compiled rates (:mod:`suspenv.models.minibus.spectral_kernel`), filled in
        #: place (fewer calls than stacking them)
        n = self.k1.shape[0]
        damp = np.ascontiguousarray(slopes.transpose(2, 1, 0))
        knee, leaf = np.empty((4, 2)), np.empty((n, 2, 3))
        knee[:, 0], knee[:, 1] = self.kb[0], self.kr[0]
        leaf[:, :, 0], leaf[:, :, 1], leaf[:, :, 2] = self.k1, self.dk, self.thr
        self.packed = (damp, knee, leaf)

    def initial(self, init_damping: float) -> np.ndarray:
        """Starting rates (n, n_rates): ``init_damping`` x the mean low-speed damping, the
        leaf's static rate, the front wheel rate, Dahl at its pre-sliding stiffness."""
        r = np.zeros((self.leaf_static.shape[0], self.n_rates))
        r[:, DAMPER] = init_damping * self.damper_mean
        r[:, LEAF] = self.leaf_static
        if self.effects:
            r[:, FRONT] = self.k_front
            r[:, DAHL_K] = 1.0  # an inert state without Dahl (c_z = 0)
            if self.dahl is not None:
                sig, fc = self.dahl["sigma"], self.dahl["f_c"]
                r[:, DAHL_C] = sig
                r[:, DAHL_K] = sig / fc * SQRT_2_PI * _DAHL_START_SV
        return r

    def rates(self, sig: np.ndarray, r: np.ndarray) -> np.ndarray:
        """New rates (n, n_rates) from the element RMS values ``sig`` (n, 6 or 12:
        columns ``SIG_*``) of the linear model built with the rates ``r``; without rear
        end stops the damper and leaf rates by the compiled loop
        (:func:`suspenv.models.minibus.spectral_kernel.damper_leaf_rates`)."""
        out = np.empty(r.shape)
        if self.stops[1]:
            sv, sd = np.maximum(sig[:, SIG_DAMPER], 1e-12), np.maximum(sig[:, SIG_LEAF], 1e-12)
            self.damper_leaf_rates(sv, sd, out)
        else:
            # C order: the loop built ahead of time reads its arrays as laid out so
            sig = np.ascontiguousarray(sig)
            spectral_kernel.damper_leaf_rates(sig, *self.packed, NEWTON_STEPS, out)
        if self.effects:
            self._effect_rates(sig, r, out)
        return out

    def damper_leaf_rates(self, sv: np.ndarray, sd: np.ndarray, out: np.ndarray) -> None:
        """Damper coefficients (N s/m) and rear leaf rates (N/m, with the rear stops')
        into ``out[:, DAMPER]``, ``out[:, LEAF]`` from the RMS damper velocities ``sv``
        (n, 4; m/s) and leaf deflections ``sd`` (n, 2; m), both > 0: the numpy form."""
        pb, pr = ndtr(self.kb / sv), ndtr(self.kr / sv)
        out[:, DAMPER] = (
            self.d_bl * (pb - 0.5)
            + self.d_bh * (1 - pb)
            + self.d_rl * (pr - 0.5)
            + self.d_rh * (1 - pr)
        )
        m = self.spring_mean(1, sv[:, 2:4], sd)
        out[:, LEAF] = self.k1 + self.dk * (1.0 - ndtr((self.thr - m) / sd))
        if self.stops[1]:
            out[:, LEAF] += self._stop_rate(1, m, sd)

    def damper_mean_force(self, sv: np.ndarray, cols: slice = DAMPER) -> np.ndarray:
        """Mean damper force (N, + resisting compression) for a zero-mean Gaussian
        velocity of RMS ``sv`` (m/s) per column ``cols`` of the dampers: ``E[F(v)]``,
        ``c_bl (s/sqrt(2 pi) - s T(k_b/s)) + c_bh s T(k_b/s)`` minus the same for
        rebound, with ``T(a) = E[max(t - a, 0)]`` (:func:`_excess`). Negative for
        a rebound-heavy damper: it pulls the suspension into compression (jacking)."""
        s0 = sv / np.sqrt(2.0 * np.pi)
        tb, tr = sv * _excess(self.kb[:, cols] / sv), sv * _excess(self.kr[:, cols] / sv)
        bump = self.d_bl[:, cols] * (s0 - tb) + self.d_bh[:, cols] * tb
        return bump - (self.d_rl[:, cols] * (s0 - tr) + self.d_rh[:, cols] * tr)

    def _compliance(
        self, nl: RideModel, end: int, sign: float, gap: float, k_stop: float, p: float
    ) -> tuple[np.ndarray, ...] | None:
        """``(A0, C0, A1, C1, K)`` of a p = 1 stop at ``end`` (each (n,)):
        :func:`deflection_compliances` of the left spring's deflection without and with
        the stop, in the whole vehicle's stiffness with the rear leaf at its rate at the
        contact point ``sign gap`` (the composite one where the helper knee lies below
        it), and that corner spring's rate K (N/m); None for p != 1."""
        if p != 1.0:
            return None
        k_leaf = self.k1 + self.dk * (self.thr < sign * gap)
        pos = nl.E[: nl.nq, : nl.n_pos]
        rates = np.array(nl.K[:, : nl.n_pos], dtype=float)
        rates[:, 2:4] = k_leaf
        stiff = np.einsum("ie,ne,je->nij", pos, rates, pos)
        e = pos[:, 2 * end]
        a0, c0 = deflection_compliances(stiff, e)
        a1, c1 = deflection_compliances(stiff + k_stop * np.outer(e, e), e)
        return a0, c0, a1, c1, (self.k_front if end == 0 else k_leaf)[:, 0]

    def set_corners(self, stats: np.ndarray | None) -> None:
        """Set the p = 1 stops' stiffness ratios ``kappa = (A0 + r C0)/(A1 + r C1) - 1``
        (:func:`deflection_compliances`) and the deflections' skewness from ``stats``
        (n, 6): per left-hand corner (front, rear) the tyre deflection's variance (m^2),
        its covariance with the spring deflection (m^2) and the spring deflection's
        skewness (-), of the linear model (``ride.corner_statistics``); r is the
        corner's temperature ratio (:func:`temperature_ratio`). ``stats=None``: r = 1
        (``kappa = k_stop e^T K^-1 e``), no skewness."""
        if stats is not None:
            self.skew = stats[:, 4:6]
        for end in (0, 1):
            self.kappa[end].clear()
            for comp in self._compliances[end]:
                if comp is None:
                    self.kappa[end].append(None)
                    continue
                a0, c0, a1, c1, k = comp
                r: np.ndarray | float = 1.0
                if stats is not None:
                    var_t, cov = stats[:, end], stats[:, 2 + end]
                    r = temperature_ratio(var_t, cov, k, self.k_tyre[:, end])
                kap = (a0 + r * c0) / (a1 + r * c1) - 1.0
                self.kappa[end].append(np.repeat(kap[:, None], 2, axis=1))

    def even_coefficients(self, sv: np.ndarray, sd: np.ndarray) -> np.ndarray:
        """Second Hermite coefficients ``c_2 = E[F He_2(u)]/2`` (N; (n, 6)) of the
        dampers' laws FL..RR in their standardised velocity (zero mean, RMS ``sv``
        (n, 4), m/s) and of the rear leaves' second stage ``dk max(d - e_k, 0)`` in
        their standardised deflection about its mean (:meth:`spring_mean` without the
        stops; RMS ``sd``
        (n, 2), m): by Stein's lemma ``E[F He_2(u)] = s^2 E[F''(m + s u)]``, for a
        piecewise-linear law ``s sum_j (slope jump)_j phi(knee_j/s)`` (jumps at the
        rebound knee, at 0 and at the bump knee; the leaf's ``dk`` at ``e_k``)."""
        phi0 = 1.0 / np.sqrt(2.0 * np.pi)

        def phi(x: np.ndarray) -> np.ndarray:
            return phi0 * np.exp(-0.5 * x * x)

        damp = (
            (self.d_rl - self.d_rh) * phi(self.kr / sv)
            + (self.d_bl - self.d_rl) * phi0
            + (self.d_bh - self.d_bl) * phi(self.kb / sv)
        )
        m = self.spring_mean(1, sv[:, 2:4], sd, stops=False)
        leaf = self.dk * phi((self.thr - m) / sd)
        return 0.5 * np.hstack([sv * damp, sd * leaf])

    def _closure(
        self, end: int, sign: float, kappa: np.ndarray, a: np.ndarray, names: str
    ) -> list[np.ndarray]:
        """:func:`stop_closure.closure_moments` of a stop at ``end`` (``sign`` +1 bump,
        -1 rebound) times the deflection's skewness ratios
        (:func:`stop_closure.skew_ratios`; a rebound stop sees the mirrored skewness)."""
        out = stop_closure.closure_moments(kappa, a, names)
        gamma = sign * self.skew[:, end : end + 1]
        if not gamma.any():
            return out
        tilt = {"mu": "mu", "dmu": "mu", "g": "g", "v": "v"}
        need = " ".join(dict.fromkeys(tilt[q] for q in names.split()))
        ratio = dict(zip(need.split(), stop_closure.skew_ratios(gamma, a, need), strict=True))
        return [o * ratio[tilt[q]] for o, q in zip(out, names.split(), strict=True)]

    def _stop_terms(self, end: int, m: np.ndarray, sd: np.ndarray) -> tuple[np.ndarray, ...]:
        """Mean force (N, + resisting compression) and its derivative in m (N/m) of the
        stops of ``end`` (0 front, 1 rear) for deflections of mean ``m`` and RMS ``sd``
        (m), (n, 2) each: p = 1 stops by the non-Gaussian closure
        (:func:`stop_closure.closure_moments`), others for a Gaussian deflection
        (:func:`stop_moments`; the derivative is then the equivalent stiffness)."""
        force, slope = np.zeros_like(m), np.zeros_like(m)
        for (sign, gap, k_stop, p), kappa in zip(self.stops[end], self.kappa[end], strict=True):
            if kappa is None:
                f, k = stop_moments(gap, k_stop, p, sd, sign * m)
                force, slope = force + sign * f, slope + k
            else:
                mu, dmu = self._closure(end, sign, kappa, (gap - sign * m) / sd, "mu dmu")
                force, slope = force + sign * k_stop * sd * mu, slope - k_stop * dmu
        return force, slope

    def _stop_rate(self, end: int, m: np.ndarray, sd: np.ndarray) -> np.ndarray:
        """Equivalent stiffness (N/m, (n, 2)) of the stops of ``end`` as
        :meth:`_stop_terms`: the closure's gain ``E[F y]/E[y^2]`` for p = 1 stops, the
        Gaussian ``E[F']`` for others."""
        rate = np.zeros_like(m)
        for (sign, gap, k_stop, p), kappa in zip(self.stops[end], self.kappa[end], strict=True):
            if kappa is None:
                rate = rate + stop_moments(gap, k_stop, p, sd, sign * m)[1]
            else:
                (g,) = self._closure(end, sign, kappa, (gap - sign * m) / sd, "g")
                rate = rate + k_stop * g
        return rate

    def remainder_coefficients(self, m: np.ndarray, sd: np.ndarray) -> np.ndarray:
        """Hermite coefficients ``sqrt(n!) c_n`` (N; (orders - 1, n, 4), n = 2..orders)
        of the p = 1 stops' remainder ``F - E[F] - gain y`` per spring (FL, FR, RL, RR)
        in its standardised deflection, for deflections of mean ``m`` and RMS ``sd`` (m;
        (n, 4)): each stop's Gaussian series (:func:`stop_closure.hermite_remainder`; a
        rebound stop's order n times ``(-1)^(n+1)``) scaled to the closure's remainder
        variance."""
        out = np.zeros((stop_closure.ORDERS - 1, *m.shape))
        odd = (np.arange(2, stop_closure.ORDERS + 1) % 2 == 1)[:, None, None]
        for end in (0, 1):
            cols = slice(2 * end, 2 * end + 2)
            for (sign, gap, k_stop, _), kappa in zip(self.stops[end], self.kappa[end], strict=True):
                if kappa is None:
                    continue
                a = (gap - sign * m[:, cols]) / sd[:, cols]
                (v,) = self._closure(end, sign, kappa, a, "v")
                gauss = stop_closure.gaussian_remainder_variance(a)
                scale = np.sqrt(np.where(gauss > 0.0, v / np.maximum(gauss, 1e-300), 1.0))
                coef = stop_closure.hermite_remainder(a) * (k_stop * sd[:, cols] * scale)
                out[:, :, cols] += np.where(odd | (sign > 0), coef, -coef)
        return out

    def dahl_remainder_coefficients(self, sig: np.ndarray) -> np.ndarray:
        """Hermite coefficients ``sqrt(n!) c_n`` (N; (orders - 1, n, 4) as
        :meth:`remainder_coefficients`, the rear leaves' columns) of the Dahl forces'
        part incoherent with the leaf deflection, in the standardised leaf deflection
        rate, from the element RMS values ``sig``: the variance of
        :func:`dahl_incoherent_variance` at the leaf deflections' RMS, spread as the sign
        law's remainder (:func:`_sign_series`: the law's force in its Coulomb limit,
        ``f_c sgn v``, whose remainder beyond the linear term is that series in v; in
        the loop the remainder's harmonics sit at the reversals, as the sign law's)."""
        assert self.dahl is not None
        # the left leaf's for both: the model is mirror-symmetric (their RMS values equal)
        sd = sig[:, SIG_LEAF][:, :1]
        var = dahl_incoherent_variance(self.dahl["f_c"], self.dahl["sigma"], sd)
        out = np.zeros((stop_closure.ORDERS - 1, var.shape[0], 4))
        out[:, :, 2:4] = _sign_series()[:, None, None] * np.sqrt(var)[None]
        return out

    def spring_mean(
        self, end: int, sv: np.ndarray, sd: np.ndarray, stops: bool = True
    ) -> np.ndarray:
        """Mean spring deflection from rest (m, (n, 2); + compression) at ``end`` (0:
        front springs, 1: rear leaves) under zero-mean Gaussian damper velocities of RMS
        ``sv`` (m/s) and spring deflections of RMS ``sd`` (m).

        The body's weight and centre of mass fix each axle's mean suspension force
        (two axles: statically determinate; the tyres stay in contact), so per side
        the spring's mean force change from rest balances the damper's mean force,
        ``E[dF_spring(m + x)] = -E[F_damper]``, with ``dF_spring(d) = K_1 d + dk
        (max(d - e_k, 0) - max(-e_k, 0)) + F_stops(d)`` (the leaf's second stage, rate
        ``dk`` beyond ``e_k``; front: ``K_1`` the wheel rate, no second stage), i.e.
        ``K_1 m + dk (s T((e_k - m)/s) - max(-e_k, 0)) + E[F_stops] = -E[F_damper]``
        (the stops' mean force of :meth:`_stop_terms`): Newton's method from the guess
        without stops, a fixed :data:`NEWTON_STEPS` (the left side rises monotonically
        in m; measured with the benchmark's stops and with stops 8-10 mm away, 4-30 mm of
        deflection RMS: the fifth step lies within 1e-13 m of the root; tests check the
        balance's residual). ``stops=False``: without the stops' mean force."""
        cols = slice(2 * end, 2 * end + 2)
        k1, dk, thr = (self.k1, self.dk, self.thr) if end else (self.k_front, 0.0, 0.0)
        rhs = -self.damper_mean_force(sv, cols) + dk * np.maximum(-thr, 0.0)
        m = (rhs - dk * sd * _excess(thr / sd)) / k1
        for _ in range(NEWTON_STEPS):
            a = (thr - m) / sd
            f = k1 * m + dk * sd * _excess(a) - rhs
            slope = k1 + dk * (1.0 - ndtr(a))
            if stops and self.stops[end]:
                f_stop, k_stop = self._stop_terms(end, m, sd)
                f, slope = f + f_stop, slope + k_stop
            m = m - f / slope
        return m

    def _effect_rates(self, sig: np.ndarray, r: np.ndarray, out: np.ndarray) -> None:
        out[:, FRONT] = self.k_front
        if self.stops[0]:
            sd_front = np.maximum(sig[:, SIG_FRONT], 1e-12)
            m_front = self.spring_mean(0, np.maximum(sig[:, 0:2], 1e-12), sd_front)
            out[:, FRONT] += self._stop_rate(0, m_front, sd_front)
        out[:, DAHL_C], out[:, DAHL_K] = r[:, DAHL_C], r[:, DAHL_K]
        for e in self.effects:
            if e.kind == "dahl_hysteresis":
                out[:, DAHL_C], out[:, DAHL_K] = dahl_rates(
                    e.params["sigma"],
                    e.params["f_c"],
                    sig[:, SIG_LEAF_V],
                    sig[:, SIG_DAHL],
                    r[:, DAHL_C],
                    r[:, DAHL_K],
                )
            elif e.kind == "coulomb_friction":
                cols = slice(0, 2) if e.location.startswith("front") else slice(2, 4)
                out[:, cols] += coulomb_rate(e.params["f_c"], e.params["v_eps"], sig[:, cols])
