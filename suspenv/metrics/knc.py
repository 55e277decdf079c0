"""K&C metrics: the 40 objectives of Tey et al. 2014 and the usual K&C outputs.

Conventions (see ``docs/knc.md``): ISO 8855 signs (x forward, y left, z up) with
engineering units at this edge: mm, deg, N, N*m. Lateral quantities are *outboard
positive* on each wheel (``y_out = y`` on the left, ``-y`` on the right) so that a
symmetric axle gives equal left and right numbers. Toe positive = toe-in; camber
negative = top of the wheel inboard; caster positive = steering axis top rearward.

Travel variables (all zero at the static position):

* wheel travel ``z_w`` [mm]: wheel-centre height change (bump positive);
* pad travel ``z_p`` [mm]: rig pad height change;
* roll angle ``phi`` [deg]: ``atan((z_wL - z_wR) / t)`` with ``t`` the wheel-centre
  track, positive when the left wheel rises relative to the body; each wheel uses
  its own sense ``phi_w = +phi`` (left) / ``-phi`` (right).

Gradient method: on each branch of the loop (descending, ascending) a quadratic is
fitted by least squares to the 7 grid points centred on the static position (+-8 mm
for the default grid); the value at static is the fit at the static abscissa, the
gradient its slope there, and a *rate* is the slope of the force curve (its
gradient then being the fit's curvature ``2c``). The loop's number is the mean over
the two branches (Tey et al. used the average of the measured loop at the static
position). Parallel and opposite travel average the left and right wheels; single
wheel travel uses the moving (left) wheel.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.measurements.knc import DISPLAY, RAD2DEG
from suspenv.metrics.knc_kernel import PICK
from suspenv.models.effects import Effect
from suspenv.models.mcpherson.params import SIDE_SIGN, Axle

if TYPE_CHECKING:  # a type only: metrics are functions of rig results, not of the rig
    from suspenv.rigs.knc import KCResult

FIT_HALF_WIDTH = 3  # grid points either side of the static position


@dataclass(frozen=True)
class KCObjective:
    """One K&C objective: a curve of a test reduced at the static position.

    Attributes:
        name: identifier (``<test>_<quantity>[_pos]``).
        test: ``"parallel"``, ``"opposite"`` or ``"single"``.
        curve: the curve's channel (see :func:`curve`).
        x: abscissa (``"wheel"``, ``"pad"`` or ``"roll"``).
        reduce: ``"gradient"``, ``"value"``, ``"rate"`` (slope of the curve) or
            ``"rate_gradient"`` (slope of the rate, i.e. curvature).
        unit: unit of the number.
        label: the paper's wording.
    """

    name: str
    test: str
    curve: str
    x: str
    reduce: str
    unit: str
    label: str


#: the objectives of a travel test, one a line: name (after the test's prefix), curve,
#: abscissa, reduction, unit, the paper's wording (the rest of the line; a backslash at
#: the end of a line joins the next)
_TRAVEL = """
susp_ride_rate         tyre_fz           wheel  rate_gradient  N/mm^2  suspension ride rate
susp_ride_rate_pos     tyre_fz           wheel  rate           N/mm    suspension ride rate (pos)
toe                    toe               wheel  gradient       deg/mm  toe change
toe_pos                toe               wheel  value          deg     toe change (pos)
camber                 camber            wheel  gradient       deg/mm  camber change
camber_pos             camber            wheel  value          deg     camber change (pos)
hub_lateral            hub_lateral       wheel  gradient       mm/mm   lateral displacement of hub
susp_contact_lateral   contact_lateral   wheel  gradient       mm/mm   suspension lateral \
displacement of tyre contact patch
hub_fore_aft           hub_fore_aft      wheel  gradient       mm/mm   suspension fore-aft \
displacement of hub
caster                 caster            wheel  gradient       deg/mm  caster change
ride_rate              tyre_fz           pad    rate_gradient  N/mm^2  ride rate
contact_lateral        contact_lateral   pad    gradient       mm/mm   lateral displacement of \
contact patch
contact_fore_aft       contact_fore_aft  pad    gradient       mm/mm   fore-aft displacement of \
contact patch
"""
#: the opposite-travel test's own objectives (as :data:`_TRAVEL`), then its roll
#: stiffness (:data:`_ROLL`)
_OPPOSITE = """
toe              toe     wheel  gradient  deg/mm   toe change
toe_pos          toe     wheel  value     deg      toe change (pos)
camber           camber  wheel  gradient  deg/mm   camber change
camber_pos       camber  wheel  value     deg      camber change (pos)
roll_caster      caster  roll   gradient  deg/deg  roll caster
roll_toe         toe     roll   gradient  deg/deg  roll toe change
roll_toe_pos     toe     roll   value     deg      roll toe change (pos)
roll_camber      camber  roll   gradient  deg/deg  roll camber
roll_camber_pos  camber  roll   value     deg      roll camber (pos)
"""
_ROLL = """
roll_force     half_force_difference half_travel_difference rate_gradient N/mm^2    roll force
roll_force_pos half_force_difference half_travel_difference rate          N/mm      roll force (pos)
roll_rate      roll_moment           roll_axle              rate_gradient N*m/deg^2 roll rate
roll_rate_pos  roll_moment           roll_axle              rate          N*m/deg   roll rate (pos)
"""
#: single wheel travel: the travel test's objectives and this one
_SINGLE = """
ride_rate_pos          tyre_fz           pad    rate           N/mm    ride rate (pos)
"""


def _table(text: str, prefix: str, test: str) -> list[KCObjective]:
    """The objectives of a table as :data:`_TRAVEL` of ``test``, names after ``prefix``."""
    out = []
    for row in filter(None, text.splitlines()):
        name, curve, x, reduce, unit, label = row.split(maxsplit=5)
        out.append(KCObjective(prefix + name, test, curve, x, reduce, unit, label))
    return out


def _objectives() -> tuple[KCObjective, ...]:
    par = _table(_TRAVEL, "par_", "parallel")
    opp = _table(_OPPOSITE + _ROLL, "opp_", "opposite")
    sgl = _table(_TRAVEL + _SINGLE, "sgl_", "single")
    return tuple(par + opp + sgl)


OBJECTIVES: tuple[KCObjective, ...] = _objectives()
OBJECTIVE_NAMES: tuple[str, ...] = tuple(o.name for o in OBJECTIVES)
OBJECTIVE_UNITS: tuple[str, ...] = tuple(o.unit for o in OBJECTIVES)
assert len(OBJECTIVES) == 40


# ------------------------------------------------------------------ curves
#: the rig channels that the objectives read (:func:`_wheel_curves`)
OBJECTIVE_CHANNELS = (
    "toe",
    "camber",
    "caster",
    "wheel_centre_x",
    "wheel_centre_y",
    "wheel_centre_z",
    "contact_x",
    "contact_y",
    "tyre_fz",
    "pad_z",
)


def _wheel_curves(res: KCResult, branch: str, window: slice | None = None) -> dict[str, np.ndarray]:
    """Per-wheel curves (n, G, 2) in edge units on one branch (``window``: only the grid
    points of that slice, which must hold the static position; the same numbers)."""
    points = slice(None) if window is None else window
    st = res.static_index - (0 if window is None else window.start)
    return _curves(lambda name: res.branch(name, branch)[:, points], st)


def _curves(b: Callable[[str], np.ndarray], st: int) -> dict[str, np.ndarray]:
    """The curves of :func:`_wheel_curves` from the channels ``b(name)`` (rows, G, 2) on
    a branch, the static position at grid index ``st``."""
    sg = SIDE_SIGN
    zw = b("wheel_centre_z")
    zp = b("pad_z")
    out = {
        "toe": b("toe") * RAD2DEG,
        "camber": b("camber") * RAD2DEG,
        "caster": b("caster") * RAD2DEG,
        "hub_lateral": b("wheel_centre_y") * sg * 1e3,
        "hub_fore_aft": b("wheel_centre_x") * 1e3,
        "contact_lateral": b("contact_y") * sg * 1e3,
        "contact_fore_aft": b("contact_x") * 1e3,
        "tyre_fz": b("tyre_fz"),
        "wheel": (zw - zw[:, st : st + 1]) * 1e3,
        "pad": (zp - zp[:, st : st + 1]) * 1e3,
    }
    phi = roll_angle(zw, b("wheel_centre_y"), st)
    out["roll"] = phi[..., None] * sg
    fz = out["tyre_fz"]
    axle = {
        "half_force_difference": 0.5 * (fz[..., 0] - fz[..., 1]),
        "half_travel_difference": 0.5 * (out["wheel"][..., 0] - out["wheel"][..., 1]),
        "roll_moment": roll_moment(fz, b("contact_y"), st),
        "roll_axle": phi,
    }
    for k, v in axle.items():  # axle curves: same on both "wheels"
        out[k] = np.stack([v, v], axis=-1)
    return out


def static_track(y: np.ndarray, st: int) -> np.ndarray:
    """Track (rows, 1) at the static grid index ``st`` of the lateral positions ``y``
    (rows, G, 2) (ISO y, left then right wheel): ``y_L - y_R``, in ``y``'s unit."""
    return (y[..., 0] - y[..., 1])[:, st : st + 1]


