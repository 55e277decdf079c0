"""The residual of the compliant McPherson axle, row by row (compiled with numba).

The one writing of the axle's equations in the product (:meth:`AxleSolver.residual
<suspenv.models.mcpherson.solver.AxleSolver.residual>` and its Jacobian call it; a joint
is edited here only). Checked against the plain-numpy element-by-element residual kept
in ``tests/mcpherson_reference.py`` (``tests/test_knc_residual_kernel.py``, at random
states off equilibrium, with and without bushing frames, placed effects, loads and rack
travel). For every row and side: the body-fixed vectors rotated, the bushing deflections
and loads (linear, through the bushing frames when oriented, plus the placed effects'
loads given by the caller), the tie rod, drop link and spring, the constraints times
``CSCALE`` (the tie rods from a rack that a compliant steering system lets move), the
tyre on the pad, the rig's wheel loads (through the pad at the loaded
contact point, or at the wheel centre), the strut friction (given by the caller), the
loads with their arms summed body by body, and the anti-roll bar's halves joined at its
middle. Frames, units and signs are the solver's (vehicle axes, x forward, y left, z up;
SI; rotation vectors in radians).

One row needs a few hundred floating-point operations, so a numpy form is
overhead-bound for the few rows of a single design; compiled, a row costs about a
microsecond. Without numba the same functions run as plain Python (slowly).
"""

from __future__ import annotations

import math

import numpy as np

from suspenv.core import compiled
from suspenv.models.mcpherson import rotation_kernel
from suspenv.models.mcpherson.rotation_kernel import _log, _series  # noqa: F401

#: numba is there: the compiled residual can run (compiled at the first call)
AVAILABLE = compiled.AVAILABLE

#: body of each rotated body-fixed vector (as ``solver.VEC_BODY``)
_VEC_BODY = np.array([0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 2, 2, 3, 3], np.int64)
#: the bodies whose rotation deflects a bushing: lower arm (both bushings), strut rod,
#: bar half (as ``solver.BUSH_BODY``; the compiled sweep's lock-up check reads it)
_BUSH_BODY = np.array([0, 0, 2, 3], np.int64)
#: the body whose load sum each of the 14 loads with an arm enters (``solver.LOAD_SUM``)
_LOAD_BODY = np.array([0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 2, 2, 3, 3], np.int64)


