"""Virtual K&C rig: vertical travel and contact-patch compliance tests of a McPherson axle.

Frame ISO 8855 (x forward, y left, z up), SI units; body and steering rack held fixed.
The travel tests (:data:`TESTS`, the three of the identification problem) prescribe
the heights of the two wheel pads relative to the static pad height
(``AxleSolver.pad_static``):

* ``parallel``: both pads move by ``+s`` (bump positive);
* ``opposite``: left pad ``+s``, right pad ``-s`` (the body-fixed equivalent of a
  roll to the right, left wheel in bump);
* ``single``: left pad ``+s``, right pad held at its static height.

The compliance tests (:data:`FORCE_TESTS`) hold both pads at their static height and
apply a horizontal force ``F`` [N] at both contact points (the pads carry no
horizontal force, so the suspension takes it all):

* ``lateral``: ``+F`` along +y on both wheels (the tyre forces of a left-hand turn:
  outboard on the left wheel, inboard on the right);
* ``longitudinal``: ``+F`` along +x on both wheels (traction positive, braking
  negative).

The grid has ``steps + 1`` points from ``-amplitude`` to ``+amplitude`` [m] (or
``-force_amplitude`` to ``+force_amplitude`` [N]) with the design (static) position
on the grid (``steps`` even). Because path-dependent effects
(hysteresis, friction) make the answer depend on the history, every test runs as a
loop design -> bump -> rebound -> design and keeps both branches: the *descending*
branch (bump to rebound) and the *ascending* branch (rebound to design, then the
first leg design to bump).

All tests of all designs are solved as one batch (rows = test x design), each step
warm-started from the previous converged step with a tangent predictor.

Return leg of a path-independent model: when the model has no element whose force
depends on the loading branch (no Dahl hysteresis at a bushing, no strut friction:
:attr:`AxleSolver.path_dependent`, decided from the model, never from data), the
state at a grid point does not depend on how the rig got there, so a revisited grid
point (rebound leg from bump back to design, last leg from rebound back to design)
reuses the state converged at the first visit instead of solving it again: both
branches are then identical, and equal to what a re-solve would give to the solver
tolerance (the re-solve starts from that very state and stops after one correction
below ``xtol``/``rtol``/``ltol``). ``reuse_revisits=False`` solves every point (the
reference path, kept for checks and the speed benchmark).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.measurements.knc import ALL_TESTS, FORCE_TESTS, TESTS
from suspenv.models.effects import Effect
from suspenv.models.mcpherson.params import Axle
from suspenv.models.mcpherson.rotation import expm_so3, log_so3
from suspenv.models.mcpherson.solver import JACOBIAN_BLOCK, NS, AxleSolver, AxleState

# the tests (TESTS: travel, FORCE_TESTS: compliance, ALL_TESTS) are named once, by the
# recording format of K&C loops
_PAD_SIGN = {"parallel": (1.0, 1.0), "opposite": (1.0, -1.0), "single": (1.0, 0.0)}
#: compliance test -> (force axis in ISO 8855, sign on the (left, right) wheel)
_FORCE_AXIS = {"lateral": (1, (1.0, 1.0)), "longitudinal": (0, (1.0, 1.0))}
#: default force amplitude of the compliance tests [N]
FORCE_AMPLITUDE = 2500.0

#: a bushing deflection above these is reported as a lock-up [m], [rad]
MAX_TRANSLATION = 0.05
MAX_ROTATION = 0.5


@dataclass
class KCResult:
    """Channels of one rig test for a batch of designs.

    Attributes:
        test: test name.
        grid: (steps + 1,) grid of the test's input: the left pad's offset [m] for a
            travel test, the contact-point force [N] for a compliance test.
        path: (P,) grid index of every step of the loop (P = 2 * steps + 1).
        channels: name -> (n, P, 2) values along the loop (SI, ISO 8855; see docs/knc.md).
        ok: (n,) True where every step converged.
        messages: (n,) failure reasons ("" when ok).
    """

    test: str
    grid: np.ndarray
    path: np.ndarray
    channels: dict[str, np.ndarray]
    ok: np.ndarray
    messages: list[str]
    states: list[AxleState] = field(default_factory=list, repr=False)

    @property
    def unit(self) -> str:
        """Unit of :attr:`grid`: ``"N"`` for a compliance test, ``"m"`` otherwise."""
        return "N" if self.test in FORCE_TESTS else "m"

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


def stroke_grid(amplitude: float = 0.040, steps: int = 30) -> np.ndarray:
    """Grid of pad offsets [m], ``steps + 1`` points, design position in the middle."""
    if not amplitude > 0:
        raise ValidationError(f"`amplitude > 0` must hold, but got amplitude={amplitude}")
    if steps < 2 or steps % 2:
        raise ValidationError(f"`steps` must be even and >= 2, but got steps={steps}")
    return np.linspace(-amplitude, amplitude, steps + 1)


def loop_path(steps: int) -> np.ndarray:
    """Grid indices of the loop design -> bump -> rebound -> design (2 * steps + 1 points)."""
    i0 = steps // 2
    return np.r_[np.arange(i0, steps + 1), np.arange(steps - 1, -1, -1), np.arange(1, i0 + 1)]


def pad_offsets(test: str, s: np.ndarray) -> np.ndarray:
    """Pad offsets (..., 2) [m] of ``test`` for left-pad stroke ``s`` (zero for a
    compliance test, whose pads stay at their static height)."""
    _check_tests((test,))
    sign = np.array(_PAD_SIGN.get(test, (0.0, 0.0)))
    return np.asarray(s, dtype=float)[..., None] * sign


def contact_forces(test: str, f: np.ndarray | float) -> np.ndarray:
    """Extra load (..., 2, 6) [N, N*m] at both contact points of ``test`` for force
    ``f`` [N] (zero for a travel test); force then moment, ISO 8855."""
    _check_tests((test,))
    f = np.asarray(f, dtype=float)
    out = np.zeros(f.shape + (2, 6))
    if test in _FORCE_AXIS:
        axis, sign = _FORCE_AXIS[test]
        out[..., axis] = f[..., None] * np.array(sign)
    return out


def _check_tests(tests: tuple[str, ...]) -> None:
    for t in tests:
        if t not in ALL_TESTS:
            raise ValidationError(f"unknown K&C test {t!r}; known tests are {ALL_TESTS}")


def run_tests(
    axle: Axle,
    tests: tuple[str, ...] = TESTS,
    amplitude: float = 0.040,
    steps: int = 30,
    effects: Sequence[Effect] = (),
    keep_states: bool = False,
    force_amplitude: float = FORCE_AMPLITUDE,
    reuse_revisits: bool = True,
) -> dict[str, KCResult]:
    """Run the rig ``tests`` on every design of ``axle``; returns {test: KCResult}.

    ``amplitude`` [m] is the pad stroke of the travel tests, ``force_amplitude`` [N]
    the contact-point force of the compliance tests. ``effects``: the axle's optional
    physics, effects-library elements placed at bushings or the strut
    (:mod:`suspenv.models.mcpherson.effects`). ``reuse_revisits``: for a
    path-independent model (see the module docstring) take a revisited grid point's
    state from its first visit instead of solving it again (``False``: solve every
    step, the reference path); a path-dependent model always solves every step.
    """
    _check_tests(tuple(tests))
    if not force_amplitude > 0:
        raise ValidationError(f"`force_amplitude > 0` must hold, but got {force_amplitude} N")
    n, nt = axle.n, len(tests)
    grid = stroke_grid(amplitude, steps)
    force_grid = stroke_grid(force_amplitude, steps) if set(tests) & set(FORCE_TESTS) else None
    path = loop_path(steps)
    # static equilibrium once per design, then one row per (test, design)
    base = AxleSolver(axle, effects)
    st0, conv0, J0 = base.solve(base.initial_state(), base.pad_static)
    tile = np.tile(np.arange(n), nt)  # rows: test-major
    solver = base.take(tile)
    st, J = st0.take(tile), J0[tile]
    del st0, J0  # the per-design copies are no longer needed (memory)
    signs = np.repeat(np.array([_PAD_SIGN.get(t, (0.0, 0.0)) for t in tests]), n, axis=0)
    # compliance tests: contact-point load per newton of the test's force (nt*n, 2, 6)
    ext_dir = (
        None
        if force_grid is None
        else np.repeat(np.stack([contact_forces(t, 1.0) for t in tests]), n, axis=0)
    )
    rows = nt * n
    ok = np.ones(rows, bool)
    msgs = [""] * rows
    pad0 = solver.pad_static
    _fail(ok, msgs, ~conv0[tile], "ConvergenceError: no static equilibrium at the design position")
    st = solver.commit(st)

    trail: list[AxleState] = []  # converged state of every step (states are not mutated)
    pending: list[tuple[AxleState, np.ndarray]] = []  # (state, pads) whose channels are due
    parts: list[dict[str, np.ndarray]] = []  # channels (steps, rows, 2) of flushed steps
    # channels are computed in vectorised calls of about 4 JACOBIAN_BLOCK row evaluations
    # each, as the steps come (bounded memory: only the states of `visited` stay alive)
    per = max(1, 4 * JACOBIAN_BLOCK // max(rows, 1))

    def flush() -> None:
        stacked = AxleState(
            np.stack([x.r for x, _ in pending]),
            np.stack([x.R for x, _ in pending]),
            np.stack([x.lam for x, _ in pending]),
        )
        parts.append(solver.outputs(stacked, np.stack([q for _, q in pending])))
        pending.clear()

    history: list[AxleState] = []  # converged states of the current leg, newest last
    visited: dict[int, AxleState] = {}  # last converged state at each grid point
    prev_ds = 0.0
    has_travel = bool(set(tests) & set(TESTS))

    def load_at(gi: int) -> tuple[np.ndarray, np.ndarray | None]:
        """(pad heights (rows, 2) [m], contact-point load (rows, 2, 6) or None) at grid ``gi``."""
        if ext_dir is None:
            return pad0 + signs * grid[gi], None
        assert force_grid is not None  # invariant: ext_dir is built exactly when force_grid is
        return pad0 + signs * grid[gi], ext_dir * force_grid[gi]

    def where(gi: int) -> str:
        parts = [f"stroke {grid[gi] * 1e3:+.2f} mm"] if has_travel else []
        if force_grid is not None:
            parts.append(f"contact force {force_grid[gi]:+.0f} N")
        return ", ".join(parts)

    # a path-independent model: every run of revisited grid points is corrected in one
    # batched residual call (see _revisit_run); `revisits` holds the run's states by step
    reuse = reuse_revisits and not solver.path_dependent
    revisits: dict[int, AxleState] = {}
    tried: set[int] = set()
    prev_gi, prev_load = path[0], load_at(path[0])
    for k, gi in enumerate(path):
        load = load_at(gi)
        if k > 0:
            ds = grid[gi] - grid[prev_gi]
            if prev_ds * ds <= 0:  # a reversal starts a new leg
                history = []
            history = [*history[-2:], st]
            if reuse and k not in tried and gi in visited:  # first step of a run of revisits
                run = [k]
                while run[-1] + 1 < path.size and int(path[run[-1] + 1]) in visited:
                    run.append(run[-1] + 1)
                tried.update(run)
                revisits = _revisit_run(
                    solver,
                    st,
                    [visited[int(path[j])] for j in run],
                    [load_at(path[j]) for j in run],
                    ok,
                    J,
                    run,
                )
            if k in revisits:
                st = revisits.pop(k)
            else:
                st, J = _step(
                    solver,
                    st,
                    prev_load,
                    load,
                    ok,
                    msgs,
                    J,
                    k,
                    where(gi),
                    history,
                    visited.get(gi),
                )
            prev_ds = ds
        visited[gi] = st
        if gi in (0, steps):  # loads and deflections peak at the ends of the stroke
            _check_state(solver, st, ok, msgs, k, where(gi))
        if keep_states:
            trail.append(st)
        pending.append((st, load[0]))
        if len(pending) == per:
            flush()
        prev_gi, prev_load = gi, load

    if pending:
        flush()
    out = {k: np.moveaxis(np.concatenate([q[k] for q in parts]), 0, 1) for k in parts[0]}
    results = {}
    for j, t in enumerate(tests):
        sl = slice(j * n, (j + 1) * n)
        test_grid = force_grid if t in FORCE_TESTS else grid
        assert test_grid is not None  # invariant: force_grid is built when a force test runs
        results[t] = KCResult(
            t,
            test_grid,
            path,
            {name: v[sl] for name, v in out.items()},
            ok[sl].copy(),
            msgs[sl],
            [_take_state(x, sl) for x in trail] if keep_states else [],
        )
    return results


def _take_state(st: AxleState, sl: slice) -> AxleState:
    return AxleState(
        st.r[sl],
        st.R[sl],
        st.lam[sl],
        {k: (a[sl], b[sl]) for k, (a, b) in st.hyst.items()},
        None if st.fric is None else (st.fric[0][sl], st.fric[1][sl]),
    )


def _fail(ok: np.ndarray, msgs: list[str], rows: np.ndarray, msg: str) -> None:
    for i in np.flatnonzero(rows & ok):
        msgs[i] = msg
    ok &= ~rows


def _step(solver, st, load_prev, load, ok, msgs, J, k, where, history, seen=None):
    """One rig step: predictor, Newton corrector, sub-stepping retry of failing rows.

    ``load_prev`` / ``load`` are (pad heights (n, 2) [m], contact-point load
    (n, 2, 6) or None) before and after the step; ``where`` describes the step for
    messages. Predictor: the state last converged at the same grid point (a revisit;
    exact for a path-independent model), else extrapolation along the leg (quadratic
    from three states, linear from two), else the tangent ``-J^-1 dres/dload``.
    """
    (pad_prev, ext_prev), (pad, ext) = load_prev, load
    if seen is not None:
        pred = st.copy()
        rows = ok[:, None, None, None]
        pred.r = np.where(rows, seen.r, st.r)
        pred.R = np.where(rows[..., None], seen.R, st.R)
        pred.lam = np.where(ok[:, None, None], seen.lam, st.lam)
    elif len(history) >= 3:
        pred = _extrapolate(st, history[-2], history[-3], ok)
    elif len(history) == 2:
        pred = _extrapolate(st, history[-2], None, ok)
    else:
        pred = _predict(solver, st, J, pad - pad_prev, ok, ext_prev, ext)
    new, conv, J = solver.solve(pred, pad, ext, active=ok, Jinv=J)
    bad = ok & ~conv
    if bad.any():  # retry the failing rows from the last converged state in 4 sub-steps
        idx = np.flatnonzero(bad)
        sub = solver.take(idx)
        trial = st.take(idx)
        sub_ok = np.ones(idx.size, bool)
        Jt = None
        for f in (0.25, 0.5, 0.75, 1.0):
            p = pad_prev[idx] + f * (pad[idx] - pad_prev[idx])
            e = None if ext is None else ext_prev[idx] + f * (ext[idx] - ext_prev[idx])
            trial, c, Jt = sub.solve(trial, p, e, active=sub_ok, Jinv=Jt)
            sub_ok &= c
        rescued = np.zeros_like(bad)
        rescued[idx[sub_ok]] = True
        new.assign(_scatter(trial, idx, new), rescued)
        _fail(
            ok,
            msgs,
            bad & ~rescued,
            f"ConvergenceError: Newton did not converge at step {k} ({where}); "
            "the linkage locks up or the design has no equilibrium there",
        )
    new = solver.commit(new)
    if not ok.all():  # failed rows keep their last converged state
        new = new.copy()
        new.assign(st, ~ok)
    return new, J


def _revisit_run(
    solver: AxleSolver,
    st: AxleState,
    seen: list[AxleState],
    loads: list[tuple[np.ndarray, np.ndarray | None]],
    ok: np.ndarray,
    Jinv: np.ndarray,
    steps: list[int],
) -> dict[int, AxleState]:
    """States {step: state} of a run of revisited grid points of a path-independent model,
    solved together: one Newton correction ``dx = -J^-1 res`` from the state of each
    point's first visit ``seen`` (the predictor :func:`_step` would use) with loads
    ``loads`` (pad heights (n, 2) [m], contact-point load (n, 2, 6) [N, N*m] or None).

    This is the arithmetic of solving the points one after the other (that solve also
    starts from ``seen``, with the same ``Jinv``, which a first iteration never
    refreshes, and stops after this first correction when it is below the tolerances),
    in batched residual calls (blocks of about ``JACOBIAN_BLOCK`` row evaluations)
    instead of one call per point. Rows that failed
    earlier (``~ok``) keep their last converged state ``st``. Returns ``{}`` (solve the
    points one by one instead) unless every correction of every row still being solved
    is below the tolerances.
    """
    n, P = solver.n, len(seen)
    r = np.stack([x.r for x in seen])
    R = np.stack([x.R for x in seen])
    lam = np.stack([x.lam for x in seen])
    pad = np.stack([x[0] for x in loads])
    exts = [x[1] for x in loads]
    ext = None if any(e is None for e in exts) else np.stack(exts)  # type: ignore[arg-type]
    # residuals in blocks of about JACOBIAN_BLOCK row evaluations (bounded memory)
    per = max(1, JACOBIAN_BLOCK // max(n, 1))
    res = np.empty((P, n, 2 * NS))
    for a in range(0, P, per):
        b = min(a + per, P)
        solver.stats["residuals"] += 1
        e = None if ext is None else ext[a:b]
        res[a:b] = solver.residual(r[a:b], R[a:b], lam[a:b], pad[a:b], st, e).reshape(
            b - a, n, 2 * NS
        )
    dx = -np.matmul(Jinv, res[..., None])[..., 0]
    size = solver._step_size(dx.reshape(P * n, 2 * NS)).reshape(P, n)
    if not (size[:, ok] < 1.0).all():  # also False for a non-finite step
        return {}
    okP = np.broadcast_to(ok, (P, n)).reshape(P * n)
    moved = solver._apply(
        AxleState(
            r.reshape((P * n,) + r.shape[2:]),
            R.reshape((P * n,) + R.shape[2:]),
            lam.reshape((P * n,) + lam.shape[2:]),
        ),
        dx.reshape(P * n, 2 * NS),
        okP,
    )
    out = {}
    for p, k in enumerate(steps):
        sl = slice(p * n, (p + 1) * n)
        new = AxleState(moved.r[sl], moved.R[sl], moved.lam[sl])
        if not ok.all():  # failed rows keep their last converged state
            new.assign(st, ~ok)
        out[k] = new
    solver.stats["solves"] += P
    return out


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
    Jinv: np.ndarray,
    dpad: np.ndarray,
    ok,
    ext_prev: np.ndarray | None = None,
    ext: np.ndarray | None = None,
):
    """Tangent predictor ``dx = -J^-1 dres`` (only the tyre depends on the pad; the
    residual is linear in the contact-point load, so its change is exact)."""
    n = solver.n
    dres = (solver.pad_sensitivity(st) * dpad[..., None]).reshape(n, -1, 1)
    if ext is not None:
        pad = solver.pad_static
        change = solver.residual(st.r, st.R, st.lam, pad, st, ext) - solver.residual(
            st.r, st.R, st.lam, pad, st, ext_prev
        )
        dres = dres + change.reshape(n, -1, 1)
    dx = -np.matmul(Jinv, dres)[..., 0]
    dx = np.where(np.isfinite(dx), dx, 0.0)
    return solver._apply(st, dx, ok)


def _extrapolate(
    st: AxleState, before: AxleState, before2: AxleState | None, ok: np.ndarray
) -> AxleState:
    """Extrapolate the last converged states one equal step along a leg: quadratic from
    three states, linear from two (``before2=None``)."""
    out = st.copy()
    rows = ok[:, None, None, None]
    w1 = log_so3(np.matmul(st.R, np.swapaxes(before.R, -1, -2)))
    if before2 is None:
        r_new, w, lam_new = 2.0 * st.r - before.r, w1, 2.0 * st.lam - before.lam
    else:
        r_new = 3.0 * (st.r - before.r) + before2.r
        w = 2.0 * w1 - log_so3(np.matmul(before.R, np.swapaxes(before2.R, -1, -2)))
        lam_new = 3.0 * (st.lam - before.lam) + before2.lam
    out.r = np.where(rows, r_new, st.r)
    out.R = np.where(rows[..., None], np.matmul(expm_so3(w), st.R), st.R)
    out.lam = np.where(ok[:, None, None], lam_new, st.lam)
    return out


def _check_state(solver, st, ok, msgs, k, where) -> None:
    """Physical plausibility of a converged step: bushing deflections within reason.

    A bushing deflecting more than 50 mm or 0.5 rad means the design cannot carry its
    loads (e.g. a top mount of a few N/mm under the spring preload) or a body has
    found a mechanism; the row fails with the bushing and the value named.
    """
    for name, d in solver.deflections(st.r, st.R).items():
        tr = np.abs(d[..., :3]).max(axis=(-1, -2))
        rot = np.abs(d[..., 3:]).max(axis=(-1, -2))
        bad = ok & (~np.isfinite(tr) | (tr > MAX_TRANSLATION) | (rot > MAX_ROTATION))
        for i in np.flatnonzero(bad):
            msgs[i] = (
                f"LockupError: the {name} bushing deflects {tr[i] * 1e3:.1f} mm / "
                f"{rot[i]:.2f} rad (limits {MAX_TRANSLATION * 1e3:g} mm, {MAX_ROTATION:g} rad) "
                f"at step {k} ({where}): the design cannot carry its loads"
            )
        ok &= ~bad
