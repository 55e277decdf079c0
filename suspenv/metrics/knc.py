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

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.effects import Effect
from suspenv.models.mcpherson.params import SIDE_SIGN, Axle
from suspenv.rigs.knc import KCResult

RAD2DEG = 180.0 / np.pi
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


def _travel_objectives(prefix: str, test: str) -> list[KCObjective]:
    O = KCObjective
    return [
        O(
            f"{prefix}_susp_ride_rate",
            test,
            "tyre_fz",
            "wheel",
            "rate_gradient",
            "N/mm^2",
            "suspension ride rate",
        ),
        O(
            f"{prefix}_susp_ride_rate_pos",
            test,
            "tyre_fz",
            "wheel",
            "rate",
            "N/mm",
            "suspension ride rate (pos)",
        ),
        O(f"{prefix}_toe", test, "toe", "wheel", "gradient", "deg/mm", "toe change"),
        O(f"{prefix}_toe_pos", test, "toe", "wheel", "value", "deg", "toe change (pos)"),
        O(f"{prefix}_camber", test, "camber", "wheel", "gradient", "deg/mm", "camber change"),
        O(f"{prefix}_camber_pos", test, "camber", "wheel", "value", "deg", "camber change (pos)"),
        O(
            f"{prefix}_hub_lateral",
            test,
            "hub_lateral",
            "wheel",
            "gradient",
            "mm/mm",
            "lateral displacement of hub",
        ),
        O(
            f"{prefix}_susp_contact_lateral",
            test,
            "contact_lateral",
            "wheel",
            "gradient",
            "mm/mm",
            "suspension lateral displacement of tyre contact patch",
        ),
        O(
            f"{prefix}_hub_fore_aft",
            test,
            "hub_fore_aft",
            "wheel",
            "gradient",
            "mm/mm",
            "suspension fore-aft displacement of hub",
        ),
        O(f"{prefix}_caster", test, "caster", "wheel", "gradient", "deg/mm", "caster change"),
        O(f"{prefix}_ride_rate", test, "tyre_fz", "pad", "rate_gradient", "N/mm^2", "ride rate"),
        O(
            f"{prefix}_contact_lateral",
            test,
            "contact_lateral",
            "pad",
            "gradient",
            "mm/mm",
            "lateral displacement of contact patch",
        ),
        O(
            f"{prefix}_contact_fore_aft",
            test,
            "contact_fore_aft",
            "pad",
            "gradient",
            "mm/mm",
            "fore-aft displacement of contact patch",
        ),
    ]


def _objectives() -> tuple[KCObjective, ...]:
    O = KCObjective
    par = _travel_objectives("par", "parallel")
    opp = [
        O("opp_toe", "opposite", "toe", "wheel", "gradient", "deg/mm", "toe change"),
        O("opp_toe_pos", "opposite", "toe", "wheel", "value", "deg", "toe change (pos)"),
        O("opp_camber", "opposite", "camber", "wheel", "gradient", "deg/mm", "camber change"),
        O("opp_camber_pos", "opposite", "camber", "wheel", "value", "deg", "camber change (pos)"),
        O("opp_roll_caster", "opposite", "caster", "roll", "gradient", "deg/deg", "roll caster"),
        O("opp_roll_toe", "opposite", "toe", "roll", "gradient", "deg/deg", "roll toe change"),
        O("opp_roll_toe_pos", "opposite", "toe", "roll", "value", "deg", "roll toe change (pos)"),
        O("opp_roll_camber", "opposite", "camber", "roll", "gradient", "deg/deg", "roll camber"),
        O("opp_roll_camber_pos", "opposite", "camber", "roll", "value", "deg", "roll camber (pos)"),
        O(
            "opp_roll_force",
            "opposite",
            "half_force_difference",
            "half_travel_difference",
            "rate_gradient",
            "N/mm^2",
            "roll force",
        ),
        O(
            "opp_roll_force_pos",
            "opposite",
            "half_force_difference",
            "half_travel_difference",
            "rate",
            "N/mm",
            "roll force (pos)",
        ),
        O(
            "opp_roll_rate",
            "opposite",
            "roll_moment",
            "roll_axle",
            "rate_gradient",
            "N*m/deg^2",
            "roll rate",
        ),
        O(
            "opp_roll_rate_pos",
            "opposite",
            "roll_moment",
            "roll_axle",
            "rate",
            "N*m/deg",
            "roll rate (pos)",
        ),
    ]
    sgl = _travel_objectives("sgl", "single")
    sgl.append(
        O("sgl_ride_rate_pos", "single", "tyre_fz", "pad", "rate", "N/mm", "ride rate (pos)")
    )
    return tuple(par + opp + sgl)


