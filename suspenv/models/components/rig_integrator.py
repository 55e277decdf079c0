"""Time integrator of the quarter car on a rig: exact linear part, implicit effect force.

Frame, units and signs as in :mod:`suspenv.models.components.quarter_car` (ISO 8855 z
up, SI; deflection ``x = z_u - z_s`` positive in compression; the suspension force
pushes the body up and the wheel down). State ``s = (z_s, z_s', z_u, z_u')`` [m, m/s].

The linear 2-DOF system (spring ``k_s``, damper ``c_s``, tyre ``k_t``) is driven by two
inputs: the road height ``z_r`` and the extra suspension force ``F_e`` of the effect
elements. Over a step ``h`` both inputs are taken linear in time (first-order hold), so
the linear part is advanced *exactly* by a matrix exponential of the augmented system
(computed once per parameter set and step length)::

    s1 = Phi s0 + G0 u0 + G1 u1,   u = (z_r, F_e)

``F_e1`` depends on the end state through the elements, ``F_e1 = f(x1, x1', z1)``, and
``x1``, ``x1'`` are affine in ``F_e1``; the scalar equation is solved by a Newton
step followed by secant steps. Stiff elements (narrow friction steps, stiff end
stops, fast hysteresis) therefore need no small sub-steps: the scheme is implicit in
the element force, and for dissipative elements the equation has a single root.
Internal element states advance with their exact solution along the step (Dahl: the
exponential approach over the deflection increment, which keeps it rate
independent; Maxwell: the first-order lag with a linear velocity).

For one parameter set the loop runs compiled (:mod:`.rig_kernel`; without numba its
plain-Python form runs); a batch of parameter sets runs row by row. The same scheme
written as closures over plain floats, ``tests/rig_reference.py``, is the reference the
compiled loop is tested against.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.linalg import expm

from suspenv.core.errors import EvaluationError
from suspenv.models.components import rig_kernel
from suspenv.models.effects import Effect

#: force kinds with an exact (or implicit) step of their internal state (others use the
#: RK4 scheme)
EXACT_STATEFUL = tuple(rig_kernel.STATE_CODES)


def supports(effects: Sequence[Effect]) -> bool:
    """True when every force effect in ``effects`` can be advanced by this scheme (a
    stateless law or an exact state step of :mod:`.rig_kernel`)."""
    return all(e.kind in rig_kernel.LAW_CODES or e.kind in EXACT_STATEFUL for e in effects)


def step_matrices(
    m_s: float, m_u: float, k_s: float, c_s: float, k_t: float, h: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``Phi`` (4, 4), ``G0`` (4, 2) and ``G1`` (4, 2) of the exact first-order-hold step.

    Inputs ``u = (z_r [m], F_e [N])``; ``s1 = Phi s0 + G0 u0 + G1 u1`` is exact when
    both inputs are linear in time over the step ``h`` [s].
    """
    A = np.array(
        [
            [0.0, 1.0, 0.0, 0.0],
            [-k_s / m_s, -c_s / m_s, k_s / m_s, c_s / m_s],
            [0.0, 0.0, 0.0, 1.0],
            [k_s / m_u, c_s / m_u, -(k_s + k_t) / m_u, -c_s / m_u],
        ]
    )
    B = np.array([[0.0, 0.0], [0.0, 1.0 / m_s], [0.0, 0.0], [k_t / m_u, -1.0 / m_u]])
    # augmented system: s' = A s + B q, q' = r, r' = 0, with q(0) = u0, r = (u1 - u0) / h
    M = np.zeros((8, 8))
    M[:4, :4] = A
    M[:4, 4:6] = B
    M[4:6, 6:8] = np.eye(2)
    E = expm(M * h)
    phi, e_q, e_r = E[:4, :4], E[:4, 4:6], E[:4, 6:8]
    return phi, e_q - e_r / h, e_r / h


def integrate(
    m_s: float,
    m_u: float,
    base: dict[str, float],
    effects: Sequence[Effect],
    t: np.ndarray,
    road: np.ndarray,
    nsub: int = 1,
    tol: float = 1e-7,
    max_iter: int = 8,
    actuator: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Body acceleration [m/s^2] and suspension deflection [m] at the samples ``t``.

    One parameter set (floats); ``effects`` are force effects with scalar parameters,
    all supported (:func:`supports`). ``nsub`` sub-steps per sample interval (the road
    linear between samples). Starts at rest on ``road[0]`` (static equilibrium). The
    element force is solved to ``tol * (1 + |F|)`` [N] per step. ``actuator`` [N] (one
    value per sample, linear between samples): a known force between body and wheel,
    positive pushing them apart (it adds to the suspension force).

    The step matrices of every distinct step length (to 1e-15 s), then one call of the
    loop :func:`rig_kernel.run`.
    """
    k_s, c_s, k_t = float(base["k_s"]), float(base["c_s"]), float(base["k_t"])
    dts = np.diff(np.asarray(t, float))
    uniform = bool(np.all(np.abs(dts - dts[0]) <= 1e-9 * abs(dts[0])))
    h_of_step = np.full(dts.size, dts[0] / nsub) if uniform else dts / nsub
    # the distinct step lengths (to 1e-15 s) and each step's, the matrices of a length's
    # first step
    _, first, mat_of_step = np.unique(
        np.round(h_of_step, 15), return_index=True, return_inverse=True
    )
    mats = [step_matrices(m_s, m_u, k_s, c_s, k_t, float(h_of_step[i])) for i in first]
    mat_of_step = mat_of_step.astype(np.int64)
    phis, g0s, g1s = (np.ascontiguousarray(np.stack([m[i] for m in mats])) for i in range(3))
    law_codes, law_par, st_codes, st_par = rig_kernel.pack(effects)
    act = np.zeros(1) if actuator is None else np.ascontiguousarray(actuator, float)
    acc = np.empty(t.size)
    defl = np.empty(t.size)
    failed = rig_kernel.run(
        phis, g0s, g1s, mat_of_step, h_of_step, int(nsub),
        np.ascontiguousarray(road, float), act, actuator is not None,
        law_codes, law_par, st_codes, st_par,
        k_s, c_s, float(m_s), float(tol), int(max_iter), acc, defl,
    )  # fmt: skip
    if failed >= 0:
        raise EvaluationError(
            f"quarter_car_rig: simulation diverged at t={t[failed + 1]:.4g} s (sub-steps {nsub})"
        )
    return acc, defl
