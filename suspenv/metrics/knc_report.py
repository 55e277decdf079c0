"""The K&C report: the numbers a chassis engineer reads, with ADAMS/Car conventions.

Frames and units (``docs/knc.md``, "K&C report: definitions and signs"): rig channels
are SI and ISO 8855 (x forward, y left, z up); report numbers are in engineering units
(mm, deg, N, N*m, %). Lateral quantities are *outboard positive on each wheel* unless
named ISO (``*_y_iso``); per-wheel numbers are (n, 2) arrays (left, right), axle
numbers are repeated on both wheels.

Travel abscissa: every curve and gradient of this report is against **wheel-centre
travel** ``z_w`` [mm] (wheel-centre height from its static value, bump positive), the
ADAMS/Car "wheel travel"; the rig drives the pads (``amplitude`` is the pad stroke),
and the wheel centre moves less than the pad by the tyre's deflection. The only
exception is the ride rate, which is by definition against the pad (ground).

Reductions: as the 40 objectives (:mod:`suspenv.metrics.knc`): on each branch of the
loop a least-squares quadratic over the 7 grid points centred on the static position;
the value at static is the fit's value, a gradient its slope; the loop's number is the
mean of the two branches.

Points (see :func:`patch_point` and :func:`carrier_patch_velocity`):

* loaded contact point ``P``: where the wheel plane's downward radius (the line from the
  wheel centre, perpendicular to the spin axis, in the vertical plane through the spin
  axis) meets the pad plane ``z = pad_z`` (the tyre is compressed, so ``P`` lies above
  the undeformed wheel's lowest point, the ``contact_*`` channels);
* the *wheel-carrier patch point*: the point of the knuckle (wheel locked to it) that is
  at ``P``; its velocity relative to the body defines the front- and side-view instant
  centres (roll centre, anti-dive). It moves with the knuckle's rotation, so its
  fore-aft path includes the knuckle pitch (channel ``knuckle_pitch``), which the
  geometric contact point does not.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.measurements.knc import DISPLAY, OPPOSED_TESTS, RAD2DEG
from suspenv.metrics.knc import (
    FIT_HALF_WIDTH,
    quadratic_fit,
    roll_angle,
    roll_moment,
)
from suspenv.models.mcpherson.params import SIDE_SIGN, AxleConstants
from suspenv.models.mcpherson.solver import (  # the channels give back the spin axis
    OUTPUT_NAMES,
    spin_axis,
    wheel_down,
)

if TYPE_CHECKING:  # a type only: metrics are functions of rig results, not of the rig
    from suspenv.rigs.knc import KCResult


@dataclass(frozen=True)
class ReportItem:
    """One number of the K&C report.

    Attributes:
        name: key in :func:`knc_report`'s dict.
        unit: engineering unit.
        test: the rig test it is read from.
        per_wheel: True for a wheel's own number, False for an axle number.
        definition: how it is computed (against wheel-centre travel unless stated).
        sign: what a positive value means.
    """

    name: str
    unit: str
    test: str
    per_wheel: bool
    definition: str
    sign: str


def _table(text: str) -> tuple[ReportItem, ...]:
    """The items of a table: a line ``name unit test wheel|axle`` ("wheel": a wheel's own
    number) and, indented below it, the definition, then ``sign:`` what a positive value
    means (each over as many lines as it needs)."""
    items = []
    for block in re.split(r"\n(?=\S)", text.strip()):
        head, _, body = block.partition("\n")
        name, unit, test, which = head.split()
        definition, _, sign = " ".join(body.split()).partition(" sign: ")
        items.append(ReportItem(name, unit, test, which == "wheel", definition, sign))
    return tuple(items)


REPORT_ITEMS: tuple[ReportItem, ...] = _table("""
toe                            deg      parallel  wheel
    toe angle at static
    sign: + toe-in
camber                         deg      parallel  wheel
    camber angle at static
    sign: - top of wheel inboard
caster                         deg      parallel  wheel
    steering axis (lower ball joint -> top mount) angle to vertical, side view
    sign: + axis top rearward
kpi                            deg      parallel  wheel
    steering axis angle to vertical, front view
    sign: + axis top inboard
scrub_radius                   mm       parallel  wheel
    lateral (vehicle y) distance from the loaded contact point to the steering axis's
    pad-plane point
    sign: + (SAE) axis meets the ground inboard of the contact point
trail                          mm       parallel  wheel
    longitudinal (vehicle x) distance from the loaded contact point to the steering axis's
    pad-plane point
    sign: + axis meets the ground ahead of the contact point
bump_steer                     deg/mm   parallel  wheel
    d toe / d z_w
    sign: + toe-in in bump
camber_gain                    deg/mm   parallel  wheel
    d camber / d z_w
    sign: - top inboard in bump
caster_gain                    deg/mm   parallel  wheel
    d caster / d z_w
    sign: + more caster in bump
track_change                   mm/mm    parallel  wheel
    d y_out(loaded contact point) / d z_w
    sign: + contact point outboard in bump
wheel_recession                mm/mm    parallel  wheel
    d x(wheel centre) / d z_w
    sign: + wheel centre forward in bump
wheel_rate                     N/mm     parallel  wheel
    d F_z / d z_w
    sign: + stiffening
ride_rate                      N/mm     parallel  wheel
    d F_z / d z_pad (tyre in series)
    sign: + stiffening
spring_motion_ratio            mm/mm    parallel  wheel
    -d(spring length)/d z_w
    sign: + spring compresses in bump
damper_motion_ratio            mm/mm    parallel  wheel
    -d(strut length: top mount to strut axis point)/d z_w
    sign: + strut compresses in bump
