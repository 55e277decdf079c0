"""Virtual K&C rig: vertical travel, compliance and steering tests of a McPherson axle.

Frame ISO 8855 (x forward, y left, z up), SI units; body held fixed, steering rack held
fixed except in the steering test.
The travel tests (:data:`TESTS`, the three of the identification problem) prescribe
the heights of the two wheel pads relative to the static pad height
(``AxleSolver.pad_static``):

* ``parallel``: both pads move by ``+s`` (bump positive);
* ``opposite``: left pad ``+s``, right pad ``-s`` (the body-fixed equivalent of a
  roll to the right, left wheel in bump);
* ``single``: left pad ``+s``, right pad held at its static height.

The compliance tests (:data:`FORCE_TESTS`) hold both pads at their static height and
apply the same load to both wheels (the pads carry no horizontal force or moment, so
the suspension takes it all). A contact-point load acts where a K&C rig applies it:
through the pad at the loaded contact point, where the wheel plane's downward radius
meets the pad plane (not at the undeformed wheel's lowest point, ~14 mm below it):

* ``lateral``: ``+F`` [N] along +y at both contact points (the tyre forces of a
  left-hand turn: outboard on the left wheel, inboard on the right);
* ``longitudinal``: ``+F`` [N] along +x at both contact points: the braking test
  (its negative half is braking; a brake force acts at the contact patch when the
  brake calliper is on the knuckle);
* ``traction``: ``+F`` [N] along +x at both wheel centres: the tractive force of a
  driven wheel, whose drive torque comes through the drive shaft and so reaches the
  knuckle as a force at the hub. It differs from ``longitudinal`` by the moment
  ``F h`` about the spin axis (``h`` the loaded radius), which the brake reacts at the
  knuckle and the drive shaft does not;
* ``aligning``: ``+M`` [N*m] about +z at both contact points (both wheels turned to
  the left: a toe-out moment on the left wheel, toe-in on the right). Each wheel's own
  sense (:func:`suspenv.measurements.knc.drive`) is toe-out positive: ``+M`` on the
  left wheel, ``-M`` on the right.

The opposed compliance tests (:data:`OPPOSED_TESTS`) load the two wheels in
opposite ISO directions, so both take the same load in their own senses:
``lateral_opposed`` ``+F`` outboard at both contact points (+y left, -y right; a
negative ``F`` converges the wheels), ``aligning_opposed`` ``+M`` toe-out at both
(+z left, -z right). A left/right symmetric axle then deflects symmetrically: the
anti-roll bar does not twist, and each wheel's response is its direct compliance plus
the other wheel's cross term (the in-phase tests give the difference).

The steering test (:data:`STEER_TESTS`, ``steering``) holds both pads at their static
height and moves the rack by ``s`` [m] along +y (ISO 8855, to the left): both tie-rod
inner points move by ``s`` in y. Which way the wheels steer depends on the geometry:
with the tie rods behind the wheel centre (a trailing steering arm, as on the reference
car) rack travel to the left steers both wheels to the right (left wheel toe-in, right
wheel toe-out); with them ahead of it, to the left.

The grid has ``steps + 1`` points from ``-amplitude`` to ``+amplitude`` in the test's
unit (:data:`DRIVE_UNIT`: ``amplitude`` [m] pad stroke, ``force_amplitude`` [N],
``moment_amplitude`` [N*m], ``rack_amplitude`` [m]) with the design (static) position
on the grid (``steps`` even). Because path-dependent effects
(hysteresis, friction) make the answer depend on the history, every test runs as a
loop design -> bump -> rebound -> design and keeps both branches: the *descending*
branch (bump to rebound) and the *ascending* branch (rebound to design, then the
first leg design to bump).

All tests of all designs are solved as one batch (rows = test x design), each step
warm-started from the previous converged step with a predictor (the tangent
``-J^-1 dres/dinput`` for a leg's first step, then linear and quadratic extrapolation of
the leg's converged states).

Path-independent model: when the model has no element whose force depends on the
loading branch (no Dahl hysteresis at a bushing, no strut friction:
:attr:`AxleSolver.path_dependent`, decided from the model, never from data), the state
at a grid point does not depend on how the rig got there, so every grid point is solved
once: the bump leg (design -> bump) and the rebound leg (design -> rebound) are solved
side by side from the static state (twice the rows per solver call, half the steps),
and the loop's return legs take the state of their grid point. Both branches are then
identical; each point is the same equilibrium that a sequential solve reaches, to the
solver tolerance (``xtol``/``rtol``/``ltol``). ``reuse_revisits=False`` solves every
step of the loop one after the other (the reference path, kept for checks and the speed
benchmark); a path-dependent model always does.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from suspenv.core import compiled
from suspenv.core.errors import ValidationError
from suspenv.measurements import knc_file
from suspenv.measurements.knc import ALL_TESTS as ALL_TESTS
from suspenv.measurements.knc import (
    DRIVE_UNIT,
    LOADED_TESTS,
    OPPOSED_TESTS,
    STEER_TESTS,
    TESTS,
    check_rig_tests,
    loop_path,
)
from suspenv.measurements.knc import FORCE_TESTS as FORCE_TESTS
from suspenv.measurements.knc import RIG_TESTS as RIG_TESTS
from suspenv.models.effects import Effect
from suspenv.models.mcpherson.params import Axle
from suspenv.models.mcpherson.rotation import relative_log, rotate, turned
from suspenv.models.mcpherson.solver import (
    JACOBIAN_BLOCK,
    OUTPUT_NAMES,
    AxleSolver,
    AxleState,
    SharedInverse,
    _inv_mul,
    lockup_text,
)

# the tests (TESTS: travel, FORCE_TESTS: compliance, STEER_TESTS: steering, ALL_TESTS,
# OPPOSED_TESTS, RIG_TESTS: all) are named once, by the recording format of K&C loops
_PAD_SIGN = {"parallel": (1.0, 1.0), "opposite": (1.0, -1.0), "single": (1.0, 0.0)}
#: compliance test -> (column of the wheel load (contact force x y z, moment x y z about
#: the contact point, wheel-centre force x y z; ISO 8855), sign on the (left, right) wheel)
_LOAD_AXIS = {
    "lateral": (1, (1.0, 1.0)),
    "longitudinal": (0, (1.0, 1.0)),
    "traction": (6, (1.0, 1.0)),
    "aligning": (5, (1.0, 1.0)),
}
# the opposed tests (OPPOSED_TESTS) turn their in-phase test's load on the right wheel,
# so that both wheels take the same load in their own senses (as K&C rigs run them)
_LOAD_AXIS.update({o: (_LOAD_AXIS[p][0], (1.0, -1.0)) for o, p in OPPOSED_TESTS.items()})
#: default force amplitude of the compliance tests [N]
FORCE_AMPLITUDE = 2500.0
#: default moment amplitude of the aligning-moment test [N*m]
MOMENT_AMPLITUDE = 250.0
#: default rack travel amplitude of the steering test [m]
RACK_AMPLITUDE = 0.030

#: the rig's input at one grid point: (pad heights (rows, 2) [m], wheel load
#: (rows, 2, 6|9) [N, N*m] or None, rack travel (rows, 2) [m] or None, wheel-centre
#: heights to reach (rows, 2) [m] (NaN: the pad is held) or None); with wheel-centre
#: heights the pad heights are the solver's first guess, which it moves in place
Load = tuple[np.ndarray, np.ndarray | None, np.ndarray | None, np.ndarray | None]
#: what a travel test drives (``run_tests``' ``travel_drive``, the measured-K&C format's
#: :data:`~suspenv.measurements.knc_file.TRAVEL_DRIVES`): the pads, or the wheel centres
#: (the rig moves each driven wheel's pad until its wheel centre is at the stroke, as a
#: rig in wheel-centre travel control does)
TRAVEL_DRIVES = knc_file.TRAVEL_DRIVES
#: step descriptions of failure messages: drive name, scale to the shown unit, shown unit
_DRIVE_NAME = {
    "lateral": "contact force",
    "longitudinal": "contact force",
    "traction": "wheel-centre force",
    "aligning": "contact moment",
    "steering": "rack travel",
    "lateral_opposed": "opposed contact force",
    "aligning_opposed": "opposed contact moment",
}
_DRIVE_SHOWN = {"m": (1e3, "mm", 2), "N": (1.0, "N", 0), "N*m": (1.0, "N*m", 1)}
#: keep the quadratic predictor's last relative rotation for the next step (the same
#: numbers; False: compute both rotations every step, the reference path of the tests
#: and the speed benchmark's baseline)
PREDICTOR_CACHE = True
#: an axle without placed effects on its two-leg loop (pads driven, no states kept) is
#: swept by one compiled call for all its designs (:func:`_run_compiled`); False: the
#: sweep driven from Python (:func:`_run_numpy`), the reference path of the tests and
#: the speed benchmark's baseline
COMPILED_SWEEP = True
#: states extrapolated by the predictor of the two-leg loop of a path-independent model
#: (:func:`_sweep_legs`): 4, cubic (3: quadratic, as the sequential loop)
LEG_ORDER = 4
#: converged states per call of the channel outputs of the two-leg loop
#: (:func:`_sweep_legs`) at most (fewer when JACOBIAN_BLOCK rows say so): the states
#: wait for their channels in groups of at most this many, which bounds their memory at
#: small batches (0.9 kB per row and state)
OUTPUT_STATES = 4


@dataclass
class KCResult:
    """Channels of one rig test for a batch of designs.

    Attributes:
        test: test name.
        grid: (steps + 1,) grid of the test's input (unit :attr:`unit`): the left pad's
            offset [m] (travel test), the force [N] (``lateral``, ``longitudinal``,
            ``traction``), the moment [N*m] (``aligning``) or the rack travel along +y
            [m] (``steering``).
        path: (P,) grid index of every step of the loop (P = 2 * steps + 1).
        channels: name -> (n, P, 2) values along the loop (SI, ISO 8855; see docs/knc.md).
        ok: (n,) True where every step converged.
        messages: (n,) failure reasons ("" when ok).
        static_points: hard points of each design's static state (the rig's design
            position), name -> (n, 2, 3) [m] ISO 8855 (:func:`static_hard_points`);
            empty for measured data (a rig records no hard points).
    """

    test: str
    grid: np.ndarray
    path: np.ndarray
    channels: dict[str, np.ndarray]
    ok: np.ndarray
    messages: list[str]
    states: list[AxleState] = field(default_factory=list, repr=False)
    static_points: dict[str, np.ndarray] = field(default_factory=dict, repr=False)

    @property
    def unit(self) -> str:
        """Unit of :attr:`grid` (:data:`DRIVE_UNIT`): ``"m"`` (travel, steering), ``"N"``
        (force) or ``"N*m"`` (aligning)."""
        return DRIVE_UNIT[self.test]

    @property
    def static_index(self) -> int:
        return (self.grid.size - 1) // 2

    def branch(self, name: str, which: str) -> np.ndarray:
        """Channel ``name`` on branch ``which`` ("down" or "up") on the grid: (n, steps+1, 2)."""
        steps = self.grid.size - 1
        i0 = steps // 2
        ch = self.channels[name]
        if which == "down":  # path positions steps-i0 .. 2*steps-i0 hold grid steps .. 0
            start = steps - i0
            return ch[:, start : start + steps + 1][:, ::-1]
        if which == "up":  # grid 0..i0 from the last leg, grid i0+1..steps from the first
            last = ch[:, 2 * steps - i0 :]
            first = ch[:, 1 : steps - i0 + 1]
            return np.concatenate([last, first], axis=1)
        raise ValidationError(f"branch must be 'down' or 'up', but got {which!r}")

    def mean_branch(self, name: str) -> np.ndarray:
        """Average of the two branches (n, steps+1, 2): the loop's mid-line."""
        return 0.5 * (self.branch(name, "down") + self.branch(name, "up"))


