"""The rig's two-leg K&C sweep of a path-independent axle, design by design (numba).

One compiled call runs what :func:`suspenv.rigs.knc.run_tests` does for a model
without path-dependent or placed effects on its two-leg loop (``reuse_revisits``,
pads driven): for every design, the static equilibrium at the static pad heights
(Newton from the design position with a fresh Jacobian), then for every test its
bump leg (design -> bump) and rebound leg (design -> rebound) step by step: the
first step of each leg from the tangent predictor ``-J^-1 (res(input) -
res(previous input))`` at the static state, the second from the quadratic through
the other leg's first step, the static state and its own first step, the others from
the cubic through the leg's last four states (rotations through the relative rotation
vectors of consecutive states), each corrected by chord Newton steps with the static
Jacobian until a step shrinks by less than half, when the leg's row gets a Jacobian
of its own; steps damped when even fresh-Jacobian steps stop shrinking. The
equations, tolerances and rules are those of :meth:`AxleSolver.solve
<suspenv.models.mcpherson.solver.AxleSolver.solve>` (residual rows:
:func:`.residual_kernel._residual_row`; body columns of the Jacobian:
:func:`.residual_kernel._row_jacobian`; the multiplier columns by forward
differences of 1 N, both sides' together where no compliant rack couples them, as
:meth:`AxleSolver.jacobian`); the differences from the numpy path: the Jacobian
inverted by its two
sides' blocks and their Schur complement, each by Gauss-Jordan elimination (not
LAPACK), and held in single precision as the
numpy path's shared inverses (also the static one, which the numpy path holds in
double precision for the static solve), the secant of the residual as the
tangent predictor's load change, and multiply-adds fused outside the residual row
(:data:`sweep`). The converged states agree with the numpy path's
to the solver tolerance (``tests/test_knc_sweep_kernel.py``).

A design whose sweep fails anywhere (no static equilibrium, a step that does not
converge, a bushing over its lock-up limits at a leg's end) is flagged
(``status``); the rig then runs it through the numpy path, which retries in
sub-steps and words the failure. Frames, units and signs: the solver's.
"""

from __future__ import annotations

import math

import numpy as np

from suspenv.core import compiled
from suspenv.models.mcpherson.residual_kernel import (  # the row's helpers: compiled too
    _BUSH_BODY,
    _ROW_BARE,
    _ROW_HELPERS,
    _ROW_INLINE,
    _bushing_loads,  # noqa: F401
    _constraints,  # noqa: F401
    _cross_add,  # noqa: F401
    _links,  # noqa: F401
    _load_sums,  # noqa: F401
    _loads_with_arms,  # noqa: F401
    _moved_work,
    _rack_shift,  # noqa: F401
    _residual_row,
    _rig_load,  # noqa: F401
    _rotated,  # noqa: F401
    _row_at,  # noqa: F401
    _row_jacobian,
    _row_work,
)
from suspenv.models.mcpherson.rotation_kernel import _expm, _log, _relative, _series, _times  # noqa: F401

NS, NQ, NX = 33, 24, 66
#: the inverse Jacobian's rows padded to a whole number of vector registers (the step's
#: product vectorises without a remainder loop); the padding stays zero
NP = 80
#: the tie rod's multiplier (its force per unit length times its length [N]): the one a
#: compliant rack lets act on the other side (:func:`.residual_kernel._rack_shift`)
TIE_ROD = 7
#: status of a design: converged everywhere, or where it failed
OK, NO_STATIC, NO_STEP, LOCKED = 0, 1, 2, 3
#: the grid points' states a sweep holds at once (:func:`_slot`): the static state, the
#: legs' first steps and the last :data:`RING` states of the leg it walks
RING = 4
SLOTS = RING + 3


def _slot(g: int, i0: int) -> int:
    """The slot of grid point ``g`` in the grid arrays (:func:`_scratch`): the design
    position ``i0`` and its two neighbours (both legs start from them) each in its own,
    the others in turn in a ring of :data:`RING` (a step reads the last four states of
    its leg, :func:`_extrapolate`; the states to keep are written out as they are made,
    :func:`_keep`)."""
    return RING + 1 + g - i0 if abs(g - i0) <= 1 else g % RING