OBJECTIVES: tuple[KCObjective, ...] = _objectives()
OBJECTIVE_NAMES: tuple[str, ...] = tuple(o.name for o in OBJECTIVES)
OBJECTIVE_UNITS: tuple[str, ...] = tuple(o.unit for o in OBJECTIVES)
assert len(OBJECTIVES) == 40


# ------------------------------------------------------------------ curves
def _wheel_curves(res: KCResult, branch: str) -> dict[str, np.ndarray]:
    """Per-wheel curves (n, G, 2) in edge units on one branch."""
    b = lambda name: res.branch(name, branch)  # noqa: E731
    sg = SIDE_SIGN
    st = res.static_index
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
    wy = b("wheel_centre_y")
    track = (wy[..., 0] - wy[..., 1])[:, st : st + 1]
    phi = np.arctan((zw[..., 0] - zw[..., 1]) / track) * RAD2DEG
    phi = phi - phi[:, st : st + 1]
    out["roll"] = phi[..., None] * sg
    fz = out["tyre_fz"]
    cy = b("contact_y")
    t_cp = (cy[..., 0] - cy[..., 1])[:, st : st + 1]
    axle = {
        "half_force_difference": 0.5 * (fz[..., 0] - fz[..., 1]),
        "half_travel_difference": 0.5 * (out["wheel"][..., 0] - out["wheel"][..., 1]),
        "roll_moment": 0.5 * (fz[..., 0] - fz[..., 1]) * t_cp,
        "roll_axle": phi,
    }
    for k, v in axle.items():  # axle curves: same on both "wheels"
        out[k] = np.stack([v, v], axis=-1)
    return out


def quadratic_fit(x: np.ndarray, y: np.ndarray, centre: int, half: int = FIT_HALF_WIDTH):
    """Least-squares quadratic through points ``centre +- half`` of (..., G) curves.

    Returns (value, slope, curvature 2c) at ``x[..., centre]``, each (...,).
    """
    lo, hi = centre - half, centre + half + 1
    if lo < 0 or hi > x.shape[-1]:
        raise ValidationError(
            f"fit window [{lo}, {hi}) must lie inside the grid of {x.shape[-1]} points"
        )
    xs = x[..., lo:hi] - x[..., centre : centre + 1]
    ys = y[..., lo:hi]
    V = np.stack([np.ones_like(xs), xs, xs * xs], axis=-1)  # (..., k, 3)
    VtV = np.einsum("...ki,...kj->...ij", V, V)
    Vty = np.einsum("...ki,...k->...i", V, ys)
    # degenerate or non-finite curves (e.g. a failed design's frozen state) give NaN
    spread = np.ptp(xs, axis=-1) if xs.shape[-1] else np.zeros(xs.shape[:-1])
    bad = ~(np.isfinite(VtV).all(axis=(-1, -2)) & np.isfinite(Vty).all(axis=-1))
    bad |= ~(spread > 0)
    bad |= ~(
        np.abs(np.linalg.det(np.where(bad[..., None, None], np.eye(3), VtV)))
        > 1e-12 * np.maximum(spread, 1e-300) ** 6
    )
    VtV = np.where(bad[..., None, None], np.eye(3), VtV)
    Vty = np.where(bad[..., None], 0.0, Vty)
    coef = np.linalg.solve(VtV, Vty[..., None])[..., 0]
    coef = np.where(bad[..., None], np.nan, coef)
    return coef[..., 0], coef[..., 1], 2.0 * coef[..., 2]


def _reduce(obj: KCObjective, curves: dict[str, np.ndarray], centre: int) -> np.ndarray:
    wheels = [0] if obj.test == "single" else [0, 1]  # single: the moving wheel only
    y = np.moveaxis(curves[obj.curve][..., wheels], -1, 1)  # (n, wheels, G)
    x = np.moveaxis(curves[obj.x][..., wheels], -1, 1)
    value, slope, curv = quadratic_fit(x, y, centre)
    pick = {"value": value, "gradient": slope, "rate": slope, "rate_gradient": curv}[obj.reduce]
    return pick.mean(axis=1)


#: reduction -> row of (value, slope, curvature) that it picks (see _reduce)
_PICK = {"value": 0, "gradient": 1, "rate": 1, "rate_gradient": 2}


