"""Compiled loops of the spectral ride method (numba), design by design.

For one design the numpy forms of a spectral ride pass are many small array calls;
these loops run the same arithmetic compiled:

- :func:`halves_matrix`: the first-order matrices of the ride model's two halves
  (:class:`suspenv.metrics.ride._Halves`) at given element rates;
- :func:`eigen`: their eigenvalues by the Francis double-shift QR iteration
  (:func:`_eigenvalues`, EISPACK's algorithm; LAPACK's for an 8x8 matrix costs
  several times more in its setup than in its arithmetic) and their eigenvectors at
  them, from the null vectors of 4x4 quadratic pencils;
- :func:`eig` (:func:`general_eigen`): the same eigenvalues and null-vector
  eigenvectors of any small real matrices (the handling's 4x4 linear systems), LAPACK
  (:func:`lapack_eig`) where they fail;
- :func:`modal_mean_square`: from the eigen-decomposition of those matrices, the
  real second-order modal terms (:func:`_modal_terms`; residues by Gaussian
  elimination instead of LAPACK's solve) and their frequency sums (:func:`_mean_square`)
  to weighted mean squares (frequencies in rad/s, responses per m of axle input,
  weights as :func:`suspenv.metrics.ride._split_grid_values`); the sums run in another
  order than numpy's matrix products, so the values agree to rounding
  (``tests/test_ride_spectral.py``: split path against the full model);
- :func:`damper_leaf_rates`: the equivalent-linear damper and rear-leaf rates of
  :meth:`suspenv.models.minibus.linearisation.ElementLinearisation.rates` for a
  model without rear end stops (``tests/test_ride_effects_spectral.py``: against the
  numpy form). The standard normal CDF as scipy's ``ndtr`` (cephes) forms it;
- :func:`take_rates`: the fixed point's update rule (which designs take new rates);
- :func:`split_update`: one fixed-point update of the split path's rates, the three
  above fused.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from suspenv.core import compiled

#: the gufunc numpy.linalg.eig calls, reached without its per-call checks (None in a
#: numpy that moved it: the public route is taken)
_LAPACK_EIG: Any = getattr(getattr(np.linalg, "_umath_linalg", None), "eig", None)


def eig(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (..., m) and eigenvectors (..., m, m; unit 2-norm columns), complex,
    of the small real matrices ``A`` (..., m, m): the compiled :func:`general_eigen`
    (~1 us a 4x4 matrix; LAPACK's costs several times more in its setup) through
    :func:`decompose`. A matrix with a non-finite entry gives NaN, so that its design
    fails as non-finite."""
    m = A.shape[-1]
    w, v = decompose(general_eigen, np.ascontiguousarray(A, dtype=float).reshape(-1, m, m))
    return w.reshape(A.shape[:-1]), v.reshape(A.shape)