def _scratch(C: int, ext: bool, rack: bool) -> tuple:
    """The sweep's scratch (made once per call, not per design or step: the helpers it
    is passed to allocate nothing, and run without reference counting): a residual (2,
    33), a step (66,), the step's single-precision sum (80,), two (3, 3) and a (3,), the
    residual row's (:func:`.residual_kernel._row_work`), the transposed inverse
    Jacobians (66, 80) of the static state and of the bump and rebound legs' rows
    (single precision, the padding zero), a leg's relative rotation vectors (S, 2, 4, 3)
    with the slots they are made at (S,) (:func:`_relative_at`; S = :data:`SLOTS`), the
    Jacobian's (:func:`_factor_work`), a design's states (:func:`_state`: the static
    state and the one walking a leg, sharing the grid points' states (S, ...) by
    :func:`_slot` and the rig's input of a grid point, ``C`` wheel-load columns
    (``ext``) and rack travel (``rack``)), the static residual (2, 33) and the lock-up
    check's (2, 3) and (3,)."""
    S = SLOTS
    Gr, GR, Gl = np.empty((S, 2, 4, 3)), np.empty((S, 2, 4, 3, 3)), np.empty((S, 2, NS - NQ))
    load = (np.zeros((1, 2)), np.zeros((1 if ext else 0, 2, C)), np.zeros((1 if rack else 0, 2)))
    return (np.empty((2, NS)), np.empty(NX), np.empty(NP, np.float32), np.empty((3, 3)),
            np.empty((3, 3)), np.empty(3), _row_work(), np.zeros((3, NX, NP), np.float32),
            (np.empty((S, 2, 4, 3)), np.zeros(S, np.int64)), _factor_work(),
            _state(Gr, GR, Gl, load), _state(Gr, GR, Gl, load), np.empty((2, NS)),
            (np.empty((2, 3)), np.empty(3)))  # fmt: skip


def _state(Gr, GR, Gl, load) -> tuple:
    """A state of a design's sweep: positions (2, 4, 3), rotations (2, 4, 3, 3) and
    multipliers (1, 2, 9), with the grid points' states ``Gr``, ``GR``, ``Gl`` and the
    rig's input ``load`` it shares with the design's other state."""
    return np.empty((2, 4, 3)), np.empty((2, 4, 3, 3)), np.empty((1, 2, NS - NQ)), Gr, GR, Gl, load


def _factor_work() -> tuple:
    """Scratch of :func:`_factor`: the transposed Jacobian (66, 66), the bodies turned
    by the Jacobian's step (2, 4, 3, 3, 3), the body columns'
    (:func:`.residual_kernel._moved_work`), a residual (2, 33) and the block inverse's
    (:func:`_inverse_work`)."""
    return (np.empty((NX, NX)), np.empty((2, 4, 3, 3, 3)), _moved_work(), np.empty((2, NS)),
            _inverse_work())  # fmt: skip


def _inverse_work() -> tuple:
    """Scratch of :func:`_block_inverse`: the blocks P, S, X, Y (33, 33), the flags of
    X's columns and Y's rows (33,), and :func:`_invert`'s for 33 and 66 unknowns."""
    n = NS
    return (np.empty((n, n)), np.empty((n, n)), np.empty((n, n)), np.empty((n, n)),
            np.empty(n, np.bool_), np.empty(n, np.bool_), (np.empty(n), np.empty(n, np.int64)),
            (np.empty(NX), np.empty(NX, np.int64)))  # fmt: skip


def _factor(d, r, R, lam1, load, model, jac, out, ws) -> bool:
    """The inverse of the Jacobian (66, 66) of design ``d`` at ``r``, ``R``, ``lam1``
    under ``load``, transposed, into ``out[:, :66]`` (66, 80) (single precision, as the
    numpy path's shared inverses; ``ws``: :func:`_scratch`). False: the Jacobian is not
    finite or singular."""
    pad1, ext1, rack1 = load
    pack, off, k_bar_shear, cscale, extra0 = model
    h, exp_h, moves, move_start, scatter, scatter_start = jac
    JT, turned = ws[9][0], ws[9][1]
    for i in range(NX):
        for j in range(NX):
            JT[i, j] = 0.0
    for s in range(2):
        for b in range(4):
            for k in range(3):
                _times(exp_h[k], R[s, b], turned[s, b, k])
    _row_jacobian(
        d, r, R, turned, lam1, pad1, ext1, rack1, extra0, pack, off, k_bar_shear, cscale, h,
        moves, move_start, scatter, scatter_start, JT.T, ws[6], ws[9][2],
    )  # fmt: skip
    _multiplier_columns(d, r, R, lam1, load, model, JT, ws)
    if not _block_inverse(JT, ws[9][4]):
        return False
    for i in range(NX):
        for j in range(NX):
            out[i, j] = JT[i, j]
    return True