def roll_angle(z: np.ndarray, y: np.ndarray, st: int) -> np.ndarray:
    """Roll angle phi (rows, G) [deg], zero at the static grid index ``st``:
    ``atan((z_L - z_R) / t)`` of the heights ``z`` (rows, G, 2) with ``t`` the
    :func:`static_track` of the lateral positions ``y`` (same length unit); positive
    when the left point rises."""
    phi = np.arctan((z[..., 0] - z[..., 1]) / static_track(y, st)) * RAD2DEG
    return phi - phi[:, st : st + 1]


def roll_moment(fz: np.ndarray, y: np.ndarray, st: int) -> np.ndarray:
    """Axle roll moment (rows, G) of the tyre forces ``fz`` (rows, G, 2) [N]:
    ``0.5 (F_zL - F_zR) t_cp``, ``t_cp`` the :func:`static_track` of the contact points'
    lateral positions ``y`` (rows, G, 2) (N*m for ``y`` in m)."""
    return 0.5 * (fz[..., 0] - fz[..., 1]) * static_track(y, st)


def quadratic_fit(x: np.ndarray, y: np.ndarray, centre: int, half: int = FIT_HALF_WIDTH):
    """Least-squares quadratic through points ``centre +- half`` of (..., G) curves.

    Returns (value, slope, curvature 2c) at ``x[..., centre]``, each (...,).
    """
    lo, hi = centre - half, centre + half + 1
    if lo < 0 or hi > x.shape[-1]:
        raise ValidationError(
            f"fit window [{lo}, {hi}) must lie inside the grid of {x.shape[-1]} points"
        )
    # the window's points first (each sum over them runs over all curves at once)
    xs = np.ascontiguousarray(np.moveaxis(x[..., lo:hi] - x[..., centre : centre + 1], -1, 0))
    ys = np.ascontiguousarray(np.moveaxis(y[..., lo:hi], -1, 0))
    # normal equations [[S0, S1, S2], [S1, S2, S3], [S2, S3, S4]] c = [T0, T1, T2] with
    # Sk = sum xs^k, Tk = sum xs^k ys, solved by Cramer's rule (cofactors C..)
    x2 = xs * xs
    S0 = np.full(xs.shape[1:], float(xs.shape[0]))
    S1, S2, S3, S4 = xs.sum(0), x2.sum(0), (x2 * xs).sum(0), (x2 * x2).sum(0)
    T0, T1, T2 = ys.sum(0), (xs * ys).sum(0), (x2 * ys).sum(0)
    C00, C01, C02 = S2 * S4 - S3 * S3, S2 * S3 - S1 * S4, S1 * S3 - S2 * S2
    C11, C12, C22 = S0 * S4 - S2 * S2, S1 * S2 - S0 * S3, S0 * S2 - S1 * S1
    det = S0 * C00 + S1 * C01 + S2 * C02
    # degenerate or non-finite curves (e.g. a failed design's frozen state) give NaN
    spread = np.ptp(xs, axis=0) if xs.shape[0] else np.zeros(xs.shape[1:])
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        bad = ~(np.isfinite(det) & np.isfinite(T0) & np.isfinite(T1) & np.isfinite(T2))
        bad |= ~(spread > 0)
        bad |= ~(np.abs(det) > 1e-12 * np.maximum(spread, 1e-300) ** 6)
        inv = np.where(bad, np.nan, 1.0 / np.where(bad, 1.0, det))
        c0 = (C00 * T0 + C01 * T1 + C02 * T2) * inv
        c1 = (C01 * T0 + C11 * T1 + C12 * T2) * inv
        c2 = (C02 * T0 + C12 * T1 + C22 * T2) * inv
    return c0, c1, 2.0 * c2


