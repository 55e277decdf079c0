"""Analytic planar solver: closed-form loop closure plus a vectorised 1-D Newton.

Frame, units and signs: see :mod:`suspenv.models.planar.geometry` (front view of the
left wheel, y outboard, z up, SI, rotations counter-clockwise positive).

Both linkages have one degree of freedom, taken as the lower-arm rotation ``phi`` from
the design position. For a given ``phi`` the pose follows in closed form:

- double wishbone: the lower ball joint rotates about the inner pivot; the upper ball
  joint is the intersection of two circles (about the upper inner pivot, radius = upper
  arm; about the lower ball joint, radius = upright length), on the design branch;
- McPherson: the lower ball joint rotates about the inner pivot; the strut axis, fixed
  in the upright at a signed distance from the ball joint, must pass through the top
  mount, which fixes the upright angle by one ``arcsin``.

Newton's method then finds, for every geometry and travel point at once, the ``phi`` at
which the contact point sits at the prescribed pad height. Derivatives with respect to
travel (motion ratio, contact-point slope, their change) come from central differences
in ``phi`` of the closed-form pose, divided by ``dz_contact/dphi`` (chain rule).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from suspenv.core.errors import LockupError, ValidationError
from suspenv.models.planar.geometry import DoubleWishbone, McPherson, PlanarGeometry

#: Newton settings: residual tolerance on the contact height (m) and iteration cap
NEWTON_TOL = 1e-10
NEWTON_MAX_ITER = 30
#: largest upright rotation (rad) between neighbouring travel points before a sweep is
#: declared broken (a branch jump past a dead centre)
MAX_THETA_STEP = 0.2
#: step in phi (rad) for derivatives of the closed-form pose
_DPHI = 1e-4


@dataclass
class PlanarSweep:
    """Poses of a batch of linkages over a travel sweep (SI).

    Shapes: ``B`` = batch shape of the geometry, ``t`` = number of travel points.

    Attributes:
        travel: (t,) m, prescribed pad (contact-point) displacement, bump positive.
        points: name -> (B..., t, 2) m, every hard point and ``contact``.
        theta: (B..., t) rad, upright rotation from the design position (CCW).
        spring_length: (B..., t) m.
        ok: (B...) bool, the linkage assembled and converged at every travel point
            (a numpy bool scalar for an unbatched geometry).
        contact_slope: (B..., t) d y_contact / d travel (exact), or None.
        theta_slope: (B..., t) rad/m, d theta / d travel, or None.
        motion_ratio: (B..., t) spring compression per wheel travel, or None.
        motion_ratio_slope: (B..., t) 1/m, d motion_ratio / d travel, or None.
        wheel_load: (B..., t) N, vertical pad force, measured (pymunk) or None.
        solver: "analytic" or "pymunk".
    """

    travel: np.ndarray
    points: dict[str, np.ndarray]
    theta: np.ndarray
    spring_length: np.ndarray
    ok: np.ndarray | np.bool_
    contact_slope: np.ndarray | None = None
    theta_slope: np.ndarray | None = None
    motion_ratio: np.ndarray | None = None
    motion_ratio_slope: np.ndarray | None = None
    wheel_load: np.ndarray | None = None
    solver: str = "analytic"
    messages: list[str] = field(default_factory=list)


# ------------------------------------------------------------ closed-form pose
class _Kernel:
    """Closed-form pose of a batch of linkages as a function of ``phi`` (B..., t).

    Components are kept as separate y and z arrays (no stacking in the inner loop), and
    the upright's orientation is carried as a unit vector ``u`` (no trigonometry): a point
    of the upright is ``B + R(u) q`` with ``q`` its design offset from the lower ball
    joint, expressed in the frame of the upright's reference direction.
    """

    def __init__(self, geom: PlanarGeometry):
        if not isinstance(geom, (DoubleWishbone, McPherson)):
            raise ValidationError(f"unknown planar geometry type {type(geom).__name__}")
        self.geom = geom

        def yz(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # (B..., 1) components
            v = np.asarray(v, dtype=float)
            return v[..., 0][..., None], v[..., 1][..., None]

        self.A = yz(geom.lower_inner)
        b0 = yz(geom.lower_outer)
        self.AB = (b0[0] - self.A[0], b0[1] - self.A[1])
        if isinstance(geom, DoubleWishbone):
            self.C = yz(geom.upper_inner)
            d0 = yz(geom.upper_outer)
            ref = (d0[0] - b0[0], d0[1] - b0[1])  # upright reference direction: B -> D
            self.r_ud2 = ref[0] ** 2 + ref[1] ** 2
            self.r_ud = np.sqrt(self.r_ud2)
            self.r_u2 = (d0[0] - self.C[0]) ** 2 + (d0[1] - self.C[1]) ** 2
            cb0 = (self.C[0] - b0[0], self.C[1] - b0[1])
            self.side = np.sign(cb0[0] * ref[1] - cb0[1] * ref[0])
            s_arm = yz(geom.spring_arm)
            self.AS = (s_arm[0] - self.A[0], s_arm[1] - self.A[1])
            self.Sb = yz(geom.spring_body)
        else:
            self.T = yz(geom.strut_top)
            u0 = yz(geom.strut_lower)
            ref = (self.T[0] - u0[0], self.T[1] - u0[1])  # strut axis, seat -> top
            norm = np.hypot(*ref)
            ref = (ref[0] / norm, ref[1] / norm)
            v0 = (b0[0] - self.T[0], b0[1] - self.T[1])
            self.offset = ref[0] * v0[1] - ref[1] * v0[0]  # signed ball-joint offset
            self.cos_sign = np.where(ref[0] * v0[0] + ref[1] * v0[1] >= 0.0, 1.0, -1.0)
        self.psi0 = np.arctan2(ref[1], ref[0])
        rn = np.hypot(*ref)
        cy, cz = ref[0] / rn, ref[1] / rn
        self.q: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        upright = {n: getattr(geom, n) for n in geom.upright_points}
        upright["contact"] = geom.contact_point
        for name, p in upright.items():
            py, pz = yz(p)
            dy, dz = py - b0[0], pz - b0[1]
            self.q[name] = (cy * dy + cz * dz, -cz * dy + cy * dz)  # R(-psi0) (P - B0)

    def arm(self, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Lower ball joint (y, z) and (cos, sin) of ``phi``."""
        c, s = np.cos(phi), np.sin(phi)
        by = self.A[0] + c * self.AB[0] - s * self.AB[1]
        bz = self.A[1] + s * self.AB[0] + c * self.AB[1]
        return by, bz, c, s

    def upright(self, phi: np.ndarray) -> tuple[np.ndarray, ...]:
        """Ball joint (by, bz), upright direction (uy, uz) and (cos, sin) of ``phi``."""
        by, bz, c, s = self.arm(phi)
        if isinstance(self.geom, DoubleWishbone):
            cby, cbz = self.C[0] - by, self.C[1] - bz
            d2 = cby * cby + cbz * cbz
            a_d = (self.r_ud2 - self.r_u2 + d2) / (2.0 * d2)
            h2 = self.r_ud2 / d2 - a_d * a_d
            h_d = self.side * np.sqrt(np.where(h2 >= 0.0, h2, np.nan))
            uy = (a_d * cby - h_d * cbz) / self.r_ud
            uz = (a_d * cbz + h_d * cby) / self.r_ud
        else:
            vy, vz = by - self.T[0], bz - self.T[1]
            L = np.sqrt(vy * vy + vz * vz)
            sin_a = self.offset / L
            cos2 = 1.0 - sin_a * sin_a
            cos_a = self.cos_sign * np.sqrt(np.where(cos2 >= 0.0, cos2, np.nan))
            uy = (cos_a * vy + sin_a * vz) / L
            uz = (-sin_a * vy + cos_a * vz) / L
        return by, bz, uy, uz, c, s

    def contact_z(self, phi: np.ndarray) -> np.ndarray:
        by, bz, uy, uz, _, _ = self.upright(phi)
        qy, qz = self.q["contact"]
        return bz + uz * qy + uy * qz

    def pose(self, phi: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
        """Points (B..., t, 2), upright rotation (B..., t) and spring length (B..., t)."""
        by, bz, uy, uz, c, s = self.upright(phi)
        shape = np.broadcast_shapes(by.shape, uy.shape)

        def point(y: np.ndarray, z: np.ndarray) -> np.ndarray:
            return np.stack(np.broadcast_arrays(y, z, np.empty(shape))[:2], axis=-1)

        pts = {"lower_inner": point(*self.A), "lower_outer": point(by, bz)}
        for name, (qy, qz) in self.q.items():
            if name != "lower_outer":
                pts[name] = point(by + uy * qy - uz * qz, bz + uz * qy + uy * qz)
        if isinstance(self.geom, DoubleWishbone):
            sy = self.A[0] + c * self.AS[0] - s * self.AS[1]
            sz = self.A[1] + s * self.AS[0] + c * self.AS[1]
            pts["upper_inner"] = point(*self.C)
            pts["spring_arm"] = point(sy, sz)
            pts["spring_body"] = point(*self.Sb)
            spring = np.hypot(sy - self.Sb[0], sz - self.Sb[1])
        else:
            pts["strut_top"] = point(*self.T)
            seat = pts["strut_lower"]
            spring = np.hypot(self.T[0] - seat[..., 0], self.T[1] - seat[..., 1])
        theta = np.arctan2(uz, uy) - self.psi0
        theta = (theta + np.pi) % (2.0 * np.pi) - np.pi
        return pts, np.broadcast_to(theta, shape), np.broadcast_to(spring, shape)


# ---------------------------------------------------------------- the solver
def solve_sweep(
    geom: PlanarGeometry, travel: np.ndarray, *, derivatives: bool = True
) -> PlanarSweep:
    """Solve a batch of linkages at every prescribed travel (m, bump positive).

    Vectorised over the geometry's batch shape and the travel points together. Rows that
    lock up (circles do not meet, strut cannot reach) or do not converge get
    ``ok=False`` and NaN poses; nothing is raised (see :func:`solve_single` for that).
    """
    travel = np.asarray(travel, dtype=float).reshape(-1)
    if travel.size == 0:
        raise ValidationError("`travel` must hold at least one point, but got none")
    bshape = geom.batch_shape
    z0 = geom.contact_point[..., 1][..., None]  # (B..., 1)
    target = z0 + travel  # (B..., t)

    # initial guess: linearise the contact height about the design position
    kernel = _Kernel(geom)
    dz0 = (
        kernel.contact_z(np.full(bshape + (1,), _DPHI))
        - kernel.contact_z(np.full(bshape + (1,), -_DPHI))
    ) / (2 * _DPHI)
    phi = np.broadcast_to(travel / dz0, bshape + travel.shape).copy()
    h = 1e-7
    for _ in range(NEWTON_MAX_ITER):
        r = kernel.contact_z(phi) - target
        if np.all(np.abs(r[np.isfinite(r)]) < NEWTON_TOL):
            break
        dr = (kernel.contact_z(phi + h) - r - target) / h
        step = r / dr
        phi = phi - np.clip(step, -0.2, 0.2)  # limit a step to ~11 deg of arm rotation
    pts, theta, spring = kernel.pose(phi)
    resid = np.abs(pts["contact"][..., 1] - target)
    # the pad drives the wheel only while dz/dphi keeps its design sign (else a dead
    # centre lies in between), and the upright must not jump between neighbouring travel
    # points (Newton landed on another assembly branch past a dead centre)
    dz = kernel.contact_z(phi + h) - kernel.contact_z(phi - h)
    ok_pt = np.isfinite(resid) & (resid < 1e3 * NEWTON_TOL) & np.isfinite(theta) & (dz * dz0 > 0)
    jump = np.abs(np.diff(theta, axis=-1)) > MAX_THETA_STEP
    ok_pt[..., 1:] &= ~jump
    ok_pt[..., :-1] &= ~jump
    ok = ok_pt.all(axis=-1)
    sweep = PlanarSweep(travel, pts, theta, spring, ok)
    if derivatives:
        _add_derivatives(kernel, phi, sweep)
    sweep.messages = [_message(ok_pt[i], travel) for i in np.ndindex(bshape)]
    return sweep


def _message(ok_pt: np.ndarray, travel: np.ndarray) -> str:
    if ok_pt.all():
        return ""
    bad = travel[~ok_pt]
    return (
        "LockupError: linkage cannot follow the travel (no assembly or past a dead centre) at "
        f"{bad.size} travel point(s) between {1e3 * bad.min():.1f} and {1e3 * bad.max():.1f} mm"
    )


def _add_derivatives(kernel: _Kernel, phi: np.ndarray, sweep: PlanarSweep) -> None:
    """Travel derivatives by central differences of the closed-form pose in ``phi``."""
    p_hi, th_hi, l_hi = kernel.pose(phi + _DPHI)
    p_lo, th_lo, l_lo = kernel.pose(phi - _DPHI)
    c, c_hi, c_lo = sweep.points["contact"], p_hi["contact"], p_lo["contact"]
    z1 = (c_hi[..., 1] - c_lo[..., 1]) / (2 * _DPHI)
    z2 = (c_hi[..., 1] - 2 * c[..., 1] + c_lo[..., 1]) / _DPHI**2
    y1 = (c_hi[..., 0] - c_lo[..., 0]) / (2 * _DPHI)
    dth = (th_hi - th_lo + np.pi) % (2 * np.pi) - np.pi
    l1 = (l_hi - l_lo) / (2 * _DPHI)
    l2 = (l_hi - 2 * sweep.spring_length + l_lo) / _DPHI**2
    sweep.contact_slope = y1 / z1
    sweep.theta_slope = dth / (2 * _DPHI) / z1
    sweep.motion_ratio = -l1 / z1
    sweep.motion_ratio_slope = -(l2 * z1 - l1 * z2) / z1**3


def solve_single(geom: PlanarGeometry, travel: np.ndarray) -> PlanarSweep:
    """Like :func:`solve_sweep` for one geometry, raising :class:`LockupError` on failure."""
    if geom.batch_shape:
        raise ValidationError(
            f"solve_single needs one geometry, but got batch shape {geom.batch_shape}"
        )
    sweep = solve_sweep(geom, travel)
    if not bool(sweep.ok):
        raise LockupError(sweep.messages[0].removeprefix("LockupError: "))
    return sweep