def _multiplier_columns(d, r, R, lam1, load, model, JT, ws) -> None:
    """The multiplier columns of the Jacobian (transposed, into the rows 24-32 and
    57-65 of ``JT``) by forward differences of 1 N from the residual the body columns
    left in ``ws[9][2][0]`` (:func:`.residual_kernel._row_jacobian`, at the same state);
    both sides' multiplier ``c`` moved together where the sides share it not (a side's
    residual reads its own multipliers only), the tie rods' (:data:`TIE_ROD`) each alone
    where a compliant rack couples them."""
    pack, off = model[0], model[1]
    base, res = ws[9][2][0], ws[9][3]
    rigid = off[14] < 0 or pack[off[14], 0, d] == 0.0
    for c in range(NS - NQ):
        together = rigid or c != TIE_ROD
        for s in range(1 if together else 2):
            kept = lam1[0, s, c], lam1[0, 1, c]
            lam1[0, s, c] += 1.0
            if together:
                lam1[0, 1, c] += 1.0
            _res(d, r, R, lam1, load, model, res, ws[6])
            lam1[0, s, c], lam1[0, 1, c] = kept
            for moved in range(2):
                for t in range(2):
                    if (t == moved) if together else (moved == s):
                        for row in range(NS):
                            JT[moved * NS + NQ + c, t * NS + row] = res[t, row] - base[t, row]


def _res(d, r, R, lam1, load, model, out, work) -> None:
    """The residual (2, 33) of design ``d`` at ``r``, ``R``, ``lam1`` under ``load``
    into ``out`` (:func:`.residual_kernel._residual_row`; ``model``: the pack, its
    offsets, the constants, then an empty stand-in for the placed effects' loads;
    ``work``: its scratch, with zero stand-ins for absent inputs)."""
    pad1, ext1, rack1 = load
    pack, off, k_bar_shear, cscale, _ = model
    n_ext = ext1.shape[2] if ext1.shape[0] else 0
    has_rack = rack1.shape[0] > 0
    _residual_row(
        r, R, lam1[0], pad1[0], ext1[0] if n_ext else work[6], n_ext,
        rack1[0] if has_rack else work[7], has_rack, work[6], False, pack, d, off, k_bar_shear,
        cscale, out, work,
    )  # fmt: skip


def _block_inverse(A: np.ndarray, ws: tuple) -> bool:
    """The matrix ``A`` (66, 66) replaced by its inverse in place, by its 33 x 33 blocks
    (a side's equations in a side's unknowns): ``P = A11^-1``, the Schur complement
    ``S = A22 - A21 P A12`` inverted, then ``[[P + X S^-1 Y, -X S^-1], [-S^-1 Y,
    S^-1]]`` with ``X = P A12``, ``Y = A21 P``. The sides are coupled by the anti-roll
    bar (and a compliant rack) only, so ``A12`` and ``A21`` are mostly zero and their
    zero rows and columns are skipped: about a third of the work of inverting ``A``
    whole. Where ``A11`` is singular (the whole may not be), ``A`` is inverted whole
    (:func:`_invert`). False: ``A`` is singular or not finite (``ws``:
    :func:`_inverse_work`)."""
    n = NS
    P, S, X, Y, cols, rows = ws[:6]
    _blocks(A, ws)
    if not _invert(P, ws[6]):
        return _invert(A, ws[7])
    _coupled(P, A[:n, n:], A[n:, :n], X, Y, S, cols, rows)
    if not _invert(S, ws[6]):
        return False
    _assemble(A, ws)
    return True


def _assemble(A: np.ndarray, ws: tuple) -> None:
    """The inverse of :func:`_block_inverse` into ``A`` from ``P = A11^-1``, ``S^-1``,
    ``X``, ``Y`` and their flags (``ws``: :func:`_inverse_work`)."""
    n = NS
    P, S, X, Y, cols, rows = ws[:6]
    for i in range(n):
        for j in range(n):
            A[i, j], A[i, n + j], A[n + i, j], A[n + i, n + j] = P[i, j], 0.0, 0.0, S[i, j]
    for c in range(n):
        if cols[c]:  # -X S^-1
            for i in range(n):
                for j in range(n):
                    A[i, n + j] -= X[i, c] * S[c, j]
        if rows[c]:  # -S^-1 Y
            for i in range(n):
                for j in range(n):
                    A[n + i, j] -= S[i, c] * Y[c, j]
    for c in range(n):  # P + X S^-1 Y = P - (-X S^-1) Y
        if rows[c]:
            for i in range(n):
                for j in range(n):
                    A[i, j] -= A[i, n + c] * Y[c, j]


def _blocks(A: np.ndarray, ws: tuple) -> None:
    """The diagonal blocks of ``A`` (66, 66) into ``P`` and ``S``, the products ``X``,
    ``Y`` and the flags of their columns and rows cleared (``ws``: :func:`_inverse_work`)."""
    n = NS
    P, S, X, Y, cols, rows = ws[:6]
    for i in range(n):
        cols[i] = rows[i] = False
        for j in range(n):
            P[i, j], S[i, j] = A[i, j], A[n + i, n + j]
            X[i, j] = Y[i, j] = 0.0