def _reduce(obj: KCObjective, curves: dict[str, np.ndarray], centre: int) -> np.ndarray:
    wheels = [0] if obj.test == "single" else [0, 1]  # single: the moving wheel only
    y = np.moveaxis(curves[obj.curve][..., wheels], -1, 1)  # (n, wheels, G)
    x = np.moveaxis(curves[obj.x][..., wheels], -1, 1)
    return quadratic_fit(x, y, centre)[PICK[obj.reduce]].mean(axis=1)


def objectives(results: dict[str, KCResult]) -> np.ndarray:
    """The 40 objectives (n, 40) from rig results of the three tests (see module doc).

    Each test's curves are made for both branches at once and its objectives x 2
    branches x 2 wheels fitted in one batched :func:`quadratic_fit` on the fit window
    only (the single-wheel test's moving wheel twice, whose mean is itself), one
    test at a time (bounded memory); the arithmetic is that of :func:`_reduce` per
    objective."""
    tests, channels = dict.fromkeys(o.test for o in OBJECTIVES), OBJECTIVE_CHANNELS
    missing = sorted(set(tests) - set(results))
    if missing:
        raise ValidationError(f"objectives need the tests {missing}, which were not run")
    cache: dict[tuple[str, str], dict[str, np.ndarray]] = {}
    centres = {results[o.test].static_index for o in OBJECTIVES}
    if len(centres) != 1 or min(centres) < FIT_HALF_WIDTH:
        # tests on different grids, or a grid too short for the fit (which then raises)
        return _objectives_one_by_one(results, cache)
    centre = centres.pop()
    window = slice(centre - FIT_HALF_WIDTH, centre + FIT_HALF_WIDTH + 1)  # the fitted points
    n, size, C = results[OBJECTIVES[0].test].ok.shape[0], window.stop - window.start, len(channels)
    F = np.empty((n, len(OBJECTIVES)))
    for test in tests:  # one test at a time (memory)
        res = results[test]
        # its channels: the rows (channel x design) of one result, whose branches are
        # taken at once, then the curves of the rows (branch x design) (the same
        # numbers, element by element)
        every = replace(res, channels={"": np.concatenate([res.channels[c] for c in channels])})
        both = np.stack([every.branch("", br)[:, window] for br in ("down", "up")])
        both = both.reshape(2, C, n, size, 2).swapaxes(0, 1).reshape(C, 2 * n, size, 2)
        curves = _curves(dict(zip(channels, both, strict=True)).__getitem__, FIT_HALF_WIDTH)
        del every, both
        idx = [i for i, o in enumerate(OBJECTIVES) if o.test == test]
        wheels = [0, 0] if test == "single" else [0, 1]  # the moving wheel twice
        x = np.stack([curves[OBJECTIVES[i].x] for i in idx])[..., wheels]
        y = np.stack([curves[OBJECTIVES[i].curve] for i in idx])[..., wheels]
        del curves
        fit = quadratic_fit(np.moveaxis(x, -1, 2), np.moveaxis(y, -1, 2), FIT_HALF_WIDTH)
        del x, y
        pick = np.stack(fit)[[PICK[OBJECTIVES[i].reduce] for i in idx], range(len(idx))]
        branch = pick.mean(axis=-1)  # (objectives, 2 n): mean over the wheels
        F[:, idx] = (0.5 * (branch[:, :n] + branch[:, n:])).T
    return F


