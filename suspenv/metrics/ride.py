"""Ride metrics of acceleration records: PSD, peak, crest factor, vibration dose value,
the minibus ride objectives of a random-road record, and the ride consequence of a road
spectrum (:func:`road_ride_consequence`).

Units: acceleration in m/s^2, time in s, frequency in Hz; PSDs are one-sided
((m/s^2)^2/Hz). Records carry time on the last axis; leading axes are a batch.
Weighted values use the ISO 2631-1 weightings of :mod:`suspenv.metrics.iso2631`.
:func:`record_objectives` turns the records of the random-road rig
(:mod:`suspenv.rigs.ride`) into these numbers; :func:`ride_spectral` computes them
without a record: the exact spectral integral of the equivalent-linear ride model over
the ISO 8608 road PSD (:mod:`suspenv.models.road`), with the crest factor and VDV a
Gaussian response is expected to reach over an exposure (:func:`gaussian_dose`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np
from scipy import signal
from scipy.special import ndtr

from suspenv.core.errors import ValidationError
from suspenv.core.identity_cache import IdentityCache
from suspenv.metrics.iso2631 import (
    weighted_rms_fft,
    weighted_signal_fft,
    weighting_magnitude,
)
from suspenv.models.effects.effect import Effect
from suspenv.models.minibus import spectral_kernel
from suspenv.models.minibus.linearisation import (
    DAHL_C,
    DAHL_K,
    DAMPER,
    FRONT,
    LEAF,
    NEWTON_STEPS,
    SIG_FRONT,
    SIG_LEAF,
    ElementLinearisation,
)
from suspenv.models.minibus.ride_model import RideModel, RideRecord, SeatMount
from suspenv.models.minibus.vehicle import (
    LOAD_CASES,
    REFERENCE_MINIBUS,
    STUDY_PICK,
    Minibus,
    VehicleParams,
    stacked_vehicle_parameters,
    vehicle_parameters,
)
from suspenv.models.minibus.vehicle import G as G_STD
from suspenv.models.road import (
    CLASS_BAND,
    RandomRoad,
    generate_profile,
    in_phase_inputs,
    profile_inputs,
    temporal_psd,
    track_coherence,
)

#: designs per block of the spectral method's full-model path (``split=False``) and of
#: its default split path (the blocks' work arrays stay in cache)
SPECTRAL_CHUNK = 32
SPLIT_CHUNK = 128
#: statistical-linearisation passes of the spectral method: without effects or with
#: leaf friction only, and with stops or damper friction (whose rates fall as their
#: RMS rises: slower convergence; tests, docs/minibus.md)
PASSES, PASSES_EFFECTS = 4, 8
#: ISO 2631-1 evaluation band (Hz) of the weighted values (as :func:`weighted_rms_fft`)
ISO_BAND = (0.5, 80.0)
#: the weighted record's peak and dose measures (:func:`record_objectives`; the spectral
#: method's Gaussian expectations, :func:`gaussian_dose`): crest factors (-) and VDVs
#: (m/s^1.75) above the front and rear suspension
DOSE_KEYS = ("crest_front", "crest_rear", "vdv_front", "vdv_rear")
#: ISO 2631-1 (6.3.1): above this crest factor the VDV is reported beside the RMS
CREST_LIMIT = 9.0
#: trapezoid points of :func:`gaussian_peak_factor`'s integral (its docstring gives the error)
PEAK_POINTS = 128
#: the rule's nodes s over 0 .. 1 as the exponent factors ``-s^2/2``, and its weights
#: there, negated (the integrand is formed as ``expm1(...) = -(1 - exp(...))``)
_PEAK_EXPONENTS = -0.5 * np.linspace(0.0, 1.0, PEAK_POINTS) ** 2
_PEAK_WEIGHTS = np.full(PEAK_POINTS, -1.0 / (PEAK_POINTS - 1))
_PEAK_WEIGHTS[[0, -1]] *= 0.5
#: uniform grid of the end stops' remainder (Hz): step (its covariances' period, 16 s,
#: covers the slowest mode's decay) and top (its spectrum folds back above): against
#: the 1/32 Hz, 32 Hz grid the weighted values move by under 2e-4, against part 3 of
#: benchmarks/minibus_stop_criteria.py (1/64 Hz to 128 Hz) by under 1e-3 (tests)
REMAINDER_STEP, REMAINDER_TOP = 1.0 / 16.0, 24.0
#: step (Hz) of the uniform grid (to ``REMAINDER_TOP``) of the deflections' skewness
#: (:func:`corner_statistics`; against a 1/64 Hz, 64 Hz grid within 0.006, as the
#: remainder's 1/16 Hz step)
SKEW_STEP = 1.0 / 8.0
#: lags (s) of the remainders' covariances the weighted mean square sums over (beyond,
#: the Wk kernel and the covariances have decayed: 5e-5 of the weighted values)
REMAINDER_LAG = 2.0
#: pairs (i <= j) of the four spring deflections FL, FR, RL, RR, and of each the
#: mirror-image pair whose correlation function it shares (road and model mirror-
#: symmetric: FR-FR as FL-FL, FR-RL as FL-RR, FR-RR as FL-RL, RR-RR as RL-RL): the six
#: distinct ones, :data:`_DISTINCT`, and each pair's index among them
_PAIRS = np.triu_indices(4)
_DISTINCT = (np.array([0, 0, 0, 0, 2, 2]), np.array([0, 1, 2, 3, 2, 3]))
_SHARED = np.array([0, 1, 2, 3, 0, 3, 2, 4, 5, 4])


def _record(a: np.ndarray, fs: float) -> np.ndarray:
    arr = np.asarray(a, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] < 2:
        raise ValidationError(
            f"an acceleration record needs >= 2 samples on its last axis, but got {arr.shape}"
        )
    if not fs > 0:
        raise ValidationError(f"`fs > 0` must hold, but got fs={fs}")
    return arr


def acceleration_psd(
    a: np.ndarray, fs: float, segment_s: float = 4.0
) -> tuple[np.ndarray, np.ndarray]:
    """One-sided Welch PSD (Hann, 50 % overlap) of a record: (f (Hz), PSD ((m/s^2)^2/Hz))."""
    a = _record(a, fs)
    nper = min(int(round(segment_s * fs)), a.shape[-1])
    return signal.welch(a, fs=fs, nperseg=nper, axis=-1)


def peak(a: np.ndarray) -> np.ndarray:
    """Largest absolute value along the last axis (m/s^2)."""
    return np.max(np.abs(np.asarray(a, dtype=float)), axis=-1)


def crest_factor(a: np.ndarray) -> np.ndarray:
    """Peak / RMS (-). ISO 2631-1 asks for VDV besides RMS when it exceeds 9."""
    a = np.asarray(a, dtype=float)
    return peak(a) / np.sqrt(np.mean(a * a, axis=-1))


def vibration_dose_value(a: np.ndarray, fs: float) -> np.ndarray:
    """VDV = (integral of a^4 dt)^(1/4) (m/s^1.75) of an (already weighted) record."""
    a = _record(a, fs)
    return (np.sum(a**4, axis=-1) / fs) ** 0.25


def gaussian_peak_factor(crossings: np.ndarray | float) -> np.ndarray:
    """Expected largest |x| over an exposure, in units of the RMS (-), of a zero-mean
    stationary Gaussian process with ``crossings`` expected zero crossings (both
    directions, ``2 nu0 T``) in it.

    |x| exceeds u/sigma at the rate ``2 nu0 exp(-u^2/2)`` (Rice); with exceedances
    counted as a Poisson stream, ``P(max|x| < u sigma) = exp(-N exp(-u^2/2))`` and the
    expected maximum ``int_0^inf 1 - exp(-N exp(-u^2/2)) du`` (a :data:`PEAK_POINTS`-
    point trapezoid over ``0 .. sqrt(2 ln max(N, 1)) + 8``, where the integrand has
    fallen below 1e-13; the integrand is even in u, so the rule converges
    geometrically: within 1e-8 of a 400,001-point rule for N from 0.3 to 1e8).
    Davenport's (1964) peak factor ``L + 0.5772/L``, ``L = sqrt(2 ln N)``, is its
    expansion for large N (1 % above it at N = 80; tests). Against 4000 Gaussian
    records of a broad band (a mode of damping ratio 0.5) it holds within 0.05 % at N
    = 80 and 120 and lies 1 % high at N = 40 (the minibus's weighted accelerations
    cross zero 100-150 times in 10 s). The Poisson count assumes independent
    exceedances: for a narrow band (a lightly damped mode alone) they come in clumps
    and the records' peaks lie lower (3.5 % at damping ratio 0.1, N = 80; tests)."""
    n = np.asarray(crossings, dtype=float)
    top = np.sqrt(2.0 * np.log(np.maximum(n, 1.0))) + 8.0
    # (few array calls: a design evaluated alone pays per call, not per element)
    g = np.exp(np.multiply.outer(top * top, _PEAK_EXPONENTS))
    g *= -n[..., None]
    return top * (np.expm1(g, out=g) @ _PEAK_WEIGHTS)