def _coupled(P, B, C, X, Y, S, cols, rows) -> None:
    """``X = P B``, ``Y = C P`` and ``S -= C X`` (each (33, 33)) over the non-zero
    entries of the coupling blocks ``B`` and ``C`` only (:func:`_block_inverse`),
    flagging ``X``'s non-zero columns in ``cols`` and ``Y``'s non-zero rows in
    ``rows``."""
    n = P.shape[0]
    for k in range(n):
        for c in range(n):
            if B[k, c] != 0.0:
                cols[c] = True
                for i in range(n):
                    X[i, c] += P[i, k] * B[k, c]
            if C[c, k] != 0.0:
                rows[c] = True
                for j in range(n):
                    Y[c, j] += C[c, k] * P[k, j]
    for i in range(n):
        for k in range(n):
            if C[i, k] != 0.0:
                for j in range(n):
                    S[i, j] -= C[i, k] * X[k, j]


def _invert(A: np.ndarray, ws: tuple) -> bool:
    """The matrix ``A`` (n, n) replaced by its inverse in place (Gauss-Jordan with
    partial pivoting; ``ws``: (n,) and (n,) int scratch); False when a pivot is zero
    or not finite."""
    row, perm = ws
    n = A.shape[0]
    for c in range(n):
        p, big = c, abs(A[c, c])
        for i in range(c + 1, n):
            if abs(A[i, c]) > big:
                p, big = i, abs(A[i, c])
        if not (big > 0.0 and big < math.inf):
            return False
        perm[c] = p
        if p != c:
            for j in range(n):
                A[c, j], A[p, j] = A[p, j], A[c, j]
        inv = 1.0 / A[c, c]
        A[c, c] = 1.0
        for j in range(n):
            A[c, j] *= inv
            row[j] = A[c, j]
        for i in range(n):
            f = A[i, c]
            if i != c and f != 0.0:
                A[i, c] = 0.0
                for j in range(n):
                    A[i, j] -= f * row[j]
    for c in range(n - 1, -1, -1):  # the row swaps undone on the columns
        p = perm[c]
        if p != c:
            for i in range(n):
                A[i, c], A[i, p] = A[i, p], A[i, c]
    return True


def _step(JiT: np.ndarray, res: np.ndarray, tol: np.ndarray, dx: np.ndarray, acc) -> float:
    """The Newton step ``dx = -J^-1 res`` (66,) from the transposed inverse Jacobian
    ``JiT`` (66, 80) (its rows added up in its single precision, which vectorises, as
    the numpy path's products with its shared single-precision inverses; ``acc`` (80,)
    single-precision scratch), and its size: the largest ``|dx| / tol`` (NaN when not
    finite)."""
    acc[:] = 0.0
    for s in range(2):
        for k in range(NS):
            c = np.float32(-res[s, k])
            j = s * NS + k
            for i in range(NP):
                acc[i] += c * JiT[j, i]
    size, finite = 0.0, True
    for i in range(NX):
        dx[i] = acc[i]
        q = abs(dx[i]) / tol[i]
        finite = finite and q < math.inf
        size = max(size, q)
    return size if finite else math.nan


def _apply(r, R, lam1, dx, f, ws) -> None:
    """Move the state by ``f dx`` in place (translations, left rotation increments,
    multipliers; :meth:`AxleSolver._apply`; ``ws``: :func:`_scratch`)."""
    E = ws[3]
    for s in range(2):
        for b in range(4):
            q = s * NS + 6 * b
            for k in range(3):
                r[s, b, k] += f * dx[q + k]
            _expm(f * dx[q + 3], f * dx[q + 4], f * dx[q + 5], E)
            _turn(E, R, R, s, b, s, b)
        for c in range(NS - NQ):
            lam1[0, s, c] += f * dx[s * NS + NQ + c]


def _newton(d, r, R, lam1, load, model, jac, chord, own, made, settings, fresh, ws):
    """Newton's method of :meth:`AxleSolver.solve` on one design's row, in place:
    chord steps with ``chord`` (66, 80) (a transposed inverse Jacobian,
    :func:`_factor`) until a step shrinks by less than half, from then on with the
    row's own ``own`` (66, 80; ``made``: it holds one already), refreshed whenever a
    step shrinks by less than half; damped when fresh steps stop shrinking.
    ``fresh``: ``chord`` is the Jacobian at the starting state; ``ws``:
    :func:`_scratch`. Returns (True when a step smaller than the tolerances was taken,
    ``own`` holds the row's own inverse)."""
    tol, maxit = settings[0], settings[1]
    res, dx, acc = ws[0], ws[1], ws[2]
    prev, alpha = math.inf, 1.0
    for _ in range(maxit):
        _res(d, r, R, lam1, load, model, res, ws[6])
        size = _step(own if made else chord, res, tol, dx, acc)
        if math.isnan(size):
            return False, made
        refresh = size > 0.5 * prev and not fresh
        if refresh:
            made = True
            if not _factor(d, r, R, lam1, load, model, jac, own, ws):
                return False, made
            size = _step(own, res, tol, dx, acc)
            if math.isnan(size):
                return False, made
        if fresh and size > 0.9 * prev:  # exact Newton cycles: damp
            alpha = max(0.5 * alpha, 1.0 / 64)
        fresh = refresh
        prev = size
        _apply(r, R, lam1, dx, 1.0 if size < 1.0 else alpha, ws)
        if size < 1.0:
            return True, made
    return False, made