def _objectives_one_by_one(
    results: dict[str, KCResult],
    cache: dict[tuple[str, str], dict[str, np.ndarray]],
    chosen: Sequence[KCObjective] = OBJECTIVES,
) -> np.ndarray:
    """:func:`objectives` (the ``chosen`` ones, in their order) with one fit per objective
    and branch (the reference path)."""
    cols = []
    for obj in chosen:
        res = results[obj.test]
        vals = []
        for br in ("down", "up"):
            key = (obj.test, br)
            if key not in cache:
                cache[key] = _wheel_curves(res, br)
            vals.append(_reduce(obj, cache[key], res.static_index))
        cols.append(0.5 * (vals[0] + vals[1]))
    return np.stack(cols, axis=1)


def loop_width(results: dict[str, KCResult], name: str = "tyre_fz", test: str = "parallel"):
    """Largest gap between the loop's branches (n, 2) of channel ``name`` (SI units)."""
    r = results[test]
    return np.abs(r.branch(name, "down") - r.branch(name, "up")).max(axis=1)


def objectives_subset(results: dict[str, KCResult], names: tuple[str, ...]) -> np.ndarray:
    """Only the named objectives (n, len(names))."""
    chosen = [OBJECTIVES[OBJECTIVE_NAMES.index(n)] for n in names]
    return _objectives_one_by_one(results, {}, chosen)