def static_hard_points(solver: AxleSolver, st: AxleState) -> dict[str, np.ndarray]:
    """Hard points (n, 2, 3) [m], ISO 8855, of the converged state ``st`` of ``solver``:
    the lower arm's bushes and ball joint (on the arm), the strut top (the top mount's
    body) and the strut axis point (on the knuckle): what a front-view construction of
    the instant centres reads (:func:`suspenv.metrics.knc_report.geometric_roll_centre`)."""
    arm = st.r[..., 0, :][..., None, :] + rotate(
        st.R[..., 0, None, :, :], solver.lca_pts
    )  # (n, 2, 3 points, 3)
    knuckle = st.r[..., 1, :] + rotate(st.R[..., 1, :, :], solver.kn_pts[:, :, 4])
    return {
        "lca_front_bush": arm[..., 0, :],
        "lca_rear_bush": arm[..., 1, :],
        "lower_ball_joint": arm[..., 2, :],
        "strut_top": st.r[..., 2, :].copy(),
        "strut_axis_point": knuckle,
    }


def stroke_grid(amplitude: float = 0.040, steps: int = 30) -> np.ndarray:
    """Grid of a test's input (pad offsets [m], force, moment, rack travel),
    ``steps + 1`` points from ``-amplitude`` to ``+amplitude``, design in the middle."""
    if not amplitude > 0:
        raise ValidationError(f"`amplitude > 0` must hold, but got amplitude={amplitude}")
    if steps < 2 or steps % 2:
        raise ValidationError(f"`steps` must be even and >= 2, but got steps={steps}")
    return np.linspace(-amplitude, amplitude, steps + 1)


def window_steps(steps: int, window: int) -> np.ndarray:
    """The steps of :func:`loop_path` ``(steps)`` that make the loop over the grid points
    within ``window`` steps of the design position: the visits of those points in loop
    order, each point once per visit as :func:`loop_path` ``(2 * window)`` takes them
    (design -> bump edge -> rebound edge -> design), as indices into the full loop."""
    i0 = steps // 2
    up = np.arange(i0, i0 + window + 1)  # design -> bump edge: step g - i0
    down = np.arange(i0 + window - 1, i0 - window - 1, -1)  # down to the rebound edge
    back = np.arange(i0 - window + 1, i0 + 1)  # back up to the design position
    return np.r_[up - i0, 2 * steps - i0 - down, 2 * steps - i0 + back]


def pad_offsets(test: str, s: np.ndarray) -> np.ndarray:
    """Pad offsets (..., 2) [m] of ``test`` for left-pad stroke ``s`` (zero for a
    compliance or steering test, whose pads stay at their static height)."""
    check_rig_tests((test,))
    sign = np.array(_PAD_SIGN.get(test, (0.0, 0.0)))
    return np.asarray(s, dtype=float)[..., None] * sign


def wheel_loads(test: str, f: np.ndarray | float) -> np.ndarray:
    """Extra load (..., 2, 9) on both wheels of ``test`` for its drive ``f`` ([N] or
    [N*m], :data:`DRIVE_UNIT`), as the solver takes it (``AxleSolver.residual``'s
    ``ext``): force [N] and moment [N*m] at the contact point, then a force [N] at the
    wheel centre; ISO 8855. Zero for a travel or steering test."""
    check_rig_tests((test,))
    f = np.asarray(f, dtype=float)
    out = np.zeros(f.shape + (2, 9))
    if test in _LOAD_AXIS:
        axis, sign = _LOAD_AXIS[test]
        out[..., axis] = f[..., None] * np.array(sign)
    return out