def _load_at(t, g, pad0_d, pad_off, ext, rack, load) -> None:
    """The rig's input of test ``t`` at grid point ``g`` into ``load`` (pad heights
    (1, 2) [m], wheel loads (1|0, 2, C), rack travel (1|0, 2) [m])."""
    pad1, ext1, rack1 = load
    for s in range(2):
        pad1[0, s] = pad0_d[s] + pad_off[t, g, s]
        if rack1.shape[0]:
            rack1[0, s] = rack[t, g, s]
        if ext1.shape[0]:
            for c in range(ext1.shape[2]):
                ext1[0, s, c] = ext[t, g, s, c]


def _extrapolate(Gr, GR, Gl, rel, g, dirn, i0, cubic, r, R, lam1, ws) -> None:
    """The state at grid point ``g`` extrapolated from those at ``g - dirn``,
    ``g - 2 dirn``, ``g - 3 dirn`` (quadratic) and ``g - 4 dirn`` (``cubic``), the
    rotations through the relative rotation vectors of consecutive states
    (extrapolated one order lower; kept in ``rel`` for the next steps,
    :func:`_relative_at`), as the rig's predictor (``knc._extrapolate``; the grid
    arrays' slots by :func:`_slot` from the design position ``i0``; ``ws``:
    :func:`_scratch`)."""
    a, b = _slot(g - dirn, i0), _slot(g - 2 * dirn, i0)
    c, e = _slot(g - 3 * dirn, i0), _slot(g - 4 * dirn, i0)
    E, M, w = ws[3], ws[4], ws[5]
    w1, w0 = _relative_at(GR, rel, a, b, M), _relative_at(GR, rel, b, c, M)
    wm = _relative_at(GR, rel, c, e, M) if cubic else w0
    for s in range(2):
        for k in range(4):
            if cubic:
                for x in range(3):
                    r[s, k, x] = 4.0 * (Gr[a, s, k, x] + Gr[c, s, k, x]) - 6.0 * Gr[b, s, k, x]
                    r[s, k, x] -= Gr[e, s, k, x]
                    w[x] = 3.0 * (w1[s, k, x] - w0[s, k, x]) + wm[s, k, x]
            else:
                for x in range(3):
                    r[s, k, x] = 3.0 * (Gr[a, s, k, x] - Gr[b, s, k, x]) + Gr[c, s, k, x]
                    w[x] = 2.0 * w1[s, k, x] - w0[s, k, x]
            _expm(w[0], w[1], w[2], E)
            _turn(E, GR[a], R, s, k, s, k)
        for x in range(NS - NQ):
            if cubic:
                v = 4.0 * (Gl[a, s, x] + Gl[c, s, x]) - 6.0 * Gl[b, s, x] - Gl[e, s, x]
            else:
                v = 3.0 * (Gl[a, s, x] - Gl[b, s, x]) + Gl[c, s, x]
            lam1[0, s, x] = v


def _turn(E, A, out, s, b, s_out, b_out) -> None:
    """``out[s_out, b_out] = E @ A[s, b]`` for rotations ``E`` (3, 3) and ``A``, ``out``
    (2, 4, 3, 3) (indexed in place: no views; ``A`` may be ``out``)."""
    for j in range(3):
        m0 = E[0, 0] * A[s, b, 0, j] + E[0, 1] * A[s, b, 1, j] + E[0, 2] * A[s, b, 2, j]
        m1 = E[1, 0] * A[s, b, 0, j] + E[1, 1] * A[s, b, 1, j] + E[1, 2] * A[s, b, 2, j]
        m2 = E[2, 0] * A[s, b, 0, j] + E[2, 1] * A[s, b, 1, j] + E[2, 2] * A[s, b, 2, j]
        out[s_out, b_out, 0, j], out[s_out, b_out, 1, j], out[s_out, b_out, 2, j] = m0, m1, m2