def _cross_add(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out += a x b`` for vectors (3,)."""
    out[0] += a[1] * b[2] - a[2] * b[1]
    out[1] += a[2] * b[0] - a[0] * b[2]
    out[2] += a[0] * b[1] - a[1] * b[0]


def _residual_row(
    rm: np.ndarray,
    Rm: np.ndarray,
    ls_all: np.ndarray,
    pad_m: np.ndarray,
    ext_m: np.ndarray,
    n_ext: int,
    rack_m: np.ndarray,
    has_rack: bool,
    extra_m: np.ndarray,
    has_extra: bool,
    pack: np.ndarray,
    d: int,
    off: np.ndarray,
    k_bar_shear: float,
    cscale: float,
    out: np.ndarray,
    work: tuple,
) -> None:
    """The residual (2, 33) of one row into ``out`` (``work``: scratch,
    :func:`_row_work`): positions ``rm`` (2, 4, 3) [m] and
    rotations ``Rm`` (2, 4, 3, 3) of both sides, multipliers ``ls_all`` (2, 9), pad
    heights ``pad_m`` (2,) [m], wheel loads ``ext_m`` (2, 6|9) (``n_ext`` columns, 0:
    none: force [N] and moment [N*m] at the loaded contact point, where the wheel
    plane's downward radius meets the pad plane, then a force [N] at the wheel centre),
    rack travel ``rack_m`` (2,) [m] (``has_rack``), the placed effects' loads
    ``extra_m`` (2, 25) (``has_extra``: columns 0-23 the loads (bushing, force xyz [N]
    then moment xyz [N*m]) that the four bushings exert against their deflection beyond
    the linear ones, vehicle axes; column 24 the strut friction force [N] along the tube
    axis, on the knuckle, opposite on the rod), design row ``d`` of ``pack``."""
    V, phi, rho, dC, Rbar, side = work[:6]
    _rotated(Rm, pack, d, off[0], V, phi, rho, Rbar)
    for a in range(3):  # the bar halves' middle points apart (side 0 minus side 1)
        dC[a] = rm[0, 3, a] + V[0, 15, a] - rm[1, 3, a] - V[1, 15, a]
    shift = _rack_shift(rm, V, ls_all, rack_m, has_rack, pack, d, off[4], off[5], off[14])
    for s in range(2):
        rr, Vs, ls, res = rm[s], V[s], ls_all[s], out[s]  # (each view made once)
        _bushing_loads(s, rr, Vs, phi[s], extra_m, has_extra, pack, d, off, side)
        _links(s, rr, Vs, ls, shift, rack_m, has_rack, pack, d, off, side)
        _constraints(s, rr, Vs, pack, d, off, cscale, side[5], res)
        _load_sums(s, rr, Vs, ls, pad_m, extra_m, has_extra, pack, d, off, k_bar_shear, dC,
                   rho, side, res)  # fmt: skip
        if n_ext:
            _rig_load(rr, pad_m[s], ext_m[s], n_ext, side[4], side[2], res)


def _row_work() -> tuple:
    """Scratch of :func:`_residual_row` (made once per loop, not per row): the rotated
    body-fixed vectors V (2, 16, 3), the rotation vectors of bodies 0, 2, 3 per side
    (2, 3, 3), that of the bar halves' relative rotation (3,), the bar halves' middle
    points apart (3,), a rotation (3, 3), per side the deflections x (bushing,
    translation/rotation, xyz), bushing loads f (bushing, force/moment, xyz), a
    3-vector, the loads F with an arm and their arms (14, 3), the link vectors D (3, 3)
    and the links' force per unit length k (3,); then zero stand-ins (2, 1) and (2,) for
    a row's absent inputs (:func:`_row_at`)."""
    side = (np.empty((4, 2, 3)), np.empty((4, 2, 3)), np.empty(3), np.empty((14, 3)),
            np.empty((14, 3)), np.empty((3, 3)), np.empty(3))  # fmt: skip
    return (np.empty((2, 16, 3)), np.empty((2, 3, 3)), np.empty(3), np.empty(3),
            np.empty((3, 3)), side, np.zeros((2, 1)), np.zeros(2))  # fmt: skip


def _rotated(
    Rm: np.ndarray,
    pack: np.ndarray,
    d: int,
    o_vec: int,
    V: np.ndarray,
    phi: np.ndarray,
    rho: np.ndarray,
    Rbar: np.ndarray,
) -> None:
    """The 16 body-fixed vectors rotated with their bodies into ``V`` (2, 16, 3) [m],
    the rotation vectors of bodies 0, 2, 3 into ``phi`` (2, 3, 3) [rad] and that of the
    bar halves' relative rotation into ``rho`` (3,) [rad] (``Rbar`` (3, 3) scratch)."""
    for s in range(2):
        for i in range(16):
            b = _VEC_BODY[i]
            w0 = pack[o_vec + 3 * i, s, d]
            w1 = pack[o_vec + 3 * i + 1, s, d]
            w2 = pack[o_vec + 3 * i + 2, s, d]
            Rb = Rm[s, b]
            for a in range(3):
                V[s, i, a] = Rb[a, 0] * w0 + Rb[a, 1] * w1 + Rb[a, 2] * w2
        _log(Rm[s, 0], phi[s, 0])
        _log(Rm[s, 2], phi[s, 1])
        _log(Rm[s, 3], phi[s, 2])
    for i in range(3):
        for j in range(3):
            Rbar[i, j] = (
                Rm[0, 3, i, 0] * Rm[1, 3, j, 0]
                + Rm[0, 3, i, 1] * Rm[1, 3, j, 1]
                + Rm[0, 3, i, 2] * Rm[1, 3, j, 2]
            )
    _log(Rbar, rho)


def _bushing_loads(s, rr, Vs, phi_s, extra_m, has_extra, pack, d, off, work) -> None:
    """Side ``s``'s bushing deflections (translation of the bushing point, rotation
    vector) into ``work[0]`` and their loads (linear, through the bushing frames when
    oriented, plus the placed effects' loads) into ``work[1]`` (4, 2, 3) [N, N*m]."""
    o_gr, o_K, o_Q = off[1], off[2], off[3]
    x, fs, xb = work[0], work[1], work[2]
    for a in range(3):
        x[0, 0, a] = rr[0, a] + Vs[0, a] - pack[o_gr + a, s, d]
        x[1, 0, a] = rr[0, a] + Vs[1, a] - pack[o_gr + 3 + a, s, d]
        x[2, 0, a] = rr[2, a] - pack[o_gr + 6 + a, s, d]
        x[3, 0, a] = rr[3, a] - pack[o_gr + 9 + a, s, d]
        x[0, 1, a] = phi_s[0, a]
        x[1, 1, a] = phi_s[0, a]
        x[2, 1, a] = phi_s[1, a]
        x[3, 1, a] = phi_s[2, a]
    for bb in range(4):
        for t in range(2):
            if o_Q < 0:
                for a in range(3):
                    fs[bb, t, a] = pack[o_K + 6 * bb + 3 * t + a, s, d] * x[bb, t, a]
            else:  # Q (K (Q^T x)) with the bushing frame Q
                q = o_Q + 9 * bb
                for a in range(3):
                    xb[a] = (
                        pack[q + a, s, d] * x[bb, t, 0]
                        + pack[q + 3 + a, s, d] * x[bb, t, 1]
                        + pack[q + 6 + a, s, d] * x[bb, t, 2]
                    ) * pack[o_K + 6 * bb + 3 * t + a, s, d]
                for a in range(3):
                    fs[bb, t, a] = (
                        pack[q + 3 * a, s, d] * xb[0]
                        + pack[q + 3 * a + 1, s, d] * xb[1]
                        + pack[q + 3 * a + 2, s, d] * xb[2]
                    )
        if has_extra:
            for t in range(2):
                for a in range(3):
                    fs[bb, t, a] += extra_m[s, 6 * bb + 3 * t + a]


def _links(s, rr, Vs, ls, shift, rack_m, has_rack, pack, d, off, work) -> None:
    """Side ``s``'s tie rod (from the rack point), drop link and spring: their vectors
    into ``work[5]`` (3, 3) [m] and forces per unit length into ``work[6]`` (3,) [N/m]."""
    o_tri, o_L, o_ks, o_Lf = off[4], off[5], off[8], off[9]
    D, k = work[5], work[6]
    for a in range(3):
        D[0, a] = rr[1, a] + Vs[4, a] - pack[o_tri + a, s, d]
        D[1, a] = rr[1, a] + Vs[5, a] - (rr[3, a] + Vs[14, a])
        D[2, a] = rr[1, a] + Vs[6, a] - (rr[2, a] + Vs[12, a])
    D[0, 1] -= shift
    if has_rack:
        D[0, 1] -= rack_m[s]
    DD2 = D[2, 0] * D[2, 0] + D[2, 1] * D[2, 1] + D[2, 2] * D[2, 2]
    k[0] = ls[7] / pack[o_L, s, d]
    k[1] = ls[8] / pack[o_L + 1, s, d]
    L = math.sqrt(DD2)
    k[2] = pack[o_ks, s, d] * (pack[o_Lf, s, d] - L) / L


def _constraints(s, rr, Vs, pack, d, off, cscale, D, res) -> None:
    """Side ``s``'s constraints times ``cscale`` into ``res[24:33]``: ball joint,
    cylindrical joint, tie rod and drop link lengths (link vectors ``D``, :func:`_links`)."""
    o_Lsq, o_L2 = off[6], off[7]
    for a in range(3):
        res[24 + a] = (rr[0, a] + Vs[2, a] - rr[1, a] - Vs[3, a]) * cscale
    c3 = c4 = c5 = c6 = 0.0
    for a in range(3):
        off_a = rr[2, a] - rr[1, a] - Vs[7, a]
        c3 += Vs[13, a] * Vs[8, a]
        c4 += Vs[13, a] * Vs[9, a]
        c5 += off_a * Vs[8, a]
        c6 += off_a * Vs[9, a]
    res[27], res[28], res[29], res[30] = c3 * cscale, c4 * cscale, c5 * cscale, c6 * cscale
    DD0 = D[0, 0] * D[0, 0] + D[0, 1] * D[0, 1] + D[0, 2] * D[0, 2]
    DD1 = D[1, 0] * D[1, 0] + D[1, 1] * D[1, 1] + D[1, 2] * D[1, 2]
    res[31] = (DD0 - pack[o_Lsq, s, d]) / pack[o_L2, s, d] * cscale
    res[32] = (DD1 - pack[o_Lsq + 1, s, d]) / pack[o_L2 + 1, s, d] * cscale


def _loads_with_arms(s, rr, Vs, ls, pad_m, zf, pack, d, off, k_bar_shear, dC, work) -> None:
    """Side ``s``'s 14 loads with an arm (LOAD_SUM order) into ``work[3]`` (14, 3) [N]
    and their arms into ``work[4]`` (14, 3) [m]: bushings 0-1, ball joint on the arm and
    the knuckle, tie rod, drop link, spring on the knuckle, cylindrical joint force
    (with the strut friction ``zf`` [N]) on the knuckle, tyre on the pad at the contact
    point (the wheel plane's downward radius), the joint's moment pair, spring and drop
    link on the rod and bar, the bar's shear at its middle."""
    o_Rw, o_kt = off[10], off[11]
    fs, F, arm, D, k = work[1], work[3], work[4], work[5], work[6]
    sz = Vs[11, 2]
    d0, d1, d2 = Vs[11, 0] * sz, Vs[11, 1] * sz, Vs[11, 2] * sz - 1.0
    scale = pack[o_Rw, s, d] / math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    d0, d1, d2 = d0 * scale, d1 * scale, d2 * scale
    fz = pack[o_kt, s, d] * (pad_m[s] - rr[1, 2] - d2)
    for a in range(3):
        u_a, v_a = Vs[8, a], Vs[9, a]
        F[0, a] = -fs[0, 0, a]
        F[1, a] = -fs[1, 0, a]
        F[2, a] = ls[a]
        F[3, a] = -ls[a]
        F[4, a] = k[0] * D[0, a]
        F[5, a] = k[1] * D[1, a]
        F[6, a] = k[2] * D[2, a]
        F[7, a] = zf * Vs[10, a] - (ls[5] * u_a + ls[6] * v_a)
        F[8, a] = 0.0
        F[10, a] = ls[3] * u_a + ls[4] * v_a
        F[9, a] = -F[10, a]
        F[11, a] = -F[6, a]
        F[12, a] = -F[5, a]
        F[13, a] = -k_bar_shear * dC[a] if s == 0 else k_bar_shear * dC[a]
        for i in range(7):
            arm[i, a] = Vs[i, a]
        arm[7, a] = rr[2, a] - rr[1, a]
        arm[9, a] = Vs[13, a]
        arm[10, a] = Vs[13, a]
        arm[11, a] = Vs[12, a]
        arm[12, a] = Vs[14, a]
        arm[13, a] = Vs[15, a]
    arm[8, 0], arm[8, 1], arm[8, 2] = d0, d1, d2
    F[8, 2] = fz


def _load_sums(s, rr, Vs, ls, pad_m, extra_m, has_extra, pack, d, off, k_bar_shear, dC,
               rho, work, res) -> None:  # fmt: skip
    """Side ``s``'s force and moment balances of the four bodies into ``res[0:24]``: the
    loads with their arms (:func:`_loads_with_arms`) summed body by body, then the
    forces and moments at the reference points: the cylindrical joint's moment pair is
    no force, bushing moments, wheel weight, the joint force (and friction) on the rod,
    bar twist."""
    o_W, o_kbr = off[12], off[13]
    fs, F, arm = work[1], work[3], work[4]
    zf = extra_m[s, 24] if has_extra else 0.0
    _loads_with_arms(s, rr, Vs, ls, pad_m, zf, pack, d, off, k_bar_shear, dC, work)
    for i in range(24):
        res[i] = 0.0
    for j in range(14):  # force, then moment arm x force (indexed: no views in the loop)
        bj = 6 * _LOAD_BODY[j]
        for a in range(3):
            res[bj + a] += F[j, a]
        res[bj + 3] += arm[j, 1] * F[j, 2] - arm[j, 2] * F[j, 1]
        res[bj + 4] += arm[j, 2] * F[j, 0] - arm[j, 0] * F[j, 2]
        res[bj + 5] += arm[j, 0] * F[j, 1] - arm[j, 1] * F[j, 0]
    for a in range(3):
        res[6 + a] += F[10, a]
        res[12 + a] -= F[10, a]
        res[3 + a] -= fs[0, 1, a] + fs[1, 1, a]
        res[12 + a] -= F[7, a]  # + f_cyl: the rod takes the joint force
        res[12 + a] -= fs[2, 0, a]
        res[15 + a] -= fs[2, 1, a]
        res[18 + a] -= fs[3, 0, a]
        res[21 + a] -= fs[3, 1, a]
        mc = pack[o_kbr + a, s, d] * rho[a]
        res[21 + a] += -mc if s == 0 else mc
    res[8] -= pack[o_W, s, d]


def _rig_load(rr, pad_s, e, n_ext, arm, xb, res) -> None:
    """The rig's wheel load ``e`` (6|9,) of one side added to its knuckle's balance
    ``res``: through the pad, at the loaded contact point (the wheel plane's downward
    radius ``arm[8]`` (3,) [m] stretched to the pad plane at height ``pad_s`` [m]), its
    moment about it, then (``n_ext == 9``) a force at the wheel centre; ``xb`` (3,)
    scratch."""
    g = (pad_s - rr[1, 2]) / arm[8, 2]
    xb[0], xb[1], xb[2] = arm[8, 0] * g, arm[8, 1] * g, arm[8, 2] * g
    for a in range(3):
        res[6 + a] += e[a]
        res[9 + a] += e[3 + a]
    _cross_add(xb, e[0:3], res[9:12])
    if n_ext == 9:
        for a in range(3):
            res[6 + a] += e[6 + a]


def _rack_shift(
    rm: np.ndarray,
    V: np.ndarray,
    lm: np.ndarray,
    rack_m: np.ndarray,
    has_rack: bool,
    pack: np.ndarray,
    d: int,
    o_tri: int,
    o_L: int,
    o_C: int,
) -> float:
    """The rack's travel [m] along +y under the net lateral force of both tie rods, of a
    compliant steering system (rack travel per newton ``C``, the pack's ``C_rack``: the
    rack mounts and the column in series; 0: rigid). Tie rod ``s`` pulls its rack end
    with ``k_s D_s`` (``k_s`` its multiplier per unit length, ``D_s`` knuckle end minus
    rack end), so the rack takes ``F = -sum k_s D_s,y`` and moves by ``C F``; with
    ``D_s,y = g_s - shift`` (``g_s`` the rack end's gap before it moves) this is solved in
    closed form: ``shift = -C sum k_s g_s / (1 - C sum k_s)``."""
    C = pack[o_C, 0, d] if o_C >= 0 else 0.0
    if C == 0.0:
        return 0.0
    num = 0.0
    den = 0.0
    for s in range(2):
        k_s = lm[s, 7] / pack[o_L, s, d]
        g = rm[s, 1, 1] + V[s, 4, 1] - pack[o_tri + 1, s, d]
        if has_rack:
            g -= rack_m[s]
        num += k_s * g
        den += k_s
    return -C * num / (1.0 - C * den)


def _residual(
    r: np.ndarray,
    R: np.ndarray,
    lam: np.ndarray,
    pad: np.ndarray,
    ext: np.ndarray,
    rack: np.ndarray,
    extra: np.ndarray,
    pack: np.ndarray,
    off: np.ndarray,
    k_bar_shear: float,
    cscale: float,
    out: np.ndarray,
) -> None:
    """Residual rows into ``out`` (M, 2, 33).

    ``r`` (M, 2, 4, 3) [m], ``R`` (M, 2, 4, 3, 3): positions and rotations of the four
    bodies of both sides; ``lam`` (L, 2, 9), ``pad`` (P, 2) [m], ``ext`` (E, 2, 6|9)
    [N, N*m] (E = 0: none), ``rack`` (K, 2) [m] (K = 0: none), ``extra`` (X, 2, 25) the
    placed effects' loads (X = 0: none; :func:`_residual_row`): row ``m`` reads entry
    ``m % L`` (and so on), as broadcasting over leading axes ending in the design rows
    does. ``pack`` (K, 2, n): the solver's per-design arrays
    (``AxleSolver._rl_pack``), row ``m`` reading design row ``m % n``; ``off``: the
    offsets of vec, ground, K, Q (-1: isotropic bushings), tri, L_links, L_links_sq,
    L_links_2, ks, L_free, Rw, kt, W, k_bar_rot in it.
    """
    work = _row_work()
    for m in range(r.shape[0]):
        _row_at(m, r[m], R[m], lam, pad, ext, rack, extra, pack, off, k_bar_shear, cscale, out[m],
                work)  # fmt: skip


def _row_at(
    m: int,
    rm: np.ndarray,
    Rm: np.ndarray,
    lam: np.ndarray,
    pad: np.ndarray,
    ext: np.ndarray,
    rack: np.ndarray,
    extra: np.ndarray,
    pack: np.ndarray,
    off: np.ndarray,
    k_bar_shear: float,
    cscale: float,
    out: np.ndarray,
    work: tuple,
) -> None:
    """:func:`_residual_row` of row ``m`` at the states ``rm``, ``Rm`` (its own, or
    perturbed), its inputs read from the arrays of :func:`_residual` (``work``:
    :func:`_row_work`, whose stand-ins take the place of absent inputs)."""
    n_ext = ext.shape[2] if ext.shape[0] else 0
    has_rack = rack.shape[0] > 0
    ext_m = ext[m % ext.shape[0]] if n_ext else work[6]
    rack_m = rack[m % rack.shape[0]] if has_rack else work[7]
    has_extra = extra.shape[0] > 0
    extra_m = extra[m % extra.shape[0]] if has_extra else work[6]
    _residual_row(
        rm, Rm, lam[m % lam.shape[0]], pad[m % pad.shape[0]], ext_m, n_ext, rack_m,
        has_rack, extra_m, has_extra, pack, m % pack.shape[2], off, k_bar_shear, cscale, out,
        work,
    )  # fmt: skip


def _jacobian(
    r: np.ndarray,
    R: np.ndarray,
    lam: np.ndarray,
    pad: np.ndarray,
    ext: np.ndarray,
    rack: np.ndarray,
    extra: np.ndarray,
    pack: np.ndarray,
    off: np.ndarray,
    k_bar_shear: float,
    cscale: float,
    h: float,
    turned: np.ndarray,
    moves: np.ndarray,
    move_start: np.ndarray,
    scatter: np.ndarray,
    scatter_start: np.ndarray,
    J: np.ndarray,
) -> None:
    """Forward-difference columns of the body coordinates into ``J`` (M, 66, 66).

    Inputs as :func:`_residual` (``extra``: loads held fixed while the coordinates
    move, so empty for an axle with placed effects, whose loads follow the
    deflections); ``h`` the step [m] or [rad]; ``turned`` (M, 2, 4, 3, 3, 3): every
    body's rotation turned by ``h`` about x, y, z (on the left; made by the caller with
    numpy, so that the perturbed states are those of the block Jacobian to the bit);
    perturbation ``p`` moves the coordinates ``moves[:, move_start[p]:move_start[p + 1]]``
    (side, body, axis; axes 3-5 are rotations) together and its difference quotients
    fill the entries ``scatter[:, scatter_start[p]:scatter_start[p + 1]]`` (side,
    residual row, Jacobian row, Jacobian column) (``solver._coloured_groups``). Other
    entries are left as they are (the caller's zeros and exact multiplier columns)."""
    work, moved = _row_work(), _moved_work()
    for m in range(r.shape[0]):
        _row_jacobian(
            m, r[m], R[m], turned[m], lam, pad, ext, rack, extra, pack, off, k_bar_shear,
            cscale, h, moves, move_start, scatter, scatter_start, J[m], work, moved,
        )  # fmt: skip


def _moved_work() -> tuple:
    """Scratch of :func:`_row_jacobian` (made once per loop, not per row): the row's
    residual (2, 33), a perturbed one (2, 33), and the perturbed positions (2, 4, 3) and
    rotations (2, 4, 3, 3)."""
    return np.empty((2, 33)), np.empty((2, 33)), np.empty((2, 4, 3)), np.empty((2, 4, 3, 3))


def _row_jacobian(
    m: int,
    rm: np.ndarray,
    Rm: np.ndarray,
    turned_m: np.ndarray,
    lam: np.ndarray,
    pad: np.ndarray,
    ext: np.ndarray,
    rack: np.ndarray,
    extra: np.ndarray,
    pack: np.ndarray,
    off: np.ndarray,
    k_bar_shear: float,
    cscale: float,
    h: float,
    moves: np.ndarray,
    move_start: np.ndarray,
    scatter: np.ndarray,
    scatter_start: np.ndarray,
    Jm: np.ndarray,
    work: tuple,
    moved: tuple,
) -> None:
    """The body-coordinate columns of row ``m``'s Jacobian into ``Jm`` (66, 66) (see
    :func:`_jacobian`; ``turned_m`` (2, 4, 3, 3, 3) its bodies turned by ``h``;
    ``work``: :func:`_row_work`; ``moved``: :func:`_moved_work`, whose first array is
    left holding the row's residual)."""
    base, res, rp, Rp = moved
    _row_at(m, rm, Rm, lam, pad, ext, rack, extra, pack, off, k_bar_shear, cscale, base, work)
    for p in range(move_start.size - 1):
        for i in range(2):  # element by element: no temporary arrays
            for j in range(4):
                for a in range(3):
                    rp[i, j, a] = rm[i, j, a]
                    for c in range(3):
                        Rp[i, j, a, c] = Rm[i, j, a, c]
        for q in range(move_start[p], move_start[p + 1]):
            s, b, k = moves[0, q], moves[1, q], moves[2, q]
            if k < 3:
                rp[s, b, k] += h
            else:
                for a in range(3):
                    for c in range(3):
                        Rp[s, b, a, c] = turned_m[s, b, k - 3, a, c]
        _row_at(m, rp, Rp, lam, pad, ext, rack, extra, pack, off, k_bar_shear, cscale, res, work)
        for q in range(scatter_start[p], scatter_start[p + 1]):
            s, row = scatter[0, q], scatter[1, q]
            Jm[scatter[2, q], scatter[3, q]] = (res[s, row] - base[s, row]) / h


#: the row's helpers, compiled with the loops that call them (here and in the sweep)
_ROW_HELPERS = (
    "_log", "_series", "_cross_add", "_rack_shift", "_residual_row", "_row_at", "_row_jacobian",
    "_rotated", "_bushing_loads", "_links", "_constraints", "_loads_with_arms",
    "_load_sums", "_rig_load", "_row_work", "_moved_work",
)  # fmt: skip
#: the helpers inlined into :func:`_residual_row` (no calls within a row: a row is
#: about a microsecond, of which the calls' reference counting was a fifth)
_ROW_INLINE = (
    *rotation_kernel.INLINE, "_cross_add", "_rack_shift", "_rotated", "_bushing_loads", "_links",
    "_constraints", "_loads_with_arms", "_load_sums", "_rig_load", "_row_work", "_moved_work",
)  # fmt: skip
#: the row, its reader and its Jacobian compiled without reference counting (their views
#: and scratch tuples cost no atomic increments; they allocate nothing: :func:`_row_work`
#: and :func:`_moved_work` are made by their callers)
_ROW_BARE = ("_residual_row", "_row_at", "_row_jacobian")
#: :func:`_residual` and :func:`_jacobian`, compiled at their first call (then loaded
#: from numba's cache)
residual = compiled.Lazy(globals(), _ROW_HELPERS, _residual, _ROW_INLINE, _ROW_BARE)
jacobian = compiled.Lazy(globals(), _ROW_HELPERS, _jacobian, _ROW_INLINE, _ROW_BARE)