def objectives(results: dict[str, KCResult]) -> np.ndarray:
    """The 40 objectives (n, 40) from rig results of the three tests (see module doc).

    All 40 objectives x 2 branches x 2 wheels are fitted in one batched
    :func:`quadratic_fit` on the fit window only (the single-wheel test's moving wheel
    twice, whose mean is itself); the arithmetic is that of :func:`_reduce` per
    objective."""
    missing = sorted({o.test for o in OBJECTIVES} - set(results))
    if missing:
        raise ValidationError(f"objectives need the tests {missing}, which were not run")
    cache: dict[tuple[str, str], dict[str, np.ndarray]] = {}
    centres = {results[o.test].static_index for o in OBJECTIVES}
    if len(centres) != 1 or min(centres) < FIT_HALF_WIDTH:
        # tests on different grids, or a grid too short for the fit (which then raises)
        return _objectives_one_by_one(results, cache)
    centre = centres.pop()
    window = slice(centre - FIT_HALF_WIDTH, centre + FIT_HALF_WIDTH + 1)  # the fitted points
    xs, ys = [], []
    for obj in OBJECTIVES:
        res = results[obj.test]
        wheels = [0, 0] if obj.test == "single" else [0, 1]  # single: the moving wheel only
        for br in ("down", "up"):
            key = (obj.test, br)
            if key not in cache:
                cache[key] = _wheel_curves(res, br)
            ys.append(cache[key][obj.curve][:, window][..., wheels])
            xs.append(cache[key][obj.x][:, window][..., wheels])
    # (n, 40 * 2, G, 2) -> (n, 40, 2 branches, 2 wheels, G)
    x = np.moveaxis(np.stack(xs, axis=1), -1, 2)
    y = np.moveaxis(np.stack(ys, axis=1), -1, 2)
    n = x.shape[0]
    shape = (n, len(OBJECTIVES), 2, 2, x.shape[-1])
    fit = np.stack(quadratic_fit(x.reshape(shape), y.reshape(shape), FIT_HALF_WIDTH))
    pick = fit[[_PICK[o.reduce] for o in OBJECTIVES], :, np.arange(len(OBJECTIVES))]
    branch = pick.mean(axis=-1)  # (40, n, 2 branches): mean over the wheels
    return (0.5 * (branch[..., 0] + branch[..., 1])).T


def _objectives_one_by_one(
    results: dict[str, KCResult], cache: dict[tuple[str, str], dict[str, np.ndarray]]
) -> np.ndarray:
    """:func:`objectives` with one fit per objective and branch (the reference path)."""
    cols = []
    for obj in OBJECTIVES:
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


# -------------------------------------------------------- usual K&C outputs
def _at_static(res: KCResult, name: str) -> np.ndarray:
    return 0.5 * (res.branch(name, "down") + res.branch(name, "up"))[:, res.static_index]


def usual_outputs(results: dict[str, KCResult]) -> dict[str, np.ndarray]:
    """Classic K&C numbers per design (n,) (left wheel unless an axle quantity), edge units.

    caster, kpi [deg]; scrub_radius, trail [mm] (positive when the steering axis meets
    the ground outboard of / ahead of the contact point); roll_centre_height [mm above
    the pad] from the contact-point motion in parallel travel,
    ``h = (t/2) d(y_out)/d(z_cp)`` (front-view instant centre of the contact point path
    meets the centreline); motion_ratio = -d(spring length)/d(wheel travel); wheel_rate,
    ride_rate [N/mm]; roll_rate [N*m/deg]; roll_steer, roll_camber [deg/deg].
    """
    par = results["parallel"]
    out = {
        "caster": _at_static(par, "caster")[:, 0] * RAD2DEG,
        "kpi": _at_static(par, "kpi")[:, 0] * RAD2DEG,
        "scrub_radius": _at_static(par, "scrub_radius")[:, 0] * 1e3,
        "trail": _at_static(par, "trail")[:, 0] * 1e3,
    }
    c = par.static_index

    def slope(res: KCResult, yname: str, xname: str, ys=1.0, xs=1.0) -> np.ndarray:
        s = []
        for br in ("down", "up"):
            y = res.branch(yname, br)[..., 0] * ys
            x = res.branch(xname, br)[..., 0] * xs
            s.append(quadratic_fit(x, y, c)[1])
        return 0.5 * (s[0] + s[1])

    half_track = _at_static(par, "contact_y")[:, 0]
    out["roll_centre_height"] = half_track * slope(par, "contact_y", "contact_z") * 1e3
    out["motion_ratio"] = -slope(par, "spring_length", "wheel_centre_z")
    out["wheel_rate"] = slope(par, "tyre_fz", "wheel_centre_z") / 1e3
    out["ride_rate"] = slope(par, "tyre_fz", "pad_z") / 1e3
    F = objectives_subset(results, ("opp_roll_rate_pos", "opp_roll_toe", "opp_roll_camber"))
    out["roll_rate"], out["roll_steer"], out["roll_camber"] = F.T
    return out