def _relative_at(GR: np.ndarray, rel, x: int, y: int, M: np.ndarray) -> np.ndarray:
    """The rotation vectors (2, 4, 3) of ``GR[x] GR[y]^T`` body by body (slots ``x``
    and ``y``: consecutive states of a leg), from ``rel`` (vectors (S, 2, 4, 3), made
    (S,) by slot ``x``: :func:`_scratch`; a slot's flag cleared when the leg writes
    the slot) or computed and kept there (``M`` (3, 3) scratch)."""
    W, made = rel
    if not made[x]:
        for s in range(2):
            for k in range(4):
                _relative(GR[x, s, k], GR[y, s, k], M, W[x, s, k])
        made[x] = 1
    return W[x]


def _store(Gr, GR, Gl, g, r, R, lam1) -> None:
    """The state ``r``, ``R``, ``lam1`` into the grid arrays ``Gr``, ``GR``, ``Gl`` at
    grid point ``g`` (element by element: no temporary arrays)."""
    for s in range(2):
        for b in range(4):
            for a in range(3):
                Gr[g, s, b, a] = r[s, b, a]
                for c in range(3):
                    GR[g, s, b, a, c] = R[s, b, a, c]
        for x in range(NS - NQ):
            Gl[g, s, x] = lam1[0, s, x]


def _keep(keep, t: int, g: int, r, R, lam1) -> None:
    """The state ``r``, ``R``, ``lam1`` of test ``t`` at grid point ``g`` into the
    sweep's outputs where they keep it (``keep``: ``r_out``, ``R_out``, ``l_out`` of
    :func:`_sweep`, their first grid point ``lo`` and the design)."""
    r_out, R_out, l_out, lo, d = keep
    q = g - lo
    if 0 <= q < r_out.shape[1]:
        _store(r_out[t, q], R_out[t, q], l_out[t, q], d, r, R, lam1)


def _load(Gr, GR, Gl, g, r, R, lam1) -> None:
    """The state at grid point ``g`` of the grid arrays into ``r``, ``R``, ``lam1``
    (:func:`_store`'s converse)."""
    for s in range(2):
        for b in range(4):
            for a in range(3):
                r[s, b, a] = Gr[g, s, b, a]
                for c in range(3):
                    R[s, b, a, c] = GR[g, s, b, a, c]
        for x in range(NS - NQ):
            lam1[0, s, x] = Gl[g, s, x]


def _locked(d, r, R, pack, off, limits, ws) -> bool:
    """A bushing deflects beyond ``limits`` (translation [m], rotation [rad]) in its
    own frame (``knc._check_state``), or a deflection is not finite (``ws``:
    :func:`_scratch`)."""
    o_vec, o_gr, o_Q = off[0], off[1], off[3]
    x, xb = ws[13]
    for s in range(2):
        for bb in range(4):
            body = _BUSH_BODY[bb]
            _log(R[s, body], x[1])
            for a in range(3):
                x[0, a] = r[s, body, a] - pack[o_gr + 3 * bb + a, s, d]
                if bb < 2:  # the lower arm's bushes: their points on the arm
                    for j in range(3):
                        x[0, a] += R[s, 0, a, j] * pack[o_vec + 3 * bb + j, s, d]
            for t in range(2):
                if o_Q >= 0:  # into the bushing frame: Q^T x
                    q = o_Q + 9 * bb
                    for a in range(3):
                        xb[a] = (
                            pack[q + a, s, d] * x[t, 0]
                            + pack[q + 3 + a, s, d] * x[t, 1]
                            + pack[q + 6 + a, s, d] * x[t, 2]
                        )
                else:
                    for a in range(3):
                        xb[a] = x[t, a]
                for a in range(3):
                    if not abs(xb[a]) <= limits[t]:
                        return True
    return False


def _first_step(d, t, g, st, res0, inputs, model, jac, chord, own, settings, ws):
    """The first step of a leg, to grid point ``g``, from the static state ``st``
    (``res0`` its residual under the static input) by the tangent predictor, walked in
    ``ws[11]``; stored in the grid arrays of ``st`` and kept (:func:`_keep`; ``ws``:
    :func:`_scratch`). Returns (status, ``own`` holds the row's own inverse
    Jacobian)."""
    r, R, lam1, Gr, GR, Gl, load = st
    rs, Rs, ls = ws[11][:3]
    pad0_d, pad_off, ext, rack, keep = inputs
    i0 = (pad_off.shape[1] - 1) // 2
    res1, dx = ws[0], ws[1]
    _load_at(t, g, pad0_d, pad_off, ext, rack, load)
    _res(d, r, R, lam1, load, model, res1, ws[6])
    for s in range(2):
        for k in range(NS):
            res1[s, k] -= res0[s, k]
    _step(chord, res1, settings[0], dx, ws[2])
    for i in range(NX):
        if not abs(dx[i]) < math.inf:
            dx[i] = 0.0
    _load(Gr, GR, Gl, _slot(i0, i0), rs, Rs, ls)  # the static state
    _apply(rs, Rs, ls, dx, 1.0, ws)
    conv, made = _newton(d, rs, Rs, ls, load, model, jac, chord, own, False, settings, False, ws)
    _store(Gr, GR, Gl, _slot(g, i0), rs, Rs, ls)
    _keep(keep, t, g, rs, Rs, ls)
    return OK if conv else NO_STEP, made