roll_centre_height             mm       parallel  axle
    front-view roll centre above the mean pad plane (instant centres of the carrier patch
    points)
    sign: + above the ground
geometric_roll_centre_height   mm       parallel  axle
    front-view construction at the static position from the hard points: each wheel's
    instant centre where the lower arm's line (its pivot axis pierced by the ball joint's
    transverse plane, to the ball joint) meets the normal to the strut axis at the strut
    top; the lines from the loaded contact points through them meet at the roll centre, its
    height above the mean pad plane
    sign: + above the ground
roll_centre_migration          mm/mm    parallel  axle
    d(roll_centre_height) / d(mean z_w)
    sign: + roll centre rises in bump
anti_dive                      %        parallel  wheel
    100 front_brake_share (wheelbase/cg_height) dx/dz of the carrier patch point
    sign: + resists dive under braking
anti_lift                      %        parallel  wheel
    100 front_drive_share (wheelbase/cg_height) dx/dz of the wheel centre
    sign: + resists front lift under traction
roll_rate                      N*m/deg  opposite  axle
    d(0.5 (F_zL - F_zR) t_cp)/d phi
    sign: + resists roll
roll_steer                     deg/deg  opposite  wheel
    d toe / d phi_w (own roll sense)
    sign: + toe-in as the wheel rises
roll_camber                    deg/deg  opposite  wheel
    d camber / d phi_w (own roll sense)
    sign: - top inboard as the wheel rises
roll_centre_y_iso              mm       opposite  axle
    front-view roll centre y at static (ISO y, + left)
    sign: + left of the centreline
roll_centre_lateral_migration  mm/deg   opposite  axle
    d(roll centre y, ISO) / d phi
    sign: + moves left (ISO +y) as phi grows (left wheel up relative to the body)
tramp_rate                     N*m/deg  opposite  axle
    axle roll (tramp) rate at the contact patches, body held: d(0.5 (F_zL - F_zR) t_cp)/d
    phi_pad, phi_pad = atan((z_pL - z_pR)/t_cp) from the pad heights: the suspension with
    its anti-roll bar in series with the tyres (roll_rate: the suspension alone, against the
    wheel centres)
    sign: + resists axle roll
arb_motion_ratio               deg/mm   opposite  axle
    d(anti-roll bar twist) / d(z_wL - z_wR)
    sign: + as the arb_twist channel
""")
STEERING_ITEMS: tuple[ReportItem, ...] = _table("""
steer_gradient                 deg/mm   steering  wheel
    d(road-wheel steer angle)/d(rack travel)
    sign: + wheel steers left as the rack moves +y
steer_ratio                    -        steering  axle
    |d(steering-wheel angle)/d(mean road-wheel angle)|, steering-wheel angle = 360 deg x
    rack travel / rack_travel_per_rev
    sign: always positive
ackermann_error                deg      steering  axle
    inner wheel's angle minus the Ackermann angle for the outer wheel's angle (wheelbase,
    kingpin-axis ground-point track), mean of both turn directions at the largest rack
    travel
    sign: + inner wheel steers more than Ackermann
ackermann_pct                  %        steering  axle
    100 (inner - outer) / (Ackermann inner - outer) of the road-wheel angles, mean of both
    turn directions at the largest rack travel (0 % parallel steer, 100 % ideal)
    sign: + towards Ackermann
""")


#: compliance test -> (load in each wheel's own sense per unit of the rig's drive (left,
#: right), unit of that load, its words)
_OWN_LOAD = {
    "lateral": (SIDE_SIGN * 1e-3, "kN", "outward (cornering) force at the contact patch"),
    "longitudinal": (
        np.array([-1e-3, -1e-3]),
        "kN",
        "rearward (braking) force at the contact patch",
    ),
    "traction": (np.array([1e-3, 1e-3]), "kN", "forward (tractive) force at the wheel centre"),
    "aligning": (SIDE_SIGN * 1e-3, "kN m", "toe-out moment about the vertical"),
}
# the opposed tests: the in-phase load turned on the right wheel (suspenv.rigs.knc)
_OWN_LOAD.update(
    {
        o: (
            _OWN_LOAD[p][0] * np.array([1.0, -1.0]),
            _OWN_LOAD[p][1],
            f"{_OWN_LOAD[p][2]}, the two wheels opposed",
        )
        for o, p in OPPOSED_TESTS.items()
    }
)


def _as_shown(chan: str) -> tuple[str, np.ndarray, str, str]:
    """A compliance output as the channel is shown (:data:`DISPLAY`), the same on both wheels."""
    shown = DISPLAY[chan]
    return chan, np.full(2, shown.scale), shown.unit, shown.sign


#: compliance outputs: suffix -> (channel, scale per wheel from SI, unit, sense)
_OWN_OUTPUT = {
    "steer": _as_shown("toe"),
    "camber": _as_shown("camber"),
    "wc_x": ("wheel_centre_x", np.array([1e3, 1e3]), "mm", "wheel centre forward"),
    "wc_y": ("wheel_centre_y", SIDE_SIGN * 1e3, "mm", "wheel centre outboard"),
}


def _compliance_items() -> tuple[ReportItem, ...]:
    out = []
    for test, (_, lu, lw) in _OWN_LOAD.items():
        for suffix, (_, _, ou, sense) in _OWN_OUTPUT.items():
            out.append(
                ReportItem(
                    f"{test}_compliance_{suffix}",
                    f"{ou}/{lu}",
                    test,
                    True,
                    f"slope at zero load of the output against the {lw}, both wheels loaded "
                    f"{'in opposite ISO directions' if 'opposed' in test else 'in phase'}, "
                    "pads static",
                    f"+ {sense} per {lu} of {lw}",
                )
            )
    return tuple(out)


#: channels whose hysteresis loop width is reported: channel -> (scale from SI, unit)
LOOP_CHANNELS = {c: (DISPLAY[c].scale, DISPLAY[c].unit) for c in ("toe", "camber", "tyre_fz")}
#: tests whose loop widths are reported
LOOP_TESTS = ("parallel", "opposite", "single", "lateral", "longitudinal", "traction", "aligning")


def _loop_items() -> tuple[ReportItem, ...]:
    return tuple(
        ReportItem(
            f"{test}_loop_width_{chan}",
            unit,
            test,
            True,
            "hysteresis: half the difference between the loading and unloading branches "
            "at the static position (the branches' mean is the other numbers' value)",
            "+ the loading branch above the unloading one",
        )
        for test in LOOP_TESTS
        for chan, (_, unit) in LOOP_CHANNELS.items()
    )


#: wheel-centre stiffness -> (compliance test, its compliance number's suffix): the
#: reciprocal of that compliance (the load per unit displacement at zero load)
_STIFFNESS = {
    "lateral_stiffness_wc": ("lateral", "wc_y"),
    "longitudinal_stiffness_wc": ("traction", "wc_x"),
}
_FORCE_ITEMS = _table("""
lateral_stiffness_wc           N/mm     lateral   wheel
    1 / lateral_compliance_wc_y: outward force at the contact patch per mm of outward
    wheel-centre displacement at zero load, both wheels loaded in phase, pads static
    sign: + the wheel centre moves with the force