def objectives_subset(results: dict[str, KCResult], names: tuple[str, ...]) -> np.ndarray:
    """Only the named objectives (n, len(names))."""
    idx = [OBJECTIVE_NAMES.index(n) for n in names]
    subset = tuple(OBJECTIVES[i] for i in idx)
    cols = []
    for obj in subset:
        res = results[obj.test]
        vals = [_reduce(obj, _wheel_curves(res, br), res.static_index) for br in ("down", "up")]
        cols.append(0.5 * (vals[0] + vals[1]))
    return np.stack(cols, axis=1)


# ---------------------------------------------------------- compliance matrix
COMPLIANCE_LOADS = ("Fx", "Fy", "Mz")
COMPLIANCE_OUTPUTS = ("toe", "camber", "wheel_centre_x", "wheel_centre_y")


def compliance_matrix(
    axle: Axle, effects: Sequence[Effect] = ()
) -> tuple[np.ndarray, dict[str, tuple[str, ...]]]:
    """Compliance at the design position (n, 2 wheels, 4 outputs, 3 loads), edge units.

    Loads on each wheel at its contact point, mirrored so that a symmetric axle gives
    equal wheels: Fx forward [kN], Fy outboard [kN], Mz [kN*m] about the vertical
    (positive turns the wheel's front outboard, i.e. towards toe-out). Outputs: toe,
    camber [deg]; wheel-centre x forward, y outboard [mm]. Entries are deg/kN, mm/kN,
    deg/(kN*m), mm/(kN*m). Linearised: the converged static state is moved by
    ``-J^-1 dres/dload`` (fresh Jacobian) and the outputs are differenced centrally.
    """
    from suspenv.models.mcpherson.rotation import cross, rotate
    from suspenv.models.mcpherson.solver import NS, AxleSolver, _down

    solver = AxleSolver(axle, effects)
    n = solver.n
    st, conv, _ = solver.solve(solver.initial_state(), solver.pad_static)
    if not conv.all():
        raise ValidationError("compliance_matrix: no static equilibrium for some designs")
    Jinv = solver.inverse_jacobian(st, solver.pad_static)
    s = rotate(st.R[:, :, 1], solver.s0)
    arm = solver.Rw[..., None] * _down(s)
    sg = SIDE_SIGN
    scale_out = {"toe": RAD2DEG, "camber": RAD2DEG, "wheel_centre_x": 1e3, "wheel_centre_y": 1e3}
    mirror_out = {"wheel_centre_y": sg}
    C = np.zeros((n, 2, len(COMPLIANCE_OUTPUTS), len(COMPLIANCE_LOADS)))
    eps = 100.0  # N or N*m: well inside the linear range
    for w in (0, 1):
        for j, load in enumerate(COMPLIANCE_LOADS):
            f = np.zeros((n, 3))
            m = np.zeros((n, 3))
            if load == "Fx":
                f[:, 0] = 1.0
            elif load == "Fy":
                f[:, 1] = sg[w]
            else:
                m[:, 2] = -sg[w]  # front outboard = toe-out
            b = np.zeros((n, 2, NS))
            b[:, w, 6:9] = f
            b[:, w, 9:12] = cross(arm[:, w], f) + m
            dx = -np.matmul(Jinv, b.reshape(n, -1, 1))[..., 0]
            ok = np.ones(n, bool)
            plus = solver.outputs(solver._apply(st, eps * dx, ok), solver.pad_static)
            minus = solver.outputs(solver._apply(st, -eps * dx, ok), solver.pad_static)
            for i, name in enumerate(COMPLIANCE_OUTPUTS):
                d = (plus[name][:, w] - minus[name][:, w]) / (2 * eps)
                d = d * scale_out[name] * mirror_out.get(name, np.ones(2))[w]
                C[:, w, i, j] = d * 1e3  # per kN or kN*m
    return C, {"outputs": COMPLIANCE_OUTPUTS, "loads": COMPLIANCE_LOADS}
