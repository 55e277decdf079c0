"""Quasi-static equilibrium of a compliant McPherson front axle, vectorised over designs.

Frame ISO 8855 (x forward, y left, z up), SI units (m, N, N*m, rad). Body fixed;
the steering rack (both tie-rod inner points) moves along +y by the rack travel given
(``rack``) and by its give under the tie rods' net lateral force, ``C F`` (rack mounts
and column in series, ``C_rack`` from the axle's constants; 0: rigid). Side index
0 = left (y > 0), 1 = right.

Model (per side, four rigid bodies, each with 6 coordinates)
-----------------------------------------------------------
0. lower control arm: front and rear bushes to the body (6-D linear springs);
1. knuckle with strut tube, hub and wheel: lower ball joint to the arm (3 exact
   constraints), tie rod from the rack point (exact distance constraint),
   drop link to the anti-roll bar (exact distance constraint), tyre as a vertical
   spring between the lowest point of the wheel and the rig pad (frictionless pad:
   vertical force only), the wheel's weight at the wheel centre;
2. strut rod: top mount bushing (6-D) to the body, cylindrical joint with the tube
   (4 exact constraints: axes parallel, rod point on the tube axis), the coil spring
   between the upper seat (rod) and the lower seat (tube) acting along the seats' line;
3. anti-roll bar half: its bush to the body (6-D), the drop link, and the joint of
   the two halves at the bar's middle: very stiff in shear and bending (the bar acts
   as one body) with the bar's torsional stiffness about the vehicle y axis (twist =
   y component of the rotation vector of R_left R_right^T).

Unknowns per side: 24 body coordinates (translation of the reference point and a
left-multiplied rotation increment) and 9 Lagrange multipliers (constraint
forces). Residual per side: the force and moment (about the body reference point)
sums of the four bodies and the nine constraint violations. A constraint multiplier
``lam`` applies the generalised force ``lam * dc/dq``.

Bushing deflection: translation of the bushing point from its design position and
the rotation vector of the body's rotation; forces and moments in vehicle axes. A
bushing with an orientation (``Axle.frames``, ADAMS 3-1-3 angles of the vehicle file)
has its diagonal stiffness in its own frame Q: the deflection is rotated into that
frame (``Q^T x``), the load back (``Q f``), i.e. ``K_vehicle = Q K Q^T`` (bushings
without an orientation skip both rotations).

Optional physics: a sequence of effects-library :class:`~suspenv.models.effects.Effect`
objects placed at bushings or the strut (:mod:`suspenv.models.mcpherson.effects`),
compiled once per solver into per-bushing element parameters.

Newton's method, vectorised over the batch: the Jacobian is a forward-difference
Jacobian of the exact residual in the body coordinates (columns with disjoint residual
rows perturbed together, batched residual calls, see :meth:`AxleSolver.jacobian`) and
in the constraint multipliers (1 N steps: the residual is linear in them), inverted with
``np.linalg.inv`` in blocks of rows and reused along the sweep (chord steps; rows that
start from the same Jacobian may share it, :class:`SharedInverse`); a row whose step
shrinks by less than half per
iteration gets a fresh Jacobian (only that row), and its steps are damped when even
fresh-Jacobian steps stop shrinking (a cycle at a Dahl reversal). A row has
converged when its Newton correction is below ``xtol`` = 1e-6 m, ``rtol`` = 1e-5 rad
and ``ltol`` = 0.1 N (the correction is applied); with path-dependent effects the
tolerances are ten times tighter and two small corrections in a row are required.
Rows that do not converge in ``maxit`` iterations are reported per row
(``converged=False``); the rig turns them into typed failures with a reason.

Output sign conventions (:meth:`AxleSolver.outputs`): toe positive = toe-in; camber
negative = top of the wheel inboard; caster positive = steering axis (lower ball
joint to top-mount centre) leaning rearward at the top; kingpin inclination positive
= axis top inboard; scrub radius (SAE sign) positive when the axis meets the pad plane
inboard of the loaded contact point (where the wheel plane's downward radius meets the
pad plane), along the vehicle's y axis; trail positive when it meets it ahead of the
loaded contact point, along x; knuckle pitch = rotation of the wheel carrier about +y
from its design attitude (front down positive); strut length = top mount centre to the
strut axis point on the knuckle;
tyre force positive in compression (the tyre is a linear two-way spring, as in the
paper); spring force positive in compression.
"""

from __future__ import annotations

import copy
import functools
import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.effects import Effect, cubic_stiffness
from suspenv.models.effects.hysteresis import dahl_segment
from suspenv.models.mcpherson import residual_kernel, sweep_kernel
from suspenv.models.mcpherson.effects import MOMENT_ARM, bushings_at, check_placement
from suspenv.models.mcpherson.params import SIDE_SIGN, Axle
from suspenv.models.mcpherson.rotation import (
    cross,
    dot,
    expm_so3,
    log_so3,
    rotate,
    turned,
)

NQ, NL = 24, 9
NS = NQ + NL  # unknowns per side
EZ = np.array([0.0, 0.0, 1.0])
#: the bar's stiffness at its middle against shear [N/m] and bending [N*m/rad]
ARB_SHEAR_STIFFNESS = 1e8
ARB_BENDING_STIFFNESS = 1e6
#: a bushing deflection above these means a lock-up: the design cannot carry its loads
#: (the rig fails the step, a vehicle file fails its assembly check) [m], [rad]
MAX_TRANSLATION = 0.05
MAX_ROTATION = 0.5
#: body of each rotated body-fixed vector (see AxleSolver._vec) and of each bushing of
#: BUSH_ORDER: the compiled residual's (defined once, there)
VEC_BODY, BUSH_BODY = residual_kernel._VEC_BODY, residual_kernel._BUSH_BODY
#: the slices of VEC_BODY held by each body (0-3)
VEC_GROUPS = ((0, 3), (3, 12), (12, 14), (14, 16))
#: bushings in the order of the stacked arrays
BUSH_ORDER = ("lca_front", "lca_rear", "top_mount", "arb_bush")
#: the coloured Jacobian of an axle without placed effects by a compiled loop (each row
#: perturbed and differenced in place, :func:`.residual_kernel.jacobian`); False: the
#: perturbations in blocks through :meth:`AxleSolver.residual`
JACOBIAN_COMPILED = True
#: empty stand-ins (0, 2) and (0, 2, 1) for the compiled residual's absent inputs
_NO_ROWS = (np.empty((0, 2)), np.empty((0, 2, 1)))
#: columns of the placed effects' loads that the compiled residual takes per side: the
#: four bushings' loads beyond the linear ones (6 each), the strut friction force
N_EXTRA = 25
#: the offsets in ``AxleSolver._rl_pack`` that the compiled residual reads, in its order
_KERNEL_FIELDS = (
    "vec", "ground", "K", "Q", "tri", "L_links", "L_links_sq", "L_links_2",
    "ks", "L_free", "Rw", "kt", "W", "k_bar_rot", "C_rack",
)  # fmt: skip
#: smooth dead band of the Dahl elements at reversals (see dahl_step) [m], [rad]
DAHL_EPS_TRANSLATION = 1e-6
DAHL_EPS_ROTATION = 1e-5
_DAHL_EPS = np.repeat([DAHL_EPS_TRANSLATION, DAHL_EPS_ROTATION], 3)  # per bushing column
#: scale of constraint rows in the residual: metres -> micrometres
CSCALE = 1e6
#: row evaluations per batched residual call of the finite-difference Jacobian (its
#: perturbations are evaluated in blocks of about this many rows x perturbations, which
#: bounds the Jacobian's temporary memory to about 2 MB at any batch size); the
#: Jacobians are inverted in blocks of JACOBIAN_BLOCK // 32 rows
JACOBIAN_BLOCK = 256
#: perturbations per batched residual call of the finite-difference Jacobian at most
#: (fewer when JACOBIAN_BLOCK says so): its temporaries, about 6.6 kB per row and
#: perturbation, stay below about 80 kB per row at small batches too (the 24
#: perturbations of a single row in one call: 157 kB)
JACOBIAN_PERTURBATIONS = 12
#: residual rows (of one side) that the lower arm's coordinates enter: its force and
#: moment and the ball joint's constraint; the strut rod's enter none of them
ARM_ROWS = np.r_[0:6, NQ : NQ + 3]
#: :meth:`AxleSolver.take` of rows that are all one design (``axle=False``) shares that
#: design's arrays as zero-stride views, the same numbers in less memory (False: a copy
#: per row, the reference path of the speed benchmark's baseline)
SHARE_ONE_DESIGN = True
#: the precision in which :class:`SharedInverse` holds the inverse Jacobians that the
#: rig's rows share: single (half the memory). The chord iteration only needs an
#: approximate inverse: rounding it to single precision changes the Newton contraction
#: by about 1e-6 (||I - M J|| measured on the static Jacobians, whose condition number
#: is about 3e9 in norm but whose entries are rounded relative to their own size), and
#: a row converges to the same tolerances (``np.float64``: the reference path of the
#: tests and the speed benchmark's baseline)
SHARED_INVERSE_DTYPE: type = np.float32
#: :class:`AxleSolver` arrays without design rows on their first axis, which
#: :meth:`AxleSolver.take` must not take rows of even when that axis happens to be as
#: long as the batch (the compiled residual's offsets are 14 numbers: a batch of 14
#: designs took them as rows); the pack has its rows last and is taken apart
_NOT_PER_ROW = frozenset({"_rl_off", "_rl_pack"})
#: the channels of :meth:`AxleSolver.outputs`, in its order
OUTPUT_NAMES = (
    "wheel_centre_x",
    "wheel_centre_y",
    "wheel_centre_z",
    "contact_x",
    "contact_y",
    "contact_z",
    "pad_z",
    "tyre_fz",
    "toe",
    "camber",
    "caster",
    "kpi",
    "scrub_radius",
    "trail",
    "spring_length",
    "spring_force",
    "arb_twist",
    "knuckle_pitch",
    "strut_length",
    "handwheel_torque",
)
#: Newton iterations after the first evaluate the residual of the rows still iterating
#: only, when they are at most half the batch (the same numbers per row; False: every
#: row at every iteration, the reference path of the speed benchmark's baseline)
SUBSET_RESIDUALS = True


