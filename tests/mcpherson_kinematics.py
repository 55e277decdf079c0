"""Pure kinematics of one McPherson corner with ideal joints (no compliance; tests only).

Frame ISO 8855 (x forward, y left, z up), SI units; points of an :class:`Axle`.

Minimal-coordinate formulation, independent of the compliant solver: the knuckle
pose (translation of the wheel centre and a rotation vector, 6 unknowns) is found
from six scalar equations with the bushings replaced by ideal joints:

1-2. the lower ball joint keeps its distances to both lower-arm bush centres
     (the rigid arm turns about the bush axis);
3.   the tie rod keeps its length (rack fixed);
4-5. the strut top (a spherical top mount) stays on the knuckle's strut line;
6.   the wheel-centre height equals the prescribed value.

Used as the reference of the "stiff bushings equal pure kinematics" tests and of the
spring preload's motion (virtual work at the design position). It shares no code with
the compliant solver (``solver.py``) beyond the input geometry (:class:`Axle`): its
rotations come from scipy's ``Rotation.from_rotvec``, not from ``rotation.py``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from suspenv.core.errors import ConvergenceError
from suspenv.models.mcpherson.params import Axle
from suspenv.models.mcpherson.solver import _perp_basis


def _rotation_matrices(w: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of rotation vectors ``w`` (..., 3) [rad] (scipy)."""
    w = np.asarray(w, dtype=float)
    return Rotation.from_rotvec(w.reshape(-1, 3)).as_matrix().reshape(w.shape[:-1] + (3, 3))


class CornerKinematics:
    """Ideal-joint kinematics of every corner of an axle batch, shape (n, 2)."""

    def __init__(self, axle: Axle):
        p = axle.points
        self.wc0 = p["wheel_centre"]
        self.F = p["lca_front_bush"]
        self.Rr = p["lca_rear_bush"]
        self.B = p["lower_ball_joint"]
        self.TRI = p["tie_rod_inner"]
        self.TRO = p["tie_rod_outer"]
        self.ST = p["strut_top"]
        self.S = p["strut_axis_point"]
        self.a = (self.S - self.ST) / np.linalg.norm(self.S - self.ST, axis=-1, keepdims=True)
        self.u, self.v = _perp_basis(self.a)
        self.dF = np.linalg.norm(self.B - self.F, axis=-1)
        self.dR = np.linalg.norm(self.B - self.Rr, axis=-1)
        self.Lt = np.linalg.norm(self.TRO - self.TRI, axis=-1)
        self.axle = axle

    def _pose(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Knuckle (translation of the wheel centre, rotation matrix) from q (..., 6)."""
        return self.wc0 + q[..., :3], _rotation_matrices(q[..., 3:])

    def point(self, q: np.ndarray, p0: np.ndarray) -> np.ndarray:
        """Current position of the knuckle point that was at ``p0`` at design."""
        r, R = self._pose(q)
        return r + np.einsum("...ij,...j->...i", R, p0 - self.wc0)

    def direction(self, q: np.ndarray, d0: np.ndarray) -> np.ndarray:
        _, R = self._pose(q)
        return np.einsum("...ij,...j->...i", R, d0)

    def equations(self, q: np.ndarray, z_wc: np.ndarray) -> np.ndarray:
        """The six kinematic equations (..., 6), zero at a solution."""
        pB = self.point(q, self.B)
        pT = self.point(q, self.TRO)
        pS = self.point(q, self.S)
        uk, vk = self.direction(q, self.u), self.direction(q, self.v)
        w = self.ST - pS
        return np.stack(
            [
                np.linalg.norm(pB - self.F, axis=-1) - self.dF,
                np.linalg.norm(pB - self.Rr, axis=-1) - self.dR,
                np.linalg.norm(pT - self.TRI, axis=-1) - self.Lt,
                (uk * w).sum(-1),
                (vk * w).sum(-1),
                self.wc0[..., 2] + q[..., 2] - z_wc,
            ],
            axis=-1,
        )

    def jacobian(self, q: np.ndarray, z_wc: np.ndarray, h: float = 1e-7) -> np.ndarray:
        """Central finite-difference Jacobian (..., 6, 6)."""
        cols = []
        for j in range(6):
            dq = np.zeros(6)
            dq[j] = h
            cols.append((self.equations(q + dq, z_wc) - self.equations(q - dq, z_wc)) / (2 * h))
        return np.stack(cols, axis=-1)

    def solve(
        self, z_wc: np.ndarray, q0: np.ndarray | None = None, tol: float = 1e-12, maxit: int = 30
    ) -> np.ndarray:
        """Knuckle coordinates q (n, 2, 6) with the wheel centre at height ``z_wc`` (n, 2) [m]."""
        q = np.zeros(self.wc0.shape[:-1] + (6,)) if q0 is None else np.array(q0, dtype=float)
        for _ in range(maxit):
            e = self.equations(q, z_wc)
            if np.max(np.abs(e)) < tol:
                return q
            q = q - np.linalg.solve(self.jacobian(q, z_wc), e[..., None])[..., 0]
        raise ConvergenceError(
            f"kinematic solve did not converge in {maxit} iterations "
            f"(max equation error {np.max(np.abs(e)):.3g} m)"
        )

    def tangent(self, q: np.ndarray, z_wc: np.ndarray) -> np.ndarray:
        """dq/dz_wc (n, 2, 6) at a solution."""
        rhs = np.zeros(q.shape)
        rhs[..., 5] = 1.0
        return np.linalg.solve(self.jacobian(q, z_wc), rhs[..., None])[..., 0]