longitudinal_stiffness_wc      N/mm     traction  wheel
    1 / traction_compliance_wc_x: forward force at the wheel centre per mm of forward
    wheel-centre displacement at zero load, both wheels loaded in phase, pads static
    sign: + the wheel centre moves with the force
force_roll_centre_height       mm       lateral   axle
    front view, lateral test: through each wheel's loaded contact point P the line of the
    ground's load change per unit outward force (outward 1, up dF_z/dF_y, the jacking
    coefficient at zero load); the two lines meet at the force-based roll centre, its height
    above the mean pad plane
    sign: + above the ground (an outward force then unloads the pad)
""")


#: compliance numbers, loop widths, wheel-centre stiffnesses and the force-based roll
#: centre (:func:`compliance_report`)
COMPLIANCE_ITEMS: dict[str, ReportItem] = {
    i.name: i for i in _compliance_items() + _loop_items() + _FORCE_ITEMS
}


def compliance_report(results: dict[str, KCResult]) -> dict[str, np.ndarray]:
    """Compliance numbers of the force tests present (:data:`COMPLIANCE_ITEMS`), each
    (n, 2): the loop mean of the slope at zero load of each wheel's output against the
    load in that wheel's own sense (:data:`_OWN_LOAD`), and the loop widths of every test
    present (:func:`loop_half_width`). NaN where a channel is missing."""
    out: dict[str, np.ndarray] = {}
    for test in _OWN_LOAD:
        if test in results:
            for suffix, (chan, scale, _, _) in _OWN_OUTPUT.items():
                out[f"{test}_compliance_{suffix}"] = _own_slope(results[test], test, chan, scale)
    for test in LOOP_TESTS:
        if test in results:
            for chan in LOOP_CHANNELS:
                out[f"{test}_loop_width_{chan}"] = loop_half_width(results[test], chan)
    for name, (test, suffix) in _STIFFNESS.items():
        if test in results:
            with np.errstate(divide="ignore"):
                out[name] = 1e3 / out[f"{test}_compliance_{suffix}"]
    if "lateral" in results:
        out["force_roll_centre_height"] = _both(force_roll_centre(results["lateral"])[1])
    return out


def force_roll_centre(res: KCResult) -> tuple[np.ndarray, np.ndarray]:
    """Force-based roll centre (y ISO [mm], height above the mean pad plane [mm]), each
    (n,), of the lateral test ``res`` (pads static, +F along +y at both loaded contact
    points P; or the ``lateral_opposed`` test, outboard at both): each wheel's jacking
    coefficient j = dF_z/dF_y (tyre load, compression +, against the outward force at
    zero load, loop mean of the 7-point fit) gives the direction (outward 1, up j) of
    the ground's load change on that wheel; its line through P (static,
    :func:`patch_point`) carries the load into the body, and the two wheels' lines meet
    at the roll centre. NaN when a channel it reads is missing. With rigid tyres and no
    load path between the wheels each line runs through the wheel's front-view instant
    centre (virtual work: the load does no work on the held wheel), so the opposed test
    gives the kinematic roll centre; the in-phase test adds the anti-roll bar's and the
    tyres' share (docs/knc.md)."""
    if res.test not in ("lateral", "lateral_opposed"):
        raise ValidationError(f"force_roll_centre needs a lateral test, but got {res.test!r}")
    if any(c not in res.channels for c in compliance_reads("force_roll_centre_height")):
        nan = np.full(res.ok.size, np.nan)
        return nan, nan
    j = _own_slope(res, res.test, "tyre_fz", np.ones(2)) * 1e-3  # N per N
    P = static_patch_point(res)
    v = np.zeros_like(P)  # the line's normal (_lines_meet): direction (s_w, j) in y-z
    v[..., 1], v[..., 2] = -j, SIDE_SIGN
    return _above_pads(*_lines_meet(P, v), P)