# ---------------------------------------------------------- compliance matrix
#: loads of :func:`compliance_matrix_full`, each on one wheel, in that wheel's own sense
FULL_COMPLIANCE_LOADS = ("Fx", "Fy", "Fz", "Mz")
#: outputs of :func:`compliance_matrix_full`, on each wheel, in that wheel's own sense
FULL_COMPLIANCE_OUTPUTS = ("toe", "camber", "wheel_centre_x", "wheel_centre_y", "wheel_centre_z")
COMPLIANCE_LOADS = ("Fx", "Fy", "Mz")
COMPLIANCE_OUTPUTS = ("toe", "camber", "wheel_centre_x", "wheel_centre_y")


def compliance_load(load: str, wheel: int) -> np.ndarray:
    """Unit load (2, 6) at the contact points [N, N*m] (force then moment, ISO 8855) of
    ``load`` on ``wheel`` (0 left, 1 right) in that wheel's own sense: Fx forward, Fy
    outboard (+y on the left wheel, -y on the right), Fz up (unloading the tyre), Mz a
    toe-out moment (turning the wheel's front outboard: +z on the left wheel, -z on
    the right; the own sense of the ``aligning`` rig test)."""
    col = {"Fx": 0, "Fy": 1, "Fz": 2, "Mz": 5}
    if load not in col or wheel not in (0, 1):
        raise ValidationError(
            f"compliance_load: `load in {FULL_COMPLIANCE_LOADS}` and `wheel in (0, 1)` must "
            f"hold, but got load={load!r}, wheel={wheel!r}"
        )
    out = np.zeros((2, 6))
    out[wheel, col[load]] = SIDE_SIGN[wheel] if load in ("Fy", "Mz") else 1.0
    return out