def _leg(d, t, dirn, i0, st, inputs, model, jac, chord, own, made, settings, ws) -> int:
    """Steps 2 .. i0 of the leg of test ``t`` in direction ``dirn`` (its first step
    and the static state in the grid arrays of ``st`` already), each stored there and
    kept (:func:`_keep`; ``own``, ``made``: the row's own inverse Jacobian,
    :func:`_newton`; ``ws``: :func:`_scratch`); returns the design's status."""
    r, R, lam1, Gr, GR, Gl, load = st
    pad0_d, pad_off, ext, rack, keep = inputs
    rel = ws[8]
    for g in range(rel[1].size):
        rel[1][g] = 0
    for j in range(2, i0 + 1):
        g = i0 + dirn * j
        _extrapolate(Gr, GR, Gl, rel, g, dirn, i0, j >= 3, r, R, lam1, ws)
        _load_at(t, g, pad0_d, pad_off, ext, rack, load)
        conv, made = _newton(d, r, R, lam1, load, model, jac, chord, own, made, settings, False,
                             ws)  # fmt: skip
        if not conv:
            return NO_STEP
        x = _slot(g, i0)
        _store(Gr, GR, Gl, x, r, R, lam1)
        rel[1][x] = 0  # the slot's relative rotation is that of the state it held
        _keep(keep, t, g, r, R, lam1)
    if _locked(d, r, R, model[0], model[1], settings[2], ws):  # loads, deflections peak at the ends
        return LOCKED
    return OK


def _design(d, inputs, model, jac, settings, lo, out, ws) -> int:
    """The sweep of design ``d`` (:func:`_sweep`; ``model``'s pack its own column, (K, 2,
    1): read contiguously; ``ws``: :func:`_scratch`); returns its status."""
    ref0, pad0, pad_off, ext, rack = inputs
    r_out, R_out, l_out = out
    i0 = (pad_off.shape[1] - 1) // 2
    st, walk, res0 = ws[10], ws[11], ws[12]
    r, R, lam1, Gr, GR, Gl, load = st
    for s in range(2):  # the design position, no loads, the static pad heights
        for b in range(4):
            for a in range(3):
                r[s, b, a] = ref0[d, s, b, a]
                for c in range(3):
                    R[s, b, a, c] = 1.0 if a == c else 0.0
        for c in range(NS - NQ):
            lam1[0, s, c] = 0.0
        load[0][0, s] = pad0[d, s]
        for c in range(load[1].shape[2] if load[1].shape[0] else 0):
            load[1][0, s, c] = 0.0
        if load[2].shape[0]:
            load[2][0, s] = 0.0
    chord = ws[7][0]
    if not _factor(0, r, R, lam1, load, model, jac, chord, ws):
        return NO_STATIC
    conv, _ = _newton(0, r, R, lam1, load, model, jac, chord, chord, True, settings, True, ws)
    if not conv:
        return NO_STATIC
    leg_inputs = (pad0[d], pad_off, ext, rack, (r_out, R_out, l_out, lo, d))
    for t in range(pad_off.shape[0]):
        _store(Gr, GR, Gl, _slot(i0, i0), r, R, lam1)
        _keep(leg_inputs[4], t, i0, r, R, lam1)
        _load_at(t, i0, pad0[d], pad_off, ext, rack, load)
        _res(0, r, R, lam1, load, model, res0, ws[6])
        # the first steps of both legs (the second steps read both), then each leg on
        legs = (leg_inputs, model, jac, chord)
        up, made_up = _first_step(0, t, i0 + 1, st, res0, *legs, ws[7][1], settings, ws)
        down, made_down = _first_step(0, t, i0 - 1, st, res0, *legs, ws[7][2], settings, ws)
        if up != OK or down != OK:
            return NO_STEP
        for k, dirn, made in ((1, 1, made_up), (2, -1, made_down)):
            status = _leg(0, t, dirn, i0, walk, *legs, ws[7][k], made, settings, ws)
            if status != OK:
                return status
    return OK


