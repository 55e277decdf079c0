"""The plain-numpy reference of the McPherson axle's residual (tests only).

The product computes the residual in one place, the compiled row loop
:mod:`suspenv.models.mcpherson.residual_kernel`. This module writes the same
equations a second way, element slot by element slot with numpy (19 load slots, each
element's force with its arm, summed per body; the placed effects' loads computed
from the bushing deflections here), and records every element load so that the balance
tests can sum them about the origin (:func:`body_loads`). It reads the solver's set-up
(the body-fixed vectors, stiffnesses and lengths; :class:`AxleSolver`) but none of its
residual arithmetic. Frames, units and signs: those of
:mod:`suspenv.models.mcpherson.solver`.
"""

from __future__ import annotations

import numpy as np

from suspenv.models.mcpherson.rotation import cross, dot, log_so3
from suspenv.models.mcpherson.solver import (
    BUSH_BODY,
    BUSH_ORDER,
    CSCALE,
    DAHL_EPS_TRANSLATION,
    NQ,
    VEC_BODY,
    AxleSolver,
    AxleState,
    dahl_step,
    wheel_down,
)

EY = np.array([0.0, 1.0, 0.0])  # the rack's direction of travel
#: body of each load slot (bushings, ball joint x2, tie rod, drop link x2, spring x2,
#: cylindrical joint x2, strut friction x2, tyre, wheel weight, external, bar)
SLOT_BODY = (0, 0, 2, 3, 0, 1, 1, 1, 3, 1, 2, 2, 1, 2, 1, 1, 1, 1, 3)
N_SLOTS = len(SLOT_BODY)
SLOT_SUM = np.zeros((4, N_SLOTS))
SLOT_SUM[list(SLOT_BODY), np.arange(N_SLOTS)] = 1.0
BUSH_SUM = np.zeros((4, 4))
BUSH_SUM[list(BUSH_BODY), np.arange(4)] = 1.0


def bushing_loads(solver: AxleSolver, x: np.ndarray, hist: dict) -> np.ndarray:
    """Generalised loads (..., 2, 4, 6) [N, N*m] that the bushings (``BUSH_ORDER``) exert
    *against* the vehicle-axes deflections ``x`` (..., 2, 4, 6) [m, rad], in vehicle
    axes: linear stiffness and the placed effects in each bushing's frame; ``hist``:
    the Dahl elements' history (bushing -> (deflection, force), bushing frame)."""
    xb = solver._to_bush(x)
    f = solver._K4 * xb
    for j, name in enumerate(BUSH_ORDER):
        extra = solver._cubic(name, xb[..., j, :])
        if name in hist:
            extra = extra + solver._dahl((name,), xb[..., j, None, :], hist)[..., 0, :]
        f[..., j, :] += extra
    return solver._to_vehicle(f)


def rack_give(solver: AxleSolver, lam: np.ndarray, gap: np.ndarray) -> np.ndarray:
    """The rack's travel (..., n) [m] along +y under the net lateral force of both tie
    rods, found by fixed-point iteration of ``shift = C F(shift)``: ``C`` the rack travel
    per newton (``solver.C_rack``), ``F = -sum_s k_s (gap_s - shift)`` the tie rods' net
    force on the rack (``k_s`` multiplier per unit length, ``gap`` (..., n, 2) the
    tie rods' y extent before the rack gives). The iteration contracts by ``C sum k``
    (about 1e-3 here) per pass; 60 passes reach round-off."""
    k = lam[..., 7] / solver.L_tie
    shift = np.zeros(gap.shape[:-1])
    for _ in range(60):
        shift = solver.C_rack * -(k * (gap - shift[..., None])).sum(axis=-1)
    return shift