def loop_half_width(res: KCResult, chan: str) -> np.ndarray:
    """Half the gap (n, 2) between the ascending (loading) and descending (unloading)
    branches of channel ``chan`` at the static position, in :data:`LOOP_CHANNELS` units
    (NaN when the channel is missing)."""
    if chan not in res.channels:
        return np.full((res.ok.size, 2), np.nan)
    i = res.static_index
    gap = res.branch(chan, "up")[:, i] - res.branch(chan, "down")[:, i]
    return 0.5 * gap * LOOP_CHANNELS[chan][0]


def _own_slope(res: KCResult, test: str, chan: str, scale: np.ndarray) -> np.ndarray:
    """Loop mean (n, 2) of the slope at zero load of channel ``chan`` times ``scale``
    (per wheel) against each wheel's own load (:data:`_OWN_LOAD`, per kN or kN m)."""
    per = _OWN_LOAD[test][0]
    if chan not in res.channels:
        return np.full((res.ok.size, 2), np.nan)
    load = res.grid[None, :, None] * per[None, None, :]

    def slope(br: str) -> np.ndarray:
        y = res.branch(chan, br) * scale
        return _fit(np.broadcast_to(load, y.shape), y, res.static_index)[1]

    return _loop(res, slope)


# ------------------------------------------------------------------ helpers
def _fit(x: np.ndarray, y: np.ndarray, centre: int) -> tuple[np.ndarray, np.ndarray]:
    """(value, slope) at ``centre`` of curves (n, G, 2) against (n, G, 2): (n, 2) each."""
    xs, ys = np.moveaxis(x, 1, -1), np.moveaxis(y, 1, -1)
    value, slope, _ = quadratic_fit(xs, ys, centre)
    return value, slope


def _loop(res: KCResult, fn) -> np.ndarray:
    """Mean over the two branches of ``fn(branch)``."""
    return 0.5 * (fn("down") + fn("up"))


def _from_static(res: KCResult, branch: str, chan: str) -> np.ndarray:
    """Channel ``chan`` (n, G, 2) [m] from its static value on ``branch``, in mm."""
    z = res.branch(chan, branch)
    return (z - z[:, res.static_index : res.static_index + 1]) * 1e3


def wheel_travel(res: KCResult, branch: str) -> np.ndarray:
    """Wheel-centre travel z_w (n, G, 2) [mm] from its static value on ``branch``."""
    return _from_static(res, branch, "wheel_centre_z")


def patch_point(res: KCResult, branch: str) -> np.ndarray:
    """Loaded contact point P (n, G, 2, 3) [m], ISO: the wheel plane's downward radius
    from the wheel centre meets the pad plane ``z = pad_z``."""
    b = lambda name: res.branch(name, branch)  # noqa: E731
    wc = np.stack([b("wheel_centre_x"), b("wheel_centre_y"), b("wheel_centre_z")], axis=-1)
    d = wheel_down(spin_axis(b("camber"), b("toe")))
    t = (b("pad_z") - wc[..., 2]) / d[..., 2]
    return wc + t[..., None] * d


def static_patch_point(res: KCResult) -> np.ndarray:
    """Loaded contact point P (n, 2, 3) [m] at the static position (:func:`patch_point`,
    mean of the two branches)."""
    return 0.5 * (patch_point(res, "down") + patch_point(res, "up"))[:, res.static_index]