def rack_travel(test: str, s: np.ndarray | float) -> np.ndarray:
    """Travel (..., 2) [m] of the (left, right) tie-rod inner points along +y for the
    steering test's rack travel ``s`` [m] (zero for every other test)."""
    check_rig_tests((test,))
    s = np.asarray(s, dtype=float)
    return s[..., None] * np.full(2, 1.0 if test in STEER_TESTS else 0.0)


def run_tests(
    axle: Axle,
    tests: tuple[str, ...] = TESTS,
    amplitude: float = 0.040,
    steps: int = 30,
    effects: Sequence[Effect] = (),
    keep_states: bool = False,
    force_amplitude: float = FORCE_AMPLITUDE,
    reuse_revisits: bool = True,
    moment_amplitude: float = MOMENT_AMPLITUDE,
    rack_amplitude: float = RACK_AMPLITUDE,
    channels: Sequence[str] | None = None,
    window: int | None = None,
    travel_drive: str = "pad",
) -> dict[str, KCResult]:
    """Run the rig ``tests`` on every design of ``axle``; returns {test: KCResult}.

    ``amplitude`` [m] is the pad stroke of the travel tests, ``force_amplitude`` [N]
    the force of ``lateral``, ``longitudinal`` and ``traction``, ``moment_amplitude``
    [N*m] the moment of ``aligning``, ``rack_amplitude`` [m] the rack travel of
    ``steering`` (module docstring). ``effects``: the axle's optional
    physics, effects-library elements placed at bushings or the strut
    (:mod:`suspenv.models.mcpherson.effects`). ``reuse_revisits``: for a
    path-independent model (see the module docstring) solve every grid point once, the
    two legs from the design position side by side, and give a revisited grid point the
    state of its first visit (``False``: solve every step of the loop in sequence, the
    reference path); a path-dependent model always solves every step.
    ``channels``: the names of the channels to keep in the results (None: all of
    :meth:`AxleSolver.outputs`; fewer channels hold less memory). ``window``: keep the
    channels of the grid points within this many steps of the design position only
    (e.g. the objectives' fit window, :data:`suspenv.metrics.knc.FIT_HALF_WIDTH`; None:
    every grid point), for a path-independent model solved on its two legs
    (``reuse_revisits``), whose two visits of a grid point are the same state. Every
    step of the loop is still solved and judged (``ok`` and the messages are those of
    the whole loop); the results then describe the loop over the window's points:
    ``grid`` its ``2 * window + 1`` points, ``path`` ``loop_path(2 * window)``, each
    channel its value at the loop's visit of that point (a failed row's frozen state
    from its failing step on, as without a window), computed at those points only (less
    memory and time). A path-dependent model (or ``reuse_revisits=False``) keeps every
    grid point: its loop's branches differ at the window's edges. ``travel_drive``
    (:data:`TRAVEL_DRIVES`): ``"pad"`` drives the travel tests' pads by the stroke;
    ``"wheel_centre"`` drives the wheel centres instead (each moving wheel's centre
    height from its static height by the stroke, the same signs; the pad of a still
    wheel, the right one of ``single``, stays at its static height): the grid is then
    the left wheel centre's travel, and the ``pad_z`` channel holds the pad heights the
    rig needed.
    """
    _check_options(tests, travel_drive, force_amplitude, moment_amplitude, rack_amplitude)
    _check_window(channels, window, steps)
    grid = stroke_grid(amplitude, steps)
    test_grids = _test_grids(tests, grid, force_amplitude, moment_amplitude, rack_amplitude)
    base = AxleSolver(axle, effects)
    args = (tests, test_grids, grid, keep_states, reuse_revisits, channels, window, travel_drive)
    two_legs = reuse_revisits and not keep_states and travel_drive == "pad"
    if COMPILED_SWEEP and compiled.AVAILABLE and two_legs and not base.effects:
        return _run_compiled(
            base, args, lambda rows: _run_numpy(AxleSolver(axle.take(rows), effects), *args)
        )
    return _run_numpy(base, *args)


def _check_options(
    tests: Sequence[str],
    travel_drive: str,
    force_amplitude: float,
    moment_amplitude: float,
    rack_amplitude: float,
) -> None:
    """Refuse unknown tests or travel drives and amplitudes that are not > 0 ([N],
    [N*m], [m]) with an error naming the rule and the value."""
    if travel_drive not in TRAVEL_DRIVES:
        raise ValidationError(
            f"`travel_drive` must be one of {TRAVEL_DRIVES}, but got {travel_drive!r}"
        )
    check_rig_tests(tuple(tests))
    amplitudes = {"force": force_amplitude, "moment": moment_amplitude, "rack": rack_amplitude}
    for (key, value), unit in zip(amplitudes.items(), ("N", "N*m", "m"), strict=True):
        if not value > 0:
            raise ValidationError(f"`{key}_amplitude > 0` must hold, but got {value} {unit}")