def decompose(loop: Any, A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (rows, m) and eigenvectors (rows, m, m), complex, of the contiguous
    stack ``A`` (rows, m, m) by the compiled ``loop`` (:func:`eigen` or
    :func:`general_eigen`), LAPACK's (:func:`lapack_eig`) for a matrix where it gives
    NaN: its QR iteration failed, or an eigenvalue's null space has more than one
    dimension (e.g. ``-I``)."""
    w = np.empty(A.shape[:2], dtype=complex)
    v = np.empty(A.shape, dtype=complex)
    loop(A, w, v)
    if np.isnan(np.vdot(v, v)):  # (one BLAS call: cheaper than a reduction)
        bad = np.isnan(v).any(axis=(1, 2))
        w[bad], v[bad] = lapack_eig(A[bad])
    return w, v


def lapack_eig(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (..., m) and eigenvectors (..., m, m), complex, of the real matrices
    ``A`` (..., m, m), the numbers of :func:`numpy.linalg.eig` without its checks and
    casts; NaN for a matrix with a non-finite entry (numpy raises for the whole stack)."""
    if _LAPACK_EIG is not None and np.isfinite(A.sum()):
        return _LAPACK_EIG(A, signature="d->DD")
    bad = ~np.isfinite(A).all(axis=(-2, -1))
    w, v = np.linalg.eig(np.where(bad[..., None, None], 0.0, A))
    w[bad], v[bad] = np.nan, np.nan
    return w, v


#: the unit round-off of float64 (negligible subdiagonal entries: below it relative to
#: their diagonal neighbours)
_EPS = 2.220446049250313e-16
#: most Francis double steps for one eigenvalue (as EISPACK's hqr)
_MAX_STEPS = 30


def _balance(a: np.ndarray) -> None:
    """``a`` (m, m) in place by a diagonal similarity of powers of 2 (exact: the same
    eigenvalues) that makes each row's and column's off-diagonal norms alike (EISPACK's
    ``balanc``)."""
    m = a.shape[0]
    done = False
    while not done:
        done = True
        for i in range(m):
            c, r = 0.0, 0.0
            for j in range(m):
                if j != i:
                    c += abs(a[j, i])
                    r += abs(a[i, j])
            if c == 0.0 or r == 0.0:
                continue
            s, f = c + r, 1.0
            while c < 0.5 * r:
                f, c = 2.0 * f, 4.0 * c
            while c > 2.0 * r:
                f, c = 0.5 * f, 0.25 * c
            if (c + r) / f < 0.95 * s:
                done = False
                for j in range(m):
                    a[i, j] /= f
                    a[j, i] *= f


def _hessenberg(a: np.ndarray) -> None:
    """``a`` (m, m) in place to upper Hessenberg form by stabilised elementary
    similarities (Gaussian elimination with row pivoting, EISPACK's ``elmhes``); the
    entries below the subdiagonal set to 0."""
    m = a.shape[0]
    for k in range(1, m - 1):
        piv, x = k, 0.0
        for i in range(k, m):
            if abs(a[i, k - 1]) > abs(x):
                piv, x = i, a[i, k - 1]
        if piv != k:
            for j in range(k - 1, m):
                a[piv, j], a[k, j] = a[k, j], a[piv, j]
            for i in range(m):
                a[i, piv], a[i, k] = a[i, k], a[i, piv]
        if x == 0.0:
            continue
        for i in range(k + 1, m):
            y = a[i, k - 1] / x
            a[i, k - 1] = 0.0
            if y != 0.0:
                for j in range(k, m):
                    a[i, j] -= y * a[k, j]
                for j in range(m):
                    a[j, k] += y * a[j, i]


def _small_subdiagonal(a: np.ndarray, hi: int, norm: float) -> int:
    """The lowest row ``l <= hi`` of the Hessenberg ``a`` whose subdiagonal entry is
    negligible (set to 0; 0 when none is): the active block is rows ``l .. hi``."""
    for l in range(hi, 0, -1):
        s = abs(a[l - 1, l - 1]) + abs(a[l, l])
        if abs(a[l, l - 1]) <= _EPS * (s if s != 0.0 else norm):
            a[l, l - 1] = 0.0
            return l
    return 0


def _francis_start(
    a: np.ndarray, lo: int, hi: int, x: float, y: float, w: float
) -> tuple[int, float, float, float]:
    """The row ``k`` where the double step with shifts of trace ``x + y`` and
    determinant ``x y - w`` starts (two consecutive small subdiagonal entries above it,
    else ``lo``) and the first column ``(p, q, r)`` of its shifted matrix, scaled."""
    k = hi - 2
    while True:
        z = a[k, k]
        r, s = x - z, y - z
        p = (r * s - w) / a[k + 1, k] + a[k, k + 1]
        q = a[k + 1, k + 1] - z - r - s
        r = a[k + 2, k + 1]
        s = abs(p) + abs(q) + abs(r)
        p, q, r = p / s, q / s, r / s
        if k == lo:
            return k, p, q, r
        u = abs(a[k, k - 1]) * (abs(q) + abs(r))
        v = abs(p) * (abs(a[k - 1, k - 1]) + abs(z) + abs(a[k + 1, k + 1]))
        if u <= _EPS * v:
            return k, p, q, r
        k -= 1


def _francis_step(a: np.ndarray, lo: int, hi: int, x: float, y: float, w: float) -> None:
    """One Francis double-shift QR step (Householder reflections of 3) on the active
    block ``lo .. hi`` of the Hessenberg ``a`` (eigenvalues only: the rows and columns
    outside the block are not updated), as EISPACK's ``hqr``."""
    m, p, q, r = _francis_start(a, lo, hi, x, y, w)
    for i in range(m + 2, hi + 1):
        a[i, i - 2] = 0.0
        if i != m + 2:
            a[i, i - 3] = 0.0
    for k in range(m, hi):
        if k != m:
            p, q = a[k, k - 1], a[k + 1, k - 1]
            r = a[k + 2, k - 1] if k + 1 != hi else 0.0
            x = abs(p) + abs(q) + abs(r)
            if x != 0.0:
                p, q, r = p / x, q / x, r / x
        s = math.copysign(math.sqrt(p * p + q * q + r * r), p)
        if s == 0.0:
            continue
        if k == m:
            if lo != m:
                a[k, k - 1] = -a[k, k - 1]
        else:
            a[k, k - 1] = -s * x
        p += s
        x, y, z = p / s, q / s, r / s
        q, r = q / p, r / p
        for j in range(k, hi + 1):
            p = a[k, j] + q * a[k + 1, j]
            if k + 1 != hi:
                p += r * a[k + 2, j]
                a[k + 2, j] -= p * z
            a[k + 1, j] -= p * y
            a[k, j] -= p * x
        for i in range(lo, min(hi, k + 3) + 1):
            p = x * a[i, k] + y * a[i, k + 1]
            if k + 1 != hi:
                p += z * a[i, k + 2]
                a[i, k + 2] -= p * r
            a[i, k + 1] -= p * q
            a[i, k] -= p


def _eigenvalues(a: np.ndarray, lam: np.ndarray) -> None:
    """Eigenvalues ``lam`` (m,) of the real matrix ``a`` (m, m; overwritten), conjugate
    pairs adjacent, positive imaginary part first (as LAPACK): balanced, reduced to
    Hessenberg form, then Francis double-shift QR (EISPACK's ``balanc``, ``elmhes``,
    ``hqr``; Wilkinson and Reinsch, *Handbook for Automatic Computation II*, 1971). NaN
    where an eigenvalue takes more than 30 double steps, or ``a`` has a non-finite
    entry."""
    m = a.shape[0]
    norm = 0.0
    for i in range(m):
        for j in range(m):
            norm += abs(a[i, j])
    if not norm < math.inf:
        lam[:] = np.nan
        return
    _balance(a)
    _hessenberg(a)
    hi, shift, steps = m - 1, 0.0, 0
    while hi >= 0:
        lo = _small_subdiagonal(a, hi, norm)
        x = a[hi, hi]
        if lo == hi:  # one real root
            lam[hi] = x + shift
            hi, steps = hi - 1, 0
            continue
        y, w = a[hi - 1, hi - 1], a[hi, hi - 1] * a[hi - 1, hi]
        if lo == hi - 1:  # a pair: real or complex conjugate
            p = 0.5 * (y - x)
            q = p * p + w
            z = math.sqrt(abs(q))
            x += shift
            if q >= 0.0:
                z = p + math.copysign(z, p)
                lam[hi - 1] = x + z
                lam[hi] = x + z
                if z != 0.0:
                    lam[hi] = x - w / z
            else:
                lam[hi - 1], lam[hi] = complex(x + p, z), complex(x + p, -z)
            hi, steps = hi - 2, 0
            continue
        if steps == _MAX_STEPS:
            lam[: hi + 1] = np.nan
            return
        if steps == 10 or steps == 20:  # exceptional shift
            shift += x
            for i in range(hi + 1):
                a[i, i] -= x
            s = abs(a[hi, hi - 1]) + abs(a[hi - 1, hi - 2])
            x = y = 0.75 * s
            w = -0.4375 * s * s
        steps += 1
        _francis_step(a, lo, hi, x, y, w)


def _null_vector(q: np.ndarray, perm: np.ndarray, x: np.ndarray) -> None:
    """``x`` (m,) with ``q x = 0`` for a singular ``q`` (m, m; overwritten) by Gaussian
    elimination with complete pivoting (pivots by ``|re| + |im|``): the last pivot, the
    smallest, taken as zero and its unknown as 1 (``perm`` (m,) int64 workspace); NaN
    when an earlier pivot is zero too."""
    m = q.shape[0]
    for k in range(m):
        perm[k] = k
    for k in range(m - 1):
        pi, pj, best = k, k, -1.0
        for i in range(k, m):
            for j in range(k, m):
                size = abs(q[i, j].real) + abs(q[i, j].imag)
                if size > best:
                    pi, pj, best = i, j, size
        if best == 0.0:  # a null space of more dimensions: no unique vector
            x[:] = np.nan
            return
        for c in range(m):
            q[k, c], q[pi, c] = q[pi, c], q[k, c]
        for i in range(m):
            q[i, k], q[i, pj] = q[i, pj], q[i, k]
        perm[k], perm[pj] = perm[pj], perm[k]
        for i in range(k + 1, m):
            f = q[i, k] / q[k, k]
            for c in range(k + 1, m):
                q[i, c] -= f * q[k, c]
    x[perm[m - 1]] = 1.0
    for k in range(m - 2, -1, -1):
        acc = 0j
        for j in range(k + 1, m):
            acc -= q[k, j] * x[perm[j]]
        x[perm[k]] = acc / q[k, k]


def _eigen(A: np.ndarray, lam: np.ndarray, V: np.ndarray) -> None:
    """Eigenvalues ``lam`` (rows, 2d; :func:`_eigenvalues`: conjugate pairs adjacent,
    NaN where the QR iteration fails) and eigenvectors ``V`` (rows, 2d, 2d; column k of
    unit 2-norm for ``lam[r, k]``) of the first-order matrices ``A`` (rows, 2d, 2d)
    whose upper right block is the identity (:func:`_halves_matrix`): ``v = [x; (lam I
    - P) x]`` with ``x`` the null vector (:func:`_null_vector`) of ``A21 + (A22 - lam
    I)(lam I - P) = (A21 - A22 P) + lam (A22 + P) - lam^2 I``, P, A21 and A22 the other
    blocks of A; the second eigenvalue of a pair takes the conjugate vector. A NaN
    eigenvalue gives a NaN vector."""
    rows, ns = lam.shape
    d = ns // 2
    a = np.empty((ns, ns))
    r0, r1 = np.empty((d, d)), np.empty((d, d))
    q = np.empty((d, d), dtype=np.complex128)
    x = np.empty(d, dtype=np.complex128)
    perm = np.empty(d, dtype=np.int64)
    for r in range(rows):
        a[:] = A[r]
        _eigenvalues(a, lam[r])
        for i in range(d):
            for j in range(d):
                acc = A[r, d + i, j]
                for c in range(d):
                    acc -= A[r, d + i, d + c] * A[r, c, j]
                r0[i, j], r1[i, j] = acc, A[r, d + i, d + j] + A[r, i, j]
        for k in range(ns):
            lk = lam[r, k]
            if k > 0 and lk.imag < 0 and lk == lam[r, k - 1].conjugate():
                for i in range(ns):
                    V[r, i, k] = V[r, i, k - 1].conjugate()
                continue
            for i in range(d):
                for j in range(d):
                    q[i, j] = r0[i, j] + lk * r1[i, j]
                q[i, i] -= lk * lk
            _null_vector(q, perm, x)
            norm = 0.0
            for i in range(d):
                y = lk * x[i]
                for c in range(d):
                    y -= A[r, i, c] * x[c]
                V[r, i, k], V[r, d + i, k] = x[i], y
                norm += x[i].real ** 2 + x[i].imag ** 2 + y.real**2 + y.imag**2
            scale = 1.0 / math.sqrt(norm)
            for i in range(ns):
                V[r, i, k] *= scale


def _general_eigen(A: np.ndarray, lam: np.ndarray, V: np.ndarray) -> None:
    """Eigenvalues ``lam`` (rows, m; :func:`_eigenvalues`) and eigenvectors ``V`` (rows,
    m, m; column k of unit 2-norm, the null vector (:func:`_null_vector`) of ``A -
    lam[r, k] I``; the second eigenvalue of a conjugate pair takes the conjugate
    vector) of the real matrices ``A`` (rows, m, m). NaN where the QR iteration fails,
    and NaN vectors where an eigenvalue's null space has more than one dimension
    (e.g. ``-I``: no unique vector)."""
    rows, m = lam.shape
    a = np.empty((m, m))
    q = np.empty((m, m), dtype=np.complex128)
    x = np.empty(m, dtype=np.complex128)
    perm = np.empty(m, dtype=np.int64)
    for r in range(rows):
        a[:] = A[r]
        _eigenvalues(a, lam[r])
        for k in range(m):
            lk = lam[r, k]
            if k > 0 and lk.imag < 0 and lk == lam[r, k - 1].conjugate():
                for i in range(m):
                    V[r, i, k] = V[r, i, k - 1].conjugate()
                continue
            for i in range(m):
                for j in range(m):
                    q[i, j] = A[r, i, j]
                q[i, i] -= lk
            _null_vector(q, perm, x)
            norm = 0.0
            for i in range(m):
                norm += x[i].real ** 2 + x[i].imag ** 2
            scale = 1.0 / math.sqrt(norm)
            for i in range(m):
                V[r, i, k] = scale * x[i]


def _mean_square(
    q0: np.ndarray,
    q1: np.ndarray,
    coef: np.ndarray,
    lo: int,
    w: np.ndarray,
    dr: np.ndarray,
    di: np.ndarray,
    wt: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out[i, o, j] = sum_h sum_f wt[f, h J + j] |g_o(f)|^2`` (n designs, p outputs,
    J weight columns per half) over the halves h of design i (rows 2 i + h of ``q0``,
    ``q1`` (2n, d) and ``coef`` (2n, 2, P, 2d) of :func:`_modal_terms`: inputs front and
    rear, outputs, the constant then the s terms; outputs ``lo .. lo + p - 1`` taken),
    with ``g = H_front + (dr + i di) H_rear`` and ``H_o = sum_k (coef[o, k] + s coef[o,
    d + k]) / (s^2 - q1[k] s + q0[k])`` at ``s = i w`` (w (Nf,) rad/s)."""
    rows, d = q0.shape
    p = out.shape[1]
    n_w, nf = out.shape[2], w.size
    # loops over the frequencies innermost (vectorised): E (d, Nf), then per output
    # the front and rear responses (Nf) accumulated mode by mode
    er, ei = np.empty((d, nf)), np.empty((d, nf))
    g0r, g0i, g1r, g1i = np.empty(nf), np.empty(nf), np.empty(nf), np.empty(nf)
    out[:] = 0.0
    for r in range(rows):
        i, off = r // 2, (r % 2) * n_w
        for k in range(d):
            for f in range(nf):
                # E = 1/(q0 - w^2 - i q1 w) = (q0 - w^2 + i q1 w)/den
                a, b = q0[r, k] - w[f] * w[f], q1[r, k] * w[f]
                inv = 1.0 / (a * a + b * b)
                er[k, f], ei[k, f] = a * inv, b * inv
        for o in range(p):
            g0r[:], g0i[:], g1r[:], g1i[:] = 0.0, 0.0, 0.0, 0.0
            for k in range(d):
                # H = E a + i w E b
                a0, b0 = coef[r, 0, lo + o, k], coef[r, 0, lo + o, d + k]
                a1, b1 = coef[r, 1, lo + o, k], coef[r, 1, lo + o, d + k]
                for f in range(nf):
                    e_r, e_i, wf = er[k, f], ei[k, f], w[f]
                    g0r[f] += a0 * e_r - b0 * wf * e_i
                    g0i[f] += a0 * e_i + b0 * wf * e_r
                    g1r[f] += a1 * e_r - b1 * wf * e_i
                    g1i[f] += a1 * e_i + b1 * wf * e_r
            for f in range(nf):
                gr = g0r[f] + dr[f] * g1r[f] - di[f] * g1i[f]
                gi = g0i[f] + dr[f] * g1i[f] + di[f] * g1r[f]
                g2 = gr * gr + gi * gi
                for j in range(n_w):
                    out[i, o, j] += g2 * wt[f, off + j]


def _halves_matrix(
    A0: np.ndarray, minv: np.ndarray, D: np.ndarray, rates: np.ndarray, A: np.ndarray
) -> None:
    """First-order matrices ``A`` (2n, 2d, 2d) of the two halves of n designs (row 2 i +
    h: design i, half h): the constant part ``A0[h]`` (2, 2d, 2d) plus, in the rate
    rows (d .. 2d - 1), ``minv[2 i + h] @ sum_e rates[i, e] D[e, h]`` with ``minv``
    (2n, d, d) the halves' inverse mass matrices, ``D`` (n_el, 2, d, 2d) the element
    geometry (``rates @ D = -[K | C]``) and ``rates`` (n, n_el) the element rates."""
    d = minv.shape[1]
    kc = np.empty((d, 2 * d))
    for i in range(rates.shape[0]):
        for h in range(2):
            r = 2 * i + h
            kc[:] = 0.0
            for e in range(rates.shape[1]):
                for a in range(d):
                    for b in range(2 * d):
                        kc[a, b] += rates[i, e] * D[e, h, a, b]
            A[r] = A0[h]
            for a in range(d):
                for b in range(2 * d):
                    acc = 0.0
                    for c in range(d):
                        acc += minv[r, a, c] * kc[c, b]
                    A[r, d + a, b] += acc


def _modal_mean_square(
    lam: np.ndarray,
    V: np.ndarray,
    B: np.ndarray,
    co: np.ndarray,
    lo: int,
    w: np.ndarray,
    dr: np.ndarray,
    di: np.ndarray,
    wt: np.ndarray,
    out: np.ndarray,
) -> None:
    """:func:`_mean_square` of the outputs ``lo ..`` (``out`` (n, p, J)) of the modal
    terms (:func:`_modal_terms`) of the halves' poles ``lam`` (2n, 2d) and eigenvectors
    ``V`` (2n, 2d, 2d) with inputs ``B`` and outputs ``co``."""
    rows, ns = lam.shape
    d = ns // 2
    q0, q1 = np.empty((rows, d)), np.empty((rows, d))
    coef = np.empty((rows, 2, co.shape[1], ns))
    _modal_terms(lam, V, B, co, q0, q1, coef)
    _mean_square(q0, q1, coef, lo, w, dr, di, wt, out)


def _solve(a: np.ndarray, x: np.ndarray) -> None:
    """``x <- a^-1 x`` (a (m, m), x (m, c), complex) by Gaussian elimination with
    partial pivoting; ``a`` is overwritten."""
    m = a.shape[0]
    for k in range(m):
        piv = k
        for i in range(k + 1, m):
            if abs(a[i, k]) > abs(a[piv, k]):
                piv = i
        if piv != k:
            for c in range(m):
                a[k, c], a[piv, c] = a[piv, c], a[k, c]
            for c in range(x.shape[1]):
                x[k, c], x[piv, c] = x[piv, c], x[k, c]
        for i in range(k + 1, m):
            f = a[i, k] / a[k, k]
            for c in range(k + 1, m):
                a[i, c] -= f * a[k, c]
            for c in range(x.shape[1]):
                x[i, c] -= f * x[k, c]
    for k in range(m - 1, -1, -1):
        for c in range(x.shape[1]):
            acc = x[k, c]
            for i in range(k + 1, m):
                acc -= a[k, i] * x[i, c]
            x[k, c] = acc / a[k, k]


def _modal_terms(
    lam: np.ndarray,
    V: np.ndarray,
    B: np.ndarray,
    co: np.ndarray,
    q0: np.ndarray,
    q1: np.ndarray,
    coef: np.ndarray,
) -> None:
    """Real second-order modal terms (``q0``, ``q1`` (rows, d), ``coef`` (rows, 2, p,
    2d)) of the first-order systems with poles ``lam`` (rows, 2d), eigenvectors ``V``
    (rows, 2d, 2d), inputs ``B`` (rows, 2d, 4: the two inputs' displacement then rate
    columns) and outputs ``co`` (rows, p, d) of the displacements, as
    :meth:`suspenv.metrics.ride._Halves.modal` defines them: conjugate pairs kept
    next to each other as LAPACK returns them, real poles last, paired among
    themselves; residues ``R = V^-1 B`` by Gaussian elimination with partial pivoting.
    """
    rows, ns = lam.shape
    d, p = ns // 2, co.shape[1]
    order = np.empty(ns, dtype=np.int64)
    a = np.empty((ns, ns), dtype=np.complex128)
    x = np.empty((ns, 4), dtype=np.complex128)
    ab = np.empty((ns, 2, 2), dtype=np.complex128)
    for r in range(rows):
        m = 0
        for real in range(2):  # complex poles first, then real ones
            for k in range(ns):
                if (lam[r, k].imag == 0) == (real == 1):
                    order[m] = k
                    m += 1
        for i in range(ns):
            for k in range(ns):
                a[i, k] = V[r, i, order[k]]
            x[i] = B[r, i]
        _solve(a, x)
        for k in range(ns):
            lk, other = lam[r, order[k]], lam[r, order[k ^ 1]]
            for i in range(2):
                ab[k, 1, i] = x[k, i] + lk * x[k, 2 + i]
                ab[k, 0, i] = -other * ab[k, 1, i]
        for kk in range(d):
            l1, l2 = lam[r, order[2 * kk]], lam[r, order[2 * kk + 1]]
            q0[r, kk], q1[r, kk] = (l1 * l2).real, (l1 + l2).real
            for o in range(p):
                cv0, cv1 = 0j, 0j
                for j in range(d):
                    cv0 += co[r, o, j] * V[r, j, order[2 * kk]]
                    cv1 += co[r, o, j] * V[r, j, order[2 * kk + 1]]
                for c in range(2):
                    for i in range(2):
                        t = ab[2 * kk, c, i] * cv0 + ab[2 * kk + 1, c, i] * cv1
                        coef[r, i, o, c * d + kk] = t.real


def _ndtr(a: float) -> float:
    """Standard normal CDF (-), as cephes' ``ndtr``: erf near 0, erfc in the tails."""
    x = a * math.sqrt(0.5)
    if abs(x) < math.sqrt(0.5):
        return 0.5 + 0.5 * math.erf(x)
    y = 0.5 * math.erfc(abs(x))
    return 1.0 - y if x > 0 else y


def _excess(a: float) -> float:
    """``E[max(t - a, 0)]`` (-) for a standard normal t (as ``linearisation._excess``)."""
    return math.exp(-0.5 * a * a) / math.sqrt(2.0 * math.pi) - a * _ndtr(-a)


def _floor(x: float) -> float:
    """``x``, at least 1e-12 (NaN stays NaN, as numpy's ``maximum``)."""
    return 1e-12 if x < 1e-12 else x


def _damper_leaf_rates(
    sig: np.ndarray,
    damp: np.ndarray,
    knee: np.ndarray,
    leaf: np.ndarray,
    passes: int,
    out: np.ndarray,
) -> None:
    """Damper coefficients (N s/m) and rear leaf rates (N/m) into ``out`` (n, >= 6)
    from the RMS damper velocities (m/s) and leaf deflections (m) ``sig`` (n, >= 6;
    columns ``SIG_DAMPER``, ``SIG_LEAF`` of :mod:`suspenv.models.minibus.
    linearisation`, each taken at least 1e-12 by :func:`_floor`): ``damp`` (n, 4, 4)
    slopes (bump low, bump high, rebound low, rebound high) per damper, ``knee`` (4, 2)
    knees (bump, rebound > 0; m/s), ``leaf`` (n, 2, 3) per leaf (primary rate K_1
    (N/m), extra rate dk (N/m), knee e_k (m) from rest);
    the leaf's mean deflection by ``passes`` Newton steps (laws and steps of
    :class:`suspenv.models.minibus.linearisation.ElementLinearisation`)."""
    c0 = 1.0 / math.sqrt(2.0 * math.pi)
    for i in range(sig.shape[0]):
        for j in range(4):
            s = _floor(sig[i, j])
            pb, pr = _ndtr(knee[j, 0] / s), _ndtr(knee[j, 1] / s)
            bl, bh, rl, rh = damp[i, j, 0], damp[i, j, 1], damp[i, j, 2], damp[i, j, 3]
            out[i, j] = bl * (pb - 0.5) + bh * (1 - pb) + rl * (pr - 0.5) + rh * (1 - pr)
        for side in range(2):
            j = 2 + side
            s, d = _floor(sig[i, j]), _floor(sig[i, 4 + side])
            k1, dk, thr = leaf[i, side, 0], leaf[i, side, 1], leaf[i, side, 2]
            tb, tr = s * _excess(knee[j, 0] / s), s * _excess(knee[j, 1] / s)
            bump = damp[i, j, 0] * (s * c0 - tb) + damp[i, j, 1] * tb
            mean_force = bump - (damp[i, j, 2] * (s * c0 - tr) + damp[i, j, 3] * tr)
            rhs = -mean_force + dk * max(-thr, 0.0)
            m = (rhs - dk * d * _excess(thr / d)) / k1
            for _ in range(passes):
                a = (thr - m) / d
                f = k1 * m + dk * d * _excess(a) - rhs
                m = m - f / (k1 + dk * (1.0 - _ndtr(a)))
            out[i, j + 2] = k1 + dk * (1.0 - _ndtr((thr - m) / d))


#: the flattened (output, displacement/velocity) mean square of :func:`_split_update`
#: behind each RMS value of :func:`_damper_leaf_rates` (dampers FL, FR: the FL damper's
#: velocity; RL, RR: the RL damper's; leaves L, R: the left leaf's deflection)
_SPLIT_SIGMA = (1, 1, 3, 3, 4, 4)


def _split_update(
    lam: np.ndarray,
    V: np.ndarray,
    B: np.ndarray,
    co: np.ndarray,
    w: np.ndarray,
    dr: np.ndarray,
    di: np.ndarray,
    wt: np.ndarray,
    damp: np.ndarray,
    knee: np.ndarray,
    leaf: np.ndarray,
    passes: int,
    tol: float,
    r: np.ndarray,
) -> int:
    """One update of the split path's equivalent-linear rates ``r`` (n, 6: dampers FL,
    FR, RL, RR (N s/m), leaves L, R (N/m)) in place; returns how many designs took new
    rates. From the halves' modes: the mean squares of the FL damper, the RL damper and
    the left leaf (outputs 2-4 of :func:`_modal_mean_square`, displacement and velocity
    weights ``wt``; the right-hand twins equal them), their RMS values (``_SPLIT_SIGMA``)
    and the rates at them (:func:`_damper_leaf_rates`), taken by :func:`_take_rates`."""
    n = r.shape[0]
    ms = np.empty((n, 3, 2))
    _modal_mean_square(lam, V, B, co, 2, w, dr, di, wt, ms)
    sig, new = np.empty((n, 6)), np.empty((n, 6))
    for i in range(n):
        for j in range(6):
            k = _SPLIT_SIGMA[j]
            sig[i, j] = math.sqrt(ms[i, k // 2, k % 2])
    _damper_leaf_rates(sig, damp, knee, leaf, passes, new)
    return _take_rates(new, r, tol)


def _take_rates(new: np.ndarray, r: np.ndarray, tol: float) -> int:
    """The fixed point's update rule: each design (row) of the rates ``r`` (n, k) takes
    its new rates ``new`` (n, k) where their largest relative change ``|new - r| /
    max(|r|, 1e-300)`` is >= ``tol`` (NaN: it keeps its rates; so a design's numbers
    never depend on the other designs of the batch); returns how many took them."""
    taken = 0
    for i in range(r.shape[0]):
        change, finite = 0.0, True
        for j in range(r.shape[1]):
            den = abs(r[i, j])
            c = abs(new[i, j] - r[i, j]) / (1e-300 if den < 1e-300 else den)
            if c != c:
                finite = False
            elif c > change:
                change = c
        if finite and change >= tol:
            taken += 1
            for j in range(r.shape[1]):
                r[i, j] = new[i, j]
    return taken


#: :func:`_halves_matrix`, :func:`_eigen`, :func:`_general_eigen`, :func:`_modal_mean_square`,
#: :func:`_damper_leaf_rates`,
#: :func:`_take_rates` and :func:`_split_update`, built ahead of time
#: (:mod:`suspenv.core.compiled`)
halves_matrix = compiled.Lazy(globals(), (), _halves_matrix)
_EIGEN_HELPERS = (
    "_balance", "_hessenberg", "_small_subdiagonal", "_francis_start", "_francis_step",
    "_eigenvalues", "_null_vector",
)  # fmt: skip
eigen = compiled.Lazy(globals(), _EIGEN_HELPERS, _eigen)
general_eigen = compiled.Lazy(globals(), _EIGEN_HELPERS, _general_eigen)
modal_mean_square = compiled.Lazy(
    globals(), ("_solve", "_modal_terms", "_mean_square"), _modal_mean_square
)
damper_leaf_rates = compiled.Lazy(globals(), ("_ndtr", "_excess", "_floor"), _damper_leaf_rates)
take_rates = compiled.Lazy(globals(), (), _take_rates)
split_update = compiled.Lazy(
    globals(),
    (
        "_solve", "_modal_terms", "_mean_square", "_modal_mean_square", "_ndtr", "_excess",
        "_floor", "_damper_leaf_rates", "_take_rates",
    ),
    _split_update,
)  # fmt: skip
