"""K&C rig loops as :class:`~suspenv.measurements.Recording` objects, and back.

One recording per rig test (travel: ``parallel``, ``opposite``, ``single``; compliance:
``lateral``, ``longitudinal``, ``traction``, ``aligning``; steering: ``steering``; see
:mod:`suspenv.rigs.knc`) of one vehicle.
Every solved step of the loop design -> bump -> rebound -> design is one sample;
the rig is quasi-static, so ``time`` is the step index in seconds (1 s per step, a
bookkeeping axis only, stated in ``meta["time_axis"]``).

Frame ISO 8855 (x forward, y left, z up), SI units:

* inputs: ``pad_left`` / ``pad_right`` [m] pad travel from the static height (bump
  positive; zero in a compliance or steering test), ``stroke`` [m] the left pad's
  stroke of a travel test or the rack travel of the steering test (along +y), or
  ``force`` the load of a compliance test, the same on both wheels (:data:`DRIVE_UNIT`:
  [N] along +y at the contact points in ``lateral``, along +x at the contact points in
  ``longitudinal`` and at the wheel centres in ``traction``; [N*m] about +z at the
  contact points in ``aligning``), ``branch`` [-]
  (0 first leg design -> bump, 1 bump -> rebound, 2 rebound -> design; "bump" is the
  +amplitude end also in a compliance test) and ``grid`` [-] (grid index of the step);
* outputs, per side (suffix ``_left`` / ``_right``): ``toe`` [rad] (+ toe-in),
  ``camber`` [rad] (- top inboard), ``tyre_fz`` [N] (+ compression),
  ``contact_lateral`` [m] (contact-point y, *outboard* positive on each side, so a
  symmetric axle gives equal left and right values in parallel travel) and
  ``contact_x`` [m] (contact-point x, forward positive).

``recording.meta`` holds ``rig = "knc"``, the test, amplitude (in the test's
:data:`DRIVE_UNIT`, named in ``meta["amplitude_unit"]``) and steps, which a
model needs to replay the same loop. ``recording.test`` is ``"knc_<test>"``.

This is the recording format only; the "measured" truth vehicles of the diagnosis
benchmark are made by :mod:`suspenv.rigs.knc_truth`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.measurements.recording import RecordingLike

#: vertical travel tests (the identification problem's three)
TESTS = ("parallel", "opposite", "single")
#: compliance tests, pads static: a horizontal force at both contact points (``lateral``
#: along +y, ``longitudinal`` along +x) or at both wheel centres (``traction``, along +x),
#: or a moment about +z at both contact points (``aligning``); see :mod:`suspenv.rigs.knc`
FORCE_TESTS = ("lateral", "longitudinal", "traction", "aligning")
#: steering test: rack travel along +y (ISO 8855, to the left), pads static
STEER_TESTS = ("steering",)
ALL_TESTS = TESTS + FORCE_TESTS + STEER_TESTS
#: opposed (anti-phase) compliance tests -> the in-phase test whose load they turn on
#: the right wheel (see :mod:`suspenv.rigs.knc`):
#: ``lateral_opposed`` +F [N] outboard at both contact points (+y left, -y right),
#: ``aligning_opposed`` +M [N*m] toe-out at both (+z left, -z right). Not in
#: :data:`ALL_TESTS` (the test car's tests); the rig runs them, the measured-K&C format
#: loads them, the identification fits them and the next-test advice ranks them
OPPOSED_TESTS: dict[str, str] = {"lateral_opposed": "lateral", "aligning_opposed": "aligning"}
#: every test the rig runs and the measured-K&C format knows
RIG_TESTS: tuple[str, ...] = (*ALL_TESTS, *OPPOSED_TESTS)
#: the tests that load the wheels (their drive, input ``force``, is a force or a moment)
LOADED_TESTS: tuple[str, ...] = (*FORCE_TESTS, *OPPOSED_TESTS)
#: unit of each rig test's drive (the rig grid, ``KCResult.unit``, a recording's amplitude):
#: pad stroke [m], force [N], moment [N*m] or rack travel [m]
DRIVE_UNIT: dict[str, str] = {
    "parallel": "m",
    "opposite": "m",
    "single": "m",
    "lateral": "N",
    "longitudinal": "N",
    "traction": "N",
    "aligning": "N*m",
    "steering": "m",
}
DRIVE_UNIT.update({o: DRIVE_UNIT[p] for o, p in OPPOSED_TESTS.items()})

SIDES = ("left", "right")
#: recorded channels: name -> (rig channel, unit, outboard sign flip on the right)
CHANNELS: dict[str, tuple[str, str, bool]] = {
    "toe": ("toe", "rad", False),
    "camber": ("camber", "rad", False),
    "tyre_fz": ("tyre_fz", "N", False),
    "contact_lateral": ("contact_y", "m", True),
    "contact_x": ("contact_x", "m", False),
}
#: degrees per radian (the display scale of every angle channel)
RAD2DEG = 180.0 / np.pi


class ChannelDisplay(NamedTuple):
    """How a K&C channel is shown to a user: its name in words, display unit, the scale
    from its SI unit (rad, m, N) to that unit and the meaning of its positive sense."""

    words: str
    unit: str
    scale: float
    sign: str

    def label(self) -> str:
        """Axis label: words, unit and sign, e.g. ``toe [deg] (+ toe-in)``."""
        return f"{self.words} [{self.unit}] (+ {self.sign})"


#: every K&C channel (rig channels and :data:`CHANNELS`) as shown to a user: the units
#: and sign words of the K&C sheet (:mod:`suspenv.metrics.knc_report`), ISO 8855 (x
#: forward, y left, z up), each wheel's raw sign except where the words say outboard
DISPLAY: dict[str, ChannelDisplay] = {
    "toe": ChannelDisplay("toe", "deg", RAD2DEG, "toe-in"),
    "camber": ChannelDisplay("camber", "deg", RAD2DEG, "top outward"),
    "caster": ChannelDisplay("caster", "deg", RAD2DEG, "axis top rearward"),
    "kpi": ChannelDisplay("KPI", "deg", RAD2DEG, "axis top inboard"),
    "tyre_fz": ChannelDisplay("wheel load", "N", 1.0, "compression"),
    "wheel_centre_x": ChannelDisplay("wheel centre x", "mm", 1e3, "forward"),
    "wheel_centre_y": ChannelDisplay("wheel centre y", "mm", 1e3, "left"),
    "wheel_centre_z": ChannelDisplay("wheel centre z", "mm", 1e3, "up"),
    "contact_x": ChannelDisplay("contact x", "mm", 1e3, "forward"),
    "contact_y": ChannelDisplay("contact y", "mm", 1e3, "left"),
    "contact_z": ChannelDisplay("contact z", "mm", 1e3, "up"),
    "contact_lateral": ChannelDisplay("contact y", "mm", 1e3, "outboard"),
}
INPUTS = ("pad_left", "pad_right", "stroke", "branch", "grid")
#: inputs of a compliance test (``force`` in place of ``stroke``)
FORCE_INPUTS = ("pad_left", "pad_right", "force", "branch", "grid")
TEST_PREFIX = "knc_"


def check_rig_tests(tests: Sequence[str]) -> None:
    """Refuse a test the rig does not run (not in :data:`RIG_TESTS`), naming it."""
    for t in tests:
        if t not in RIG_TESTS:
            raise ValidationError(f"unknown K&C test {t!r}; known tests are {RIG_TESTS}")


def output_names(channels: Sequence[str] = tuple(CHANNELS)) -> tuple[str, ...]:
    """Recorded output names, ``<channel>_<side>``."""
    return tuple(f"{c}_{s}" for c in channels for s in SIDES)


def loop_path(steps: int) -> np.ndarray:
    """Grid indices of the rig's loop design -> bump -> rebound -> design (2 * steps + 1
    points) on a grid of ``steps`` intervals with the design position at ``steps // 2``."""
    i0 = steps // 2
    return np.r_[np.arange(i0, steps + 1), np.arange(steps - 1, -1, -1), np.arange(1, i0 + 1)]