@dataclass(frozen=True)
class _Placed:
    """The solver's compiled effects (see :func:`_compile`).

    hysteresis: bushing -> (initial stiffness over the bushing's, saturation force [N],
    saturation moment [N*m]) of its Dahl elements; cubic: bushing -> (cubic over linear
    force at ``x_ref``, ``x_ref`` [m]); friction: strut (level [N], pre-sliding
    stiffness [N/m]) or None.
    """

    hysteresis: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    cubic: dict[str, tuple[float, float]] = field(default_factory=dict)
    friction: tuple[float, float] | None = None


def _scalar(effect: Effect, name: str) -> float:
    v = effect.params[name]
    if np.ndim(v) != 0:
        raise ValidationError(
            f"axle effect {effect.name!r}: the solver takes one value per parameter, but "
            f"`{name}` has shape {np.shape(v)} (solve rows with different values apart)"
        )
    return float(v)


def _compile(effects: Sequence[Effect]) -> _Placed:
    """Per-bushing element parameters of ``effects`` (each checked where it sits)."""
    hyst: dict[str, tuple[float, float, float]] = {}
    cubic: dict[str, tuple[float, float]] = {}
    friction: tuple[float, float] | None = None
    seen_friction = False
    for e in effects:
        if not isinstance(e, Effect):
            raise ValidationError(
                f"axle effects must be Effect instances, but got {type(e).__name__}"
            )
        check_placement(e)
        if e.kind == "coulomb_friction":
            if seen_friction:
                raise ValidationError(
                    f"axle effect {e.name!r}: one strut friction at most, but got a second"
                )
            seen_friction = True
            f_c = _scalar(e, "f_c")
            if f_c > 0:
                friction = (f_c, _scalar(e, "sigma"))
            continue
        table: dict = hyst if e.kind == "dahl_hysteresis" else cubic
        for b in bushings_at(e.location):
            if b in table:
                raise ValidationError(
                    f"axle effect {e.name!r}: one {e.kind} element per bushing, but bushing "
                    f"{b!r} already has one"
                )
            if e.kind == "dahl_hysteresis":
                f_c = _scalar(e, "f_c")
                hyst[b] = (_scalar(e, "sigma_ratio"), f_c, f_c * MOMENT_ARM)
            else:
                cubic[b] = (_scalar(e, "ratio"), _scalar(e, "x_ref"))
    return _Placed(hyst, cubic, friction)


@dataclass
class AxleState:
    """Converged (or trial) state of a batch of axles.

    r (n, 2, 4, 3) body reference points [m]; R (n, 2, 4, 3, 3) body rotations;
    lam (n, 2, 9) constraint multipliers; hyst: bushing name -> (deflection, Dahl
    force) at the last committed step, each (n, 2, 6); fric: (slide, Dahl force) (n, 2).
    """

    r: np.ndarray
    R: np.ndarray
    lam: np.ndarray
    hyst: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    fric: tuple[np.ndarray, np.ndarray] | None = None

    def copy(self) -> AxleState:
        return self.moved(self.r.copy(), self.R.copy(), self.lam.copy())

    def _histories(self, f: Callable[[np.ndarray], np.ndarray]) -> tuple:
        """(hyst, fric): the path-dependent histories with ``f`` applied to each array."""
        hyst = {k: (f(a), f(b)) for k, (a, b) in self.hyst.items()}
        return hyst, None if self.fric is None else (f(self.fric[0]), f(self.fric[1]))

    def moved(self, r: np.ndarray, R: np.ndarray, lam: np.ndarray) -> AxleState:
        """A state at ``r``, ``R``, ``lam`` with a copy of this one's path-dependent
        histories."""
        return AxleState(r, R, lam, *self._histories(np.copy))

    def take(self, rows: np.ndarray | slice, views: bool = False) -> AxleState:
        """The state of the given rows (index array, boolean mask, or a slice), copied
        (``views``: views of a slice's rows)."""

        def pick(a: np.ndarray) -> np.ndarray:
            return a[rows] if views else a[rows].copy()

        return AxleState(pick(self.r), pick(self.R), pick(self.lam), *self._histories(pick))

    def assign(self, other: AxleState, rows: np.ndarray) -> None:
        """Copy ``other``'s values into this state for the boolean/int ``rows``."""
        self.r[rows], self.R[rows], self.lam[rows] = other.r[rows], other.R[rows], other.lam[rows]
        for k in self.hyst:
            self.hyst[k][0][rows] = other.hyst[k][0][rows]
            self.hyst[k][1][rows] = other.hyst[k][1][rows]
        if self.fric is not None and other.fric is not None:
            self.fric[0][rows] = other.fric[0][rows]
            self.fric[1][rows] = other.fric[1][rows]


class SharedInverse:
    """Inverse Jacobians (66 x 66, units of :meth:`AxleSolver.jacobian` inverted) of
    ``groups * nd`` rows that share one per design.

    Row ``i`` (rows group-major: ``i = g * nd + d``) uses ``base[d]`` (the inverse of
    design ``d``, e.g. at its static equilibrium) until :meth:`set` gives it its own.
    The same numbers as ``base[np.tile(arange(nd), groups)]`` (one copy per row), held
    once per design: the rig's rows (test x leg x design) start from the same static
    Jacobian, and only the rows that the solver refreshes get a matrix of their own.
    Held in ``dtype`` (default :data:`SHARED_INVERSE_DTYPE`); the products are computed
    in it and returned in the residual's precision.
    """

    def __init__(self, base: np.ndarray, groups: int, dtype: type | None = None):
        self.dtype = np.dtype(SHARED_INVERSE_DTYPE if dtype is None else dtype)
        self.base = np.asarray(base, dtype=self.dtype)
        self.nd = base.shape[0]
        self.groups = groups
        self.slot = np.full(groups * self.nd, -1)  # row -> index into own (-1: shared)
        self.own = np.empty((0,) + base.shape[1:], self.dtype)

    def mul(self, res: np.ndarray) -> np.ndarray:
        """``J^-1 res`` (m, 66) for residuals ``res`` (m, 66) of every row."""
        r = res.astype(self.dtype, copy=False)
        out = np.matmul(self.base, r.reshape(self.groups, self.nd, -1, 1))
        out = out.reshape(res.shape)
        mine = np.flatnonzero(self.slot >= 0)
        if mine.size:
            out[mine] = np.matmul(self.own[self.slot[mine]], r[mine][..., None])[..., 0]
        del r  # before the product is cast back (memory)
        return out.astype(res.dtype, copy=False)

    def set(self, rows: np.ndarray, mats: np.ndarray) -> None:
        """Give ``rows`` (bool mask) their own inverse Jacobians ``mats`` (k, 66, 66)."""
        idx = np.flatnonzero(rows)
        new = idx[self.slot[idx] < 0]
        self.slot[new] = self.own.shape[0] + np.arange(new.size)
        if new.size:
            grown = np.empty((new.size,) + self.base.shape[1:], self.dtype)
            self.own = np.concatenate([self.own, grown])
        self.own[self.slot[idx]] = mats


def _inv_mul(Jinv: np.ndarray | SharedInverse, res: np.ndarray) -> np.ndarray:
    """``J^-1 res`` (m, 66) of per-row inverses (m, 66, 66) or a :class:`SharedInverse`."""
    if isinstance(Jinv, SharedInverse):
        return Jinv.mul(res)
    return np.matmul(Jinv, res[..., None])[..., 0]


def lockup_text(name: str, translation: float, rotation: float) -> str:
    """The words of a lock-up of bushing ``name`` (:meth:`AxleSolver.lockups`): its
    deflection [m], [rad] and the limits."""
    return (
        f"the {name} bushing deflects {translation * 1e3:.1f} mm / {rotation:.2f} rad (limits "
        f"{MAX_TRANSLATION * 1e3:g} mm, {MAX_ROTATION:g} rad)"
    )


def spin_axis(camber: np.ndarray, toe: np.ndarray) -> np.ndarray:
    """Outboard unit spin axis (..., 2, 3) from camber and toe [rad] (signs: module doc)."""
    sg = SIDE_SIGN
    return np.stack(
        [np.sin(toe) * np.cos(camber), sg * np.cos(toe) * np.cos(camber), -np.sin(camber)], axis=-1
    )


def wheel_down(s: np.ndarray) -> np.ndarray:
    """Unit vector (..., 3) in the wheel plane pointing down (towards the contact point)
    of the spin axes ``s`` (..., 3): ``(s . EZ) s - EZ``, normalised."""
    d = s[..., 2:3] * s
    d[..., 2] -= 1.0
    return d / _length(d)


