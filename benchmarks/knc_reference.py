"""Reference paths of the K&C evaluation kept for the speed benchmark's baseline and the
tests (not the product's): the finite-difference Jacobian of the axle's residual with
one perturbation per column.

Frames, units and signs: those of :mod:`suspenv.models.mcpherson.solver`.
"""

from __future__ import annotations

import numpy as np

import suspenv.models.mcpherson.solver as solver_module
from suspenv.models.mcpherson.rotation import expm_so3
from suspenv.models.mcpherson.solver import NQ, NS, AxleSolver, AxleState


def jacobian_by_columns(
    solver: AxleSolver,
    st: AxleState,
    pad: np.ndarray,
    ext: np.ndarray | None = None,
    h: float = 1e-7,
    rack: np.ndarray | None = None,
) -> np.ndarray:
    """:meth:`AxleSolver.jacobian` (n, 66, 66) with one forward difference per column
    (body coordinates by ``h`` [m] or [rad], multipliers by a 1 N step), the reference
    path: a drop-in for the method (``monkeypatch.setattr(AxleSolver, "jacobian",
    jacobian_by_columns)``)."""
    n = solver.n
    # the bar halves and the tie-rod multiplier (a compliant rack moves with both
    # tie rods) couple the sides: their columns one side at a time
    apart = [18 + k for k in range(6)] + [NQ + 7]
    shared = [j for j in range(NS) if j not in apart]  # 26 columns
    # perturbations: (column j, side) with side None for both sides at once
    cols: list[tuple[int, int | None]] = [(j, None) for j in shared]
    cols += [(j, s) for s in (0, 1) for j in apart]
    hl = 1.0
    exp_h = expm_so3(h * np.eye(3))  # rotations by h about x, y, z
    base = solver.residual(st.r, st.R, st.lam, pad, st, ext, rack=rack)  # (n, 2, 33)
    J = np.zeros((n, 2 * NS, 2 * NS))
    # perturbed residuals in blocks of about JACOBIAN_BLOCK row evaluations (memory)
    per = max(1, solver_module.JACOBIAN_BLOCK // max(n, 1))
    for a in range(0, len(cols), per):
        block = cols[a : a + per]
        P = len(block)
        r = np.broadcast_to(st.r, (P,) + st.r.shape).copy()
        R = np.broadcast_to(st.R, (P,) + st.R.shape).copy()
        lam = np.broadcast_to(st.lam, (P,) + st.lam.shape).copy()
        for p, (j, side) in enumerate(block):
            sd = slice(None) if side is None else side
            if j >= NQ:
                lam[p, :, sd, j - NQ] += hl
                continue
            b, k = divmod(j, 6)
            if k < 3:
                r[p, :, sd, b, k] += h
            else:
                R[p, :, sd, b] = np.matmul(exp_h[k - 3], st.R[:, sd, b])
        d = solver.residual(r, R, lam, pad, st, ext, rack=rack) - base  # (P, n, 2, 33)
        for p, (j, side) in enumerate(block):
            step = hl if j >= NQ else h
            if side is None:
                for s in (0, 1):
                    J[:, s * NS : (s + 1) * NS, s * NS + j] = d[p, :, s] / step
            else:
                J[:, :, side * NS + j] = d[p].reshape(n, 2 * NS) / step
    return J