def branch_index(steps: int) -> np.ndarray:
    """Branch of every step of the loop: 0 design->bump, 1 bump->rebound, 2 rebound->design."""
    i0 = steps // 2
    # design .. bump inclusive, bump-1 .. rebound, rebound+1 .. design
    return np.repeat([0.0, 1.0, 2.0], [steps - i0 + 1, steps, i0])


def is_knc(rec: object) -> bool:
    """True for a K&C rig recording (``meta["rig"] == "knc"`` or test ``knc_*``)."""
    meta = getattr(rec, "meta", {}) or {}
    return meta.get("rig") == "knc" or str(getattr(rec, "test", "")).startswith(TEST_PREFIX)


def rig_test(rec: RecordingLike) -> str:
    """The rig test (``parallel`` ...) of a K&C recording."""
    test = str(rec.meta.get("knc_test", rec.test.removeprefix(TEST_PREFIX)))
    if test not in RIG_TESTS:
        raise ValidationError(
            f"recording {rec.name!r}: the K&C test must be one of {RIG_TESTS}, but got {test!r}"
        )
    return test


def is_force_test(rec: RecordingLike) -> bool:
    """True for a compliance (force or moment, input ``force``) recording, in phase or
    opposed."""
    return rig_test(rec) in LOADED_TESTS