def _check_window(channels: Sequence[str] | None, window: int | None, steps: int) -> None:
    """Refuse ``channels`` that are not rig channels (:data:`OUTPUT_NAMES`) and a
    ``window`` that is not a whole number of grid steps in ``1..steps/2``."""
    unknown = sorted(set(channels or ()) - set(OUTPUT_NAMES))
    if unknown or (channels is not None and isinstance(channels, str)):
        raise ValidationError(
            f"`channels` must name rig channels, but got {channels!r}; the channels are "
            f"{OUTPUT_NAMES}"
        )
    whole = isinstance(window, int | np.integer) and not isinstance(window, bool)
    if window is not None and not (whole and 0 < window <= steps // 2):
        raise ValidationError(
            f"`window` must be a whole number of grid steps in 1..steps/2 = 1..{steps // 2} "
            f"(or None), but got window={window!r}"
        )


def _test_grids(
    tests: Sequence[str],
    grid: np.ndarray,
    force_amplitude: float,
    moment_amplitude: float,
    rack_amplitude: float,
) -> dict[str, np.ndarray]:
    """Each test's own grid (:data:`DRIVE_UNIT`) of as many points as the travel grid
    ``grid`` [m] (the travel tests'): force [N], moment [N*m] or rack travel [m]."""
    steps = grid.size - 1
    own_amplitude = {"aligning": moment_amplitude, "steering": rack_amplitude}
    return {
        t: grid
        if t in TESTS
        else stroke_grid(own_amplitude.get(OPPOSED_TESTS.get(t, t), force_amplitude), steps)
        for t in tests
    }


def _run_compiled(
    base: AxleSolver, args: tuple, rerun: Callable[[np.ndarray], dict[str, KCResult]]
) -> dict[str, KCResult]:
    """:func:`run_tests` (``args``: those of :func:`_run_numpy`) of an axle without
    placed effects on its two-leg loop, by one compiled sweep of all its designs
    (:meth:`AxleSolver.two_leg_sweep`: the rules of :func:`_sweep_legs`, the same
    states to the solver tolerance); the designs it flags are run again by ``rerun``
    (design rows -> results: the numpy path, which retries in sub-steps and words the
    failure)."""
    tests, test_grids, grid, _, _, channels, window, _ = args
    n, steps = base.n, grid.size - 1
    i0, path = steps // 2, loop_path(steps)
    kept, loop = _window(steps, window)
    pad_off = np.stack([pad_offsets(t, grid) for t in tests])  # (T, G, 2) [m]
    ext, rack = _stacked_drives(tests, test_grids.__getitem__)  # (T, G, 2, 6|9), (T, G, 2)
    st, status = base.two_leg_sweep(pad_off, ext, rack, kept)
    bad = np.flatnonzero(status)
    if bad.size:  # their states: the design position (their channels come from rerun)
        st.r[:, :, bad], st.R[:, :, bad], st.lam[:, :, bad] = base.ref0[bad], np.eye(3), 0.0
    pads = base.pad_static + pad_off[:, kept, None, :]  # (T, Q, n, 2) [m]
    ch = base.outputs(st, pads, channels)  # (T, Q, n, 2)
    kept_steps = np.arange(path.size) if window is None else window_steps(steps, window)
    at = path[kept_steps] - range(grid.size)[kept][0]  # each kept step's state
    mid = i0 - range(grid.size)[kept][0]  # the design position: every drive is zero there
    hard = static_hard_points(base, AxleState(st.r[0, mid], st.R[0, mid], st.lam[0, mid]))
    # every test's channels along its loop at once (T * n, P, 2), each test a view
    rows = len(tests) * n
    ch = {
        name: np.ascontiguousarray(v[:, at].swapaxes(1, 2)).reshape(rows, at.size, 2)
        for name, v in ch.items()
    }
    results = _results(tests, test_grids, kept, loop, ch, np.ones(rows, bool), [""] * rows, hard)
    if bad.size:
        again = rerun(bad)
        for name, v in hard.items():
            v[bad] = again[tests[0]].static_points[name]
        for t, res in results.items():
            for name, v in res.channels.items():
                v[bad] = again[t].channels[name]
            res.ok[bad] = again[t].ok
            for q, i in enumerate(bad.tolist()):
                res.messages[i] = again[t].messages[q]
    return results


def _run_numpy(
    base: AxleSolver,
    tests: tuple[str, ...],
    test_grids: dict[str, np.ndarray],
    grid: np.ndarray,
    keep_states: bool,
    reuse_revisits: bool,
    channels: Sequence[str] | None,
    window: int | None,
    travel_drive: str,
) -> dict[str, KCResult]:
    """:func:`run_tests` (its arguments checked) with the solver ``base`` of the axle,
    the tests' grids ``test_grids`` and the travel grid ``grid``: the sweeps driven from
    Python, every call vectorised over the rows (test x design), the reference path
    of :func:`_run_compiled`."""
    n, nt = base.n, len(tests)
    steps = grid.size - 1
    path = loop_path(steps)
    # static equilibrium once per design, then one row per (test, design)
    st0, conv0, J0 = base.solve(base.initial_state(), base.pad_static)
    assert isinstance(J0, np.ndarray)  # a fresh solve: one inverse Jacobian per design
    hard_points = static_hard_points(base, st0)
    tile = np.tile(np.arange(n), nt)  # rows: test-major
    solver = base.take(tile, axle=False)
    del base  # the rows' solver holds what the sweep needs (memory)
    # a path-independent model: both legs from the design position side by side, every
    # grid point solved once (see _sweep_legs); else every step of the loop in sequence
    reuse = reuse_revisits and not solver.path_dependent
    # the steps of the loop whose channels are kept: all, or the loop over the window
    # (the two-leg loop only: each visit of a grid point is then the same state)
    window = window if reuse else None
    kept_steps = np.arange(path.size) if window is None else window_steps(steps, window)
    st = st0.take(tile)
    # the static inverse Jacobians: one per design (shared by the rows of the legs) or
    # one per row (the sequential loop); in a box, so that the sweep can free them
    J_box = [J0 if reuse else J0[tile]]
    del st0, J0  # the per-design copies are no longer needed (memory)
    rows = nt * n
    ok = np.ones(rows, bool)
    msgs = [""] * rows
    _fail(ok, msgs, ~conv0[tile], "ConvergenceError: no static equilibrium at the design position")
    st = solver.commit(st)
    centred = st if travel_drive == "wheel_centre" else None
    sweep = _row_inputs(solver.pad_static, tests, test_grids, grid, n, centred)
    # step descriptions of failure messages, formatted once per grid point when asked for
    where_at = functools.cache(
        functools.partial(_where_text, tests, test_grids, centred is not None)
    )
    if reuse:
        legs = solver.take(np.tile(np.arange(rows), 2), axle=False)  # leg x test x design
        st_box = [st]  # (the sweep frees the static state once its legs start from it)
        del solver, st, centred
        out, trail = _sweep_legs(
            legs, st_box, J_box, nt, ok, msgs, sweep, where_at, path, keep_states, channels,
            kept_steps,
        )  # fmt: skip
    else:
        # channels in vectorised calls of about 4 JACOBIAN_BLOCK row evaluations each
        per = max(1, 4 * JACOBIAN_BLOCK // max(rows, 1))
        out, trail = _sweep_loop(
            solver, st, J_box.pop(), ok, msgs, sweep, where_at, path, per, keep_states, channels
        )
    points, loop = _window(steps, window)
    return _results(tests, test_grids, points, loop, out, ok, msgs, hard_points, trail)


def _results(
    tests: Sequence[str],
    test_grids: dict[str, np.ndarray],
    points: slice,
    loop: np.ndarray,
    channels: dict[str, np.ndarray],
    ok: np.ndarray,
    msgs: list[str],
    hard_points: dict[str, np.ndarray],
    trail: Sequence[AxleState] = (),
) -> dict[str, KCResult]:
    """Every test's :class:`KCResult` from the rows (test x design, test-major) of the
    channels {name: (rows, Q, 2)}, ``ok`` (rows,), messages and kept states (``trail``)
    at the grid ``points`` on the ``loop``; each test's channels and states are views
    of its rows."""
    n = ok.size // len(tests)
    results = {}
    for j, t in enumerate(tests):
        sl = slice(j * n, (j + 1) * n)
        results[t] = KCResult(
            t,
            test_grids[t][points],
            loop,
            {name: v[sl] for name, v in channels.items()},
            ok[sl].copy(),
            msgs[sl],
            [x.take(sl, views=True) for x in trail],
            hard_points,
        )
    return results


def _window(steps: int, window: int | None) -> tuple[slice, np.ndarray]:
    """The grid points (a slice of the ``steps + 1``) whose channels the results keep and
    the loop over them (:func:`loop_path`): every grid point (``window`` None) or those
    within ``window`` steps of the design position."""
    if window is None:
        return slice(None), loop_path(steps)
    i0 = steps // 2
    return slice(i0 - window, i0 + window + 1), loop_path(2 * window)


def _stacked_drives(
    tests: Sequence[str], drive: Callable[[str], np.ndarray | float], n: int = 1
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The :func:`wheel_loads` (T n, ..., 2, 6|9) and :func:`rack_travel` (T n, ..., 2)
    of the ``tests`` at their drives ``drive(test)``, each test's ``n`` times (rows
    test-major; None where no test loads the wheels or moves the rack); the wheel-centre
    force's columns only when ``traction`` runs."""
    cols = 9 if "traction" in tests else 6
    ext = rack = None
    if set(tests) & set(LOADED_TESTS):
        ext = np.repeat(np.stack([wheel_loads(t, drive(t))[..., :cols] for t in tests]), n, axis=0)
    if set(tests) & set(STEER_TESTS):
        rack = np.repeat(np.stack([rack_travel(t, drive(t)) for t in tests]), n, axis=0)
    return ext, rack


def _row_inputs(
    pad0: np.ndarray,
    tests: Sequence[str],
    test_grids: dict[str, np.ndarray],
    grid: np.ndarray,
    n: int,
    centred: AxleState | None,
) -> _Sweep:
    """The rig's inputs (:class:`_Sweep`) of every row (test x ``n`` designs,
    test-major) at static pad heights ``pad0`` [m]: the tests' pad signs, drive grids,
    wheel loads and rack travel per unit drive and, for a wheel-centre travel drive,
    the static wheel-centre heights of the moving wheels in the rows' static state
    ``centred`` (None: the pads are driven)."""
    signs = np.repeat(np.array([_PAD_SIGN.get(t, (0.0, 0.0)) for t in tests]), n, axis=0)
    # every row's own grid (nt*n, steps+1): the drive of its test at each grid point
    row_grid = np.repeat(np.stack([test_grids[t] for t in tests]), n, axis=0)
    # wheel load (nt*n, 2, 6|9) and tie-rod travel (nt*n, 2) per unit of the test's drive
    ext_dir, rack_dir = _stacked_drives(tests, lambda _: 1.0, n)
    # wheel-centre drive: the static wheel-centre heights of the moving wheels (NaN: held
    # by the pad)
    centre0 = None if centred is None else np.where(signs != 0, centred.r[:, :, 1, 2], np.nan)
    return _Sweep(pad0, signs, grid, row_grid, ext_dir, rack_dir, centre0)


def _where_text(
    tests: Sequence[str], test_grids: dict[str, np.ndarray], centred: bool, gi: int
) -> str:
    """The rig's input at grid index ``gi`` in words for failure messages: every test's
    drive in its shown unit (``centred``: the travel tests drive the wheel centres)."""
    parts = []
    for t in tests:
        scale, shown, digits = _DRIVE_SHOWN[DRIVE_UNIT[t]]
        value = test_grids[t][gi] * scale
        stroke = "wheel-centre travel" if centred else "stroke"
        parts.append(f"{_DRIVE_NAME.get(t, stroke)} {value:+.{digits}f} {shown}")
    return ", ".join(dict.fromkeys(parts))


@dataclass(frozen=True)
class _Sweep:
    """The rig's inputs of every row (test x design): static pad heights ``pad0`` (m, 2)
    [m], pad sign per unit stroke ``signs`` (m, 2), the travel grid ``grid`` (G,) [m],
    each row's drive grid ``row_grid`` (m, G) (:data:`DRIVE_UNIT`), the wheel load per
    unit drive ``ext_dir`` (m, 2, 6|9) or None, the rack travel per unit drive
    ``rack_dir`` (m, 2) or None and, for a wheel-centre travel drive, the static
    wheel-centre heights ``centre0`` (m, 2) [m] (NaN where the pad is held) or None."""

    pad0: np.ndarray
    signs: np.ndarray
    grid: np.ndarray
    row_grid: np.ndarray
    ext_dir: np.ndarray | None
    rack_dir: np.ndarray | None
    centre0: np.ndarray | None = None

    def load(self, gi: np.ndarray | int, reps: int = 1) -> Load:
        """The rig's input at grid index ``gi`` (an int, or one per row of ``reps``
        stacked copies of the rows): (pad heights (reps*m, 2) [m], wheel load
        (reps*m, 2, 6|9) or None, rack travel (reps*m, 2) [m] or None, wheel-centre
        heights (reps*m, 2) [m] or None)."""
        m = self.pad0.shape[0]
        g = np.broadcast_to(np.asarray(gi), (reps * m,))
        rr = _tiled_rows(m, reps)
        drive = self.row_grid[rr, g]
        ext = None if self.ext_dir is None else self.ext_dir[rr] * drive[:, None, None]
        rack = None if self.rack_dir is None else self.rack_dir[rr] * drive[:, None]
        stroke = self.signs[rr] * self.grid[g][:, None]
        centre = None if self.centre0 is None else self.centre0[rr] + stroke
        return self.pad0[rr] + stroke, ext, rack, centre


@functools.lru_cache(maxsize=8)
def _tiled_rows(m: int, reps: int) -> np.ndarray:
    """``np.tile(np.arange(m), reps)``, read-only and kept for the next call."""
    out = np.tile(np.arange(m), reps)
    out.flags.writeable = False
    return out


def _outputs(
    solver: AxleSolver,
    states: list[AxleState],
    pads: list[np.ndarray],
    per: int,
    names: Sequence[str] | None = None,
) -> dict[str, np.ndarray]:
    """Channels {name: (len(states), rows, 2)} of ``states`` at pad heights ``pads``,
    in vectorised calls of ``per`` states each (bounded memory); ``names``: only these
    channels (None: all)."""
    parts = []
    for a in range(0, len(states), per):
        chunk = states[a : a + per]
        if len(chunk) == 1:  # one state: views, no copies (memory)
            x = chunk[0]
            stacked = AxleState(x.r[None], x.R[None], x.lam[None])
            parts.append(solver.outputs(stacked, pads[a][None], names))
            continue
        stacked = AxleState(
            np.stack([x.r for x in chunk]),
            np.stack([x.R for x in chunk]),
            np.stack([x.lam for x in chunk]),
        )
        parts.append(solver.outputs(stacked, np.stack(pads[a : a + per]), names))
    return {k: np.concatenate([q[k] for q in parts]) for k in parts[0]}


def _sweep_loop(
    solver: AxleSolver,
    st: AxleState,
    J: np.ndarray,
    ok: np.ndarray,
    msgs: list[str],
    sweep: _Sweep,
    where_at: Callable[[int], str],
    path: np.ndarray,
    per: int,
    keep_states: bool,
    names: Sequence[str] | None,
) -> tuple[dict[str, np.ndarray], list[AxleState]]:
    """Every step of the loop ``path`` solved in sequence (a path-dependent model, or
    the reference path ``reuse_revisits=False``). Returns (channels {name: (rows, P,
    2)} of the channels ``names`` (None: all), states of every step when
    ``keep_states``)."""
    grid = sweep.grid
    trail: list[AxleState] = []  # converged state of every step (states are not mutated)
    pending: list[tuple[AxleState, np.ndarray]] = []  # (state, pads) whose channels are due
    parts: list[dict[str, np.ndarray]] = []  # channels (steps, rows, 2) of flushed steps

    def flush() -> None:
        parts.append(_outputs(solver, [x for x, _ in pending], [q for _, q in pending], per, names))
        pending.clear()

    history: list[AxleState] = []  # converged states of the current leg, newest last
    # the last relative rotation the predictor computed (see _extrapolate; None: none kept)
    rel: dict | None = {} if PREDICTOR_CACHE else None
    visited: dict[int, AxleState] = {}  # last converged state at each grid point
    prev_ds = 0.0
    prev_gi, prev_load = path[0], sweep.load(path[0])
    for k, gi in enumerate(path):
        load = sweep.load(gi)
        at = f"step {k} ({where_at(gi)})"
        if k > 0:
            ds = grid[gi] - grid[prev_gi]
            if prev_ds * ds <= 0:  # a reversal starts a new leg
                history = []
            history = [*history[-2:], st]
            st, J = _step(
                solver, st, prev_load, load, ok, msgs, J, at, history, visited.get(gi), rel
            )
            prev_ds = ds
        visited[gi] = st
        if gi in (0, grid.size - 1):  # loads and deflections peak at the ends of the stroke
            _check_state(solver, st, ok, msgs, at)
        if keep_states:
            trail.append(st)
        pending.append((st, load[0]))
        if len(pending) == per:
            flush()
        prev_gi, prev_load = gi, load

    if pending:
        flush()
    out = {k: np.moveaxis(np.concatenate([q[k] for q in parts]), 0, 1) for k in parts[0]}
    return out, trail


def _sweep_legs(
    lsolver: AxleSolver,
    st_box: list[AxleState],
    J_box: list[np.ndarray],
    nt: int,
    ok: np.ndarray,
    msgs: list[str],
    sweep: _Sweep,
    where_at: Callable[[int], str],
    path: np.ndarray,
    keep_states: bool,
    names: Sequence[str] | None,
    kept_steps: np.ndarray,
) -> tuple[dict[str, np.ndarray], list[AxleState]]:
    """The loop of a path-independent model from its two legs, solved side by side.

    The state at a grid point does not depend on how the rig got there (module
    docstring), so every grid point is solved once: the bump leg (design -> bump) and
    the rebound leg (design -> rebound) start together from the static state
    (``st_box``: a list holding it, emptied here; rows: leg x test x design, ``2 * rows``
    in every solver call; ``lsolver`` the solver of these rows) with the static inverse
    Jacobians (``J_box``: a list holding them, one per design, emptied here; shared by
    the rows until the solver refreshes one:
    :class:`~suspenv.models.mcpherson.solver.SharedInverse`), and the loop's return legs
    take the state of their grid point. Both branches of the loop are then identical.
    Predictors: the tangent for a leg's first step, then the quadratic and the cubic
    through the leg's last states (:data:`LEG_ORDER`; see the loop's comments).

    Failures are reported as the sequential loop reports them: the first failing step
    of the loop (its index ``k`` in ``path``) in the message, and the row's last
    converged state at every later step. Returns (channels {name: (rows, Q, 2)} of
    ``names`` (None: all) at the ``Q`` steps ``kept_steps`` of the loop (indices into
    ``path``), states of those steps when ``keep_states``).
    """
    steps = sweep.grid.size - 1
    i0 = steps // 2
    grid_at = path[kept_steps]  # grid index of every kept step
    reach = int(np.abs(grid_at - i0).max())
    lst, kept, last, lok, lmsgs, chans = _march_legs(
        lsolver, st_box, J_box, nt, ok, msgs, sweep, where_at, keep_states, names, reach
    )
    m = ok.size
    # a row fails when either leg fails; the bump leg comes first in the loop
    up_ok, down_ok = lok[:m], lok[m:]
    for i in range(m):
        msgs[i] = lmsgs[i] if not up_ok[i] else lmsgs[m + i]
    ok &= up_ok & down_ok
    # every row's grid index at each kept step of the loop; a failed row keeps its last
    # converged state from its failing step on (the step of that state in the loop)
    P = path.size
    k_last = np.where(~up_ok, last[:m] - i0, np.where(~down_ok, 2 * steps - i0 - last[m:], P))
    frozen = np.where(~up_ok, last[:m], last[m:])
    later = kept_steps[None, :] >= k_last[:, None]  # (rows, Q): from the failing step on
    idx = np.where(later, frozen[:, None], grid_at[None, :])
    out = {
        name: np.ascontiguousarray(v[grid_at - chans.lo].swapaxes(0, 1))
        for name, v in chans.ch.items()
    }
    bad = np.flatnonzero(k_last < P)
    if bad.size:  # the failed leg's row of each failed row
        rows = np.where(~up_ok[bad], bad, m + bad)
        _freeze_failed(out, lsolver, lst, rows, bad, later, sweep, grid_at, names)
    del lst
    return out, _grid_states(kept, idx) if keep_states else []


def _march_legs(
    lsolver: AxleSolver,
    st_box: list[AxleState],
    J_box: list[np.ndarray],
    nt: int,
    ok: np.ndarray,
    msgs: list[str],
    sweep: _Sweep,
    where_at: Callable[[int], str],
    keep_states: bool,
    names: Sequence[str] | None,
    reach: int,
) -> tuple[AxleState, list[AxleState], np.ndarray, np.ndarray, list[str], _LegChannels]:
    """Both legs of :func:`_sweep_legs` stepped from the static state (``st_box``,
    ``J_box``: emptied here) to the ends of the stroke, rows leg x ``m`` (bump leg
    first) of the ``m`` rows whose ``ok`` (m,) and messages ``msgs`` are given.

    Returns the legs' last states, the states of every leg step (the static state
    first) when ``keep_states``, the grid index of each leg row's last converged state
    (2 m,), the legs' ok (2 m,) and messages, and the channels ``names`` at the grid
    points within ``reach`` steps of the design position."""
    st = st_box.pop()
    m = st.r.shape[0]
    i0 = (sweep.grid.size - 1) // 2
    lst = st.take(np.tile(np.arange(m), 2))  # rows: leg-major (bump leg, rebound leg)
    del st  # (memory)
    Jinv: np.ndarray | SharedInverse = SharedInverse(J_box.pop(), 2 * nt)
    lok = np.tile(ok, 2)
    lmsgs = msgs + msgs
    direction = np.repeat([1, -1], m)
    last = np.full(2 * m, i0)  # grid index of every leg row's last converged state
    rel: dict | None = {} if PREDICTOR_CACHE else None
    history: list[AxleState] = []
    kept: list[AxleState] = [lst] if keep_states else []
    chans = _LegChannels(lsolver, m, reach, i0, names)
    prev_load = sweep.load(i0, 2)
    chans.pending.append((0, lst, prev_load[0]))
    for j in range(1, i0 + 1):
        gi = i0 + direction * j
        load = sweep.load(gi, 2)
        at = functools.partial(_leg_where, where_at, _loop_step(j, gi, direction, i0), gi)
        history = _leg_history(history, lst, j, m)
        lst, Jinv = _step(lsolver, lst, prev_load, load, lok, lmsgs, Jinv, at, history, None, rel)
        # the predictor's relative rotations of the states before the last are cached: no
        # later step reads their rotation matrices (unless their channels are due)
        if rel is not None and not keep_states:
            chans.release(history[:-1])
        last[lok] = gi[lok]
        if j == i0:  # loads and deflections peak at the ends of the stroke
            _check_state(lsolver, lst, lok, lmsgs, at)
        if keep_states:
            kept.append(lst)
        chans.add(j, lst, load[0])
        prev_load = load
    chans.flush()
    return lst, kept, last, lok, lmsgs, chans


def _loop_step(j: int, gi: np.ndarray, direction: np.ndarray, i0: int) -> np.ndarray:
    """The step (2 m,) of the sequential loop (:func:`loop_path`) that first reaches
    each leg row's grid point ``gi`` at leg step ``j`` (``direction``: +1 on the bump
    leg, -1 on the rebound leg)."""
    steps = 2 * i0
    return np.where(direction > 0, j, 2 * steps - i0 - gi)


def _leg_where(where_at: Callable[[int], str], k: np.ndarray, gi: np.ndarray, i: int) -> str:
    """Leg row ``i``'s step in words: its step ``k`` of the loop and grid point ``gi``."""
    return f"step {k[i]} ({where_at(gi[i])})"


def _leg_history(history: list[AxleState], lst: AxleState, j: int, m: int) -> list[AxleState]:
    """The states (oldest first) that the predictor of leg step ``j`` extrapolates from,
    ending with the last converged state ``lst`` (rows leg x ``m``): the legs' first
    steps and the static state are three equally spaced states of both legs, so the
    second step is extrapolated quadratically from them, the third cubically from them
    and the second step; later steps from the leg's last :data:`LEG_ORDER` states."""
    if j == 2:
        return [lst.take(np.r_[m : 2 * m, 0:m]), history[-1], lst]
    return [*history[-(LEG_ORDER - 1) :], lst]


def _grid_states(kept: list[AxleState], idx: np.ndarray) -> list[AxleState]:
    """The state of every kept step of the loop from the legs' states ``kept`` (leg step
    0 .. i0, rows leg x m): row ``i`` at kept step ``q`` in the state of grid point
    ``idx[i, q]`` (m, Q), the bump side from the bump leg, the rebound side from the
    rebound leg (the design position is the static state of both)."""
    m = idx.shape[0]

    def at_grid(x: np.ndarray) -> np.ndarray:  # (i0 + 1, 2 * rows, ...) -> (G, rows, ...)
        return np.concatenate([x[:0:-1, m:], x[:, :m]])

    r = at_grid(np.stack([x.r for x in kept]))
    R = at_grid(np.stack([x.R for x in kept]))
    lam = at_grid(np.stack([x.lam for x in kept]))
    rr = np.arange(m)
    return [
        AxleState(r[idx[:, q], rr], R[idx[:, q], rr], lam[idx[:, q], rr])
        for q in range(idx.shape[1])
    ]


class _LegChannels:
    """The channels of the two-leg loop's states (rows: leg x ``m``) at the grid points
    ``i0 - reach .. i0 + reach`` (the steps ``j <= reach`` of both legs) as the steps
    come, in calls of about JACOBIAN_BLOCK rows and at most OUTPUT_STATES states (bounded
    memory); a window's few states (``reach < i0``) one by one (views: the least memory)."""

    def __init__(self, lsolver: AxleSolver, m: int, reach: int, i0: int, names) -> None:
        self.solver, self.m, self.reach, self.lo, self.names = lsolver, m, reach, i0 - reach, names
        self.per = 1 if reach < i0 else max(1, min(JACOBIAN_BLOCK // (2 * m), OUTPUT_STATES))
        self.ch: dict[str, np.ndarray] = {}  # name -> (2 * reach + 1, m, 2)
        self.pending: list[tuple[int, AxleState, np.ndarray]] = []  # (step j, state, pads)

    def add(self, j: int, st: AxleState, pads: np.ndarray) -> None:
        """Leg step ``j``'s state ``st`` at pad heights ``pads``, kept while its channels
        are due."""
        if j <= self.reach:
            self.pending.append((j, st, pads))
        if len(self.pending) >= self.per:
            self.flush()

    def release(self, old: list[AxleState]) -> None:
        """:func:`_release_rotations` of the states ``old`` whose channels are not due."""
        for x in old:
            if all(p is not x for _, p, _ in self.pending):
                _release_rotations(x)

    def flush(self) -> None:
        """The channels of the pending states."""
        if not self.pending:
            return
        states, pads = [x for _, x, _ in self.pending], [q for _, _, q in self.pending]
        m, reach = self.m, self.reach
        for name, v in _outputs(self.solver, states, pads, self.per, self.names).items():
            if name not in self.ch:  # v: (states, 2 * m, 2)
                self.ch[name] = np.empty((2 * reach + 1, m) + v.shape[2:])
            for q, (j, _, _) in enumerate(self.pending):
                self.ch[name][reach + j] = v[q, :m]
                if j:
                    self.ch[name][reach - j] = v[q, m:]
        self.pending.clear()


def _freeze_failed(out, lsolver, lst, rows, bad, later, sweep, grid_at, names) -> None:
    """Into the channels ``out`` {name: (m, Q, 2)} of the failed rows ``bad`` (b,), from
    their failing step on (``later`` (m, Q)): those of their failed legs' last states
    (rows ``rows`` of ``lst``) at the rig's input of each kept step (grid ``grid_at``)."""
    pads = np.stack([sweep.load(g)[0][bad] for g in grid_at])  # (Q, b, 2)
    st, Q = lst.take(rows), grid_at.size
    r, R, lam = (np.broadcast_to(a, (Q,) + a.shape) for a in (st.r, st.R, st.lam))
    late = lsolver.take(rows, axle=False).outputs(AxleState(r, R, lam), pads, names)
    for q, row in enumerate(bad.tolist()):
        for name, v in late.items():
            out[name][row, later[row]] = v[later[row], q]


#: the rotation matrices of a state that no step reads again (no rows: a read fails)
_RELEASED_ROTATIONS = np.empty((0, 2, 4, 3, 3))
_RELEASED_ROTATIONS.flags.writeable = False


def _release_rotations(st: AxleState) -> None:
    """Free the rotation matrices (rows, 2, 4, 3, 3) of a state of the two-leg loop that
    only the predictor's cached relative rotations stand for now (memory: half a state);
    its positions and multipliers stay for the extrapolation."""
    st.R = _RELEASED_ROTATIONS


def _fail(ok: np.ndarray, msgs: list[str], rows: np.ndarray, msg: str | Callable[[int], str]):
    """Mark ``rows`` (bool mask) failed with message ``msg`` (text, or row -> text),
    keeping the first message of rows that had already failed."""
    for i in np.flatnonzero(rows & ok):
        msgs[i] = msg if isinstance(msg, str) else msg(int(i))
    ok &= ~rows


def _step(solver, st, load_prev, load, ok, msgs, J, at, history, seen=None, rel=None):
    """One rig step: predictor, Newton corrector, sub-stepping retry of failing rows.

    ``load_prev`` / ``load`` are (pad heights (n, 2) [m], wheel load (n, 2, 6|9) or
    None, rack travel (n, 2) [m] or None, wheel-centre heights (n, 2) [m] or None: see
    :data:`Load`) before and after the step; a wheel-centre drive's pads are first
    guessed from the last step's (moved by the change of the wheel-centre height) and
    then moved by the solver, in place; ``at`` describes
    the step for messages (text, or row -> text: ``"step k (drive)"``). ``J``: inverse
    Jacobians, per row (n, 66, 66) or a :class:`SharedInverse`. Predictor: the state
    last converged at the same grid point (a revisit; exact for a path-independent
    model), else extrapolation along the leg (quadratic from the three states of
    ``history``, linear from two), else the tangent ``-J^-1 dres/dload``.
    """
    (pad_prev, _, _, centre_prev), (pad, ext, rack, centre) = load_prev, load
    guess = None
    if centre is not None and centre_prev is not None:
        np.copyto(pad, pad_prev + (centre - centre_prev), where=np.isfinite(centre))
        guess = pad.copy()  # the sub-steps below start from it
    # the prediction goes straight to Newton, which frees each iterate it leaves (memory)
    new, conv, J = solver.solve(
        _prediction(solver, st, load_prev, load, ok, J, history, seen, rel),
        pad,
        ext,
        active=ok,
        Jinv=J,
        rack=rack,
        centre=centre,
    )
    bad = ok & ~conv
    if bad.any():  # retry the failing rows from the last converged state in 4 sub-steps
        rescued = _substeps(solver, st, new, bad, load_prev, load, guess)
        _fail(ok, msgs, bad & ~rescued, functools.partial(_no_convergence, at))
    new = solver.commit(new)
    if not ok.all():  # failed rows keep their last converged state
        new = new.copy()
        new.assign(st, ~ok)
    return new, J


def _substeps(
    solver: AxleSolver,
    st: AxleState,
    new: AxleState,
    bad: np.ndarray,
    load_prev: Load,
    load: Load,
    guess: np.ndarray | None,
) -> np.ndarray:
    """Retry the rows ``bad`` (bool mask) that failed a step from their last converged
    state ``st`` in four equal sub-steps of the rig's input from ``load_prev`` to
    ``load`` (the pads towards ``guess`` [m] under a wheel-centre drive); the rescued
    rows' states go into ``new`` and, under a wheel-centre drive, their pads into
    ``load``'s (the others' back to the last step's). Returns the rescued rows."""
    idx = np.flatnonzero(bad)
    sub = solver.take(idx, axle=False)
    trial = st.take(idx)
    sub_ok = np.ones(idx.size, bool)
    Jt = None
    pad_prev, pad = load_prev[0], load[0]
    aim = (pad if guess is None else guess, *load[1:])
    for f in (0.25, 0.5, 0.75, 1.0):
        p = pad_prev[idx] + f * (aim[0][idx] - pad_prev[idx])
        e, q, c = (_between(a, b, idx, f) for a, b in zip(load_prev[1:], aim[1:], strict=True))
        trial, conv, Jt = sub.solve(trial, p, e, active=sub_ok, Jinv=Jt, rack=q, centre=c)
        sub_ok &= conv
    rescued = np.zeros_like(bad)
    rescued[idx[sub_ok]] = True
    new.assign(_scatter(trial, idx, new), rescued)
    if guess is not None:  # the rescued rows' pads; the failed rows' last ones
        pad[idx] = np.where(sub_ok[:, None], p, pad_prev[idx])
    return rescued


def _between(
    a: np.ndarray | None, b: np.ndarray | None, idx: np.ndarray, f: float
) -> np.ndarray | None:
    """The rows ``idx`` of the input ``f`` of the way from ``a`` to ``b`` (None when
    the input is not given)."""
    return None if a is None or b is None else a[idx] + f * (b[idx] - a[idx])


def _no_convergence(at: str | Callable[[int], str], i: int) -> str:
    """The failure message of row ``i`` whose Newton iteration did not converge at the
    step ``at`` (text, or row -> text)."""
    return (
        f"ConvergenceError: Newton did not converge at {at if isinstance(at, str) else at(i)}; "
        "the linkage locks up or the design has no equilibrium there"
    )


def _prediction(solver, st, load_prev, load, ok, J, history, seen, rel) -> AxleState:
    """The predictor of :func:`_step` (its docstring): the revisited state, the
    extrapolation along the leg, or the tangent."""
    (pad_prev, ext_prev, rack_prev, _), (pad, ext, rack, _) = load_prev, load
    if seen is not None:
        pred = st.copy()
        rows = ok[:, None, None, None]
        pred.r = np.where(rows, seen.r, st.r)
        pred.R = np.where(rows[..., None], seen.R, st.R)
        pred.lam = np.where(ok[:, None, None], seen.lam, st.lam)
        return pred
    if len(history) >= 2:  # (before, before2, before3) of st = history[-1], None if absent
        older = [*history[-2:-5:-1], None, None]
        return _extrapolate(st, older[0], older[1], ok, rel, older[2])
    return _predict(solver, st, J, pad - pad_prev, ok, ext_prev, ext, rack_prev, rack)


def _scatter(part: AxleState, idx: np.ndarray, like: AxleState) -> AxleState:
    """A full-size state equal to ``like`` except the rows ``idx`` taken from ``part``."""
    out = like.copy()
    out.r[idx], out.R[idx], out.lam[idx] = part.r, part.R, part.lam
    for key in out.hyst:
        out.hyst[key][0][idx], out.hyst[key][1][idx] = part.hyst[key]
    if out.fric is not None and part.fric is not None:
        out.fric[0][idx], out.fric[1][idx] = part.fric
    return out


def _predict(
    solver: AxleSolver,
    st: AxleState,
    Jinv: np.ndarray | SharedInverse,
    dpad: np.ndarray,
    ok,
    ext_prev: np.ndarray | None = None,
    ext: np.ndarray | None = None,
    rack_prev: np.ndarray | None = None,
    rack: np.ndarray | None = None,
):
    """Tangent predictor ``dx = -J^-1 dres`` (only the tyre depends on the pad; the
    residual is linear in the wheel load, so its change is exact; the change with the
    rack travel is the residual's secant at ``st``)."""
    n = solver.n
    dres = (solver.pad_sensitivity(st) * dpad[..., None]).reshape(n, -1, 1)
    if ext is not None or rack is not None:
        pad = solver.pad_static
        change = solver.residual(st.r, st.R, st.lam, pad, st, ext, rack=rack) - solver.residual(
            st.r, st.R, st.lam, pad, st, ext_prev, rack=rack_prev
        )
        dres = dres + change.reshape(n, -1, 1)
    dx = -_inv_mul(Jinv, dres[..., 0])
    dx = np.where(np.isfinite(dx), dx, 0.0)
    return solver._apply(st, dx, ok)


def _relative_rotation(a: AxleState, b: AxleState, cache: dict | None) -> np.ndarray:
    """Rotation vectors of ``a.R b.R^T``; ``cache`` (a dict or None) keeps the last two
    computed, so that the next step's predictor, whose older pairs are this step's newer
    ones (states are never mutated), does not compute them again."""
    if cache is not None:
        for hit in cache.get("pairs", ()):
            if hit[0] is a and hit[1] is b:
                return hit[2]
    w = relative_log(a.R, b.R)
    if cache is not None:
        cache["pairs"] = [*cache.get("pairs", [])[-1:], (a, b, w)]
    return w


def _extrapolate(
    st: AxleState,
    before: AxleState,
    before2: AxleState | None,
    ok: np.ndarray,
    rel: dict | None = None,
    before3: AxleState | None = None,
) -> AxleState:
    """Extrapolate the last converged states one equal step along a leg: cubic from
    four states (``before3`` given), quadratic from three, linear from two
    (``before2=None``); rotations through the relative rotation vectors of consecutive
    states (extrapolated one order lower). ``rel``: a cache of the last relative
    rotations (:func:`_relative_rotation`; the same numbers either way)."""
    rows = ok[:, None, None, None]
    # the older pairs first: they are the last steps' newer pairs (cached), then this one
    wm = None if before3 is None or before2 is None else _relative_rotation(before2, before3, rel)
    w0 = None if before2 is None else _relative_rotation(before, before2, rel)
    w1 = _relative_rotation(st, before, rel)
    if before2 is None or w0 is None:
        r_new, w, lam_new = 2.0 * st.r - before.r, w1, 2.0 * st.lam - before.lam
    elif before3 is None or wm is None:
        r_new = 3.0 * (st.r - before.r) + before2.r
        w = 2.0 * w1 - w0
        lam_new = 3.0 * (st.lam - before.lam) + before2.lam
    else:
        r_new = 4.0 * (st.r + before2.r) - 6.0 * before.r - before3.r
        w = 3.0 * (w1 - w0) + wm
        lam_new = 4.0 * (st.lam + before2.lam) - 6.0 * before.lam - before3.lam
    R_new = turned(w, st.R)
    if not ok.all():  # failed rows keep their state
        r_new = np.where(rows, r_new, st.r)
        R_new = np.where(rows[..., None], R_new, st.R)
        lam_new = np.where(ok[:, None, None], lam_new, st.lam)
    return st.moved(r_new, R_new, lam_new)  # the path-dependent histories copied


def _check_state(solver, st, ok, msgs, at) -> None:
    """Physical plausibility of a converged step: bushing deflections within reason.

    A bushing deflecting more than 50 mm or 0.5 rad means the design cannot carry its
    loads (e.g. a top mount of a few N/mm under the spring preload) or a body has
    found a mechanism; the row fails with the bushing and the value named.
    """
    for name, tr, rot, locked in solver.lockups(st):
        bad = ok & locked
        for i in np.flatnonzero(bad):
            msgs[i] = (
                f"LockupError: {lockup_text(name, tr[i], rot[i])} at "
                f"{at if isinstance(at, str) else at(int(i))}: the design cannot carry its loads"
            )
        ok &= ~bad