def compliance_matrix_full(
    axle: Axle, effects: Sequence[Effect] = ()
) -> tuple[np.ndarray, dict[str, tuple[str, ...]]]:
    """Full compliance at the design position (n, 2 responding wheels, 5 outputs,
    4 loads, 2 loaded wheels), edge units, direct and cross-wheel terms.

    ``C[:, i, o, l, j]`` is output ``o`` of wheel ``i`` per unit load ``l`` on wheel ``j``
    alone (:func:`compliance_load`: Fx forward, Fy outboard, Fz up, Mz toe-out, each in
    the loaded wheel's own sense, at its contact point), pads and rack held. Outputs in
    the responding wheel's own sense: toe (+ toe-in), camber (- top inboard) [deg];
    wheel-centre x forward, y outboard, z up [mm]. Entries per kN or kN*m: deg/kN,
    mm/kN, deg/(kN*m), mm/(kN*m). ``i == j``: direct terms; ``i != j``: the other
    wheel's response (through the anti-roll bar). Linearised: the converged static
    state is moved by ``-J^-1 dres/dload`` (fresh Jacobian; ``dres/dload`` from the
    residual's external-load path, the one the rig's compliance tests use, in which the
    residual is linear) and the outputs are differenced centrally.
    """
    from suspenv.models.mcpherson.solver import AxleSolver

    solver = AxleSolver(axle, effects)
    n = solver.n
    pad = solver.pad_static
    st, conv, _ = solver.solve(solver.initial_state(), pad)
    if not conv.all():
        raise ValidationError("compliance_matrix: no static equilibrium for some designs")
    Jinv = solver.inverse_jacobian(st, pad)
    base = solver.residual(st.r, st.R, st.lam, pad, st, np.zeros((n, 2, 6)))
    sg = SIDE_SIGN
    C = np.zeros((n, 2, len(FULL_COMPLIANCE_OUTPUTS), len(FULL_COMPLIANCE_LOADS), 2))
    eps = 100.0  # N or N*m: well inside the linear range
    ok = np.ones(n, bool)
    for j in (0, 1):
        for k, load in enumerate(FULL_COMPLIANCE_LOADS):
            ext = np.broadcast_to(compliance_load(load, j), (n, 2, 6))
            b = solver.residual(st.r, st.R, st.lam, pad, st, np.array(ext)) - base
            dx = -np.matmul(Jinv, b.reshape(n, -1, 1))[..., 0]
            plus = solver.outputs(solver._apply(st, eps * dx, ok), pad)
            minus = solver.outputs(solver._apply(st, -eps * dx, ok), pad)
            for o, name in enumerate(FULL_COMPLIANCE_OUTPUTS):
                d = (plus[name] - minus[name]) / (2 * eps)  # (n, 2) per N
                d = d * DISPLAY[name].scale
                if name == "wheel_centre_y":
                    d = d * sg
                C[:, :, o, k, j] = d * 1e3  # per kN or kN*m
    return C, {"outputs": FULL_COMPLIANCE_OUTPUTS, "loads": FULL_COMPLIANCE_LOADS}


def compliance_matrix(
    axle: Axle, effects: Sequence[Effect] = ()
) -> tuple[np.ndarray, dict[str, tuple[str, ...]]]:
    """Direct compliance at the design position (n, 2 wheels, 4 outputs, 3 loads), edge
    units: the ``i == j`` terms of :func:`compliance_matrix_full` for the loads Fx
    (forward), Fy (outboard) [per kN] and Mz [per kN*m] (a toe-out moment: turning the
    wheel's front outboard, the own sense of the ``aligning`` test) and the outputs
    toe, camber [deg], wheel-centre x forward, y outboard [mm]."""
    full, _ = compliance_matrix_full(axle, effects)
    o = [FULL_COMPLIANCE_OUTPUTS.index(x) for x in COMPLIANCE_OUTPUTS]
    k = [FULL_COMPLIANCE_LOADS.index(x) for x in COMPLIANCE_LOADS]
    C = np.stack([full[:, w][:, o][:, :, k, w] for w in (0, 1)], axis=1)
    return C, {"outputs": COMPLIANCE_OUTPUTS, "loads": COMPLIANCE_LOADS}