def residual(
    solver: AxleSolver,
    r: np.ndarray,
    R: np.ndarray,
    lam: np.ndarray,
    pad: np.ndarray,
    state: AxleState,
    ext: np.ndarray | None = None,
    record: list | None = None,
    rack: np.ndarray | None = None,
) -> np.ndarray:
    """:meth:`AxleSolver.residual` element slot by element slot (19 load slots, every
    element's load with its arm, summed per body; the placed effects' loads computed
    here from the deflections), in numpy; ``record`` (a list) receives every element
    load as ``(body, point, force, moment)`` for balance checks."""
    lead = r.shape[:-2]
    # every body-fixed vector rotated by its own body's matrix, one product per vector
    V = np.matmul(R[..., VEC_BODY, :, :], solver._vec[..., None])[..., 0]  # (..., 16, 3)
    r0, r1, r2, r3 = r[..., 0, :], r[..., 1, :], r[..., 2, :], r[..., 3, :]
    arms = np.zeros(lead + (N_SLOTS, 3))
    forces = np.zeros(lead + (N_SLOTS, 3))
    M = np.zeros(lead + (4, 3))

    # the rotation vectors of the bushings' bodies and of the bar halves' relative
    # rotation, in one call (the same numbers as one call each: per matrix)
    R_bar = np.matmul(R[..., 0, 3, :, :], np.swapaxes(R[..., 1, 3, :, :], -1, -2))
    side = R.shape[:-4]
    # (bodies 0, 2, 3 of both sides; the lower arm holds two bushings)
    logs = log_so3(
        np.concatenate(
            [R[..., [0, 2, 3], :, :].reshape(side + (6, 3, 3)), R_bar[..., None, :, :]],
            axis=-3,
        )
    )
    phi = logs[..., :6, :].reshape(side + (2, 3, 3))[..., [0, 0, 1, 2], :]
    rho = logs[..., 6, :]

    # bushings (to the fixed body): slots 0-3
    f = bushing_loads(solver, solver._deflections(r, R, V[..., 0:2, :], phi), state.hyst)
    arms[..., 0:2, :] = V[..., 0:2, :]
    forces[..., 0:4, :] = -f[..., :3]
    M -= np.matmul(BUSH_SUM, f[..., 3:])

    # lower ball joint: slots 4-5
    lb = lam[..., 0:3]
    arms[..., 4, :], forces[..., 4, :] = V[..., 2, :], lb
    arms[..., 5, :], forces[..., 5, :] = V[..., 3, :], -lb

    # tie rod from the rack point (moved by the rack travel along +y and, with a
    # compliant steering system, by the rack's give under both tie rods' net force): slot 6
    tri = solver.tri if rack is None else solver.tri + rack[..., None] * EY
    d = r1 + V[..., 4, :] - tri
    d[..., 1] -= rack_give(solver, lam, d[..., 1])[..., None]
    arms[..., 6, :] = V[..., 4, :]
    forces[..., 6, :] = (lam[..., 7] / solver.L_tie)[..., None] * d
    c_tie = (dot(d, d) - solver.L_tie**2) / (2 * solver.L_tie)

    # drop link: slots 7-8
    d = r1 + V[..., 5, :] - r3 - V[..., 14, :]
    fd = (lam[..., 8] / solver.L_drop)[..., None] * d
    arms[..., 7, :], forces[..., 7, :] = V[..., 5, :], fd
    arms[..., 8, :], forces[..., 8, :] = V[..., 14, :], -fd
    c_drop = (dot(d, d) - solver.L_drop**2) / (2 * solver.L_drop)

    # coil spring between the seats: slots 9-10
    e = r1 + V[..., 6, :] - r2 - V[..., 12, :]
    L = np.sqrt(dot(e, e))
    fs = (solver.ks * (solver.L_free - L) / L)[..., None] * e
    arms[..., 9, :], forces[..., 9, :] = V[..., 6, :], fs
    arms[..., 10, :], forces[..., 10, :] = V[..., 12, :], -fs

    # cylindrical joint, rod in tube: slots 11-12 (-f on the knuckle at the rod point)
    w = r2 - r1 - V[..., 7, :]
    uv = V[..., 8:10, :]
    ar = V[..., 13, :]
    f_cyl = lam[..., 5, None] * V[..., 8, :] + lam[..., 6, None] * V[..., 9, :]
    m_rod = cross(ar, lam[..., 3, None] * V[..., 8, :] + lam[..., 4, None] * V[..., 9, :])
    forces[..., 11, :] = f_cyl
    arms[..., 12, :], forces[..., 12, :] = r2 - r1, -f_cyl
    M[..., 2, :] += m_rod
    M[..., 1, :] -= m_rod
    aw = np.empty(lead + (2, 3))  # rod axis and rod point offset, rows
    aw[..., 0, :], aw[..., 1, :] = ar, w
    c_cyl = np.swapaxes(np.matmul(uv, np.swapaxes(aw, -1, -2)), -1, -2).reshape(lead + (4,))

    # strut friction (Dahl) along the tube axis, rod against tube: slots 13-14
    if state.fric is not None:
        ak = V[..., 10, :]
        slide = dot(w, ak)
        s_prev, z_prev = (np.broadcast_to(q, slide.shape) for q in state.fric)
        f_c, sigma = solver._friction()
        zf = dahl_step(s_prev, slide, sigma, f_c, z_prev, DAHL_EPS_TRANSLATION)
        forces[..., 13, :] = -zf[..., None] * ak
        arms[..., 14, :], forces[..., 14, :] = r2 - r1, zf[..., None] * ak

    # tyre on the pad (slot 15), wheel weight (16), external wheel load (17)
    cp_arm = solver.Rw[..., None] * wheel_down(V[..., 11, :])
    arms[..., 15, :] = cp_arm
    forces[..., 15, 2] = solver.kt * (pad - r1[..., 2] - cp_arm[..., 2])
    forces[..., 16, 2] = -solver.wheel_weight
    if ext is not None:  # through the pad at the loaded contact point (on the pad plane)
        load_arm = cp_arm * ((pad - r1[..., 2]) / cp_arm[..., 2])[..., None]
        arms[..., 17, :], forces[..., 17, :] = load_arm, ext[..., :3]
        M[..., 1, :] += ext[..., 3:6]
        if ext.shape[-1] == 9:  # a force at the wheel centre: at the contact point
            forces[..., 17, :] += ext[..., 6:9]  # plus the moment (wc - cp) x f
            M[..., 1, :] -= cross(load_arm, ext[..., 6:9])

    # anti-roll bar: the halves meet at the bar's middle (slot 18); stiff in shear and
    # bending, the bar's torsional stiffness about the vehicle y axis
    dC = r3[..., 0, :] + V[..., 0, 15, :] - r3[..., 1, :] - V[..., 1, 15, :]
    fC = -solver.k_bar_shear * dC
    mC = -solver.k_bar_rot * rho
    arms[..., 18, :] = V[..., 15, :]
    forces[..., 0, 18, :], forces[..., 1, 18, :] = fC, -fC
    M[..., 0, 3, :] += mC
    M[..., 1, 3, :] -= mC

    if record is not None:
        for k, b in enumerate(SLOT_BODY):
            record.append((b, r[..., b, :] + arms[..., k, :], forces[..., k, :], 0.0 * r1))
        for b in range(4):
            record.append((b, r[..., b, :], 0.0 * r1, M[..., b, :]))

    Fb = np.matmul(SLOT_SUM, forces)
    Mb = M + np.matmul(SLOT_SUM, cross(arms, forces))
    cons = np.concatenate(
        [r0 + V[..., 2, :] - r1 - V[..., 3, :], c_cyl, c_tie[..., None], c_drop[..., None]],
        axis=-1,
    )
    return np.concatenate(
        [np.concatenate([Fb, Mb], axis=-1).reshape(lead + (NQ,)), CSCALE * cons], axis=-1
    )


def body_loads(
    solver: AxleSolver,
    st: AxleState,
    pad: np.ndarray,
    ext: np.ndarray | None = None,
    history=None,
    rack: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Net force [N] and moment about the global origin [N*m] on every body,
    (n, 2, 4, 3) each, summed from the element loads :func:`residual` records at
    state ``st`` (``history``: the state whose path-dependent element history to
    use, default ``st``; ``rack``: as in :meth:`residual`). Zero at an equilibrium:
    for balance checks."""
    loads: list = []
    hist = st if history is None else history
    residual(solver, st.r, st.R, st.lam, pad, hist, ext, loads, rack)
    F = np.zeros(st.r.shape[:-2] + (4, 3))
    M = np.zeros_like(F)
    for body, p, f, m in loads:
        p, f, m = np.broadcast_arrays(p, f, m)
        F[..., body, :] += f
        M[..., body, :] += cross(p, f) + m
    return F, M