def _above_pads(y: np.ndarray, z: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A front-view point (y ISO, z) [m] as (y [mm], height above the mean pad plane [mm]),
    the pad plane that of the two wheels' contact points ``P`` (..., 2, 3) [m]."""
    ground = 0.5 * (P[..., 0, 2] + P[..., 1, 2])
    return y * 1e3, (z - ground) * 1e3


def carrier_patch_velocity(
    res: KCResult, branch: str, need_pitch: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """(P, dP/dz_w): the loaded contact point P (n, G, 2, 3) [m] and the velocity of the
    wheel-carrier point at P per metre of wheel-centre travel (n, G, 2, 3) [m/m], ISO.

    v = v_wc + w x (P - wc), the carrier's angular velocity w from the spin axis's
    change (w_perp = s x ds, s from the toe and camber channels) and the rotation about
    +y from ``knuckle_pitch`` (fixes w's component along s). Derivatives along the
    branch against each wheel's own wheel-centre height (second-order differences).

    Without a ``knuckle_pitch`` channel (a measurement that lacks it) and
    ``need_pitch=False``, w's component along s is taken as zero: that changes only the
    velocity's x component (s x (P - wc) is horizontal and along x to first order), so
    the front view (roll centre) stays right and the side view (anti-dive) does not;
    ``need_pitch=True`` raises instead."""
    have_pitch = "knuckle_pitch" in res.channels
    if need_pitch and not have_pitch:
        raise ValidationError(
            f"carrier_patch_velocity: test {res.test!r} has no `knuckle_pitch` channel, which "
            "the wheel carrier's side-view path needs"
        )
    b = lambda name: res.branch(name, branch)  # noqa: E731
    z = b("wheel_centre_z")
    wc = np.stack([b("wheel_centre_x"), b("wheel_centre_y"), z], axis=-1)
    s = spin_axis(b("camber"), b("toe"))
    P = patch_point(res, branch)

    def ddz(y: np.ndarray) -> np.ndarray:  # y (n, G, 2[, 3]) against z (n, G, 2)
        zz = z if y.ndim == z.ndim else z[..., None]
        return np.gradient(y, axis=1) / np.gradient(zz, axis=1)

    ds = ddz(s)
    w = np.cross(s, ds)
    if have_pitch:
        wy = ddz(b("knuckle_pitch"))
        w = w + ((wy - w[..., 1]) / s[..., 1])[..., None] * s
    return P, ddz(wc) + np.cross(w, P - wc)


def _lines_meet(P: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Front-view roll centre (y, z) ISO [m] (...,) where the lines through each wheel's
    patch point P (..., 2, 3), perpendicular to its velocity v (..., 2, 3) in the y-z
    plane, meet."""
    n = np.stack([v[..., 2], -v[..., 1]], axis=-1)  # (..., 2 wheels, 2): perpendicular
    p = P[..., 1:3]
    y, z = np.moveaxis(_meet(p[..., 0, :], n[..., 0, :], p[..., 1, :], n[..., 1, :]), -1, 0)
    return y, z


def roll_centre_curve(res: KCResult, branch: str) -> tuple[np.ndarray, np.ndarray]:
    """Roll centre along a branch: (y ISO [mm], height above the mean pad plane [mm]),
    each (n, G). Front view: each wheel's line through its carrier patch point,
    perpendicular to that point's velocity relative to the body (the line to the
    wheel's front-view instant centre); the roll centre is where the two lines meet."""
    P, v = carrier_patch_velocity(res, branch, need_pitch=False)
    return _above_pads(*_lines_meet(P, v), P)


def _meet(p: np.ndarray, d: np.ndarray, q: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Where the lines p + a d and q + b e meet (..., 2), in a plane (points and
    directions (..., 2))."""
    det = d[..., 0] * -e[..., 1] + e[..., 0] * d[..., 1]
    r = q - p
    a = (r[..., 0] * -e[..., 1] + e[..., 0] * r[..., 1]) / det
    return p + a[..., None] * d


def front_view_instant_centre(points: dict[str, np.ndarray]) -> np.ndarray:
    """Each wheel's front-view instant centre (y, z) ISO [m] (n, 2, 2) of a McPherson
    corner from its hard points (n, 2, 3) [m] (:func:`~suspenv.rigs.knc.static_hard_points`):
    the lower arm's line, from where its pivot axis (front to rear bush) crosses the
    transverse plane of the ball joint to the ball joint, meets the line through the
    strut top perpendicular to the strut axis (strut top to strut axis point), both
    projected on the y-z plane (the drawing-board construction; exact for a linkage
    whose arm axis is along x and strut axis in the y-z plane)."""
    F, Rr, B = points["lca_front_bush"], points["lca_rear_bush"], points["lower_ball_joint"]
    T, S = points["strut_top"], points["strut_axis_point"]
    A = F + ((B[..., 0] - F[..., 0]) / (Rr[..., 0] - F[..., 0]))[..., None] * (Rr - F)
    k = S - T
    normal = np.stack([k[..., 2], -k[..., 1]], axis=-1)
    return _meet(A[..., 1:], B[..., 1:] - A[..., 1:], T[..., 1:], normal)


def geometric_roll_centre(res: KCResult) -> tuple[np.ndarray, np.ndarray]:
    """Geometric roll centre (y ISO [mm], height above the mean pad plane [mm]), each
    (n,), at the static position of ``res`` (a rig result with
    :attr:`~suspenv.rigs.knc.KCResult.static_points`): the lines from each wheel's loaded
    contact point P (:func:`patch_point`, static) through its
    :func:`front_view_instant_centre` meet at it. It equals the kinematic roll centre
    (:func:`roll_centre_curve`) where the construction is exact; off design and for a
    skewed arm axis or strut they differ."""
    P = static_patch_point(res)
    ic = front_view_instant_centre(res.static_points)
    p = P[..., 1:]
    y, z = np.moveaxis(_meet(p[:, 0], ic[:, 0] - p[:, 0], p[:, 1], ic[:, 1] - p[:, 1]), -1, 0)
    return _above_pads(y, z, P)


# ------------------------------------------------------------------ the report
def _need(results: dict[str, KCResult], test: str) -> KCResult:
    if test not in results:
        raise ValidationError(f"the K&C report needs the {test!r} test, which was not run")
    res = results[test]
    if res.static_index < FIT_HALF_WIDTH:
        raise ValidationError(
            f"the K&C report needs `steps >= {2 * FIT_HALF_WIDTH}` (a 7-point fit around the "
            f"static position), but the {test!r} test has steps={res.grid.size - 1}"
        )
    return res


def _both(v: np.ndarray) -> np.ndarray:
    """An axle number (n,) or curve (n, G) repeated on both wheels (..., 2)."""
    return np.repeat(v[..., None], 2, axis=-1)


def _grad(res: KCResult, y_of, x_of=wheel_travel) -> np.ndarray:
    """Loop mean of the fitted slope at static of ``y_of(branch)`` against
    ``x_of(res, branch)`` (both (n, G, 2)): (n, 2)."""
    return _loop(res, lambda br: _fit(x_of(res, br), y_of(br), res.static_index)[1])


def _value(res: KCResult, y_of, x_of=wheel_travel) -> np.ndarray:
    """Loop mean of the fitted value at static of ``y_of(branch)``: (n, 2)."""
    return _loop(res, lambda br: _fit(x_of(res, br), y_of(br), res.static_index)[0])


def pad_travel(res: KCResult, branch: str) -> np.ndarray:
    """Pad travel z_p (n, G, 2) [mm] from its static value on ``branch``."""
    return _from_static(res, branch, "pad_z")


def mean_wheel_travel(res: KCResult, branch: str) -> np.ndarray:
    """Mean of the two wheels' wheel-centre travel (n, G, 2) [mm] (repeated)."""
    return _both(wheel_travel(res, branch).mean(axis=-1))


def travel_difference(res: KCResult, branch: str) -> np.ndarray:
    """z_wL - z_wR (n, G, 2) [mm] (repeated)."""
    zw = wheel_travel(res, branch)
    return _both(zw[..., 0] - zw[..., 1])


def roll_axis(res: KCResult, branch: str) -> np.ndarray:
    """Roll angle phi (n, G, 2) [deg] = atan((z_wL - z_wR)/t), t the static wheel-centre
    track, zero at static (as the 40 objectives; :func:`~suspenv.metrics.knc.roll_angle`),
    repeated on both wheels."""
    b = lambda name: res.branch(name, branch)  # noqa: E731
    return _both(roll_angle(b("wheel_centre_z"), b("wheel_centre_y"), res.static_index))


def own_roll(res: KCResult, branch: str) -> np.ndarray:
    """Each wheel's own roll sense phi_w = +phi (left), -phi (right) (n, G, 2) [deg]."""
    return roll_axis(res, branch) * SIDE_SIGN


def travel_report(
    results: dict[str, KCResult], constants: AxleConstants | None = None
) -> dict[str, np.ndarray]:
    """The travel-test numbers of :data:`REPORT_ITEMS`, each (n, 2) (left, right wheel;
    axle numbers repeated), in the items' units. Needs ``parallel`` and ``opposite``.
    ``constants`` gives wheelbase, cg height and brake/drive shares for anti-dive/lift
    (default: :class:`AxleConstants` defaults)."""
    c = constants or AxleConstants()
    par = _need(results, "parallel")
    opp = _need(results, "opposite")
    sg = SIDE_SIGN
    out: dict[str, np.ndarray] = {}

    def chan(res: KCResult, name: str, scale: float = 1.0):
        return lambda br: res.branch(name, br) * scale

    for name in ("toe", "camber", "caster", "kpi"):
        out[name] = _value(par, chan(par, name, RAD2DEG))
    out["scrub_radius"] = _value(par, chan(par, "scrub_radius", 1e3))
    out["trail"] = _value(par, chan(par, "trail", 1e3))
    out["bump_steer"] = _grad(par, chan(par, "toe", RAD2DEG))
    out["camber_gain"] = _grad(par, chan(par, "camber", RAD2DEG))
    out["caster_gain"] = _grad(par, chan(par, "caster", RAD2DEG))
    out["track_change"] = _grad(par, lambda br: patch_point(par, br)[..., 1] * sg * 1e3)
    out["wheel_recession"] = _grad(par, chan(par, "wheel_centre_x", 1e3))
    out["wheel_rate"] = _grad(par, chan(par, "tyre_fz"))
    out["ride_rate"] = _grad(par, chan(par, "tyre_fz"), pad_travel)
    nan = np.full(out["toe"].shape, np.nan)  # a number whose channel was not measured
    for name, length in (("spring", "spring_length"), ("damper", "strut_length")):
        ratio = -_grad(par, chan(par, length, 1e3)) if length in par.channels else nan
        out[f"{name}_motion_ratio"] = ratio

    # roll centre and its migration against the mean wheel travel (parallel)
    def rc(res: KCResult, k: int):  # the roll centre's y (k = 0) or height (k = 1)
        return lambda br: _both(roll_centre_curve(res, br)[k])

    out["roll_centre_height"] = _value(par, rc(par, 1), mean_wheel_travel)
    out["roll_centre_migration"] = _grad(par, rc(par, 1), mean_wheel_travel)
    out["geometric_roll_centre_height"] = (
        _both(geometric_roll_centre(par)[1]) if par.static_points else nan
    )

    # side-view paths: anti-dive (carrier patch point), anti-lift (wheel centre)
    lever = c.wheelbase / c.cg_height

    def patch_slope(br: str) -> np.ndarray:
        _, v = carrier_patch_velocity(par, br)
        return v[..., 0] / v[..., 2]

    out["anti_dive"] = (
        100.0 * c.front_brake_share * lever * _value(par, patch_slope)
        if "knuckle_pitch" in par.channels
        else nan
    )
    out["anti_lift"] = 100.0 * c.front_drive_share * lever * out["wheel_recession"]

    # opposite travel: roll rate, roll steer and camber, roll centre's lateral position
    oi = opp.static_index

    def moment(br: str) -> np.ndarray:
        return _both(roll_moment(opp.branch("tyre_fz", br), opp.branch("contact_y", br), oi))

    def pad_roll(res: KCResult, br: str) -> np.ndarray:  # phi_pad [deg], zero at static
        return _both(roll_angle(res.branch("pad_z", br), res.branch("contact_y", br), oi))

    out["roll_rate"] = _grad(opp, moment, roll_axis)
    out["tramp_rate"] = _grad(opp, moment, pad_roll)
    out["roll_steer"] = _grad(opp, chan(opp, "toe", RAD2DEG), own_roll)
    out["roll_camber"] = _grad(opp, chan(opp, "camber", RAD2DEG), own_roll)
    out["roll_centre_y_iso"] = _value(opp, rc(opp, 0), roll_axis)
    out["roll_centre_lateral_migration"] = _grad(opp, rc(opp, 0), roll_axis)
    out["arb_motion_ratio"] = (
        _grad(opp, chan(opp, "arb_twist", RAD2DEG), travel_difference)
        if "arb_twist" in opp.channels
        else nan
    )
    return out


# -------------------------------------------------------- usual K&C outputs
def usual_outputs(results: dict[str, KCResult]) -> dict[str, np.ndarray]:
    """Classic K&C numbers per design (n,) (left wheel unless an axle quantity), edge units:
    the left-wheel column of the K&C report (:func:`suspenv.metrics.knc_report.travel_report`,
    whose docstring and ``docs/knc.md`` give every definition and sign).

    caster, kpi [deg]; scrub_radius (SAE: positive when the steering axis meets the pad
    plane inboard of the loaded contact point), trail (positive when it meets it ahead)
    [mm]; roll_centre_height [mm above the pad plane] from the front-view instant centres
    of the wheel carriers' points at the loaded contact points in parallel travel;
    motion_ratio = -d(spring length)/d(wheel-centre travel); wheel_rate (against
    wheel-centre travel), ride_rate (against pad travel) [N/mm]; roll_rate [N*m/deg];
    roll_steer, roll_camber [deg/deg].
    """
    rep = travel_report(results)
    keys = {"spring_motion_ratio": "motion_ratio"}
    names = (
        "caster", "kpi", "scrub_radius", "trail", "roll_centre_height", "spring_motion_ratio",
        "wheel_rate", "ride_rate", "roll_rate", "roll_steer", "roll_camber",
    )  # fmt: skip
    return {keys.get(k, k): rep[k][:, 0] for k in names}


# ------------------------------------------------------------------ steering
def steer_angle(res: KCResult, branch: str) -> np.ndarray:
    """Road-wheel steer angle delta (n, G, 2) [deg] from static, about +z (ISO: + the
    wheel's front turns to the left): delta_w = -sign_w (toe_w - toe_w,static)."""
    toe = res.branch("toe", branch) * RAD2DEG
    st = res.static_index
    return -SIDE_SIGN * (toe - toe[:, st : st + 1])


def ackermann_error_curve(
    res: KCResult, branch: str, wheelbase_mm: float, track_mm: np.ndarray
) -> np.ndarray:
    """Ackermann error (n, G) [deg] along the steering test: the inner wheel's steer
    angle minus the angle that would turn it about the same centre as the outer wheel,
    ``atan(L tan d_o / (L - t tan d_o))`` (L wheelbase, t the static kingpin-axis
    ground-point track ``track_mm`` (n,)); the inner wheel is the one on the side the
    axle turns to (left for a mean steer angle > 0). Zero where the wheels are straight."""
    turn, inner, outer = _inner_outer(steer_angle(res, branch))
    to = np.tan(np.deg2rad(outer))
    ideal = np.rad2deg(np.arctan2(wheelbase_mm * to, wheelbase_mm - track_mm[:, None] * to))
    return np.where(turn != 0, inner - ideal, 0.0)


def _inner_outer(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The turn's sense (+1 left, -1 right, 0 straight) and the inner and outer wheels'
    steer angles as magnitudes in that sense [deg], each (...,), of the steer angles
    ``d`` (..., 2) (left, right; the inner wheel on the side the mean angle turns to)."""
    turn = np.sign(d.mean(axis=-1))
    inner = np.where(turn > 0, d[..., 0], d[..., 1]) * turn
    outer = np.where(turn > 0, d[..., 1], d[..., 0]) * turn
    return turn, inner, outer


def steering_curves(
    res: KCResult, constants: AxleConstants | None = None, track_mm: np.ndarray | None = None
) -> dict[str, np.ndarray]:
    """Curves of the ``steering`` test on the loop's mid-line (mean of the branches):
    ``rack`` (G,) [mm] (rack travel along +y), ``toe`` (n, G, 2) [deg] (+ toe-in, left
    and right), ``steer_angle`` (n, G, 2) [deg] (+ front to the left) and
    ``ackermann_error`` (n, G) [deg] (:func:`ackermann_error_curve`; ``track_mm`` (n,)
    the kingpin-axis ground-point track, default this test's own static one)."""
    c = constants or AxleConstants()
    t = kingpin_ground_track(res) if track_mm is None else np.asarray(track_mm, float)
    return {
        "rack": res.grid * 1e3,
        "toe": res.mean_branch("toe") * RAD2DEG,
        "steer_angle": _loop(res, lambda br: steer_angle(res, br)),
        "ackermann_error": _loop(res, lambda br: ackermann_error_curve(res, br, c.wheelbase, t)),
    }


def kingpin_ground_track(res: KCResult) -> np.ndarray:
    """Static track (n,) [mm] of the steering axes' pad-plane points: from the loaded
    contact point, the trail (x) and the SAE scrub radius (y, inboard positive)."""
    P = static_patch_point(res)
    scrub = res.mean_branch("scrub_radius")[:, res.static_index]
    gy = P[..., 1] - SIDE_SIGN * scrub
    return (gy[:, 0] - gy[:, 1]) * 1e3


def steering_report(
    results: dict[str, KCResult], constants: AxleConstants | None = None
) -> dict[str, np.ndarray]:
    """The steering numbers of :data:`STEERING_ITEMS`, each (n, 2) (axle numbers
    repeated), from the ``steering`` test (rack travel [m] along +y, pads static)."""
    c = constants or AxleConstants()
    res = _need(results, "steering")
    ci = res.static_index
    rack = lambda br: np.broadcast_to(  # noqa: E731
        (res.grid * 1e3)[None, :, None], res.branch("toe", br).shape
    )
    grad = _loop(res, lambda br: _fit(rack(br), steer_angle(res, br), ci)[1])
    out = {"steer_gradient": grad}
    # steering-wheel angle [deg] per mm of rack: 360 / c-factor
    sw_per_mm = 360.0 / c.rack_travel_per_rev
    ratio = sw_per_mm / np.abs(grad.mean(axis=-1))
    out["steer_ratio"] = _both(ratio)
    track = kingpin_ground_track(results.get("parallel", res))
    err = _loop(res, lambda br: _ends(ackermann_error_curve(res, br, c.wheelbase, track)))
    out["ackermann_error"] = _both(err)
    out["ackermann_pct"] = _both(_loop(res, lambda br: ackermann_pct(res, br, c.wheelbase, track)))
    return out


def _ends(v: np.ndarray) -> np.ndarray:
    """Mean (n,) of the first and last columns of ``v`` (n, G): both ends of the rack travel."""
    return 0.5 * (v[:, 0] + v[:, -1])


def ackermann_pct(
    res: KCResult, branch: str, wheelbase_mm: float, track_mm: np.ndarray
) -> np.ndarray:
    """Ackermann percentage (n,) on ``branch``: ``100 (d_i - d_o) / (d_A - d_o)`` at both
    ends of the rack travel, averaged (``d_i``, ``d_o`` the inner and outer wheels' steer
    angles, ``d_A`` the Ackermann angle for ``d_o``: :func:`ackermann_error_curve`)."""
    _, inner, outer = _inner_outer(steer_angle(res, branch))
    err = ackermann_error_curve(res, branch, wheelbase_mm, track_mm)
    ends = [0, -1]
    inner, outer, ideal = inner[:, ends], outer[:, ends], inner[:, ends] - err[:, ends]
    return _ends(100.0 * (inner - outer) / (ideal - outer))


def knc_report(
    results: dict[str, KCResult], constants: AxleConstants | None = None
) -> dict[str, np.ndarray]:
    """Every report number the ``results`` allow: :func:`travel_report` (needs
    ``parallel`` and ``opposite``) and :func:`steering_report` (needs ``steering``).
    A channel the results lack (a rig that records no contact-patch position, say)
    makes the numbers that read it NaN (:func:`report_needs` says which)."""
    with np.errstate(all="ignore"):
        return knc_report_filled(_filled(results, np.nan), constants)


#: channels whose absence the report handles itself (the numbers reading them are NaN,
#: the others computed without them)
OPTIONAL_CHANNELS = ("knuckle_pitch", "spring_length", "strut_length", "arb_twist")


def _filled(results: dict[str, KCResult], value: float, only: str = "") -> dict[str, KCResult]:
    """``results`` with every rig channel they lack set to NaN, or, probing the missing
    channel ``only`` (``"test:channel"``), that one NaN (absent if optional) and the
    other missing ones ``value``. Optional channels (:data:`OPTIONAL_CHANNELS`) stay
    absent unless probed with a finite ``value``."""
    out = {}
    for t, r in results.items():
        shape = next(iter(r.channels.values())).shape
        extra = {}
        for c in OUTPUT_NAMES:
            probed = f"{t}:{c}" == only
            if c in r.channels or (c in OPTIONAL_CHANNELS and (probed or np.isnan(value))):
                continue
            extra[c] = np.full(shape, np.nan if probed else value)
        out[t] = dataclasses.replace(r, channels={**r.channels, **extra}) if extra else r
    return out


def report_needs(results: dict[str, KCResult]) -> dict[str, str]:
    """Report and compliance items (:data:`ALL_ITEMS`, :data:`COMPLIANCE_ITEMS`) the
    ``results`` cannot give, each with what it needs: a test not run, or the channels
    (``test:channel``) the rig did not record."""
    needs: dict[str, list[str]] = {}
    for item in ALL_ITEMS.values():
        if item.test not in results or (item.test == "parallel" and "opposite" not in results):
            tests = [t for t in (item.test, "opposite") if t not in results]
            needs[item.name] = [f"the {t} test" for t in dict.fromkeys(tests)]
    par = results.get("parallel")
    if par is not None and not par.static_points:
        needs.setdefault("geometric_roll_centre_height", []).append(
            "the hard points (a model of the axle; a rig does not record them)"
        )
    for item in COMPLIANCE_ITEMS.values():
        if item.test not in results:
            needs[item.name] = [f"the {item.test} test"]
            continue
        have = results[item.test].channels
        lacks = [f"channel {item.test}:{c}" for c in compliance_reads(item.name) if c not in have]
        if lacks:
            needs[item.name] = lacks
    missing = [f"{t}:{c}" for t, r in results.items() for c in OUTPUT_NAMES if c not in r.channels]
    for m in missing:
        with np.errstate(all="ignore"):
            rep = knc_report_filled(_filled(results, 0.0, only=m))
        for name, v in rep.items():
            if not np.all(np.isfinite(v)):
                needs.setdefault(name, []).append(f"channel {m}")
    return {k: "needs: " + ", ".join(v) for k, v in needs.items()}


#: channels the loaded contact point P is built from (:func:`patch_point`)
_PATCH_CHANNELS = ("wheel_centre_x", "wheel_centre_y", "wheel_centre_z", "toe", "camber", "pad_z")


def compliance_reads(name: str) -> tuple[str, ...]:
    """The rig channels a :data:`COMPLIANCE_ITEMS` number reads."""
    if name == "force_roll_centre_height":
        return ("tyre_fz", *_PATCH_CHANNELS)
    if name in _STIFFNESS:
        return (_OWN_OUTPUT[_STIFFNESS[name][1]][0],)
    if "_loop_width_" in name:
        return (name.rpartition("_loop_width_")[2],)
    return (_OWN_OUTPUT[name.rpartition("_compliance_")[2]][0],)


def knc_report_filled(
    results: dict[str, KCResult], constants: AxleConstants | None = None
) -> dict[str, np.ndarray]:
    """:func:`knc_report` of results that hold every channel (no filling)."""
    out: dict[str, np.ndarray] = {}
    if "parallel" in results and "opposite" in results:
        out.update(travel_report(results, constants))
    if "steering" in results:
        out.update(steering_report(results, constants))
    return out


ALL_ITEMS: dict[str, ReportItem] = {i.name: i for i in REPORT_ITEMS + STEERING_ITEMS}