class AxleSolver:
    """Equilibrium solver for a batch of axles (see the module docstring)."""

    def __init__(
        self,
        axle: Axle,
        effects: Sequence[Effect] = (),
        xtol: float = 1e-6,
        rtol: float = 1e-5,
        ltol: float = 0.1,
        maxit: int = 30,
    ):
        self.axle = axle
        self.n = axle.n
        self._set_effects(effects, xtol, rtol, ltol, maxit)
        self._set_bodies(axle.points)
        self._set_elements(axle)
        self._size_preload()
        self._set_stacks(axle.frames)
        # the per-design arrays of the compiled residual (see _pack)
        self._rl_pack: np.ndarray | None = None
        self._rl_off: np.ndarray | None = None  # the compiled residual's offsets in the pack

    def _set_effects(
        self, effects: Sequence[Effect], xtol: float, rtol: float, ltol: float, maxit: int
    ) -> None:
        """The placed effects and the Newton tolerances ``xtol`` [m], ``rtol`` [rad],
        ``ltol`` [N] and iteration limit ``maxit`` (module docstring)."""
        self.effects: tuple[Effect, ...] = tuple(effects)
        self._placed = _compile(self.effects)
        #: True when an element's force depends on the loading branch (Dahl hysteresis at
        #: a bushing, strut friction), so that the equilibrium at a given rig input depends
        #: on the travel history; False for linear and cubic (elastic) bushings only
        self.path_dependent = bool(self._placed.hysteresis) or self._placed.friction is not None
        # path-dependent elements are stiff over their micrometre-scale reversals: converge
        # ten times tighter so that their force residual stays small
        tight = 0.1 if self.path_dependent else 1.0
        self.xtol, self.rtol, self.ltol = xtol * tight, rtol * tight, ltol * tight
        # reversals of path-dependent elements may need damped (slower) iterations
        self.maxit = 2 * maxit if self.path_dependent else maxit

    def _set_bodies(self, p: dict[str, np.ndarray]) -> None:
        """The bodies at the design position from the hard points ``p`` (n, 2, 3) [m]:
        reference points ``ref0`` (n, 2, 4, 3) (lower arm: the middle of its bushes;
        knuckle: the wheel centre; strut rod: the strut top; bar half: its bush), the
        body-fixed points relative to them [m], the strut axis ``a`` (unit, strut top
        towards the knuckle) with two unit normals ``u``, ``v``, and the tie-rod and
        drop-link lengths [m]; vehicle axes."""
        ref = np.stack(
            [
                0.5 * (p["lca_front_bush"] + p["lca_rear_bush"]),
                p["wheel_centre"],
                p["strut_top"],
                p["arb_bush"],
            ],
            axis=2,
        )  # (n, 2, 4, 3)
        self.ref0 = ref
        self.lca_pts = (
            np.stack([p["lca_front_bush"], p["lca_rear_bush"], p["lower_ball_joint"]], axis=2)
            - ref[:, :, 0:1]
        )
        self.kn_pts = (
            np.stack(
                [
                    p["lower_ball_joint"],
                    p["tie_rod_outer"],
                    p["drop_link_strut"],
                    p["spring_lower_seat"],
                    p["strut_axis_point"],
                ],
                axis=2,
            )
            - ref[:, :, 1:2]
        )
        self.s_upper_seat = p["spring_upper_seat"] - ref[:, :, 2]
        self.s_arb_end = p["arb_drop_link"] - ref[:, :, 3]
        mid = p["arb_bush"].copy()
        mid[..., 1] = 0.0  # the bar's middle: its bush point on the vehicle's x-z plane
        self.s_arb_mid = mid - ref[:, :, 3]
        a = p["strut_axis_point"] - p["strut_top"]
        self.a = a / _length(a)
        self.u, self.v = _perp_basis(self.a)
        # tie rod and drop link: lengths, squared and doubled (n, 2, 2)
        tie = p["tie_rod_outer"] - p["tie_rod_inner"]
        drop = p["drop_link_strut"] - p["arb_drop_link"]
        self._L_links = _length(np.stack([tie, drop], axis=-2))[..., 0]
        self.L_tie, self.L_drop = self._L_links[..., 0], self._L_links[..., 1]
        self._L_links_sq = self._L_links**2
        self._L_links_2 = 2 * self._L_links

    def _set_elements(self, axle: Axle) -> None:
        """The elastic elements and loads of ``axle`` (SI): the bar's stiffnesses at its
        middle, the bushings' stiffnesses ``K`` and body points ``ground``, the tie rods'
        rack points ``tri``, the wheel's static spin axis ``s0``, tyre, spring and wheel
        weight, and the steering system's rack compliance ``C_rack`` (n,) [m/N] and rack
        travel per pinion radian ``rack_gain`` [m/rad]."""
        p = axle.points
        kb = axle.arb_torsion
        self.k_bar_shear = ARB_SHEAR_STIFFNESS
        self.k_bar_rot = np.empty(kb.shape + (3,))  # (n, 3) about x, y, z [N*m/rad]
        self.k_bar_rot[:, 0] = self.k_bar_rot[:, 2] = ARB_BENDING_STIFFNESS
        self.k_bar_rot[:, 1] = kb
        self.ground = {
            "lca_front": p["lca_front_bush"],
            "lca_rear": p["lca_rear_bush"],
            "top_mount": p["strut_top"],
            "arb_bush": p["arb_bush"],
        }
        self.tri = p["tie_rod_inner"]
        self.s0 = spin_axis(axle.camber0, axle.toe0)
        self.K = axle.bush
        self.kt, self.Rw = axle.tyre_rate, axle.wheel_radius
        self.ks = axle.spring_rate
        self.wheel_weight = axle.wheel_weight
        c_rack = axle.constants.rack_compliance
        self.C_rack = (
            np.full(self.n, c_rack) if axle.rack_compliance is None else axle.rack_compliance
        )
        self.rack_gain = axle.constants.rack_gain
        self.L_spring0 = _length(p["spring_lower_seat"] - p["spring_upper_seat"])[..., 0]

    def _set_stacks(self, frames: dict[str, np.ndarray]) -> None:
        """The arrays stacked as the residual reads them: every body-fixed vector grouped
        by body (``_vec_body``, :data:`VEC_GROUPS`), the bushings' stiffnesses ``_K4``
        (n, 2, 4, 6) and ground points ``_ground4`` (n, 2, 4, 3) in :data:`BUSH_ORDER`, and
        the bushing frames ``_Q`` (n, 2, 4, 3, 3) when a bushing has an orientation
        (``frames``), else None."""
        # every body-fixed vector, rotated in one batched product by the residual
        vec = np.stack(
            [
                self.lca_pts[:, :, 0],  # 0 lower-arm front bush
                self.lca_pts[:, :, 1],  # 1 lower-arm rear bush
                self.lca_pts[:, :, 2],  # 2 ball joint (arm)
                self.kn_pts[:, :, 0],  # 3 ball joint (knuckle)
                self.kn_pts[:, :, 1],  # 4 tie-rod outer
                self.kn_pts[:, :, 2],  # 5 drop-link point
                self.kn_pts[:, :, 3],  # 6 spring lower seat
                self.kn_pts[:, :, 4],  # 7 strut axis point
                self.u,  # 8 tube axis normal u
                self.v,  # 9 tube axis normal v
                self.a,  # 10 tube axis
                self.s0,  # 11 wheel spin axis
                self.s_upper_seat,  # 12 spring upper seat
                self.a,  # 13 rod axis
                self.s_arb_end,  # 14 bar end (drop link)
                self.s_arb_mid,  # 15 bar middle
            ],
            axis=2,
        )
        # the same vectors grouped by body (VEC_GROUPS), each group's rows contiguous (held
        # once: :attr:`_vec` puts them back together)
        self._vec_body = {
            b: np.ascontiguousarray(vec[:, :, a:z]) for b, (a, z) in enumerate(VEC_GROUPS)
        }
        self._K4 = np.stack([self.K[b] for b in BUSH_ORDER], axis=2)  # (n, 2, 4, 6)
        self._ground4 = np.stack([self.ground[b] for b in BUSH_ORDER], axis=2)
        self._Q: np.ndarray | None = None
        if frames:
            eye = np.broadcast_to(np.eye(3), self.s0.shape[:-1] + (3, 3))
            self._Q = np.stack([frames.get(b, eye) for b in BUSH_ORDER], axis=2)

    @property
    def _vec(self) -> np.ndarray:
        """Every body-fixed vector (n, 2, 16, 3) [m or unit], in the order of
        :data:`VEC_BODY` (made from the per-body groups :attr:`_vec_body`)."""
        return np.concatenate([self._vec_body[b] for b in range(len(VEC_GROUPS))], axis=2)

    def take(self, rows: np.ndarray, axle: bool = True) -> AxleSolver:
        """A solver for the given design rows (index array or mask), sharing the set-up.

        ``axle=False``: the solver's arrays only, its ``axle`` left whole (not taken
        row by row; less memory): enough for everything but :meth:`initial_state`
        (residuals, Jacobians, :meth:`solve`, outputs), e.g. the rig's rows; rows that
        are all the same design then share its arrays (read-only zero-stride views, the
        same numbers)."""
        idx = np.arange(self.n)[rows]
        share = SHARE_ONE_DESIGN and not axle and idx.size > 0
        one = share and bool((idx == idx[0]).all())

        def pick(v: np.ndarray) -> np.ndarray:
            if one or (share and v.strides[0] == 0):  # one design's array
                return _repeated(v[idx[0], ...], idx.size)
            return v[idx]

        out = copy.copy(self)
        for key, val in self.__dict__.items():
            if key in _NOT_PER_ROW or key in ("K", "ground"):  # not rows, or views (below)
                continue
            if isinstance(val, np.ndarray) and val.ndim and val.shape[0] == self.n:
                setattr(out, key, pick(val))
            elif (
                isinstance(val, dict)
                and val
                and all(isinstance(v, np.ndarray) and v.shape[0] == self.n for v in val.values())
            ):
                setattr(out, key, {k: pick(v) for k, v in val.items()})
        # the bushings' stiffnesses and ground points by name: views of the stacked arrays
        # (held once)
        out.K = {b: out._K4[:, :, BUSH_ORDER.index(b)] for b in self.K}
        out.ground = {b: out._ground4[:, :, BUSH_ORDER.index(b)] for b in self.ground}
        if self._rl_pack is not None:  # the rows-last arrays: rows on the last axis
            # row m reads the pack's column m % c (c columns: the compiled residual's
            # rule), so that rows repeating the designs in order share the pack
            pk = self._rl_pack
            c = pk.shape[-1]
            col = idx % c
            if c == 1 or (
                share and idx.size % c == 0 and np.array_equal(col, np.arange(idx.size) % c)
            ):
                out._rl_pack = pk  # the designs repeated in order (e.g. the rig's rows)
            elif one:  # one design: its column, once
                out._rl_pack = np.ascontiguousarray(pk[..., col[0], None])
            else:
                out._rl_pack = pk[..., col]
        if axle:
            out.axle = self.axle.take(idx)
        out.n = idx.size
        return out

    # ------------------------------------------------------------------ set-up
    def _size_preload(self) -> None:
        """Spring free length and static pad height from virtual work at the design position.

        With ideal joints (no bushing deflection) the design position is in exact
        equilibrium under the static tyre load (corner load + wheel weight) when the
        spring force is ``F = (Fz dz_cp - W dz_wc) / (-dL)`` along the kinematic
        motion (dz_wc = 1, :meth:`_unit_motion`). The static pad height loads the tyre
        by ``Fz / kt``.
        """
        ax, p = self.axle, self.axle.points
        wc = p["wheel_centre"]
        dq = self._unit_motion(p)
        # the spring: from the lower seat (knuckle) to the upper seat on the strut rod
        seat = _length(self.s_upper_seat)  # along the rod from the strut top
        e = p["spring_lower_seat"] - p["strut_top"] - seat * self.a
        e = e / _length(e)
        c = cross(np.stack([self.a, self.kn_pts[:, :, 3]]), np.stack([e, e]))  # 3: lower seat
        turn = dot(c[0], dq[..., 3:])  # the rod turns with the knuckle
        dL = dot(np.concatenate([e, c[1]], axis=-1), dq) - seat[..., 0] * turn
        # the contact point: the wheel centre's height minus Rw sqrt(1 - s_z^2)
        s = self.s0
        ds_z = dq[..., 3] * s[..., 1] - dq[..., 4] * s[..., 0]  # (dw x s)_z
        dcp = dq[..., 2] + self.Rw * s[..., 2] * ds_z / np.sqrt(1.0 - s[..., 2] ** 2)
        Fz = ax.corner_load + ax.wheel_weight
        F_spring = (Fz * dcp - ax.wheel_weight) / (-dL)
        self.motion_ratio_kinematic = -dL
        self.L_free = self.L_spring0 + F_spring / self.ks
        cp0 = (wc + self.Rw[..., None] * wheel_down(s))[..., 2]
        self.pad_static = cp0 + Fz / self.kt

    def _unit_motion(self, p: dict[str, np.ndarray]) -> np.ndarray:
        """The knuckle's motion (n, 2, 6) (translation ``dt`` [m], rotation ``dw`` [rad],
        vehicle axes) per metre of wheel-centre rise at the design position, with ideal
        joints: the six ideal-joint equations (the tests' reference
        ``CornerKinematics``, ``tests/mcpherson_kinematics.py``) in closed form: a
        knuckle move moves its point ``q`` by ``dt + dw x (q - wheel centre)``."""
        wc = p["wheel_centre"]
        # d(e . point at) / d(dt, dw) = (e, (at - wc) x e): the cross products of a step
        # in one call each (the same numbers as one call per row); ``at - wc``: the
        # knuckle's body-fixed points (ball joint, tie-rod outer, strut axis point)
        B, TRO, strut = p["lower_ball_joint"], p["tie_rod_outer"], p["strut_axis_point"]
        links = np.stack(
            [B - p["lca_front_bush"], B - p["lca_rear_bush"], TRO - p["tie_rod_inner"]]
        )
        e3 = links / _length(links)  # the two lower-arm links and the tie rod
        gap = p["strut_top"] - strut  # the strut top stays on the knuckle's strut line
        ball, tro, arm_s = (self.kn_pts[:, :, k] for k in (0, 1, 4))
        c = cross(
            np.stack([ball, ball, tro, arm_s, arm_s, self.u, self.v]),
            np.stack([e3[0], e3[1], e3[2], self.u, self.v, gap, gap]),
        )
        # the six rows (translation, rotation): the three links, the strut line (u, v),
        # the wheel-centre height
        M = np.zeros(wc.shape[:-1] + (6, 6))
        rows_last = (1, 2, 0, 3)  # (row, n, 2, 3) -> (n, 2, row, 3)
        M[..., :3, :3] = e3.transpose(rows_last)
        M[..., :3, 3:] = c[:3].transpose(rows_last)
        M[..., 3, :3] = -self.u
        M[..., 4, :3] = -self.v
        M[..., 3:5, 3:] = (c[5:] - c[3:5]).transpose(rows_last)
        M[..., 5, 2] = 1.0
        rhs = np.zeros(wc.shape[:-1] + (6, 1))
        rhs[..., 5, 0] = 1.0
        return np.linalg.solve(M, rhs)[..., 0]

    def initial_state(self) -> AxleState:
        n = self.n
        R = np.broadcast_to(np.eye(3), (n, 2, 4, 3, 3)).copy()
        st = AxleState(self.ref0.copy(), R, np.zeros((n, 2, NL)))
        for b in self._placed.hysteresis:
            st.hyst[b] = (np.zeros((n, 2, 6)), np.zeros((n, 2, 6)))
        if self._placed.friction is not None:
            slide0 = -np.linalg.norm(
                self.ground["top_mount"] - self.axle.points["strut_axis_point"], axis=-1
            )
            st.fric = (slide0, np.zeros((n, 2)))
        return st

    # --------------------------------------------------------------- elements
    def _friction(self) -> tuple[float, float]:
        """(level [N], pre-sliding stiffness [N/m]) of the strut friction."""
        if self._placed.friction is None:
            raise ValidationError("the axle has no strut friction")
        return self._placed.friction

    def _cubic(self, name: str, x: np.ndarray) -> np.ndarray:
        """The load (..., 6) that the placed cubic stiffness of bushing ``name`` exerts
        *against* its deflection ``x`` (..., 6) (bushing frame); zero without one."""
        f = np.zeros(np.broadcast_shapes(x.shape, self.K[name].shape))
        if name in self._placed.cubic:
            ratio, x_ref = self._placed.cubic[name]
            k3 = ratio * self.K[name][..., :3] / x_ref**2
            f[..., :3] += cubic_stiffness(x[..., :3], k3)
        return f

    def _dahl(self, names: Sequence[str], x: np.ndarray, hist: dict) -> np.ndarray:
        """Dahl forces (..., k, 6) of the bushings ``names`` (k) at their deflections
        ``x`` (..., k, 6) (bushing frames), from their histories ``hist`` (bushing ->
        (deflection, Dahl force) of the last committed step), in one :func:`dahl_step`."""
        idx = [BUSH_ORDER.index(b) for b in names]
        par = np.array([self._placed.hysteresis[b] for b in names])  # (k, 3)
        sigma = par[:, 0:1] * self._K4[:, :, idx]  # (n, 2, k, 6)
        fc = np.repeat(par[:, 1:], 3, axis=1)  # force on translation, moment on rotation
        x_prev = np.stack([hist[b][0] for b in names], axis=-2)
        z_prev = np.stack([hist[b][1] for b in names], axis=-2)
        return dahl_step(x_prev, x, sigma, fc, z_prev, _DAHL_EPS)

    def deflections(self, r: np.ndarray, R: np.ndarray) -> dict[str, np.ndarray]:
        """Bushing deflections (..., 2, 6): translation [m] and rotation vector [rad], in
        each bushing's frame (vehicle axes for a bushing without an orientation)."""
        x = self._bush_deflections(r, R)
        return {name: x[..., j, :] for j, name in enumerate(BUSH_ORDER)}

    def lockups(self, st: AxleState) -> Iterator[tuple[str, np.ndarray, np.ndarray, np.ndarray]]:
        """Per bushing at the state ``st``: (name, its largest translation [m] and rotation
        [rad] over both sides (n,), locked (n,) bool: beyond :data:`MAX_TRANSLATION` or
        :data:`MAX_ROTATION`, or not finite)."""
        for name, d in self.deflections(st.r, st.R).items():
            tr = np.abs(d[..., :3]).max(axis=(-1, -2))
            rot = np.abs(d[..., 3:]).max(axis=(-1, -2))
            yield name, tr, rot, ~((tr <= MAX_TRANSLATION) & (rot <= MAX_ROTATION))

    def _bush_deflections(self, r: np.ndarray, R: np.ndarray) -> np.ndarray:
        """:meth:`deflections` stacked (..., 2, 4, 6) in BUSH_ORDER."""
        arm = self._vec_body[0][..., 0:2, :]  # the lower arm's two bushes
        return self._to_bush(self._deflections(r, R, rotate(R[..., [0, 0], :, :], arm)))

    def _to_bush(self, x: np.ndarray) -> np.ndarray:
        """Stacked deflections (..., 2, 4, 6) from vehicle axes into the bushing frames
        (``Q^T``; identity without orientations)."""
        return x if self._Q is None else _rotate_six(np.swapaxes(self._Q, -1, -2), x)

    def _to_vehicle(self, f: np.ndarray) -> np.ndarray:
        """Stacked loads (..., 2, 4, 6) from the bushing frames into vehicle axes (``Q``)."""
        return f if self._Q is None else _rotate_six(self._Q, f)

    def _deflections(
        self, r: np.ndarray, R: np.ndarray, arms_lca: np.ndarray, phi: np.ndarray | None = None
    ) -> np.ndarray:
        """Stacked bushing deflections (..., 2, 4, 6) in BUSH_ORDER (``phi``: the rotation
        vectors ``log_so3(R[..., [0, 0, 2, 3], :, :])`` when already computed)."""
        pts = np.concatenate([r[..., 0:1, :] + arms_lca, r[..., 2:4, :]], axis=-2)
        if phi is None:  # the lower arm's once, for both of its bushes
            phi = log_so3(R[..., [0, 2, 3], :, :])[..., [0, 0, 1, 2], :]
        return np.concatenate([pts - self._ground4, phi], axis=-1)

    # ---------------------------------------------------------------- residual
    def residual(
        self,
        r: np.ndarray,
        R: np.ndarray,
        lam: np.ndarray,
        pad: np.ndarray,
        state: AxleState,
        ext: np.ndarray | None = None,
        rack: np.ndarray | None = None,
    ) -> np.ndarray:
        """Residual (..., n, 2, 33) of trial coordinates ``r`` (..., n, 2, 4, 3) [m] and
        ``R`` (..., n, 2, 4, 3, 3); the inputs broadcast against (..., n, 2).

        ``pad`` (n, 2) pad heights [m]; ``ext`` (n, 2, 6) extra force [N] and moment
        [N*m] on the wheel at the loaded contact point (where the wheel plane's downward
        radius meets the pad plane: the rig's pad), or (n, 2, 9) with a further force [N]
        (columns 6-8) at the wheel centre. ``rack`` (n, 2) [m]: travel of the tie-rod
        inner points along +y from their design position (None: zero). ``state``: the
        history of the path-dependent effects. Rows per side: force [N] and moment about
        the reference point [N*m] of the four bodies (vehicle axes), then the constraints
        times :data:`CSCALE`: ball joint (3), cylindrical joint (4), tie rod, drop link.

        Computed row by row by the compiled loop :func:`.residual_kernel.residual` (the
        one writing of the equations); the placed effects' loads (cubic and Dahl
        bushings, strut friction: :meth:`_effect_loads`) are computed here from the
        deflections and handed to it.
        """
        if r.shape[-4:-2] != (self.n, 2) or R.shape[:-3] != r.shape[:-2]:
            raise ValidationError(
                f"residual: states must be (..., n, 2, 4, 3) and (..., n, 2, 4, 3, 3) with "
                f"n = {self.n}, but got {r.shape} and {R.shape}"
            )
        extra = self._effect_loads(r, R, state)
        lead = r.shape[:-2]
        out = np.empty((math.prod(lead[:-1]), 2, NS))
        residual_kernel.residual(*self._kernel_inputs(r, R, lam, pad, ext, rack, extra), out)
        return out.reshape(lead + (NS,))

    def _effect_loads(self, r: np.ndarray, R: np.ndarray, state: AxleState) -> np.ndarray | None:
        """The placed effects' loads (..., n, 2, :data:`N_EXTRA`) at the coordinates
        ``r``, ``R`` (None without placed effects): the four bushings' loads beyond the
        linear ones [N, N*m] (vehicle axes; cubic stiffness and Dahl elements in each
        bushing's frame, history from ``state``) and the strut friction force [N] along
        the tube axis on the knuckle (Dahl, from the slide of the rod in the tube)."""
        placed = self._placed
        if not (placed.cubic or placed.hysteresis or placed.friction):
            return None
        out = np.zeros(r.shape[:-2] + (N_EXTRA,))
        if placed.cubic or placed.hysteresis:
            xb = self._bush_deflections(r, R)
            f = np.zeros_like(xb)
            for j, name in enumerate(BUSH_ORDER):
                if name in placed.cubic:
                    f[..., j, :] = self._cubic(name, xb[..., j, :])
            names = [b for b in BUSH_ORDER if b in state.hyst]
            if names:  # every Dahl bushing in one step
                idx = [BUSH_ORDER.index(b) for b in names]
                f[..., idx, :] += self._dahl(names, xb[..., idx, :], state.hyst)
            out[..., :24] = self._to_vehicle(f).reshape(out.shape[:-1] + (24,))
        if state.fric is not None:
            out[..., 24] = self._strut_friction(r, R, state.fric)[1]
        return out

    def _strut_friction(
        self, r: np.ndarray, R: np.ndarray, fric: tuple[np.ndarray, np.ndarray]
    ) -> tuple[np.ndarray, np.ndarray]:
        """The slide (..., n, 2) [m] of the rod in the tube (along the tube axis, from
        the knuckle's strut axis point) at the coordinates ``r``, ``R`` and the strut
        friction's Dahl force [N] there, from ``fric`` (slide, force) of the last
        committed step."""
        R1 = R[..., 1, :, :]
        ak = rotate(R1, self.a)
        slide = dot(r[..., 2, :] - r[..., 1, :] - rotate(R1, self.kn_pts[..., 4, :]), ak)
        s_prev, z_prev = (np.broadcast_to(q, slide.shape) for q in fric)
        f_c, sigma = self._friction()
        return slide, dahl_step(s_prev, slide, sigma, f_c, z_prev, DAHL_EPS_TRANSLATION)

    def _pack(self) -> np.ndarray:
        """The solver's per-design arrays that the compiled residual reads (K, 2, c),
        made once (``_rl_pack``; offsets ``_rl_off``) and taken with the solver's rows by
        :meth:`take`, row ``m`` reading column ``m % c`` (c = n, or fewer columns
        shared by rows that repeat the designs in order)."""
        if self._rl_pack is None:
            parts = [(name, a, tail) for name, a, tail in self._pack_parts() if a is not None]
            widths = tuple((name, math.prod(a.shape[a.ndim - tail :])) for name, a, tail in parts)
            self._rl_off, size = _pack_offsets(widths)
            self._rl_pack = np.empty((size, 2, self.n))
            at = 0
            for (_, a, tail), (_, w) in zip(parts, widths, strict=True):
                # rows last: the (n, 2, w) view of these pack rows takes the array (its side
                # axis broadcast where it has one value per design)
                self._rl_pack[at : at + w].T[...] = a.reshape(a.shape[: a.ndim - tail] + (w,))
                at += w
        if not (self._rl_pack.flags.c_contiguous and self._rl_pack.flags.writeable):
            return np.array(self._rl_pack, order="C")  # one compiled type
        return self._rl_pack

    def _pack_parts(self) -> list[tuple[str, np.ndarray | None, int]]:
        """(field of :data:`_KERNEL_FIELDS`, array (n, 2 or 1, ...), its trailing axes
        per side) of every per-design array of the pack, in pack order (the body-fixed
        vectors body by body, :data:`VEC_GROUPS`, as field ``vec``; no frames: None)."""
        vec = [("vec", self._vec_body[b], 2) for b in range(len(VEC_GROUPS))]
        return [
            *vec,
            ("ground", self._ground4, 2),
            ("K", self._K4, 2),
            ("Q", self._Q, 3),
            ("tri", self.tri, 1),
            ("L_links", self._L_links, 1),
            ("L_links_sq", self._L_links_sq, 1),
            ("L_links_2", self._L_links_2, 1),
            ("ks", self.ks, 0),
            ("L_free", self.L_free, 0),
            ("Rw", self.Rw, 0),
            ("kt", self.kt, 0),
            ("W", self.wheel_weight, 0),
            ("k_bar_rot", self.k_bar_rot[:, None, :], 1),
            ("C_rack", self.C_rack[:, None], 0),
        ]

    def _kernel_inputs(
        self,
        r: np.ndarray,
        R: np.ndarray,
        lam: np.ndarray,
        pad: np.ndarray,
        ext: np.ndarray | None,
        rack: np.ndarray | None,
        extra: np.ndarray | None = None,
    ) -> tuple:
        """The arguments of :func:`.residual_kernel.residual` (and of its Jacobian): the
        states flattened to rows, the inputs given per design row read as such (others
        broadcast), the per-design pack with its offsets. Every array C-contiguous and
        writeable (a copy where it is a read-only view, e.g. the states of a block of one
        perturbation broadcast): numba's JIT types a read-only array apart and would run a
        second machine code of the loop for it."""
        lead = r.shape[:-2]  # (..., n, 2)
        rows = lead[:-1]
        M = math.prod(rows)
        pack = self._pack()  # row m reads column m % c (take() shares or takes columns)
        n = self.n

        def rows_of(a: np.ndarray | None, tail: int) -> np.ndarray:
            """``a`` (..., 2, *tail) as (rows or design rows, 2, *tail), or empty."""
            if a is None:
                return _NO_ROWS[tail]
            head = a.shape[: a.ndim - 1 - tail]
            if head == (n,) or head == rows:
                k = n if head == (n,) else M
            else:
                a, k = np.broadcast_to(a, lead + a.shape[a.ndim - tail :]), M
            return np.require(a, float, ("C", "W")).reshape((k,) + a.shape[a.ndim - 1 - tail :])

        return (
            np.require(r.reshape(M, 2, 4, 3), float, ("C", "W")),
            np.require(R.reshape(M, 2, 4, 3, 3), float, ("C", "W")),
            rows_of(lam, 1),
            rows_of(pad, 0),
            rows_of(ext, 1),
            rows_of(rack, 0),
            rows_of(extra, 1),
            pack,
            self._rl_off,
            float(self.k_bar_shear),
            CSCALE,
        )

    # ---------------------------------------------------------------- Jacobian
    def jacobian(
        self,
        st: AxleState,
        pad: np.ndarray,
        ext: np.ndarray | None = None,
        h: float = 1e-7,
        rack: np.ndarray | None = None,
    ) -> np.ndarray:
        """Jacobian (n, 66, 66) of the full residual with respect to (x_left, x_right).

        Body coordinates: forward differences (step ``h`` [m] or [rad]), the
        perturbations batched in blocks of about :data:`JACOBIAN_BLOCK` row evaluations
        per residual call. Only the bar halves couple the sides, so every other column
        is perturbed on both sides at once; the bar-half columns are perturbed one side
        at a time. Columns whose residual rows are disjoint share a perturbation (a
        lower-arm and a strut-rod coordinate: the lower arm's rows are its own force and
        moment and the ball joint's constraint, which no strut-rod coordinate enters),
        which gives the very numbers of perturbing them apart. The multiplier columns:
        differences of the residual too (:meth:`_multiplier_columns`). The
        reference path, one perturbation per column: ``benchmarks/knc_reference.py``.
        """
        n = self.n
        J = np.zeros((n, 2 * NS, 2 * NS))
        if JACOBIAN_COMPILED and self._effect_loads(st.r, st.R, st) is None:
            # the compiled loop: each row perturbed and differenced in place (no blocks)
            args = self._kernel_inputs(st.r, st.R, st.lam, pad, ext, rack)
            # every body turned by h about x, y, z: (n, 2, 4, axis, 3, 3)
            turned = np.matmul(_exp_h(h)[:, None, None, None], st.R[None])
            turned = np.ascontiguousarray(turned.transpose(1, 2, 3, 0, 4, 5))
            residual_kernel.jacobian(*args, h, turned, *_KERNEL_COLOURING, J)
        else:
            self._body_columns_in_blocks(st, pad, ext, h, rack, J)
        self._multiplier_columns(st, pad, ext, rack, J)
        return J

    def _body_columns_in_blocks(
        self,
        st: AxleState,
        pad: np.ndarray,
        ext: np.ndarray | None,
        h: float,
        rack: np.ndarray | None,
        J: np.ndarray,
    ) -> None:
        """The coloured perturbations of :meth:`jacobian` in blocks of at most
        :data:`JACOBIAN_PERTURBATIONS` through :meth:`residual`, their differences into
        the body-coordinate columns of ``J`` (n, 66, 66)."""
        n = self.n
        exp_h = _exp_h(h)  # rotations by h about x, y, z
        base = self.residual(st.r, st.R, st.lam, pad, st, ext, rack=rack)  # (n, 2, 33)
        per = max(1, min(JACOBIAN_BLOCK // max(n, 1), JACOBIAN_PERTURBATIONS))
        moves, scatter = _COLOURED_MOVES, _COLOURED_SCATTER
        for a in range(0, _N_COLOURED, per):
            P = min(per, _N_COLOURED - a)
            r = np.broadcast_to(st.r, (P,) + st.r.shape).copy()
            R = np.broadcast_to(st.R, (P,) + st.R.shape).copy()
            # the coordinate moves of these perturbations: (perturbation, side, body, axis)
            i0, i1 = np.searchsorted(moves[0], [a, a + P])
            p, sd, b, k = (x[i0:i1] for x in moves)
            tr = k < 3
            r[p[tr] - a, :, sd[tr], b[tr], k[tr]] += h
            ro = ~tr
            turned = np.matmul(exp_h[k[ro] - 3][:, None], np.moveaxis(st.R[:, sd[ro], b[ro]], 0, 1))
            R[p[ro] - a, :, sd[ro], b[ro]] = turned
            d = self.residual(r, R, st.lam, pad, st, ext, rack=rack) - base  # (P, n, 2, 33)
            d /= h
            # every difference to its Jacobian entry (row, column)
            i0, i1 = np.searchsorted(scatter[0], [a, a + P])
            p, sd, row, jr, jc = (x[i0:i1] for x in scatter)
            J[:, jr, jc] = d[p - a, :, sd, row].T

    def _multiplier_columns(
        self,
        st: AxleState,
        pad: np.ndarray,
        ext: np.ndarray | None,
        rack: np.ndarray | None,
        J: np.ndarray,
    ) -> None:
        """The multiplier columns of ``J`` (n, 66, 66) by forward differences of 1 N
        (N*m for the joint's moments ``lam[3:5]``), all in one residual call, as the
        compiled sweep takes them. The residual is linear in the multipliers, so the
        differences are exact up to the round-off of the kN-sized load sums (about
        1e-11); a multiplier enters its own side's rows only, so both sides' are moved
        at once, but for the tie rods of a compliant steering system, which move the
        rack and so enter both sides' rows: those one side at a time."""
        coupled = bool(np.any(self.C_rack > 0))
        cols: list[tuple[int, int | None]] = [(k, None) for k in range(NL) if k != 7 or not coupled]
        cols += [(7, s) for s in (0, 1)] if coupled else []
        base = self.residual(st.r, st.R, st.lam, pad, st, ext, rack=rack)
        per = max(1, min(JACOBIAN_BLOCK // max(self.n, 1), JACOBIAN_PERTURBATIONS))
        for a in range(0, len(cols), per):  # in blocks, as the body columns (memory)
            block = cols[a : a + per]
            lam = np.repeat(st.lam[None], len(block), axis=0)
            for p, (k, side) in enumerate(block):
                lam[p, :, slice(None) if side is None else side, k] += 1.0
            r, R = (np.broadcast_to(q, lam.shape[:1] + q.shape) for q in (st.r, st.R))
            d = self.residual(r, R, lam, pad, st, ext, rack=rack) - base
            for p, (k, side) in enumerate(block):
                if side is None:
                    for s in (0, 1):
                        J[:, s * NS : (s + 1) * NS, s * NS + NQ + k] = d[p, :, s]
                else:
                    J[:, :, side * NS + NQ + k] = d[p].reshape(self.n, 2 * NS)

    # ------------------------------------------------------------------ update
    @staticmethod
    def _apply(st: AxleState, dx: np.ndarray, rows: np.ndarray) -> AxleState:
        """New state = st moved by dx (n, 66) on ``rows`` (bool mask)."""
        if not rows.all():
            dx = np.where(rows[:, None], dx, 0.0)
        dx = dx.reshape(st.r.shape[0], 2, NS)
        dq = dx[..., :NQ].reshape(st.r.shape[0], 2, 4, 6)
        return st.moved(st.r + dq[..., :3], turned(dq[..., 3:], st.R), st.lam + dx[..., NQ:])

    def _step_size(self, dx: np.ndarray, dp: np.ndarray | None = None) -> np.ndarray:
        """Per-row size (n,) of a Newton step relative to the tolerances (< 1: converged):
        the largest of its translations over ``xtol``, rotations over ``rtol`` and
        multipliers over ``ltol`` (NaN for a step that is not finite), and of the pad
        steps ``dp`` (n, 2) [m] of a wheel-centre drive over ``xtol``."""
        size = np.abs(dx)
        size /= _tolerances(self.xtol, self.rtol, self.ltol)  # in place (memory)
        out = size.max(axis=-1)
        if dp is not None:
            out = np.maximum(out, np.abs(dp).max(axis=-1) / self.xtol)
        return out

    def solve(
        self,
        st: AxleState,
        pad: np.ndarray,
        ext: np.ndarray | None = None,
        active: np.ndarray | None = None,
        Jinv: np.ndarray | SharedInverse | None = None,
        rack: np.ndarray | None = None,
        centre: np.ndarray | None = None,
    ) -> tuple[AxleState, np.ndarray, np.ndarray | SharedInverse]:
        """Newton iteration from ``st`` for pad heights ``pad`` (n, 2), extra wheel load
        ``ext`` and rack travel ``rack`` (n, 2) [m] (see :meth:`residual`).

        ``Jinv`` is an inverse Jacobian to start with (e.g. from the previous step; per
        row (n, 66, 66) or a :class:`SharedInverse`); a
        row's Jacobian is refreshed when its Newton step shrinks by less than half, and
        its step is damped (halved, down to 1/64, for the rest of the solve) when even a
        fresh Jacobian's steps stop shrinking (a cycle, e.g. at a reversal of a Dahl
        element). Returns (state, converged (n,) bool, inverse Jacobian);
        ``Jinv`` is updated in place. Rows not in ``active`` are left untouched and
        reported as not converged.

        ``centre`` (n, 2) [m]: wheel-centre heights to reach (NaN: that wheel's pad is
        held at ``pad``), the rig's wheel-centre travel drive: the pad heights of those
        wheels become unknowns, updated in place in ``pad`` with the bordered Newton step
        of :class:`_CentreDrive`; a row has converged when its pad steps are below
        ``xtol`` too.
        """
        n = self.n
        active = np.ones(n, bool) if active is None else active.copy()
        rows = _NewtonRows(n)
        if Jinv is None:
            Jinv = self.inverse_jacobian(st, pad, ext, active, rack)
            rows.fresh[:] = True
        drive = None if centre is None else _CentreDrive(self, st, Jinv, centre)
        for _ in range(self.maxit):
            res = self._open_residuals(st, pad, ext, rack, active & ~rows.conv & rows.finite)
            dx = _inv_mul(Jinv, res)  # a new array: negated in place (memory)
            np.negative(dx, out=dx)
            dp = None if drive is None else drive.border(st, dx)
            size = self._step_size(dx, dp)
            rows.finite = np.isfinite(size)
            todo = active & ~rows.conv & rows.finite
            if not todo.any():
                break
            refresh = todo & (size > 0.5 * rows.prev) & ~rows.fresh  # slow without a fresh J
            if refresh.any():  # refresh these rows' Jacobians (in place), recompute steps
                dp, size = self._refresh(
                    refresh, st, pad, ext, rack, res, Jinv, dx, dp, drive, size
                )
            del res  # not read again this iteration (memory)
            step = rows.step_lengths(todo, size, refresh)
            dx *= step[:, None]  # in place (memory): dx is not read again
            dx[~todo] = 0.0
            st = self._apply(st, dx, todo)
            if dp is not None:  # the driven wheels' pads move with the step
                pad += np.where(todo[:, None], dp * step[:, None], 0.0)
            del dx  # freed before the next iteration makes its own (memory)
            rows.converge(todo, size, self.path_dependent)
            if (rows.conv | ~active | ~rows.finite).all():
                break
        return st, rows.conv & active, Jinv

    def _open_residuals(
        self,
        st: AxleState,
        pad: np.ndarray,
        ext: np.ndarray | None,
        rack: np.ndarray | None,
        need: np.ndarray,
    ) -> np.ndarray:
        """The residuals (n, 66) of :meth:`solve`'s iterate: of the rows still iterating
        (``need``, bool mask) only when they are at most half the batch (the same numbers
        per row; the others NaN: their steps are not taken), else of every row."""
        n = self.n
        if not (SUBSET_RESIDUALS and n >= 8 and 2 * need.sum() <= n):
            return self.residual(st.r, st.R, st.lam, pad, st, ext, rack=rack).reshape(n, 2 * NS)
        idx = np.flatnonzero(need)
        res = np.full((n, 2 * NS), np.nan)
        sub, st_i, pad_i, ext_i, rack_i = self._rows(idx, st, pad, ext, rack)
        res[idx] = sub.residual(st_i.r, st_i.R, st_i.lam, pad_i, st_i, ext_i, rack=rack_i).reshape(
            idx.size, 2 * NS
        )
        return res

    def _refresh(
        self,
        rows: np.ndarray,
        st: AxleState,
        pad: np.ndarray,
        ext: np.ndarray | None,
        rack: np.ndarray | None,
        res: np.ndarray,
        Jinv: np.ndarray | SharedInverse,
        dx: np.ndarray,
        dp: np.ndarray | None,
        drive: _CentreDrive | None,
        size: np.ndarray,
    ) -> tuple[np.ndarray | None, np.ndarray]:
        """Fresh inverse Jacobians of ``rows`` (bool mask) at ``st`` into ``Jinv`` and
        their Newton steps into ``dx`` (both in place) from the residuals ``res`` (n,
        66); returns the pad steps ``dp`` (n, 2) [m] of a wheel-centre drive (None
        without one) and the step sizes (n,) (:meth:`_step_size`) with these rows'
        recomputed."""
        sub, st_i, pad_i, ext_i, rack_i = self._rows(rows, st, pad, ext, rack)
        fresh_inv = sub.inverse_jacobian(st_i, pad_i, ext_i, rack=rack_i)
        if isinstance(Jinv, SharedInverse):
            Jinv.set(rows, fresh_inv)
        else:
            Jinv[rows] = fresh_inv
        dx[rows] = -np.matmul(fresh_inv, res[rows][..., None])[..., 0]
        del fresh_inv  # kept by Jinv (memory)
        if drive is not None and dp is not None:
            dp = np.where(rows[:, None], drive.border(st, dx, rows), dp)
        return dp, np.where(rows, self._step_size(dx, dp), size)

    def _rows(
        self,
        rows: np.ndarray,
        st: AxleState,
        pad: np.ndarray,
        ext: np.ndarray | None,
        rack: np.ndarray | None,
    ) -> tuple[AxleSolver, AxleState, np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The solver, state and inputs of the given rows (index array or mask)."""
        return (
            self.take(rows, axle=False),
            st.take(rows),
            pad[rows],
            None if ext is None else ext[rows],
            None if rack is None else rack[rows],
        )

    def inverse_jacobian(self, st, pad, ext=None, active=None, rack=None) -> np.ndarray:
        """Inverse (n, 66, 66) of :meth:`jacobian`; singular rows (lock-up) become NaN."""
        J = self.jacobian(st, pad, ext, rack=rack)
        if active is not None:
            J[~active] = np.eye(2 * NS)
        bad = ~np.isfinite(J).all(axis=(1, 2))
        J[bad] = np.eye(2 * NS)
        # inverted in place, in blocks of rows (bounded memory; the same numbers)
        per = max(1, JACOBIAN_BLOCK // 32)
        for a in range(0, J.shape[0], per):
            blk = J[a : a + per]
            try:
                blk[...] = np.linalg.inv(blk)
            except np.linalg.LinAlgError:
                for i in range(blk.shape[0]):
                    try:
                        blk[i] = np.linalg.inv(blk[i])
                    except np.linalg.LinAlgError:
                        blk[i] = np.nan
        J[bad] = np.nan
        return J

    def two_leg_sweep(
        self,
        pad_off: np.ndarray,
        ext: np.ndarray | None,
        rack: np.ndarray | None,
        kept: slice,
        h: float = 1e-7,
    ) -> tuple[AxleState, np.ndarray]:
        """The rig's two-leg sweep of every design in one compiled call
        (:func:`.sweep_kernel.sweep`: static equilibrium, then every test's bump and
        rebound legs from it, Newton step by step as :meth:`solve`) for an axle without
        placed effects. Per test and grid point (T, G): pad offsets ``pad_off`` (T, G,
        2) [m] from :attr:`pad_static`, wheel loads ``ext`` (T, G, 2, 6|9) [N, N*m] or
        None, rack travel ``rack`` (T, G, 2) [m] or None. Returns the states at the grid
        points ``kept`` (T, Q, n, ...) and every design's status (n,) (0: converged
        everywhere, else :data:`.sweep_kernel.NO_STATIC`, ``NO_STEP`` or ``LOCKED``)."""
        if self._placed.cubic or self._placed.hysteresis or self._placed.friction:
            raise ValidationError("two_leg_sweep: the compiled sweep takes no placed effects")
        T, G = pad_off.shape[:2]
        Q = len(range(G)[kept])
        n = self.n
        r = np.empty((T, Q, n, 2, 4, 3))
        R = np.empty((T, Q, n, 2, 4, 3, 3))
        lam = np.empty((T, Q, n, 2, NL))
        status = np.zeros(n, np.int64)
        pack = self._pack()
        sweep_kernel.sweep(
            pack, self._rl_off, float(self.k_bar_shear), CSCALE,
            np.ascontiguousarray(self.ref0, dtype=float),
            np.ascontiguousarray(np.broadcast_to(self.pad_static, (n, 2)), dtype=float),
            np.ascontiguousarray(pad_off, dtype=float),
            np.empty((0, 0, 2, 1)) if ext is None else np.ascontiguousarray(ext, dtype=float),
            np.empty((0, 0, 2)) if rack is None else np.ascontiguousarray(rack, dtype=float),
            np.array(_tolerances(self.xtol, self.rtol, self.ltol)), self.maxit, h,
            np.array(_exp_h(h)), *_KERNEL_COLOURING,
            np.array([MAX_TRANSLATION, MAX_ROTATION]), range(G)[kept][0], r, R, lam, status,
        )  # fmt: skip
        return AxleState(r, R, lam), status

    def pad_sensitivity(self, st: AxleState) -> np.ndarray:
        """d(residual)/d(pad height) (n, 2, 33): the tyre force and its moment on the knuckle."""
        out = np.zeros(st.lam.shape[:-1] + (NS,))
        s = rotate(st.R[..., 1, :, :], self.s0)
        arm = self.Rw[..., None] * wheel_down(s)  # contact point - wheel centre
        out[..., 6 + 2] = self.kt
        out[..., 9:12] = cross(arm, EZ) * self.kt[..., None]
        return out

    def commit(self, st: AxleState) -> AxleState:
        """Make the converged state the history of the path-dependent elements."""
        if not st.hyst and st.fric is None:
            return st
        out = st.copy()
        defl = self.deflections(st.r, st.R)
        names = list(out.hyst)
        if names:
            z = self._dahl(names, np.stack([defl[b] for b in names], axis=-2), st.hyst)
            for k, name in enumerate(names):
                out.hyst[name] = (defl[name].copy(), z[..., k, :].copy())
        if st.fric is not None:
            out.fric = self._strut_friction(st.r, st.R, st.fric)
        return out

    # ----------------------------------------------------------------- outputs
    def rack_force(self, st: AxleState) -> np.ndarray:
        """Net lateral force (..., n) [N] of both tie rods on the rack at a converged
        state, along +y. Each tie rod pulls its rack end towards its knuckle end with
        its multiplier per unit length; the rack end's y is where the tie rod's design
        length puts it (its x and z are the inner point's: the rack moves along y
        only), on the side of the inner point it had at design."""
        pt = st.r[..., 1, :] + rotate(st.R[..., 1, :, :], self.kn_pts[:, :, 1])
        d = pt - self.tri  # knuckle end - rack end, y still to be set
        side = np.sign(self.ref0[..., 1, 1] + self.kn_pts[..., 1, 1] - self.tri[..., 1])
        d_y = side * np.sqrt(np.maximum(self.L_tie**2 - d[..., 0] ** 2 - d[..., 2] ** 2, 0.0))
        return -(st.lam[..., 7] / self.L_tie * d_y).sum(axis=-1)

    def outputs(
        self, st: AxleState, pad: np.ndarray, names: Sequence[str] | None = None
    ) -> dict[str, np.ndarray]:
        """Channels (n, 2) [SI, ISO 8855] of a converged state; see ``docs/knc.md``.

        ``names``: compute only these channels (None: all; the same numbers)."""

        def want(*keys: str) -> bool:
            return names is None or any(key in names for key in keys)

        R1 = st.R[..., 1, :, :]
        wc = st.r[..., 1, :]
        s = rotate(R1, self.s0)
        down = wheel_down(s)
        cp = wc + self.Rw[..., None] * down
        sg = SIDE_SIGN
        out: dict[str, np.ndarray] = {
            "wheel_centre_x": wc[..., 0],
            "wheel_centre_y": wc[..., 1],
            "wheel_centre_z": wc[..., 2],
            "contact_x": cp[..., 0],
            "contact_y": cp[..., 1],
            "contact_z": cp[..., 2],
            "pad_z": pad,
            "tyre_fz": self.kt * (pad - cp[..., 2]),
        }
        if want("toe"):  # the wheel's heading sg (s x EZ) = sg (s_y, -s_x, 0), normalised
            hx, hy = sg * s[..., 1], sg * -s[..., 0]
            hn = np.sqrt(hx * hx + hy * hy)
            out["toe"] = -sg * np.arctan2(hy / hn, hx / hn)
        if want("camber"):
            out["camber"] = -np.arcsin(np.clip(s[..., 2], -1, 1))
        top = st.r[..., 2, :]
        if want("caster", "kpi", "scrub_radius", "trail"):
            pB = wc + rotate(R1, self.kn_pts[:, :, 0])
            k = top - pB
            k /= _length(k)
            out["caster"] = np.arctan2(-k[..., 0], k[..., 2])
            if want("kpi"):
                out["kpi"] = np.arctan2(-sg * k[..., 1], k[..., 2])
        if want("scrub_radius", "trail"):
            # steering axis meets the pad plane at g; the loaded contact point cpl is where
            # the wheel plane's downward radius meets the pad plane; scrub radius (SAE sign:
            # positive when g lies inboard of cpl) and trail (positive when g lies ahead of
            # cpl) along the vehicle's y and x axes, as ADAMS/Car's suspension outputs
            t = (pad - pB[..., 2]) / k[..., 2]
            g = pB + t[..., None] * k
            cpl = wc + ((pad - wc[..., 2]) / down[..., 2])[..., None] * down
            out["scrub_radius"] = sg * (cpl[..., 1] - g[..., 1])
            out["trail"] = g[..., 0] - cpl[..., 0]
        if want("spring_length", "spring_force"):
            pL = wc + rotate(R1, self.kn_pts[:, :, 3])
            pU = top + rotate(st.R[..., 2, :, :], self.s_upper_seat)
            L = np.linalg.norm(pL - pU, axis=-1)
            out["spring_length"] = L
            out["spring_force"] = self.ks * (self.L_free - L)
        if want("arb_twist"):
            R_bar = np.matmul(st.R[..., 0, 3, :, :], np.swapaxes(st.R[..., 1, 3, :, :], -1, -2))
            rho = log_so3(R_bar)[..., 1]
            out["arb_twist"] = np.stack([rho, rho], axis=-1)
        if want("knuckle_pitch"):
            # wheel-carrier pitch: rotation about +y of the knuckle from its design attitude
            out["knuckle_pitch"] = log_so3(R1)[..., 1]
        if want("strut_length"):
            out["strut_length"] = np.linalg.norm(
                top - wc - rotate(R1, self.kn_pts[:, :, 4]), axis=-1
            )
        if want("handwheel_torque"):
            f = self.rack_force(st)
            out["handwheel_torque"] = np.stack([f, f], axis=-1) * self.rack_gain
        keep = OUTPUT_NAMES if names is None else [k for k in OUTPUT_NAMES if k in names]
        return {k: np.array(out[k], dtype=float) for k in keep}


class _NewtonRows:
    """Per-row bookkeeping of :meth:`AxleSolver.solve` (n rows): converged, last step
    size ``prev`` (relative to the tolerances), Jacobian fresh at the previous iterate,
    step length ``alpha`` (damped when fresh Newton steps stop shrinking), a small step
    at the previous iteration, and a finite last step."""

    def __init__(self, n: int) -> None:
        self.conv = np.zeros(n, bool)
        self.prev = np.full(n, np.inf)
        self.fresh = np.zeros(n, bool)
        self.alpha = np.ones(n)
        self.small_before = np.zeros(n, bool)
        self.finite = np.ones(n, bool)

    def step_lengths(self, todo: np.ndarray, size: np.ndarray, refresh: np.ndarray) -> np.ndarray:
        """The step lengths (n,) of the rows ``todo`` with step sizes ``size`` (a
        converging step is taken in full); rows whose exact Newton steps cycle are damped
        (halved, down to 1/64, for the rest of the solve). ``refresh``: the rows whose
        Jacobians were refreshed at this iterate."""
        stuck = todo & self.fresh & (size > 0.9 * self.prev)  # exact Newton cycles: damp
        self.alpha = np.where(stuck, np.maximum(0.5 * self.alpha, 1.0 / 64), self.alpha)
        self.fresh = refresh
        self.prev = np.where(todo, size, self.prev)
        return np.where(size < 1.0, 1.0, self.alpha)

    def converge(self, todo: np.ndarray, size: np.ndarray, path_dependent: bool) -> None:
        """Mark the rows ``todo`` whose step was small (``size`` < 1) converged; with
        ``path_dependent`` elements two small steps in a row (the kink of a reversal can
        leave the first small step inaccurate)."""
        small = todo & (size < 1.0)
        self.conv |= small & (self.small_before if path_dependent else True)
        self.small_before = small


#: the wheel-centre height of side ``s`` among a row's unknowns (knuckle z): s*NS + this
_WC_Z = 6 + 2


class _CentreDrive:
    """The rig's wheel-centre travel drive in :meth:`AxleSolver.solve`: the driven
    wheels' pad heights ``p`` are unknowns beside the state ``x``, with the equations
    ``z_wc(x) = centre``. The bordered Newton step from the state step ``dx0 = -J^-1
    res`` (chord inverse ``J^-1``): ``dx = dx0 - (J^-1 B) dp`` with ``B = dres/dpad``
    (:meth:`AxleSolver.pad_sensitivity`, one column per wheel) and ``dp`` from
    ``C dx = centre - z_wc``, i.e. ``(C J^-1 B) dp = C dx0 - (centre - z_wc)``, ``C``
    picking the wheel-centre heights; a wheel whose ``centre`` is NaN keeps ``dp = 0``.
    ``J^-1 B`` is taken once, at the state the solve starts from (a chord, as ``J^-1``).
    """

    def __init__(self, solver: AxleSolver, st: AxleState, Jinv, centre: np.ndarray):
        n = solver.n
        B = np.zeros((2, n, 2 * NS))  # column per wheel: d(residual)/d(its pad)
        sens = solver.pad_sensitivity(st)  # (n, 2, NS)
        for w in (0, 1):
            B[w, :, w * NS : (w + 1) * NS] = sens[:, w]
        self.JB = np.stack([_inv_mul(Jinv, B[w]) for w in (0, 1)], axis=-1)  # (n, 66, 2)
        self.driven = np.isfinite(centre)
        self.centre = np.where(self.driven, centre, 0.0)
        S = self.JB[:, [_WC_Z, NS + _WC_Z], :]  # (n, 2 wheel heights, 2 pads)
        both = self.driven[:, :, None] & self.driven[:, None, :]
        self.S = np.where(both, S, np.eye(2))  # undriven: dp = 0 (identity, zero rhs)

    def border(self, st: AxleState, dx: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
        """The pad steps ``dp`` (n, 2) [m] of the state steps ``dx`` (n, 66), which it
        corrects in place (``rows``: those rows only, bool mask; the others' ``dp`` 0)."""
        rows = np.ones(dx.shape[0], bool) if rows is None else rows
        gap = self.centre - st.r[:, :, 1, 2]  # centre - z_wc
        rhs = np.where(self.driven, dx[:, [_WC_Z, NS + _WC_Z]] - gap, 0.0)
        dp = np.linalg.solve(self.S, rhs[..., None])[..., 0]
        dp[~rows] = 0.0
        dx -= np.matmul(self.JB, dp[..., None])[..., 0]
        return dp


def dahl_step(x_prev, x, sigma, f_c, z_prev, eps) -> np.ndarray:
    """Dahl force after moving from ``x_prev`` to ``x``: the library's exact step
    (:func:`~suspenv.models.effects.hysteresis.dahl_segment`, as its path form takes it)
    on an increment passed through a smooth dead band of width ``eps``,
    ``dx_eff = dx (1 - eps / sqrt(dx^2 + eps^2))``, so the force is a smooth function of
    ``x`` at a reversal (the exact element has a kink there, on which Newton's method
    can cycle). The lag it introduces is ``eps`` (1e-6 m, 1e-5 rad), far below anything
    measured. ``sigma`` [N/m] > 0 and ``f_c`` [N] > 0 (checked where the effect is
    placed; a strut friction of level 0 is not placed).
    """
    x = np.asarray(x, dtype=float)
    dx = x - x_prev
    dx_eff = dx * (1.0 - eps / np.sqrt(dx * dx + eps * eps))
    dx_eff = (x_prev + dx_eff) - x_prev  # the path's own segment, as the path form takes it
    a, decay = dahl_segment(dx_eff, sigma, f_c)
    return a + decay * z_prev


def _coloured_groups() -> tuple[np.ndarray, np.ndarray, int]:
    """The perturbations of :meth:`AxleSolver.jacobian` (body coordinates): their
    coordinate moves ``(perturbation, side, body, axis)`` and the Jacobian entries that
    their differences fill ``(perturbation, side, residual row, Jacobian row, Jacobian
    column)``, each sorted by perturbation, and their number.

    Perturbations: lower arm + strut rod coordinate ``k`` on both sides at once (their
    residual rows are disjoint: ARM_ROWS for the lower arm), knuckle coordinate ``k`` on
    both sides at once, bar-half coordinate ``k`` one side at a time (the bar couples
    the sides).
    """
    groups: list[list[tuple[int, int | None]]] = [[(k, None), (12 + k, None)] for k in range(6)]
    groups += [[(6 + k, None)] for k in range(6)]
    groups += [[(18 + k, s)] for s in (0, 1) for k in range(6)]
    moves, scatter = [], []
    for p, group in enumerate(groups):
        for j, side in group:
            b, k = divmod(j, 6)
            for s in (0, 1) if side is None else (side,):
                moves.append((p, s, b, k))
        for s in (0, 1):  # the differences of both sides' rows
            for row in range(NS):
                if len(group) == 2:  # lower-arm rows to its column, the others to the rod's
                    j, side = group[0] if row in ARM_ROWS else group[1]
                else:
                    j, side = group[0]
                col = (s if side is None else side) * NS + j
                scatter.append((p, s, row, s * NS + row, col))
    return np.array(moves).T, np.array(scatter).T, len(groups)


_COLOURED_MOVES, _COLOURED_SCATTER, _N_COLOURED = _coloured_groups()
#: the colouring as the compiled Jacobian reads it: moves (side, body, axis) and their
#: start per perturbation, scatter entries (side, residual row, Jacobian row and column)
#: and their start per perturbation
_KERNEL_COLOURING = (
    np.ascontiguousarray(_COLOURED_MOVES[1:], dtype=np.int64),
    np.searchsorted(_COLOURED_MOVES[0], np.arange(_N_COLOURED + 1)).astype(np.int64),
    np.ascontiguousarray(_COLOURED_SCATTER[1:], dtype=np.int64),
    np.searchsorted(_COLOURED_SCATTER[0], np.arange(_N_COLOURED + 1)).astype(np.int64),
)


@functools.lru_cache(maxsize=4)
def _tolerances(xtol: float, rtol: float, ltol: float) -> np.ndarray:
    """The tolerance of every unknown (66,) of both sides (read-only, cached)."""
    body = np.r_[np.full(3, xtol), np.full(3, rtol)]
    side = np.r_[np.tile(body, 4), np.full(NL, ltol)]
    out = np.tile(side, 2)
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=4)
def _exp_h(h: float) -> np.ndarray:
    """Rotation matrices (3, 3, 3) by ``h`` [rad] about x, y, z (read-only, cached)."""
    out = expm_so3(h * np.eye(3))
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=4)
def _pack_offsets(widths: tuple[tuple[str, int], ...]) -> tuple[np.ndarray, int]:
    """The offsets (read by the compiled residual in the order of :data:`_KERNEL_FIELDS`;
    -1: absent) of the pack's fields of the given ``(field, width)`` in pack order (a
    field's first), and the pack's height (cached: the compiled loops read the offsets
    only)."""
    where: dict[str, int] = {}
    at = 0
    for name, w in widths:
        where.setdefault(name, at)
        at += w
    off = np.array([where.get(k, -1) for k in _KERNEL_FIELDS], np.int64)
    return off, at


def _repeated(v: np.ndarray, k: int) -> np.ndarray:
    """``k`` copies of ``v`` stacked on a new first axis, as a read-only zero-stride view."""
    if not v.flags.c_contiguous:
        return np.broadcast_to(v, (k,) + v.shape)
    out = np.ndarray((k,) + v.shape, v.dtype, v, 0, (0,) + v.strides)  # quicker to make
    out.flags.writeable = False
    return out


def _perp_basis(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors perpendicular to unit ``a`` (..., 3)."""
    helper = np.zeros_like(a)
    helper[..., 0] = 1.0
    u = cross(a, helper)  # np.cross's products and differences, in fewer calls
    u /= _length(u)
    v = cross(a, u)
    return u, v


def _rotate_six(Q: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``Q`` (..., 3, 3) applied to both halves of six-vectors (..., 6): translation and
    rotation vector (deflections), or force and moment (loads)."""
    return np.concatenate([rotate(Q, x[..., :3]), rotate(Q, x[..., 3:])], axis=-1)


def _length(v: np.ndarray) -> np.ndarray:
    """Lengths (..., 1) of vectors (..., 3) (``np.linalg.norm``'s sum, in fewer calls)."""
    x, y, z = v[..., 0:1], v[..., 1:2], v[..., 2:3]
    return np.sqrt(x * x + y * y + z * z)


__all__ = ["AxleSolver", "AxleState", "spin_axis", "wheel_down"]