def _sweep(
    pack: np.ndarray,
    off: np.ndarray,
    k_bar_shear: float,
    cscale: float,
    ref0: np.ndarray,
    pad0: np.ndarray,
    pad_off: np.ndarray,
    ext: np.ndarray,
    rack: np.ndarray,
    tol: np.ndarray,
    maxit: int,
    h: float,
    exp_h: np.ndarray,
    moves: np.ndarray,
    move_start: np.ndarray,
    scatter: np.ndarray,
    scatter_start: np.ndarray,
    limits: np.ndarray,
    lo: int,
    r_out: np.ndarray,
    R_out: np.ndarray,
    l_out: np.ndarray,
    status: np.ndarray,
) -> None:
    """The two-leg sweep of every design (module docstring).

    ``pack``, ``off``, ``k_bar_shear``, ``cscale``: the solver's per-design arrays and
    constants as :func:`.residual_kernel._residual` reads them (``pack`` (K, 2, n));
    ``ref0`` (n, 2, 4, 3) [m] the bodies' reference points at design, ``pad0`` (n, 2)
    [m] the static pad heights; per test and grid point (T, G): the pad offsets
    ``pad_off`` (T, G, 2) [m], wheel loads ``ext`` (T, G, 2, C) [N, N*m] ((0, 0, 2, 1):
    none) and rack travel ``rack`` (T, G, 2) [m] ((0, 0, 2): none); Newton's
    tolerance of each unknown ``tol`` (66,) and ``maxit``; the Jacobian's step ``h``,
    the rotations by ``h`` about x, y, z ``exp_h`` (3, 3, 3) and its colouring
    (``solver._KERNEL_COLOURING``); the lock-up ``limits`` (2,) [m, rad]. Writes the
    states at the grid points ``lo .. lo + Q - 1`` of every test into ``r_out`` (T, Q,
    n, 2, 4, 3), ``R_out`` (T, Q, n, 2, 4, 3, 3), ``l_out`` (T, Q, n, 2, 9) and every
    design's status (:data:`OK`, :data:`NO_STATIC`, :data:`NO_STEP`, :data:`LOCKED`)
    into ``status`` (n,)."""
    jac = (h, exp_h, moves, move_start, scatter, scatter_start)
    settings = (tol, maxit, limits)
    inputs = (ref0, pad0, pad_off, ext, rack)
    ws = _scratch(ext.shape[3], ext.shape[0] > 0, rack.shape[0] > 0)
    for d in range(ref0.shape[0]):
        own = np.ascontiguousarray(pack[:, :, d : d + 1])  # the design's column, contiguous
        model = (own, off, k_bar_shear, cscale, np.empty((0, 2, 1)))
        status[d] = _design(d, inputs, model, jac, settings, lo, (r_out, R_out, l_out), ws)


_HELPERS = (
    *_ROW_HELPERS, "_expm", "_slot", "_scratch", "_state", "_factor_work", "_inverse_work",
    "_factor", "_multiplier_columns", "_res", "_block_inverse", "_blocks", "_assemble",
    "_coupled", "_invert", "_step", "_apply", "_turn", "_times", "_newton", "_load_at",
    "_extrapolate", "_relative_at", "_relative", "_store", "_keep", "_load", "_locked",
    "_first_step", "_leg", "_design",
)  # fmt: skip
#: the helpers inlined into their callers: those of every step and every grid point
#: (Newton's method and the predictor too: a call passes every array of their scratch
#: tuples as a few hundred words on the stack)
_INLINE = (
    *_ROW_INLINE, "_slot", "_scratch", "_state", "_factor_work", "_inverse_work", "_res",
    "_step", "_apply", "_load_at", "_turn", "_relative_at", "_store", "_keep", "_load",
    "_newton", "_extrapolate", "_blocks", "_assemble",
)  # fmt: skip
#: the sweep's own helpers that the others are inlined into (the residual row is called)
_CALLED = ("_design", "_first_step", "_leg", "_factor", "_multiplier_columns",
           "_block_inverse", "_coupled", "_invert", "_locked")  # fmt: skip
#: the helpers below :func:`_sweep` compiled without reference counting (they allocate
#: no array: the scratch is made by :func:`_sweep`; counted, every array of the scratch
#: tuples passed to a helper cost an atomic increment and decrement, about a seventh of
#: the sweep)
_BARE = (*_ROW_BARE, *_CALLED)
#: :func:`_sweep`, built ahead of time or compiled at its first call; the sweep's own
#: helpers with fused multiply-adds (a step's single-precision product, the rotation
#: series, the inverse: about a tenth of the sweep; the states move by about 1e-12 m,
#: far inside the solver's tolerance), the residual row as the residual's loops have it
sweep = compiled.Lazy(globals(), _HELPERS, _sweep, _INLINE, _BARE, contract=_CALLED)