def gaussian_dose(
    ms: np.ndarray, ms_rate: np.ndarray, exposure_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """Expected crest factor (-) and vibration dose value (m/s^1.75) over ``exposure_s``
    (s) of a stationary zero-mean Gaussian weighted acceleration of mean square ``ms``
    ((m/s^2)^2, the spectral moment m0) whose rate has mean square ``ms_rate``
    ((m/s^3)^2, m2 = ``int (2 pi f)^2 S(f) df``).

    Crest factor: the expected largest |a| over the RMS, :func:`gaussian_peak_factor`
    of ``2 nu0 T`` crossings, ``nu0 = sqrt(m2/m0)/(2 pi)`` the zero up-crossing rate
    (Hz). VDV: ``E[a^4] = 3 sigma^4`` for a Gaussian, so ``VDV^4 = int a^4 dt`` has the
    expectation ``3 sigma^4 T`` and the VDV is taken as ``(3 sigma^4 T)^(1/4)`` (the
    fourth root of the expected dose)."""
    ms = np.asarray(ms, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        # 2 nu0 T crossings; a crossing count of NaN or inf gives a NaN crest factor
        crest = gaussian_peak_factor(np.sqrt(ms_rate / ms) * (exposure_s / np.pi))
    return crest, np.sqrt(ms) * (3.0 * exposure_s) ** 0.25


# ------------------------------------------------------------------ random-road record
def record_objectives(
    rec: RideRecord, fs: float, load_cases: Sequence[str]
) -> dict[str, dict[str, np.ndarray]]:
    """Ride objectives per load case of a random-road record sampled at ``fs`` (Hz)
    (:func:`suspenv.rigs.ride.random_road_run`; rows: the load cases stacked in order).

    ``{load_case: {key: (n,)}}``: ISO 2631-1 Wk-weighted ``aw_*`` and unweighted
    ``rms_*`` RMS vertical acceleration (m/s^2) above the front and rear suspension, the
    weighted record's (:func:`weighted_signal_fft`) crest factor ``crest_*`` (-) and
    vibration dose value ``vdv_*`` (m/s^1.75; ISO 2631-1 asks for it beside the RMS where
    the crest factor exceeds 9), and ``ok``: False (values NaN) where it diverged.
    """
    n = rec.acc_front.shape[0] // len(load_cases)
    ok = rec.ok if rec.ok is not None else np.isfinite(rec.acc_front).all(axis=-1)
    bad = ~ok
    a_f, a_r = rec.acc_front.astype(float), rec.acc_rear.astype(float)
    a_f[bad], a_r[bad] = 0.0, 0.0
    values = {}
    for end, a in (("front", a_f), ("rear", a_r)):
        w = weighted_signal_fft(a, fs, "Wk")
        values[f"aw_{end}"] = weighted_rms_fft(a, fs, "Wk")
        with np.errstate(invalid="ignore", divide="ignore"):
            values[f"crest_{end}"] = crest_factor(w)
        values[f"vdv_{end}"] = vibration_dose_value(w, fs)
        values[f"rms_{end}"] = np.sqrt(np.mean(a**2, axis=-1))
    out = {}
    for i, lc in enumerate(load_cases):
        sl = slice(i * n, (i + 1) * n)
        out[lc] = {k: np.where(bad[sl], np.nan, v[sl]) for k, v in values.items()}
        out[lc]["ok"] = ok[sl]
    return out


# ------------------------------------------------------------------ spectral method
def frequency_grid(
    road: RandomRoad, n_freq: int = 400
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integration grid of the spectral method: (f (Hz), quadrature weights, ISO-band mask).

    Temporal road band f = v n over ISO 8608's class band ``CLASS_BAND`` (the band the
    time-domain profile generator fills), capped at the time-domain profile's Nyquist
    frequency ``sample_rate``; log-spaced (constant relative resolution, so a mode of
    damping ratio zeta at f_r gets about ``2 zeta / dlnf`` points in its half-power
    band), with the ISO 2631-1 band edge 0.5 Hz as a grid point. Trapezoid weights.
    """
    v = road.speed
    f_a = v * CLASS_BAND[0]
    f_b = min(v * CLASS_BAND[1], road.sample_rate)
    lo, hi = max(f_a, ISO_BAND[0]), min(f_b, ISO_BAND[1])
    edges = [f_a] + ([lo] if lo > f_a else []) + [f_b]
    if hi < f_b:
        edges.insert(-1, hi)
    span = np.log(f_b / f_a)
    parts = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        k = max(8, int(np.ceil(n_freq * np.log(b / a) / span)))
        parts.append(np.geomspace(a, b, k + 1)[:-1])
    f = np.concatenate(parts + [np.array([f_b])])
    w = np.zeros_like(f)
    df = np.diff(f)
    w[:-1] += df / 2
    w[1:] += df / 2
    iso = (f >= lo - 1e-12) & (f <= hi + 1e-12)
    return f, w, iso


def road_terms(
    f: np.ndarray, road: RandomRoad, vehicle: Minibus
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Road terms at frequencies f (Hz) inside the road band: the temporal PSD Gq
    (m^2/Hz, one-sided, with the tyre enveloping), the rear wheels' delay factor
    ``e^(-i 2 pi f L/v)`` and the left/right coherency rho (-)."""
    v = road.speed
    gq = temporal_psd(f, v, road.road_class)
    if road.enveloping:
        gq = gq * np.sinc(f / v * road.enveloping) ** 2
    delay = np.exp(-2j * np.pi * f * vehicle.wheelbase / v)
    return gq, delay, track_coherence(f / v, vehicle.track_front)


@functools.lru_cache(maxsize=32)
def _road_grid(road: RandomRoad, n_freq: int, vehicle: Minibus) -> tuple[np.ndarray, ...]:
    """Grid (f, weights, ISO mask) with the road terms on it: temporal PSD Gq (with the
    tyre enveloping), rear delay factor, left/right coherency, and Wk^2 in the ISO band.
    Cached per (road, grid size, vehicle); the arrays are read-only."""
    f, w, iso = frequency_grid(road, n_freq)
    gq, delay, rho = road_terms(f, road, vehicle)
    wk2 = np.where(iso, weighting_magnitude(f, "Wk") ** 2, 0.0)
    out = (f, w, iso, gq, delay, rho, wk2)
    for a in out:
        a.flags.writeable = False
    return out


def _output_matrix(model: RideModel) -> np.ndarray:
    """Rows (8, nq) mapping q to: measuring-point displacements (front, rear), damper
    compressions (FL, FR, RL, RR), rear leaf compressions at the seats (L, R)."""
    nq, npos = model.nq, model.n_pos
    out = np.zeros((8, nq))
    if model.seat:
        out[0, 7] = out[1, 8] = 1.0
    else:
        out[0, 0] = out[1, 1] = 1.0
        out[0:2, 2] = model.measure_y
    out[2:6] = model.E[nq:, npos : npos + 4].T
    out[6:8] = model.E[:nq, 2:4].T
    return out


def modal_form(
    M: np.ndarray,
    C: np.ndarray,
    K: np.ndarray,
    Kin: np.ndarray,
    Cin: np.ndarray,
    Co: np.ndarray,
    hyst: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Poles (n, ns) and residues (n, ns, p, m) of ``M qdd + C qd + K q = Kin u + Cin ud``
    with output ``y = Co q``, for :func:`modal_response` (ns = 2 nq states).

    Output ``y = Co q`` (Co (p, nq)) per unit harmonic input u (m inputs) at frequencies
    f (Hz): ``H = Co (K - w^2 M + i w C)^-1 (Kin + i w Cin)``, computed as
    ``C_x (i w I - A)^-1 (B0 + i w B1)`` of the first-order form ``x = [q, qd]`` through
    the eigen-decomposition ``A = V diag(lam) V^-1`` (batched over n): per mode
    ``(B0 + s B1)/(s - lam) = R1 + (R0 + lam R1)/(s - lam)`` with ``R = V^-1 B``; the
    constant part maps to ``C_x V R1 = C_x B1 = 0`` (B1 acts on velocities only). Cost:
    one (Nf x ns) @ (ns x p m) product per design. Velocity/acceleration responses are
    ``i w H`` and ``-w^2 H``.

    ``hyst = (Pz, cz, kz)``: nz linear first-order force elements ``dz/dt = cz (Pz qd) -
    kz z`` (Pz (nz, nq): element deflection per q; cz (n, nz) N/m, kz (n, nz) 1/s) acting
    on q as ``-Pz^T z`` (the linearised Dahl elements); they add nz states (ns = 2 nq +
    nz) and nz outputs, the forces z (N), after Co's p rows.
    """
    n, nq = M.shape[0], M.shape[1]
    m_in = Kin.shape[-1]
    nz = 0 if hyst is None else hyst[0].shape[0]
    ns = 2 * nq + nz
    Minv = np.linalg.inv(M)
    A = np.zeros((n, ns, ns))
    A[:, :nq, nq : 2 * nq] = np.eye(nq)
    A[:, nq : 2 * nq, :nq] = -Minv @ K
    A[:, nq : 2 * nq, nq : 2 * nq] = -Minv @ C
    B = np.zeros((n, ns, 2 * m_in), dtype=complex)
    B[:, nq : 2 * nq, :m_in] = Minv @ Kin
    B[:, nq : 2 * nq, m_in:] = Minv @ Cin
    Cx = np.zeros((Co.shape[0] + nz, ns))
    Cx[: Co.shape[0], :nq] = Co
    if hyst is not None:
        Pz, cz, kz = hyst
        A[:, nq : 2 * nq, 2 * nq :] = -Minv @ Pz.T
        A[:, 2 * nq :, nq : 2 * nq] = cz[:, :, None] * Pz[None]
        A[:, 2 * nq :, 2 * nq :] = -kz[:, :, None] * np.eye(nz)
        Cx[Co.shape[0] :, 2 * nq :] = np.eye(nz)
    lam, V = spectral_kernel.decompose(spectral_kernel.general_eigen, A)  # (n, ns), (n, ns, ns)
    R = np.linalg.solve(V, B)
    Rm = R[:, :, :m_in] + lam[:, :, None] * R[:, :, m_in:]  # (n, ns, m)
    CV = np.einsum("pi,nik->npk", Cx, V)  # (n, p, ns)
    # P[k, p, i] = CV[p, k] Rm[k, i]: residue of mode k from input i to output p
    P = CV.transpose(0, 2, 1)[:, :, :, None] * Rm[:, :, None, :]
    return lam, P


def modal_response(lam: np.ndarray, P: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``H(f) = sum_k P_k / (i 2 pi f - lam_k)``: (n, Nf, p, m) from poles lam (n, K) and
    residues P (n, K, p, m) (see :func:`modal_form`)."""
    n, k, p, m = P.shape
    s = 2j * np.pi * np.asarray(f, dtype=float)
    Wm = s[None, :, None] - lam[:, None, :]  # (n, Nf, K)
    np.divide(1.0, Wm, out=Wm)
    return (Wm @ P.reshape(n, k, p * m)).reshape(n, f.size, p, m)


def _track_lines(
    G: np.ndarray, delay: np.ndarray, rho: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The two uncorrelated parts (n, Nf, p) per unit road PSD of outputs with responses
    G (n, Nf, p, 4) per wheel input (FL, FR, RL, RR): ``g_L + rho g_R`` and ``sqrt(1 -
    rho^2) g_R`` (the Cholesky columns of ``[[1, rho], [rho, 1]]``, rho the tracks'
    coherency), ``g = H_front + delay H_rear`` per track (``delay = e^{-i w L/v}``)."""
    left = G[..., 0] + delay[None, :, None] * G[..., 2]
    right = G[..., 1] + delay[None, :, None] * G[..., 3]
    r = rho[None, :, None]
    return left + r * right, np.sqrt(np.maximum(1.0 - r * r, 0.0)) * right


def _output_psd(
    G: np.ndarray,
    f: np.ndarray,
    road_in: np.ndarray,
    delay: np.ndarray,
    rho: np.ndarray,
    power: Sequence[int],
) -> np.ndarray:
    """One-sided output PSDs (n, p, Nf) from responses G (n, Nf, p, 4) per wheel input
    displacement; output j's PSD is multiplied by ``(2 pi f)^(2 power[j])`` (0: as G,
    1: its rate, 2: its second derivative)."""
    h1, h2 = _track_lines(G, delay, rho)
    psd = (h1.real**2 + h1.imag**2 + h2.real**2 + h2.imag**2) * road_in[None, :, None]
    w2 = (2 * np.pi * f) ** 2
    psd *= w2[None, :, None] ** np.asarray(power, dtype=float)[None, None, :]
    return np.moveaxis(psd, 1, 2)


# ------------------------------------------------------------------ symmetric split
#: the base model's coordinates q = [z_f, z_r, phi, z_FL, z_FR, z_RL, z_RR] as its
#: symmetric half x_s = T_SYM^T q (z_f, z_r, front wheel and rear axle bounce) and its
#: antisymmetric half x_a = T_ANTI^T q (body roll, front wheel and rear axle roll), both
#: in m (phi in rad); q = T_SYM x_s + T_ANTI x_a, [T_SYM, T_ANTI] orthonormal
_H = float(np.sqrt(0.5))
T_SYM = np.array(
    [
        [1.0, 0, 0, 0],
        [0, 1.0, 0, 0],
        [0, 0, 0, 0],
        [0, 0, _H, 0],
        [0, 0, _H, 0],
        [0, 0, 0, _H],
        [0, 0, 0, _H],
    ]
)
T_ANTI = np.array(
    [
        [0, 0, 0],
        [0, 0, 0],
        [1.0, 0, 0],
        [0, _H, 0],
        [0, -_H, 0],
        [0, 0, _H],
        [0, 0, -_H],
    ]
)
#: wheel inputs (FL, FR, RL, RR) from a half's axle inputs (front, rear): u = J u_half,
#: with u_sym = (u_left + u_right)/2 and u_anti = (u_left - u_right)/2 per axle
J_SYM = np.array([[1.0, 0], [1, 0], [0, 1], [0, 1]])
J_ANTI = np.array([[1.0, 0], [-1, 0], [0, 1], [0, -1]])
#: rows of :func:`_output_matrix` the split path evaluates: measuring points front and
#: rear, then FL damper, RL damper and left leaf (their right-hand twins have the same
#: RMS value: the symmetric parts equal, the antisymmetric ones opposite)
_SPLIT_ROWS = (0, 1, 2, 4, 6)


class _SplitGeometry(NamedTuple):
    """Design-independent matrices of the two halves of the base model, stacked (axis 0:
    symmetric, antisymmetric), each in d = 4 coordinates ``x = T^T q``: the
    antisymmetric half's 3 plus an inert padding coordinate (no mass, element, input or
    output; its two first-order states carry the fixed poles -1 +- i 1/s and zero
    residues), so both halves share one batched eigen-decomposition. n_el = n_pos +
    n_vel element rates per design (N/m, N m/rad, N s/m)."""

    T: np.ndarray  # (2, nq, d)
    D: np.ndarray  # (n_el, 2 * 2 d^2): rates @ D = -[K | C] (2, d, 2d), halves first
    Gin: np.ndarray  # (n_el, 2 * 4 d): rates @ Gin = [K_in | C_in] (2, d, 4), axle inputs
    co: np.ndarray  # (2, 5, d): the ``_SPLIT_ROWS`` outputs per x
    A0: np.ndarray  # (2, 2d, 2d): the first-order matrices' constant part


_SPLIT_D = 4
_SPLIT_GEOMETRY: IdentityCache[_SplitGeometry] = IdentityCache()


def _split_geometry(model: RideModel) -> _SplitGeometry:
    """The :class:`_SplitGeometry` of a seatless model (cached per vehicle object and
    measuring point)."""
    return _SPLIT_GEOMETRY.get(
        [model.vehicle], (model.measure_y,), lambda: _new_split_geometry(model)
    )


def _new_split_geometry(model: RideModel) -> _SplitGeometry:
    """:func:`_split_geometry`, built (read-only)."""
    nq, npos, d = model.nq, model.n_pos, _SPLIT_D
    n_el = model.E.shape[1]
    co_all = _output_matrix(model)[list(_SPLIT_ROWS)]
    T = np.zeros((2, nq, d))
    T[0] = T_SYM
    T[1, :, :3] = T_ANTI
    D = np.zeros((n_el, 2, d, 2 * d))
    Gin = np.zeros((n_el, 2, d, 4))
    A0 = np.zeros((2, 2 * d, 2 * d))
    for h, J in enumerate((J_SYM, J_ANTI)):
        pos = (T[h].T @ model.E[:nq, :npos]).T  # (n_pos, d) element deflection per x
        vel = (T[h].T @ model.E[nq:, npos:]).T  # (n_vel, d)
        D[:npos, h, :, :d] = -pos[:, :, None] * pos[:, None, :]
        D[npos:, h, :, d:] = -vel[:, :, None] * vel[:, None, :]
        # road through the tyres (compression = road - wheel), per axle input
        Gin[6:10, h, :, :2] = -pos[6:10, :, None] * J[:, None, :]
        Gin[npos + 4 : npos + 8, h, :, 2:] = -vel[4:8, :, None] * J[:, None, :]
        A0[h, :d, d:] = np.eye(d)
    # the padding coordinate: x' = -x + v, v' = -x - v (decoupled; poles -1 +- i)
    A0[1, d - 1, d - 1] = A0[1, 2 * d - 1, d - 1] = A0[1, 2 * d - 1, 2 * d - 1] = -1.0
    geo = _SplitGeometry(
        T, D.reshape(n_el, -1), Gin.reshape(n_el, -1), np.stack([co_all @ t for t in T]), A0
    )
    for a in geo:
        a.flags.writeable = False
    return geo


class _Halves:
    """The two decoupled halves of the symmetric base ride model (no seat) for a batch
    of n designs, interleaved into 2 n rows (design i: row 2 i symmetric, row 2 i + 1
    antisymmetric): ``x = T^T q``.

    The model is mirror-symmetric about the vehicle's centreline (both tracks' springs,
    dampers, tyres and wheel masses alike; the measuring points only enter the outputs),
    so ``T_SYM^T (M, C, K) T_ANTI = 0`` and the 7-DOF system splits exactly into a 4-DOF
    symmetric and a 3-DOF antisymmetric one. The axle inputs of the halves are
    uncorrelated with PSDs ``Gq (1 + rho)/2`` and ``Gq (1 - rho)/2`` (rho the real
    left/right coherency), so ``|g_L + rho g_R|^2 + (1 - rho^2)|g_R|^2`` of
    :func:`ride_spectral` equals ``(1 + rho)/2 |g_s|^2 + (1 - rho)/2 |g_a|^2`` with
    ``g_s = g_L + g_R`` and ``g_a = g_L - g_R`` the halves' responses per axle input.
    """

    def __init__(self, geo: _SplitGeometry, model: RideModel):
        """The halves of the designs of ``model`` (seatless), geometry ``geo``: their
        inverse mass, road input and output matrices (:func:`_halves_blocks`)."""
        n, d = model.n, _SPLIT_D
        self.minv, self.B, self.co = _halves_blocks(geo, model)
        self.A0 = geo.A0
        self.D = geo.D.reshape(-1, 2, d, 2 * d)
        # the first-order matrices of a pass, refilled by every pass (read by its eigenvalues
        # and eigenvectors before the next)
        self._A = np.empty((2 * n, 2 * d, 2 * d))

    def modal(self, rates: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Poles (2n, 2d) and eigenvectors (2n, 2d, 2d) of the halves' first-order
        matrices at element rates (n, n_el), 2 n rows: the compiled
        :func:`suspenv.models.minibus.spectral_kernel.halves_matrix` and
        :func:`~suspenv.models.minibus.spectral_kernel.eigen`, LAPACK for a row where
        that fails (:func:`~suspenv.models.minibus.spectral_kernel.decompose`)."""
        return spectral_kernel.decompose(spectral_kernel.eigen, self.matrix(rates))

    def matrix(self, rates: np.ndarray) -> np.ndarray:
        """The halves' first-order matrices (2n, 2d, 2d; states ``[x, xd]``) at element
        rates (n, n_el): :func:`suspenv.models.minibus.spectral_kernel.halves_matrix`
        into a work array that the next call overwrites."""
        spectral_kernel.halves_matrix(self.A0, self.minv, self.D, rates, self._A)
        return self._A


def _halves_mean_square(
    modes: tuple[np.ndarray, np.ndarray],
    B: np.ndarray,
    co: np.ndarray,
    rows: slice,
    grid: tuple[np.ndarray, ...],
    wt: np.ndarray,
) -> np.ndarray:
    """``sum_f wt_h[f, j] |g_p(f)|^2`` summed over the halves h (n designs, p, j), with
    ``g_p = H_p,front + e^{-i w L/v} H_p,rear`` a half's displacement response (output
    unit per m of axle input) for the outputs ``rows`` of the output matrices ``co``
    (2n, outputs, d), from the halves' eigen-decomposition ``modes`` (poles (2n, 2d),
    eigenvectors (2n, 2d, 2d); residues of output p for axle input i at mode k ``cv[p,
    k] rm[k, i]`` as :func:`modal_form`, each conjugate pair (or pair of real poles)
    summed into one real second-order term) and road input matrices ``B`` (2n, 2d, 4),
    on the grid ``grid = (w, w^2, Re, Im of e^{-i w L/v})`` (w in rad/s, L/v the rear
    wheels' delay) with weights ``wt = [wt_sym | wt_anti]`` (Nf, 2 j)
    (:func:`_split_grid`); the compiled
    :func:`suspenv.models.minibus.spectral_kernel.modal_mean_square`."""
    w, _, dr, di = grid
    out = np.empty((co.shape[0] // 2, rows.stop - rows.start, wt.shape[1] // 2))
    spectral_kernel.modal_mean_square(*modes, B, co, rows.start, w, dr, di, wt, out)
    return out


#: :func:`_halves_blocks`' cache
_HALVES_BLOCKS: IdentityCache[tuple[np.ndarray, ...]] = IdentityCache()


def _halves_blocks(geo: _SplitGeometry, model: RideModel) -> tuple[np.ndarray, ...]:
    """The halves' inverse mass matrices ``T^T M^-1 T`` (2n, d, d) (1/kg, 1/(kg m^2)),
    road input matrices ``[0 | M_h^-1 [K_in | C_in]]`` (2n, 2d, 4) (complex; the road
    acts through the tyres, whose rates the vehicle fixes) and output matrices (2n, 5,
    d) on the rows of ``model``'s designs. No design variable changes them, only the
    parameter blocks (load cases) and their rows: read-only, kept per geometry,
    inverse mass terms (:attr:`RideModel.inverse_blocks`, kept per load case
    themselves) and rows per block."""
    terms = model.inverse_blocks
    return _HALVES_BLOCKS.get(
        [geo, terms], tuple(model.counts), lambda: _new_halves_blocks(geo, model, terms)
    )


def _new_halves_blocks(
    geo: _SplitGeometry, model: RideModel, terms: np.ndarray
) -> tuple[np.ndarray, ...]:
    """:func:`_halves_blocks`, built (read-only)."""
    k, nq, d, n = terms.shape[0], model.nq, _SPLIT_D, model.n
    minv = np.zeros((k, nq, nq))
    minv.reshape(k, -1)[:, :: nq + 1] = terms[:, :nq]  # the diagonals
    minv[:, 0, 1] = minv[:, 1, 0] = terms[:, nq]
    minv_h = geo.T.transpose(0, 2, 1) @ minv[:, None] @ geo.T
    B = np.zeros((k, 2, 2 * d, 4), dtype=complex)
    B[:, :, d:] = minv_h @ (model.tyre_rates[None, None] @ geo.Gin).reshape(1, 2, d, 4)
    rows = (
        minv_h.repeat(model.counts, axis=0).reshape(2 * n, d, d),
        B.repeat(model.counts, axis=0).reshape(2 * n, 2 * d, 4),
        np.concatenate([geo.co] * n),
    )
    for a in rows:
        a.flags.writeable = False
    return rows


_SPLIT_GRIDS: IdentityCache[tuple[tuple[np.ndarray, ...], np.ndarray]] = IdentityCache(64)


def _split_grid(
    road: RandomRoad, n_freq: int, vehicle: Minibus, final: bool
) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """:func:`_split_grid_values`, looked up by the identity of ``road`` and ``vehicle``
    first (hashing a vehicle costs more than the lookup)."""
    return _SPLIT_GRIDS.get(
        [road, vehicle], (n_freq, final), lambda: _split_grid_values(road, n_freq, vehicle, final)
    )


def _output_weights(w2: np.ndarray, wk2: np.ndarray, final: bool) -> tuple[np.ndarray, ...]:
    """The mean-square weights of a displacement response's |H|^2 per output column, from
    w^2 (rad^2/s^2) and Wk^2 on the grid: ``final``: w^4 Wk^2 (weighted acceleration),
    w^4 (acceleration), w^6 Wk^2 (the weighted acceleration's rate); else 1
    (displacement) and w^2 (velocity)."""
    return (w2 * w2 * wk2, w2 * w2, w2 * w2 * w2 * wk2) if final else (np.ones_like(w2), w2)


@functools.lru_cache(maxsize=32)
def _split_grid_values(
    road: RandomRoad, n_freq: int, vehicle: Minibus, final: bool
) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """``((w, w^2, Re, Im of the rear delay factor), weights)`` on the
    :func:`frequency_grid` of ``n_freq`` points (w = 2 pi f, rad/s). The weights (Nf,
    2 J) turn ``|g|^2`` (displacement per axle input) into mean squares: quadrature x Gq
    x (1 + rho)/2 (columns 0 .. J - 1, symmetric half) or (1 - rho)/2 (columns J .. 2J -
    1, antisymmetric half) x, per half, ``final`` (J = 3): w^4 Wk^2 (weighted
    acceleration, ISO band), w^4 (acceleration, whole band) and w^6 Wk^2 (the weighted
    acceleration's rate, ISO band); else (J = 2) 1 (displacement) and w^2 (velocity).
    Read-only, cached."""
    f, wq, _, gq, delay, rho, wk2 = _road_grid(road, n_freq, vehicle)
    w = 2 * np.pi * f
    w2 = w * w
    cols = _output_weights(w2, wk2, final)
    grid = (w, w2, np.ascontiguousarray(delay.real), np.ascontiguousarray(delay.imag))
    wt = np.stack([wq * gq * (0.5 * half) * c for half in (1.0 + rho, 1.0 - rho) for c in cols])
    wt = np.ascontiguousarray(wt.T)
    for a in (*grid, wt):
        a.flags.writeable = False
    return grid, wt


# ------------------------------------------------------------------ equivalent linear
def _fixed_point(
    r: np.ndarray,
    update: Callable[[Any, np.ndarray], int] | None,
    modal: Callable[[np.ndarray], Any],
    iterations: int,
    tol: float | None,
) -> tuple[np.ndarray, int, Any]:
    """Equivalent-linear rates of :func:`ride_spectral` from the starting rates ``r``
    (n, n_rates; columns of :mod:`suspenv.models.minibus.linearisation`; updated in
    place): ``(rates, passes, modal form of the rates)``; ``modal(r)`` builds a modal
    form, ``update(m, r)`` takes the new rates of modal form ``m`` into ``r`` by the rule
    of :func:`suspenv.models.minibus.spectral_kernel.take_rates` and returns how many
    designs took them; ``update=None``: the plain linearised model (``r`` as given)."""
    if update is None:
        return r, 0, modal(r)
    n_iter = 0
    m = None
    for it in range(iterations):
        m = modal(r)
        n_iter += 1
        if tol is None and it == iterations - 1:
            break  # fixed number of passes: the last pass's rates serve
        # when every design has converged, the rates of this pass are the fixed point
        # within ``tol`` and its modal form serves
        if not update(m, r):
            break
        m = None
    if m is None:
        m = modal(r)
    return r, n_iter, m


def _spectral_result(
    ms: np.ndarray, r: np.ndarray, n_iter: int, exposure_s: float
) -> dict[str, np.ndarray]:
    """:func:`ride_spectral`'s dict from the mean squares ``ms`` (n, front/rear,
    weighted/unweighted/weighted rate; (m/s^2)^2, (m/s^3)^2), the rates used (n,
    n_rates) and the exposure (s) of the Gaussian crest factors and VDVs
    (:func:`gaussian_dose`)."""
    rms = np.sqrt(ms[:, :, :2])
    crest, vdv = gaussian_dose(ms[:, :, 0], ms[:, :, 2], exposure_s)
    return {
        "aw_front": rms[:, 0, 0],
        "aw_rear": rms[:, 1, 0],
        "rms_front": rms[:, 0, 1],
        "rms_rear": rms[:, 1, 1],
        "crest_front": crest[:, 0],
        "crest_rear": crest[:, 1],
        "vdv_front": vdv[:, 0],
        "vdv_rear": vdv[:, 1],
        "ok": np.isfinite(rms).all(axis=(1, 2)),
        "damper_c": r[:, DAMPER],
        "leaf_k": r[:, LEAF],
        "iterations": np.array(n_iter),
    }


def _spectral_split(
    params: list[VehicleParams],
    road: RandomRoad,
    vehicle: Minibus,
    seat: SeatMount | None,
    n_freq: int,
    equivalent_linear: bool,
    iterations: int,
    tol: float | None,
    n_freq_iter: int,
    init_damping: float,
) -> dict[str, np.ndarray]:
    """:func:`ride_spectral` of one chunk through the model's two decoupled halves
    (:class:`_Halves`; no seat); ``params`` the chunk's stacked vehicle parameters."""
    model = RideModel(params, linear=not equivalent_linear)
    npos = model.n_pos
    rates = model.K.astype(float)  # element rates, dampers and leaves set per pass
    halves = _Halves(_split_geometry(model), model)

    def modal(r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rates[:, 2:4] = r[:, LEAF]
        rates[:, npos : npos + 4] = r[:, DAMPER]
        return halves.modal(rates)

    (w, _, dr, di), wt_i = _split_grid(road, n_freq_iter, vehicle, False)
    update: Callable[[Any, np.ndarray], int] | None = None
    if equivalent_linear:
        lz = ElementLinearisation(model)
        r0, tol_ = lz.initial(init_damping), 0.0 if tol is None else tol

        def update(m: tuple[np.ndarray, np.ndarray], r: np.ndarray) -> int:
            # the RMS values of the FL and RL dampers and the left leaf (their
            # right-hand twins equal), the rates at them, taken by take_rates's rule
            return int(
                spectral_kernel.split_update(
                    *m, halves.B, halves.co, w, dr, di, wt_i, *lz.packed, NEWTON_STEPS, tol_, r
                )
            )

    else:
        r0 = np.hstack([model.damper_mean, model.leaf_static_rate])
    r, n_iter, m = _fixed_point(r0, update, modal, iterations, tol)
    grid, wt = _split_grid(road, n_freq, vehicle, True)
    ms = _halves_mean_square(m, halves.B, halves.co, slice(0, 2), grid, wt)
    return _spectral_result(ms, r, n_iter, road.duration_s)


#: the halves of the mirror-symmetric model for :func:`_spectral_modal`: (T, J, S) with
#: T the half's coordinates, J its axle inputs and S (1, 2) its share of the left and
#: right Dahl forces, z_h = S (z_L, z_R); the whole model: (None, None, I)
_HALF_MAPS = ((T_SYM, J_SYM, np.array([[_H, _H]])), (T_ANTI, J_ANTI, np.array([[_H, -_H]])))
_WHOLE_MAP = ((None, None, np.eye(2)),)


def _whole_modal(
    lin: RideModel, effects: bool, dahl: bool
) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """``r -> (poles, residues)``: :func:`modal_form` of the whole linear model ``lin``
    (every wheel input) at the rates ``r`` (n, n_rates; columns of
    :mod:`suspenv.models.minibus.linearisation`), with ``dahl`` a linearised Dahl state
    per leaf. Outputs: measuring points front, rear; dampers FL..RR; leaves L, R; with
    ``effects`` the front springs FL, FR; with ``dahl`` the Dahl forces z_L, z_R."""
    nq = lin.nq
    Co = np.vstack([_output_matrix(lin), lin.E[:nq, 0:2].T])[: 10 if effects else 8]
    leaves = lin.E[:nq, 2:4].T  # (2, nq) leaf compression at the seats per q

    def modal(r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        system = lin.linear_system(r[:, DAMPER], r[:, LEAF], r[:, FRONT] if effects else None)
        hyst = (leaves, r[:, DAHL_C], r[:, DAHL_K]) if dahl else None
        return modal_form(*system, Co, hyst)

    return modal


def _whole_mean_square(
    modes: tuple[np.ndarray, np.ndarray],
    rows: slice,
    road: RandomRoad,
    n_freq: int,
    vehicle: Minibus,
    final: bool,
) -> np.ndarray:
    """Mean squares (n, outputs ``rows``, J) of the whole model's modal form ``modes``
    (:func:`_whole_modal`) on the ``n_freq``-point grid: ``final`` (J = 3): Wk-weighted
    acceleration in the ISO band, acceleration, the weighted acceleration's rate; else
    (J = 2) displacement, rate."""
    lam, P = modes
    f, wq, _, gq, delay, rho, wk2 = _road_grid(road, n_freq, vehicle)
    G = modal_response(lam, P[:, :, rows], f)
    psd = _output_psd(G, f, gq, delay, rho, (0,) * G.shape[2])
    w2 = (2 * np.pi * f) ** 2
    cols = _output_weights(w2, wk2, final)
    return psd @ np.column_stack([wq * c for c in cols])


class _EffectHalves:
    """The two decoupled halves (:class:`_Halves`) of the mirror-symmetric ride model
    with effects, for :func:`_spectral_modal`: element rates set per pass (dampers,
    leaves, front springs) and, with ``dahl``, one linearised Dahl state per half
    (``z_h = S (z_L, z_R)``, :data:`_HALF_MAPS`; the left leaf's ``c_z``, ``k_z``, the
    right one's being equal), acting on the half as ``-pz^T z_h``.

    A half's states are ``[x (4), z (nz), xd (4), pad (nz)]`` (nz = 1 with Dahl, else 0),
    so that the compiled modal sums (:func:`suspenv.models.minibus.spectral_kernel.
    modal_mean_square`: outputs of the first d = 4 + nz states, an even number 2 d of
    states) serve; the pad is an inert state (pole -1, no input, no output). Outputs
    (rows of ``co``): :data:`_SPLIT_ROWS` (measuring points front, rear, FL and RL
    damper and left leaf compressions), the FL front spring's compression, then z_h."""

    def __init__(self, lin: RideModel, dahl: bool):
        geo = _split_geometry(lin)
        self.halves = h = _Halves(geo, lin)
        n, nq, self.nz = lin.n, lin.nq, int(dahl)
        d = _SPLIT_D + self.nz
        self.npos, self.rates = lin.n_pos, lin.K.astype(float)
        self.co = np.zeros((2 * n, len(_SPLIT_ROWS) + 1 + self.nz, d))
        self.co[:, : len(_SPLIT_ROWS), :_SPLIT_D] = h.co
        self.co[:, len(_SPLIT_ROWS), :_SPLIT_D] = np.tile(lin.E[:nq, 0] @ geo.T, (n, 1))
        self.B = np.zeros((2 * n, 2 * d, 4), dtype=complex)
        self.B[:, d : d + _SPLIT_D] = h.B[:, _SPLIT_D:]
        if dahl:
            self.co[:, -1, _SPLIT_D] = 1.0
            pz = np.vstack(
                [S @ lin.E[:nq, 2:4].T @ T for T, (_, _, S) in zip(geo.T, _HALF_MAPS, strict=True)]
            )
            self.pz = np.tile(pz, (n, 1))  # (2n, 4): leaf force per unit z_h on x
            self.fz = -(h.minv @ self.pz[..., None])[..., 0]  # xd' per unit z_h
            # the decomposed states [x, xd, z] among the 2 d, and their work array
            self.place = np.r_[0:_SPLIT_D, d : d + _SPLIT_D, _SPLIT_D]
            self._A = np.zeros((2 * n, 2 * d - 1, 2 * d - 1))

    def modal(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Poles (2n, 2d) and eigenvectors (2n, 2d, 2d) of the halves at the rates ``r``
        (n, n_rates; columns of :mod:`suspenv.models.minibus.linearisation`): without
        Dahl :meth:`_Halves.modal`; with it the compiled eigen-decomposition of the
        states ``[x, xd, z]`` (:func:`~suspenv.models.minibus.spectral_kernel.
        general_eigen`, LAPACK where it fails), the pad's pole and unit vector added."""
        rates = self.rates
        rates[:, 0:2], rates[:, 2:4] = r[:, FRONT], r[:, LEAF]
        rates[:, self.npos : self.npos + 4] = r[:, DAMPER]
        if not self.nz:
            return self.halves.modal(rates)
        A, m = self._A, 2 * _SPLIT_D
        A[:, :m, :m] = self.halves.matrix(rates)
        A[:, _SPLIT_D:m, m] = self.fz
        A[:, m, _SPLIT_D:m] = r[:, DAHL_C][:, :1].repeat(2, axis=0) * self.pz
        A[:, m, m] = -r[:, DAHL_K][:, 0].repeat(2)
        lam9, V9 = spectral_kernel.decompose(spectral_kernel.general_eigen, A)
        lam = np.full((A.shape[0], m + 2), -1.0 + 0j)
        lam[:, : m + 1] = lam9
        V = np.zeros((A.shape[0], m + 2, m + 2), dtype=complex)
        V[:, self.place, : m + 1] = V9
        V[:, m + 1, m + 1] = 1.0
        return lam, V

    def mean_square(
        self,
        modes: tuple[np.ndarray, np.ndarray],
        rows: slice,
        road: RandomRoad,
        n_freq: int,
        vehicle: Minibus,
        final: bool,
    ) -> np.ndarray:
        """Mean squares (n, outputs ``rows``, J) of the halves with the eigen-
        decomposition ``modes`` (:meth:`modal`) on the ``n_freq``-point grid, weights of
        :func:`_split_grid` (``final``: Wk-weighted acceleration in the ISO band,
        acceleration, the weighted acceleration's rate; else displacement, rate): the
        compiled :func:`~suspenv.models.minibus.spectral_kernel.modal_mean_square`."""
        grid, wt = _split_grid(road, n_freq, vehicle, final)
        return _halves_mean_square(modes, self.B, self.co, rows, grid, wt)

    def residues(
        self, modes: tuple[np.ndarray, np.ndarray], row: int
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per half (symmetric, antisymmetric) the poles (n, 2d) and residues (n, 2d, 1,
        2) of output ``row`` for the axle inputs (front, rear), as :func:`modal_form`
        gives them, from the eigen-decomposition ``modes`` (:meth:`modal`); the pad's
        mode (residue zero) left out."""
        lam, V = modes
        R = np.linalg.solve(V, self.B)
        cv = np.einsum("rj,rjk->rk", self.co[:, row], V[:, : self.co.shape[2]])
        P = (cv[:, :, None] * (R[:, :, :2] + lam[:, :, None] * R[:, :, 2:]))[:, :, None]
        k = lam.shape[1] - self.nz
        return [(lam[h::2, :k], P[h::2, :k]) for h in (0, 1)]


def _spectral_modal(
    params: list[VehicleParams],
    road: RandomRoad,
    vehicle: Minibus,
    seat: SeatMount | None,
    n_freq: int,
    equivalent_linear: bool,
    iterations: int,
    tol: float | None,
    n_freq_iter: int,
    init_damping: float,
    effects: Sequence[Effect] = (),
    halves: bool = False,
) -> dict[str, np.ndarray]:
    """:func:`ride_spectral` of one chunk by modal sums: of the whole first-order system
    (:func:`_whole_modal`: all 2 nq states, every wheel input, complex sums), or with
    ``halves`` (seatless, with ``effects``) of its decoupled symmetric and antisymmetric
    halves (:class:`_EffectHalves`: each with one Dahl state for the pair of leaves,
    ``z_h = S (z_L, z_R)``; left-hand elements only, the right-hand ones have the same
    RMS values; compiled sums). With ``effects`` also the front springs' and the Dahl
    elements' equivalent-linear rates (a Dahl element adds one first-order state per
    leaf)."""
    lin = RideModel(params, seat=seat, linear=True)
    lz = ElementLinearisation(RideModel(params, effects, seat)) if equivalent_linear else None
    dahl = lz is not None and lz.dahl is not None
    # per element (dampers FL..RR, leaves L, R, front springs FL, FR) its output's index
    # among the ``rows`` of the passes (with halves its left-hand twin's), and those of
    # the Dahl forces z_L, z_R (with halves the one of z_h, twice: z_L^2 = (z_s^2 +
    # z_a^2)/2)
    n_el = 8 if effects else 6
    modal: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    mean_square: Callable[..., np.ndarray]
    if halves:
        eh = _EffectHalves(lin, dahl)
        modal, mean_square = eh.modal, eh.mean_square
        twin, z_rows, rows = [j // 2 for j in range(n_el)], [4, 4], slice(2, 6 + dahl)
    else:
        modal, mean_square = _whole_modal(lin, bool(effects), dahl), _whole_mean_square
        twin, z_rows, rows = list(range(n_el)), [n_el, n_el + 1], slice(2, 2 + n_el + 2 * dahl)

    def sigma(m: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        ms = mean_square(m, rows, road, n_freq_iter, vehicle, False)
        e = ms[:, twin]
        sq = [e[:, 0:4, 1], e[:, 4:6, 0]]  # damper rates, leaf deflections
        if effects:
            z = np.zeros_like(sq[1])
            if dahl:
                z = ms[:, z_rows, 0] / (2.0 if halves else 1.0)
            sq += [e[:, 6:8, 0], e[:, 4:6, 1], z]  # front springs, leaf rates, Dahl
        return np.sqrt(np.concatenate(sq, axis=1))

    update: Callable[[Any, np.ndarray], int] | None = None
    if lz is None:
        r0 = np.hstack([lin.damper_mean, lin.leaf_static_rate])
    else:
        r0, tol_ = lz.initial(init_damping), 0.0 if tol is None else float(tol)

        def update(m: tuple[np.ndarray, np.ndarray], r: np.ndarray) -> int:
            return int(spectral_kernel.take_rates(lz.rates(sigma(m), r), r, tol_))

    stops = lz is not None and any(k is not None for end in lz.kappa for k in end)
    if stops:
        assert lz is not None
        lz.set_corners(corner_statistics(lin, lz, road, vehicle, n_freq_iter, halves))
    r, n_iter, m = _fixed_point(r0, update, modal, iterations, tol)
    ms = mean_square(m, slice(0, 2), road, n_freq, vehicle, True)
    if lz is not None and (stops or dahl):
        # the remainders' common terms, once: element RMS values, uniform road, direct
        sig, uniform, direct = sigma(m), _uniform_road(road, vehicle), _direct(lin)
        lin_ms, ms = ms, ms[..., :2]
        if stops:
            ms = ms + _stop_remainder(lin, lz, r, sig, uniform, direct)
        if dahl:
            leaf = eh.residues(m, 4) if halves else [(m[0], m[1][:, :, 6:8])]
            ms = ms + _dahl_remainder(lz, leaf, sig, uniform, direct)
        # the remainders' rates: taken in the linear part's proportion (same nu0)
        rate = lin_ms[..., 2] * ms[..., 0] / lin_ms[..., 0]
        ms = np.concatenate([ms, rate[..., None]], axis=-1)
    return _spectral_result(ms, r, n_iter, road.duration_s)


@functools.cache
def _remainder_lags() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The stops' remainder grids: the uniform frequencies (Hz) ``REMAINDER_STEP``
    apart up to ``REMAINDER_TOP``, the indices of the lags within ``REMAINDER_LAG``
    (of the periodic lag grid ``k/(2 REMAINDER_TOP)`` their inverse FFT gives, lag 0
    first) and there the Wk kernel ``(2/N) sum_f Wk(f)^2 cos(2 pi f tau)`` (ISO band,
    N the lag grid's points): a covariance function's Wk-weighted mean square is its
    sum against it (Parseval). Read-only, cached."""
    f = np.arange(0.0, REMAINDER_TOP + REMAINDER_STEP / 2, REMAINDER_STEP)
    nfft = 2 * (f.size - 1)
    k = np.arange(nfft)
    idx = np.flatnonzero(np.minimum(k, nfft - k) <= REMAINDER_LAG * 2 * REMAINDER_TOP)
    band = (f >= ISO_BAND[0]) & (f <= ISO_BAND[1])
    wk2 = np.where(band, weighting_magnitude(np.maximum(f, REMAINDER_STEP), "Wk") ** 2, 0.0)
    kern = (2.0 / nfft) * np.cos(2 * np.pi * np.outer(idx, np.arange(f.size)) / nfft) @ wk2
    for a in (f, idx, kern):
        a.flags.writeable = False
    return f, idx, kern


#: :func:`_uniform_road`'s cache
_UNIFORM_ROADS: IdentityCache[tuple[np.ndarray, ...]] = IdentityCache()


def _uniform_road(road: RandomRoad, vehicle: Minibus) -> tuple[np.ndarray, ...]:
    """The remainders' uniform grid (Hz) and lag indices (:func:`_remainder_lags`) and
    there the road's PSD Gq (its class band, zero outside), the rear wheels' delay
    factor and the tracks' coherency (:func:`road_terms`). Read-only, kept per road
    and vehicle object (and by value)."""
    return _UNIFORM_ROADS.get([road, vehicle], (), lambda: _uniform_road_values(road, vehicle))


@functools.lru_cache(maxsize=32)
def _uniform_road_values(road: RandomRoad, vehicle: Minibus) -> tuple[np.ndarray, ...]:
    """:func:`_uniform_road`, built (read-only)."""
    f, idx, _ = _remainder_lags()
    out = (f, idx, *_band_road(f, road, vehicle))
    for a in out:
        a.flags.writeable = False
    return out


def _band_road(f: np.ndarray, road: RandomRoad, vehicle: Minibus) -> tuple[np.ndarray, ...]:
    """:func:`road_terms` at frequencies f (Hz), Gq zero outside the road's class band."""
    lo, hi = road.speed * CLASS_BAND[0], min(road.speed * CLASS_BAND[1], road.sample_rate)
    gq, delay, rho = road_terms(np.maximum(f, lo), road, vehicle)
    return np.where((f >= lo) & (f <= hi), gq, 0.0), delay, rho


def corner_statistics(
    lin: RideModel,
    lz: ElementLinearisation,
    road: RandomRoad,
    vehicle: Minibus,
    n_freq: int,
    halves: bool,
) -> np.ndarray:
    """Per left-hand corner (front spring, rear leaf) of the plain linearised model
    ``lin`` (mean low-speed damping, static leaf rate): the tyre deflection's variance
    (m^2; road minus wheel, + compression), its covariance with the spring deflection
    (m^2) and the spring deflection's skewness (-), (n, 6) in that order, the front's
    column before the rear's. Variances over the road band on the ``n_freq``-point grid
    (:func:`frequency_grid`; the tyre deflection carries the road's whole band), the
    skewness on a uniform grid (``SKEW_STEP`` to ``REMAINDER_TOP``); modal sums of the
    whole model or with ``halves`` of its halves (:func:`_spectral_modal`).

    The skewness to second order (a Volterra perturbation): the dampers' and the leaf
    second stages' forces beyond their linear parts carry ``c_2 He_2(u)`` of their
    standardised velocity or deflection u (:meth:`ElementLinearisation.
    even_coefficients`); for jointly Gaussian first-order motion ``E[x^2 He_2(u)] =
    2 R^2``, so the deflection's third cumulant is ``6 sum c_2 int_0^inf h(tau)
    R(tau)^2 dtau`` with h the deflection's impulse response to that force and ``R(tau)
    = E[x(t) u(t - tau)]``, both by the inverse FFT of the uniform grid's spectra."""
    forms = _corner_forms(lin, halves)
    f, wq, _, gq, delay, rho, _ = _road_grid(road, n_freq, vehicle)
    var_t, cov = 0.0, 0.0
    for g, w in _corner_parts(forms, [0, 1, 2, 3], f, (gq, delay, rho), halves):
        var_t = var_t + (np.abs(g[:, :, 2:4]) ** 2).transpose(0, 2, 1) @ (w * wq)
        cov = cov + (g[:, :, 0:2] * g[:, :, 2:4].conj()).real.transpose(0, 2, 1) @ (w * wq)
    return np.hstack([var_t, cov, _corner_skewness(forms, lz, road, vehicle, halves)])


def _corner_forms(lin: RideModel, halves: bool) -> list[tuple[np.ndarray, np.ndarray]]:
    """Modal forms (:func:`modal_form`) of the plain linearised model ``lin``, whole or
    its two halves: inputs the road (axles or wheels), then unit forces in the dampers
    FL..RR and the leaves L, R (+ resisting compression); outputs x_F, x_R, the wheels
    FL, RL, the damper compressions FL..RR and the leaf deflections L, R."""
    nq, npos = lin.nq, lin.n_pos
    M, C, K, Kin, Cin = lin.linear_system()
    pos, vel = lin.E[:nq, :npos], lin.E[nq:, npos:]
    src = -np.hstack([vel[:, 0:4], pos[:, 2:4]])
    Co = np.vstack([pos[:, [0, 2]].T, np.eye(nq)[[3, 5]], vel[:, 0:4].T, pos[:, 2:4].T])
    forms = []
    for T, J, _ in _HALF_MAPS if halves else _WHOLE_MAP:
        m, c, k, kin, cin, co, fs = M, C, K, Kin, Cin, Co, src
        if T is not None:
            tt = T.T
            m, c, k, kin, cin = tt @ m @ T, tt @ c @ T, tt @ k @ T, tt @ kin @ J, tt @ cin @ J
            co, fs = Co @ T, tt @ src
        fs = np.broadcast_to(fs, (M.shape[0], *fs.shape))
        kin, cin = np.concatenate([kin, fs], -1), np.concatenate([cin, 0.0 * fs], -1)
        forms.append(modal_form(m, c, k, kin, cin, co))
    return forms


def _corner_parts(
    forms: list[tuple[np.ndarray, np.ndarray]],
    rows: list[int],
    f: np.ndarray,
    terms: tuple[np.ndarray, ...],
    halves: bool,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Independent components ``(g (n, Nf, len(rows)), weight (Nf,))`` of the outputs
    ``rows`` of :func:`_corner_forms` on the grid f (Hz) under the road (``terms``: its
    PSD, the rear wheels' delay factor and the tracks' coherency, :func:`road_terms`):
    their cross-spectra are ``sum g_i conj(g_j) weight``; rows 2, 3 (wheels) turned
    into tyre deflections (road minus wheel), 4-7 into velocities."""
    gq, delay, rho = terms
    rear = 1 if halves else 2  # the rear-left input's column
    out = []
    d = delay[None, :, None]
    for h, (lam, P) in enumerate(forms):
        G = modal_response(lam, P[:, :, rows, : P.shape[-1] - 6], f)
        for j, row in enumerate(rows):
            if row in (2, 3):
                G[:, :, j] *= -1.0
                G[:, :, j, 0 if row == 2 else rear] += 1.0
            elif 4 <= row < 8:
                G[:, :, j] *= 2j * np.pi * f[None, :, None]
        if halves:
            out.append((G[..., 0] + d * G[..., 1], 0.5 * gq * (1.0 + (1 - 2 * h) * rho)))
            continue
        out += [(g, gq) for g in _track_lines(G, delay, rho)]
    return out


def _corner_skewness(
    forms: list[tuple[np.ndarray, np.ndarray]],
    lz: ElementLinearisation,
    road: RandomRoad,
    vehicle: Minibus,
    halves: bool,
) -> np.ndarray:
    """The left front spring's and rear leaf's deflection skewness (-, (n, 2)) to
    second order (:func:`corner_statistics`) on the uniform ``SKEW_STEP`` grid."""
    f = np.arange(0.0, REMAINDER_TOP + SKEW_STEP / 2, SKEW_STEP)
    terms = _band_road(f, road, vehicle)
    nt, df = 2 * (f.size - 1), SKEW_STEP
    var, Sxd = np.zeros(()), np.zeros(())  # sums over the parts
    for g, w in _corner_parts(forms, [0, 1, *range(4, 10)], f, terms, halves):
        var = var + (np.abs(g) ** 2).transpose(0, 2, 1) @ (w * df)
        Sxd = Sxd + g[:, :, :2, None] * g[:, :, None, 2:].conj() * w[None, :, None, None]
    sd = np.sqrt(var[:, 2:8])
    R = np.fft.irfft(Sxd, nt, axis=1)[:, : nt // 2] * (0.5 * nt * df) / sd[:, None, None, :]
    H = sum(modal_response(lam, P[:, :, 0:2, P.shape[-1] - 6 :], f) for lam, P in forms)
    h = np.fft.irfft(H, nt, axis=1)[:, : nt // 2]
    c2 = lz.even_coefficients(sd[:, 0:4], sd[:, 4:6])
    k3 = 6.0 * np.einsum("nj,npj->np", c2, (h * R * R).sum(1))  # h dtau = irfft(H) here
    return k3 / var[:, 0:2] ** 1.5


def _deflection_correlations(
    lin: RideModel, r: np.ndarray, dahl: bool, uniform: tuple[np.ndarray, ...]
) -> np.ndarray:
    """Correlation functions ``rho_ij(tau)`` (n, 6, lags) of the spring deflections FL,
    FR, RL, RR (the pairs of ``_DISTINCT``; ``E[d_i(t) d_j(t + tau)]`` over their RMS
    values, at the lags of :func:`_remainder_lags`) of the linear model with the rates
    ``r`` under the road (its class band; ``uniform``: :func:`_uniform_road`): their
    cross-spectra on the uniform grid, back by the inverse FFT."""
    f, idx, gq, delay, rho = uniform
    nq = lin.nq
    M, C, K, Kin, Cin = lin.linear_system(r[:, DAMPER], r[:, LEAF], r[:, FRONT])
    springs = lin.E[:nq, 0:4].T
    hyst = (springs[2:4], r[:, DAHL_C], r[:, DAHL_K]) if dahl else None
    G = modal_response(*modal_form(M, C, K, Kin, Cin, springs, hyst), f)[:, :, :4]
    S = _track_cross_spectra(G, delay, rho, _DISTINCT) * gq
    R = np.fft.irfft(S, axis=2)[:, :, idx]
    sd = np.sqrt(R[:, [0, 0, 0, 0, 4, 4], 0] * R[:, [0, 0, 4, 4, 4, 4], 0])  # times a constant
    return R / sd[:, :, None]


def _track_cross_spectra(
    G: np.ndarray, delay: np.ndarray, rho: np.ndarray, pairs: tuple[np.ndarray, np.ndarray]
) -> np.ndarray:
    """Cross-spectra (n, pairs, Nf) per unit road PSD of outputs with responses G (n,
    Nf, p, 4) per wheel input, for the output ``pairs`` (i, j): ``E[y_i conj(y_j)]``
    from the two tracks (:func:`_track_lines`)."""
    i, j = pairs
    cols = [c.transpose(0, 2, 1) for c in _track_lines(G, delay, rho)]
    return sum(c[:, j].conj() * c[:, i] for c in cols)


def _leaf_rate_correlations(
    modes: list[tuple[np.ndarray, np.ndarray]],
    uniform: tuple[np.ndarray, ...],
) -> np.ndarray:
    """Correlation functions (n, 6, lags; as :func:`_deflection_correlations`, only the
    rear pairs RL-RL and RL-RR set, the rest zero) of the rear leaf deflection rates of
    the linear model with the modal forms ``modes`` (poles, residues as
    :func:`modal_form`) of the leaves' outputs: of its halves (two forms, one output,
    the left leaf, axle inputs: :meth:`_EffectHalves.residues`; the right leaf is the
    symmetric half's part less the antisymmetric one's, whose inputs are uncorrelated
    with PSDs ``Gq (1 +- rho)/2``) or of the whole model (one form, outputs the left
    and right leaves, wheel inputs); their spectra times
    ``(2 pi f)^2`` on the uniform grid (``uniform``: :func:`_uniform_road`), back by the
    inverse FFT."""
    f, idx, gq, delay, rho = uniform
    if len(modes) == 2:
        parts = []
        for sign, (lam, P) in zip((1.0, -1.0), modes, strict=True):
            G = modal_response(lam, P, f)[:, :, 0]  # (n, Nf, 2)
            g = G[..., 0] + delay[None] * G[..., 1]
            parts.append(0.5 * (1.0 + sign * rho) * (g.real**2 + g.imag**2))
        S = np.stack([parts[0] + parts[1], parts[0] - parts[1]], axis=1)
    else:
        lam, P = modes[0]
        G = modal_response(lam, P, f)
        S = _track_cross_spectra(G, delay, rho, (np.array([0, 0]), np.array([0, 1])))
    R = np.fft.irfft(S * (gq * (2 * np.pi * f) ** 2), axis=2)[:, :, idx]
    out = np.zeros((R.shape[0], 6, idx.size))
    out[:, 4:6] = R / R[:, :1, :1]
    return out


def _mehler_mean_square(direct: np.ndarray, coef: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """Mean squares ((m/s^2)^2; (n, front/rear, weighted/unweighted)) of forces on the
    four springs acting through the mass matrix only, ``direct`` (n, 2, 4; m/s^2 per N
    at the measuring points), each force a Hermite series ``sum_n c_n He_n(u)`` of its
    spring's standardised process u with coefficients ``coef`` (``sqrt(n!) c_n``, N;
    (orders - 1, n, 4), n = 2, 3, ...) and the processes' correlation functions
    ``rho`` (:func:`_deflection_correlations`): the cross-covariances by Mehler's
    formula ``sum_n (sqrt(n!) c_n)(sqrt(n!) c_n') rho^n``, weighted: Wk in the ISO band
    (:func:`_remainder_lags`); unweighted: the whole variance."""
    kern = _remainder_lags()[2]
    # the springs and orders with a remainder (the others add nothing: skipped), the
    # pairs (i <= j) of those springs and the distinct pairs they share
    size = np.abs(coef)
    on, orders = size.max(axis=(0, 1)) > 0, np.flatnonzero(size.max(axis=(1, 2)) > 0)
    i, j = _PAIRS
    pairs = np.flatnonzero(on[i] & on[j])
    distinct, shared = np.unique(_SHARED[pairs], return_inverse=True)
    i, j = i[pairs], j[pairs]
    twice = np.where(i == j, 1.0, 2.0)  # pairs i < j stand for (i, j) and (j, i)
    # per order and distinct pair: the Wk-weighted sum over the lags and the lag-0
    # value of rho^n (n = order + 2)
    base = rho[:, distinct]
    top = orders[-1] + 2 if orders.size else 1
    power = np.cumprod(np.broadcast_to(base, (top, *base.shape)), axis=0)[1:][orders]
    sums = np.stack([power @ kern, power[..., 0]], axis=2)  # (orders, n, 2, distinct)
    dc = direct[None] * coef[orders, :, None, :]  # (orders, n, 2, 4): m/s^2 per unit term
    terms = dc[..., i] * dc[..., j] * twice
    return np.einsum("onpk,onwk->npw", terms, sums[..., shared])


def _direct(lin: RideModel) -> np.ndarray:
    """Accelerations at the measuring points front, rear (n, 2, 4; m/s^2 per N) of a
    force compressing each spring FL, FR, RL, RR, through the mass matrix alone."""
    M = lin.linear_system()[0]
    return _output_matrix(lin)[0:2] @ np.linalg.solve(M, -lin.E[: lin.nq, 0:4])


def _stop_remainder(
    lin: RideModel,
    lz: ElementLinearisation,
    r: np.ndarray,
    sig: np.ndarray,
    uniform: tuple[np.ndarray, ...],
    direct: np.ndarray,
) -> np.ndarray:
    """Mean squares ((m/s^2)^2; (n, front/rear, weighted/unweighted)) that the p = 1
    end stops' remainders ``F - E[F] - gain y`` add at the measuring points, the
    remainders acting through the mass matrix only (orthogonal to every state: their
    direct feedthrough ``M^-1``; with a seat they reach the body, not the seats).
    Their cross-covariances by Mehler's formula from the deflections' correlations
    (:func:`_deflection_correlations`) and the stops' Hermite coefficients at the
    deflections' means and RMS values of the element RMS values ``sig``
    (:meth:`ElementLinearisation.remainder_coefficients`); weighted: Wk in the ISO band
    (:func:`_remainder_lags`); unweighted: the whole variance. ``uniform``: the road on
    the uniform grid (:func:`_uniform_road`); ``direct``: :func:`_direct` of ``lin``."""
    rho = _deflection_correlations(lin, r, lz.dahl is not None, uniform)
    sd = np.hstack([sig[:, SIG_FRONT], sig[:, SIG_LEAF]])
    ends = (slice(0, 2), slice(2, 4))
    means = np.hstack([lz.spring_mean(e, sig[:, c], sd[:, c]) for e, c in enumerate(ends)])
    return _mehler_mean_square(direct, lz.remainder_coefficients(means, sd), rho)


def _dahl_remainder(
    lz: ElementLinearisation,
    modes: list[tuple[np.ndarray, np.ndarray]],
    sig: np.ndarray,
    uniform: tuple[np.ndarray, ...],
    direct: np.ndarray,
) -> np.ndarray:
    """Mean squares ((m/s^2)^2; (n, front/rear, weighted/unweighted)) that the Dahl
    forces' parts incoherent with the leaf motion add at the measuring points
    (:meth:`ElementLinearisation.dahl_remainder_coefficients`: the sign law's Hermite
    series in the leaf deflection rate, of the variance the law leaves beside the
    equivalent element), through the mass matrix only as the stops' remainders
    (:func:`_stop_remainder`), cross-covariances by Mehler's formula from the leaf
    deflection rates' correlations (:func:`_leaf_rate_correlations` of the leaves'
    modal forms ``modes``); none with the stops'
    remainders (at equal times the rate is uncorrelated with the deflection); ``uniform``
    and ``direct`` as there."""
    rho = _leaf_rate_correlations(modes, uniform)
    return _mehler_mean_square(direct, lz.dahl_remainder_coefficients(sig), rho)


def ride_spectral(
    X: np.ndarray,
    load_cases: Sequence[str] = LOAD_CASES,
    road: RandomRoad | None = None,
    vehicle: Minibus = REFERENCE_MINIBUS,
    seat: SeatMount | None = None,
    n_freq: int = 400,
    equivalent_linear: bool = True,
    iterations: int | None = None,
    tol: float | None = None,
    n_freq_iter: int = 150,
    init_damping: float = 0.85,
    split: bool = True,
    effects: Sequence[Effect] = (),
    params: Sequence[VehicleParams] | None = None,
) -> dict[str, np.ndarray]:
    """Ride RMS values by the exact spectral integral of the (equivalent-)linear model.

    ``a^2 = integral |W(f)|^2 Gq(f) [ |g_L + rho g_R|^2 + (1 - rho^2) |g_R|^2 ] df`` with
    Gq the ISO 8608 temporal PSD at the run's speed, rho the left/right coherency,
    ``g_L = H_FL + e^{-i 2 pi f L/v} H_RL`` (rear wheels on the front tracks L/v later;
    likewise g_R) and H the transfer functions of the linear state-space model from each
    wheel's road input to the output, ``H = C (i 2 pi f I - A)^-1 (B0 + i 2 pi f B1)``,
    evaluated by the batched modal expansion of A. Weighted values (``aw_*``) integrate
    over ISO 2631-1's 0.5-80 Hz with the analogue Wk (:func:`weighting_magnitude`), the
    unweighted (``rms_*``) over the whole road band, as :func:`record_objectives` does
    on a record.

    ``equivalent_linear``: the nonlinear elements (asymmetric digressive dampers, two-stage
    rear leaf) are replaced by their Gaussian equivalent-linear rates (statistical
    linearisation, Stein/Kazakov: ``c_eq = E[F'(v)]`` for a Gaussian element velocity or
    deflection of the RMS the linear model predicts, on an ``n_freq_iter``-point grid),
    iterated towards the fixed point from ``init_damping`` x the mean low-speed damping:
    ``tol=None`` (default) runs exactly ``iterations`` passes (``iterations - 1``
    updates; None: ``PASSES``, with effects ``PASSES_EFFECTS``) for every design, so
    the objectives are smooth functions of the design (no data-dependent stopping);
    with a number, each design stops when every rate's relative change is below
    ``tol`` (at most ``iterations`` passes). At the defaults the objectives lie within
    0.1 % of the exact fixed point on fine grids (tests).
    ``equivalent_linear=False``: the plain linearised model (mean low-speed damping,
    static leaf rate). Tyre lift-off is not modelled.

    ``effects`` (the ride model's, :data:`suspenv.models.minibus.ride_model.
    SUPPORTED_EFFECTS`): linear end stops (p = 1) through the non-Gaussian closure's
    gain and mean force, their impacts' remainder added through the mass matrix
    (:func:`_stop_remainder`), other stops and damper Coulomb friction through their
    Gaussian equivalent rates, the rear leaves' Dahl interleaf friction through Wen's
    equivalent-linear first-order element (one state per leaf; :mod:`suspenv.models.
    minibus.linearisation`) and its force's part incoherent with the leaf added as the
    stops' remainder is (:func:`_dahl_remainder`), all in the same fixed-point passes
    (by default 4 with leaf friction only, within 1e-3 of the fixed point, 8 with stops
    or damper friction, within 0.5 %; tests); the model's halves then carry one Dahl state
    each and take the compiled eigen-decomposition and modal sums (:class:`_EffectHalves`;
    with a seat or ``split=False`` the whole model's complex modal sums).

    ``split`` (default True; only without a seat): the mirror-symmetric model is
    evaluated as its decoupled symmetric (4-DOF) and antisymmetric (3-DOF) halves
    (:class:`_Halves`: one 8-state eigen-decomposition per half instead of one 14-state
    one, one combined input per axle and half, only the outputs each stage needs, real
    arithmetic in the frequency sums). The same integral as
    ``split=False``, the modal expansion of the whole model over every wheel input (the
    reference; always used with a seat, which breaks the symmetry): the values agree to
    round-off (tests: relative 1e-10).

    Crest factors and VDVs (``crest_*`` (-), ``vdv_*`` (m/s^1.75), the keys of
    :func:`record_objectives`): the expected values over the exposure ``road.duration_s``
    (s; the time method's record length) of a stationary Gaussian Wk-weighted
    acceleration with the weighted mean square and the mean square of its rate from the
    same integral (:func:`gaussian_dose`). The (equivalent-)linear model under a
    Gaussian road gives a Gaussian response; the nonlinear model's is close to it
    (docs/minibus.md: kurtosis 2.9-3.0 of 10 s records, 3.3 for the softest design's
    empty rear). With ``effects`` the Gaussian assumption leaves out how the nonlinear
    forces shape the tails beyond their mean square: interleaf friction clips them
    (records' kurtosis 2.6-2.8, crest factors about 9 % below the Gaussian value, VDVs
    3 %), end stops that are reached add impacts (heavier tails); the remainders'
    spectra are taken in the linear part's proportion of rate to value (the same
    crossing rate). The closure's second-order skewness (:func:`corner_statistics`) is
    the spring deflections', not the acceleration's, and is not used here.

    Returns a dict with (n_rows,) arrays ``aw_front``, ``aw_rear``, ``rms_front``,
    ``rms_rear`` (m/s^2), the ``DOSE_KEYS``, ``ok`` for the load cases stacked in order,
    plus ``damper_c``
    (n_rows, 4; N s/m, FL, FR, RL, RR) and ``leaf_k`` (n_rows, 2; N/m, left, right), the
    rates used, and ``iterations`` (passes run, the most of any design). ``params``:
    :func:`stacked_vehicle_parameters` of X in ``load_cases``, if already at hand.
    """
    road = road or RandomRoad()
    X = np.atleast_2d(np.asarray(X, dtype=float))
    cases = [load_cases] if isinstance(load_cases, str) else list(load_cases)
    use_split = split and seat is None and not effects
    if iterations is None:
        slow = any(e.kind != "dahl_hysteresis" for e in effects)
        iterations = PASSES_EFFECTS if slow else PASSES
    if effects and not equivalent_linear:
        raise ValidationError("ride effects need equivalent_linear=True, but it is False")
    chunk: Callable[..., dict[str, np.ndarray]] = _spectral_split
    if not use_split:
        halves = bool(effects) and split and seat is None
        chunk = functools.partial(_spectral_modal, effects=tuple(effects), halves=halves)
    size = SPLIT_CHUNK if use_split else SPECTRAL_CHUNK
    if params is None:
        params = stacked_vehicle_parameters(X, cases, vehicle)
    args = (road, vehicle, seat, n_freq, equivalent_linear, iterations, tol)
    n = X.shape[0]
    if n <= size:
        return chunk(list(params), *args, n_freq_iter, init_damping)
    # chunks keep the (rows x frequencies x modes) work arrays in cache; a design's
    # numbers do not depend on its chunk (every operation is per design)
    parts = [
        chunk([p.take(slice(i, i + size)) for p in params], *args, n_freq_iter, init_damping)
        for i in range(0, n, size)
    ]
    nc = len(cases)
    out: dict[str, np.ndarray] = {}
    for key in parts[0]:
        if key == "iterations":
            out[key] = np.array(max(int(q[key]) for q in parts))
            continue
        out[key] = np.concatenate(
            [
                q[key][j * (q["ok"].size // nc) : (j + 1) * (q["ok"].size // nc)]
                for j in range(nc)
                for q in parts
            ]
        )
    return out


# ------------------------------------------------------------------ working space
def tyre_load_response(
    G_wheel: np.ndarray, f: np.ndarray, k_tyre: float, c_tyre: float, inputs: Sequence[int]
) -> np.ndarray:
    """Dynamic tyre loads (N per m of road input; + = more load) (n, Nf, p, m) from the
    wheel-centre displacement responses ``G_wheel`` (n, Nf, p, m) of wheels standing on
    road inputs ``inputs`` (p entries, input index per wheel): ``(k + i w c)(u_j - z_j)``,
    the tyre compression (road minus wheel) through the tyre's spring and damper."""
    Gt = -np.asarray(G_wheel, dtype=complex)
    for j, i in enumerate(inputs):
        Gt[:, :, j, i] += 1.0
    return Gt * (k_tyre + 2j * np.pi * np.asarray(f)[None, :, None, None] * c_tyre)


def working_space(
    X: np.ndarray,
    load_cases: Sequence[str] = LOAD_CASES,
    road: RandomRoad | None = None,
    vehicle: Minibus = REFERENCE_MINIBUS,
    damper_c: np.ndarray | None = None,
    leaf_k: np.ndarray | None = None,
    n_freq: int = 400,
) -> dict[str, np.ndarray]:
    """RMS suspension deflection and dynamic tyre load per axle by the spectral integral.

    Same model, road and grid as :func:`ride_spectral` (whose equivalent-linear rates
    ``damper_c`` (n_rows, 4) and ``leaf_k`` (n_rows, 2) it takes; computed when None).
    Returns (n_rows,) arrays for the load cases stacked in order:
    ``defl_front``/``defl_rear`` (m): RMS compression of the front spring (wheel centre
    minus body at the wheel) and of the rear leaf at its seat (axle minus body), the
    relative motion that uses up the travel to the bump stop; ``tyre_front``/
    ``tyre_rear`` (-): RMS dynamic tyre load over the static wheel load (sprung share
    plus unsprung weight). Left and right are equal (mirror-symmetric model and road
    statistics); the left side is computed.
    """
    road = road or RandomRoad()
    X = np.atleast_2d(np.asarray(X, dtype=float))
    cases = [load_cases] if isinstance(load_cases, str) else list(load_cases)
    if damper_c is None or leaf_k is None:
        sp = ride_spectral(X, cases, road, vehicle)
        damper_c, leaf_k = sp["damper_c"], sp["leaf_k"]
    params = stacked_vehicle_parameters(X, cases, vehicle)
    lin = RideModel(params, linear=True)
    nq = lin.nq
    Co = np.zeros((4, nq))
    Co[0], Co[1] = lin.E[:nq, 0], lin.E[:nq, 2]  # front spring FL, rear leaf L
    Co[2, 3] = Co[3, 5] = 1.0  # wheel centres FL, RL
    lam, P = modal_form(*lin.linear_system(damper_c, leaf_k), Co)
    f, wq, _, gq, delay, rho, _ = _road_grid(road, n_freq, vehicle)
    G = modal_response(lam, P, f)
    Gt = tyre_load_response(
        G[:, :, 2:4], f, vehicle.tyre_vertical_stiffness, vehicle.tyre_vertical_damping, (0, 2)
    )
    rms = np.sqrt(
        _output_psd(np.concatenate([G[:, :, :2], Gt], axis=2), f, gq, delay, rho, (0,) * 4) @ wq
    )
    static = np.concatenate(
        [
            np.column_stack(
                [
                    np.full(p.n, p.front_static_load + vehicle.unsprung_front * G_STD),
                    np.full(p.n, p.rear_static_load + vehicle.unsprung_rear * G_STD),
                ]
            )
            for p in params
        ]
    )
    return {
        "defl_front": rms[:, 0],
        "defl_rear": rms[:, 1],
        "tyre_front": rms[:, 2] / static[:, 0],
        "tyre_rear": rms[:, 3] / static[:, 1],
    }


def exceedance_probability(travel: float | np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Probability (-) that a zero-mean Gaussian response of RMS ``sigma`` reaches
    ``|x| >= travel`` at a given instant: ``2 (1 - Phi(travel / sigma))`` (both
    directions: bump stop and, at the same gap, rebound stop)."""
    return 2.0 * ndtr(-np.asarray(travel, dtype=float) / np.asarray(sigma, dtype=float))


def road_ride_consequence(
    spectrum: tuple[float, float],
    standard_gd0: float,
    measured: tuple[np.ndarray, float] | None = None,
    speed_kmh: float = 80.0,
    seeds: tuple[int, ...] = (0, 1, 2),
    duration_s: float = 10.0,
    sample_rate: float = 100.0,
) -> dict[str, Any]:
    """The ride consequence of a road spectrum: ISO 2631-1 Wk-weighted RMS vertical
    acceleration (m/s^2) of the reference minibus (study pick, no load) on ISO 8608
    roads of ``spectrum`` = (Gd(n0) m^3, w) vs roads of Gd(n0) ``standard_gd0`` and the
    standard's w = 2 (mean over ``seeds``), and on the ``measured`` profile (elevation
    m, spacing m) with both tracks in phase vs a w = 2 road in phase."""
    veh = REFERENCE_MINIBUS
    model = RideModel(vehicle_parameters(STUDY_PICK[None, :], "no_load", veh))
    v = speed_kmh / 3.6
    dt = 1.0 / sample_rate
    n_settle = int(sample_rate)
    n_rec = int(round(duration_s * sample_rate))
    n_steps = n_settle + n_rec
    dx = v * dt / 2.0
    length = 2 * n_rec * dx

    def aw(z: np.ndarray, zd: np.ndarray) -> tuple[float, float]:
        rec = model.simulate(z, zd, dt, discard=n_settle)
        return (
            float(weighted_rms_fft(rec.acc_front, sample_rate, "Wk")[0]),
            float(weighted_rms_fft(rec.acc_rear, sample_rate, "Wk")[0]),
        )

    out: dict[str, Any] = {"speed_kmh": speed_kmh, "seeds": list(seeds), "design": "study pick"}
    res: dict[str, list[tuple[float, float]]] = {"measured_spectrum": [], "standard": []}
    for s in seeds:
        for key, (gd0, w) in (("measured_spectrum", spectrum), ("standard", (standard_gd0, 2.0))):
            prof = generate_profile(length, dx, gd0, s, veh.track_front, waviness=w)
            res[key].append(aw(*profile_inputs(prof, v, 2 * n_steps + 1, n_settle, veh.wheelbase)))
    for key, vals in res.items():
        arr = np.array(vals)
        out[f"aw_front_{key}"] = float(arr[:, 0].mean())
        out[f"aw_rear_{key}"] = float(arr[:, 1].mean())
        out[f"aw_front_{key}_seed_std"] = float(arr[:, 0].std(ddof=1)) if len(arr) > 1 else 0.0
        out[f"aw_rear_{key}_seed_std"] = float(arr[:, 1].std(ddof=1)) if len(arr) > 1 else 0.0
    out["ratio_front"] = out["aw_front_measured_spectrum"] / out["aw_front_standard"]
    out["ratio_rear"] = out["aw_rear_measured_spectrum"] / out["aw_rear_standard"]
    if measured is None:
        return out
    z_m, dx_m = measured
    n_fit = int(np.floor((len(z_m) - 1) * dx_m / dx))
    if n_fit > 2 * (n_settle + 8):
        # the measured track resampled to the simulation's half-step grid, in phase on
        # both sides; periodic continuation is not needed (runs cover the profile)
        zm = np.interp(dx * np.arange(n_fit), dx_m * np.arange(len(z_m)), z_m)
        zm = zm - np.linspace(zm[0], zm[-1], zm.size)
        std_prof = generate_profile(
            n_fit * dx, dx, standard_gd0, seeds[0] if seeds else 0, None, waviness=2.0
        )
        n_run = min((n_fit - 1) // 2 - int(np.ceil(veh.wheelbase / dx)) - 2, 3 * n_steps)
        for key, track in (("measured_profile", zm), ("standard", std_prof.left)):
            front, rear = aw(*in_phase_inputs(track, dx, v, n_run, veh.wheelbase))
            out[f"aw_front_{key}_in_phase"] = front
            out[f"aw_rear_{key}_in_phase"] = rear
    return out