def drive(rec: RecordingLike, side: str) -> np.ndarray:
    """Each wheel's own excitation along the loop, over the test's amplitude [-].

    Travel test: the pad's travel (bump positive). Compliance test: the load in the
    wheel's own sense: outboard positive in ``lateral`` (the two wheels of a +y force
    see opposite signs); forward positive in ``longitudinal`` and ``traction``; in
    ``aligning`` positive for a moment that turns that wheel's front outboard (a
    toe-out moment: +z on the left wheel, -z on the right, so the two wheels of a +z
    moment see opposite signs); an opposed test loads both wheels in their own sense,
    so both see the drive. Steering test: the rack travel towards the wheel's
    own outboard side (+y on the left wheel, -y on the right). A symmetric axle gives
    equal left and right channels at equal drive.
    """
    amp = float(rec.meta["amplitude"])
    test = rig_test(rec)
    if test in STEER_TESTS:
        s = np.asarray(rec.inputs["stroke"], float) / amp
        return -s if side == "right" else s
    if not is_force_test(rec):
        return np.asarray(rec.inputs[f"pad_{side}"], float) / amp
    f = np.asarray(rec.inputs["force"], float) / amp
    return -f if (test in ("lateral", "aligning") and side == "right") else f


def reading_drive(rec: RecordingLike, side: str) -> np.ndarray:
    """The drive a wheel's channels are read against [-]: its own :func:`drive`, or,
    for the wheel that has none (the still wheel of single-wheel travel), the left
    wheel's."""
    own = drive(rec, side)
    return own if own.any() else drive(rec, "left")


def mirrored(rec: RecordingLike) -> bool:
    """True when the right wheel's own drive is the left wheel's reversed (opposite
    travel, lateral force, aligning moment, steering): equal own drive then sits at
    mirrored grid points."""
    return bool(np.allclose(drive(rec, "right"), -drive(rec, "left")) and drive(rec, "left").any())


def drive_label(rec: RecordingLike) -> tuple[str, float]:
    """(axis label, factor from SI to the plotted unit) of a recording's drive."""
    test = OPPOSED_TESTS.get(rig_test(rec), rig_test(rec))
    if test == "aligning":
        return "own toe-out moment about z at the contact point [N*m]", 1.0
    if test in STEER_TESTS:
        return "rack travel towards the wheel's outboard side [mm]", 1e3
    if is_force_test(rec):
        what = {"lateral": "outboard contact", "traction": "forward wheel-centre"}.get(
            test, "forward contact"
        )
        return f"own {what} force [kN]", 1e-3
    if test == "single":
        return "left pad travel [mm] (the right pad stays)", 1e3
    return "own pad travel [mm]", 1e3


def half_loops(rec: RecordingLike, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A channel along the loop split into its two branches on the grid.

    Returns ``(down, up)``, each ``(steps + 1,)`` ordered by grid index: ``down`` is
    the bump -> rebound branch, ``up`` the rebound -> bump branch (rebound -> design,
    then the first leg design -> bump).
    """
    steps = int(rec.meta["steps"])
    gi, br = rec.inputs["grid"].astype(int), rec.inputs["branch"].astype(int)
    v = np.asarray(values, float)
    down = np.full(steps + 1, np.nan)
    up = np.full(steps + 1, np.nan)
    sel_d = br == 1
    down[gi[sel_d]] = v[sel_d]
    down[steps] = v[np.flatnonzero(gi == steps)[0]]  # the bump end starts the descent
    sel_u = br != 1
    up[gi[sel_u]] = v[sel_u]
    up[0] = v[np.flatnonzero(gi == 0)[0]]
    return down, up
