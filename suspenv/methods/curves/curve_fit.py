"""Whole-curve, noise-weighted fit of a McPherson axle to measured K&C loops.

The residual of a design is, for every measured rig test, fitted channel, wheel and
sample of the loop, ``(simulated - measured) / sigma_channel`` (dimensionless; the
channel's measurement noise ``sigma`` in SI units). The simulated loop is solved on
a uniform grid of the test's drive (left pad stroke [m], force [N], moment [N*m] or
rack travel [m]) from ``-A`` to ``+A`` (``A`` the largest measured ``|drive|``) and
read per loading branch at the measured drive values: samples of branch 1 (``+end
-> -end``) from the descending branch, samples of branches 0 and 2 (``design ->
+end``, ``-end -> design``) from the ascending one, linear in the drive between grid
points (exact when the measured drive lies on the grid, as in loops that
``suspenv knc`` writes). Values, slopes, curvature, static caster and both
hysteresis branches all enter; channels are SI and ISO 8855 (x forward, y left, z
up), left and right wheels in their raw (not outboard) signs.

Parameters: the vehicle's design space (ADAMS/Car units at this edge: mm, N/mm,
N*mm/deg, N*m/rad, deg) mapped to the unit cube, stiffnesses logarithmically
(:func:`~suspenv.rigs.knc_fit.fit_space`). By default the model is symmetric (one
design for both sides).

Two stages (:func:`fit_curves`):

1. **global**: CMA-ES (pycma) on the sum of squared residuals in the unit cube,
   every generation evaluated as one batch of rig simulations;
2. **polish**: the K&C fit's one least-squares driver and restart rule
   (:func:`suspenv.rigs.knc_fit.polish`), which the K&C diagnosis also uses.

Both report why they stopped.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.space import DesignSpace, Parameter
from suspenv.models.effects import Effect
from suspenv.models.mcpherson.params import AxleConstants, build_axle
from suspenv.rigs.knc import KCResult
from suspenv.rigs.knc_fit import (
    StageResult,
    UnitFit,
    amplitude_kwargs,
    effect_scale,
    fit_space,
    polish,
    rig_run,
    same_rows,
    say,
)

#: channels fitted when measured (SI, ISO 8855; raw signs, left and right wheels)
FIT_CHANNELS = (
    "toe",
    "camber",
    "caster",
    "kpi",
    "tyre_fz",
    "wheel_centre_x",
    "wheel_centre_y",
    "wheel_centre_z",
    "contact_x",
    "contact_y",
    "contact_z",
)


@dataclass
class MeasuredCurves:
    """One measured test as the fit reads it.

    Attributes:
        test: rig test name.
        drive: (P,) drive of every sample (SI: left pad stroke [m], force [N], ...).
        branch: (P,) int, 0 design -> +end, 1 +end -> -end, 2 -end -> design.
        values: channel -> (P, 2) measured values (SI, raw ISO 8855, left, right).
        amplitude: half-range of the simulated grid (largest ``|drive|``).
        steps: grid intervals of the simulated loop (even).
    """

    test: str
    drive: np.ndarray
    branch: np.ndarray
    values: dict[str, np.ndarray]
    amplitude: float
    steps: int
    # interpolation: grid interval index and weight per sample, descending-branch mask
    _i0: np.ndarray = field(default_factory=lambda: np.zeros(0, int), repr=False)
    _w: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    _start: np.ndarray = field(default_factory=lambda: np.zeros(0, bool), repr=False)

    def __post_init__(self) -> None:
        grid = np.linspace(-self.amplitude, self.amplitude, self.steps + 1)
        d = np.clip(self.drive, grid[0], grid[-1])
        i0 = np.clip(np.searchsorted(grid, d, side="right") - 1, 0, self.steps - 1)
        self._i0 = i0
        self._w = (d - grid[i0]) / (grid[i0 + 1] - grid[i0])
        # the loop's start (branch 0 at the design drive): the state before any travel,
        # which path-dependent elements (hysteresis, friction) leave only once
        self._start = (self.branch == 0) & (self.drive == 0.0)

    def read(self, res: KCResult, channel: str) -> np.ndarray:
        """Simulated ``channel`` (n, P, 2) of ``res`` at the measured samples (per branch;
        the loop's start sample from the path's first state)."""
        down = res.branch(channel, "down")
        up = res.branch(channel, "up")
        w = self._w[None, :, None]
        a = (1 - w) * down[:, self._i0] + w * down[:, self._i0 + 1]
        b = (1 - w) * up[:, self._i0] + w * up[:, self._i0 + 1]
        out = np.where((self.branch == 1)[None, :, None], a, b)
        out[:, self._start] = res.channels[channel][:, :1]
        return out


def measured_curves(measured: Any, steps: int | None = None) -> MeasuredCurves:
    """:class:`MeasuredCurves` of a measured test (``.test``, ``.drive``, ``.branch``,
    ``.channels``, as :class:`suspenv.measurements.knc_file.MeasuredTest`).

    The simulated grid has ``steps`` intervals (default: ``(P - 1) / 2`` for a loop of
    ``P`` samples, made even, at least 8)."""
    drive = np.asarray(measured.drive, float)
    branch = np.asarray(measured.branch, int)
    if drive.ndim != 1 or drive.size < 3 or branch.shape != drive.shape:
        raise ValidationError(
            f"measured test {measured.test!r}: `drive` and `branch` must be (P,) with P >= 3, "
            f"but got {drive.shape} and {branch.shape}"
        )
    amp = float(np.max(np.abs(drive)))
    if not amp > 0:
        raise ValidationError(
            f"measured test {measured.test!r}: the drive must move (`max|drive| > 0`), but "
            f"got max|drive| = {amp}"
        )
    if steps is None:
        steps = max(8, (drive.size - 1) // 2)
        steps += steps % 2
    values = {
        c: np.asarray(v, float)
        for c, v in measured.channels.items()
        if c in FIT_CHANNELS and np.asarray(v).shape == (drive.size, 2)
    }
    return MeasuredCurves(measured.test, drive, branch, values, amp, int(steps))


class CurveModel(UnitFit):
    """Residuals ``(simulated - measured) / sigma`` of designs against measured loops.

    Args:
        tests: measured tests (:class:`MeasuredCurves`), one per rig test.
        sigma: channel -> noise standard deviation (SI, > 0); a channel without one is
            not fitted.
        space: the design space (physical bounds of the 49 parameters).
        base: full design (49,) the parameters not in ``free`` are held at.
        free: names of the fitted parameters (default: all of ``space`` and of
            ``effect_free``).
        constants: the vehicle's :class:`AxleConstants`; ``effects``: the simulated
            model's fixed effects (path-dependent ones make every call slower).
        two_sided: False (default): one design for both sides (left = right); True: each
            free parameter but ``arb_torsion`` (one bar) gets a right-side twin named
            ``<name>@right``, and a design is (98,): left then right (both in the
            left-side file convention, as ``[design_right]`` of a vehicle file).
        chunk: designs per rig call (bounded memory, about 0.5 MB per design and test).
        orientation: bushing frame orientations of the vehicle (see
            :func:`suspenv.models.mcpherson.params.build_axle`).
        travel_drive: what the measured travel tests drove, ``"pad"`` or
            ``"wheel_centre"`` (:func:`suspenv.rigs.knc.run_tests`).
        effect_free: parameters of ``effects`` that a design carries, each named
            ``<effect name>.<parameter>`` with its bounds (a positive range on a log
            scale); a model design (``width`` values) is the design (49, or 98
            two-sided), then these values. Rows with different values are solved apart.
    """

    def __init__(
        self,
        tests: Sequence[MeasuredCurves],
        sigma: Mapping[str, float],
        space: DesignSpace,
        base: np.ndarray,
        free: Sequence[str] | None = None,
        constants: AxleConstants | None = None,
        effects: Sequence[Effect] = (),
        two_sided: bool = False,
        chunk: int = 64,
        orientation: Mapping[str, Sequence[float]] | None = None,
        travel_drive: str = "pad",
        effect_free: Sequence[Parameter] = (),
    ):
        self.travel_drive = travel_drive
        self.tests = list(tests)
        if not self.tests:
            raise ValidationError("the fit needs at least one measured test, but got none")
        self.space = fit_space(space)
        self.two_sided = bool(two_sided)
        self.effects = tuple(effects)
        self.constants = constants or AxleConstants()
        self.effect_free = tuple(_effect_parameters(self.effects, self.constants, effect_free))
        self.base = np.asarray(base, float).copy()
        d, k = self.space.dim, len(self.effect_free)
        if self.base.ndim != 1 or not (
            self.base.size in (d, d + k) or self.sides <= self.base.size <= self.width
        ):
            raise ValidationError(
                f"base design must have {d}, {d + k} (one side and the fitted effect values) "
                f"or {self.sides}..{self.width} values, but got {self.base.shape}"
            )
        self.base = self.full(self.base)[0]
        own = [p.name for p in self.effect_free]
        names = list([*self.space.names, *own] if free is None else free)
        for n in names:
            if n not in own:
                self.space.index(n)  # unknown names are errors with suggestions
        if len(set(names)) != len(names) or not names:
            raise ValidationError(f"free parameters must be unique and not empty, got {names}")
        self.free = names
        self.free_index, self.sub = self._fitted(names)
        self.orientation = dict(orientation or {})
        self.chunk = int(chunk)
        self.sigma: dict[str, float] = {}
        for c in sorted({c for t in self.tests for c in t.values}):
            s = sigma.get(c)
            if s is not None and np.isfinite(s) and s > 0:
                self.sigma[c] = float(s)
        # residual layout: blocks (test, channel) -> slice of the residual vector
        self.blocks: list[tuple[str, str, slice]] = []
        k = 0
        self._measured = []
        for t in self.tests:
            for c in sorted(t.values):
                if c not in self.sigma:
                    continue
                v = t.values[c]
                self.blocks.append((t.test, c, slice(k, k + v.size)))
                self._measured.append(v.reshape(-1) / self.sigma[c])
                k += v.size
        if not self.blocks:
            raise ValidationError(
                "no measured channel can be fitted: every channel needs a noise level > 0 and "
                f"one of the names {FIT_CHANNELS}"
            )
        self.size = k
        self.measured = np.concatenate(self._measured)
        self.stats = {"designs": 0, "calls": 0, "seconds": 0.0}
        self._groups = _call_groups(self.tests)

    def variant(self, **changes: Any) -> CurveModel:
        """The same model with other keywords of the constructor (``tests``: other
        measured curves, e.g. a test held out of the fit; ``base``, ``free``, ...)."""
        kw: dict[str, Any] = {
            "tests": self.tests,
            "sigma": self.sigma,
            "space": self.space,
            "base": self.base[: self.sides] if "two_sided" in changes else self.base,
            "free": self.free,
            "constants": self.constants,
            "effects": self.effects,
            "two_sided": self.two_sided,
            "chunk": self.chunk,
            "orientation": self.orientation,
            "travel_drive": self.travel_drive,
            "effect_free": self.effect_free,
        }
        kw.update(changes)
        return CurveModel(**kw)

    # ------------------------------------------------------------------ designs
    def _fitted(self, names: Sequence[str]) -> tuple[np.ndarray, DesignSpace]:
        """Columns of a model design the fitted values sit in, and their space: the free
        design parameters, their right twins (two-sided), the fitted effect parameters."""
        d = self.space.dim
        own = [p.name for p in self.effect_free]
        index = [self.space.index(n) for n in names if n not in own]
        params = [self.space.parameters[i] for i in index]
        if self.two_sided:
            twins = [i for i in index if self.space.names[i] != "arb_torsion"]
            index += [d + i for i in twins]
            params += [
                replace(self.space.parameters[i], name=f"{self.space.names[i]}@right")
                for i in twins
            ]
        mine = [j for j, n in enumerate(own) if n in names]
        index += [self.sides + j for j in mine]
        params += [self.effect_free[j] for j in mine]
        return np.array(index, int), DesignSpace(params)

    @property
    def sides(self) -> int:
        """Design values of a model design: 49, or 98 two-sided (left then right)."""
        return self.space.dim * (2 if self.two_sided else 1)

    @property
    def width(self) -> int:
        """Values of a model design: :attr:`sides`, then the fitted effect parameters."""
        return self.sides + len(self.effect_free)

    @property
    def travel_amplitude(self) -> float:
        """Pad stroke amplitude [m] of the measured travel tests (the largest; 0.040, the
        rig's default, without one): the travel amplitude of the tests the model simulates
        beyond the measured ones (their loads are the rig's own)."""
        from suspenv.measurements.knc import TESTS

        return max([t.amplitude for t in self.tests if t.test in TESTS] or [0.040])

    def full(self, X: np.ndarray) -> np.ndarray:
        """Designs (n, 49), (n, 98) or (n, width) as the model's (n, width): a 49-value
        design of a two-sided model is the same on both sides; the fitted effect
        parameters not given are the effects' own values."""
        X = np.atleast_2d(np.asarray(X, float))
        d = self.space.dim
        if self.two_sided and X.shape[1] in (d, d + len(self.effect_free)):
            X = np.concatenate([X[:, :d], X], axis=1)
        k = X.shape[1] - self.sides
        if 0 <= k < len(self.effect_free):
            own = [_own_value(self.effects, self.constants, p.name) for p in self.effect_free[k:]]
            X = np.concatenate([X, np.tile(own, (X.shape[0], 1))], axis=1)
        return X

    def _owned(self, x: np.ndarray, owner: str) -> dict[str, Any]:
        """The fitted values ``<owner>.<parameter>`` of design ``x``: parameter -> value."""
        vals = self.full(x)[0][self.sides :]
        return {
            p.name.partition(".")[2]: float(v)
            for p, v in zip(self.effect_free, vals, strict=True)
            if p.name.partition(".")[0] == owner
        }

    def effects_at(self, x: np.ndarray) -> tuple[Effect, ...]:
        """The model's effects with the fitted effect parameters of design ``x``."""
        out = []
        for e in self.effects:
            mine = self._owned(x, e.name)
            out.append(e.with_params(mine) if mine else e)
        return tuple(out)

    def constants_at(self, x: np.ndarray) -> AxleConstants:
        """The vehicle's constants with the fitted ones (``constants.<name>``) of ``x``."""
        mine = self._owned(x, CONSTANTS)
        return replace(self.constants, **mine) if mine else self.constants

    # --------------------------------------------------------------- simulation
    def axle(self, X: np.ndarray) -> Any:
        """The batched :class:`~suspenv.models.mcpherson.params.Axle` of designs X (see
        :meth:`full`; the rows share their fitted constants, those of the first)."""
        X = self.full(X)
        d = self.space.dim
        right = X[:, d : 2 * d] if self.two_sided else None
        return build_axle(X[:, :d], right, self.constants_at(X[0]), self.orientation or None)

    def run(
        self,
        X: np.ndarray,
        tests: Sequence[str],
        steps: int,
        effects: Sequence[Effect],
        amplitudes: Mapping[str, float],
    ) -> dict[str, KCResult]:
        """:func:`rig_run` of designs X (see :meth:`full`) with ``effects`` held and the
        rig's own travel drive (the pads), all rows of a set of fitted constants in one
        call."""
        return self._solve(X, [(steps, amplitudes, tuple(tests), "pad")], effects, None)[0]

    def simulate(self, X: np.ndarray) -> tuple[dict[str, KCResult], np.ndarray, list[str]]:
        """Rig results {test: KCResult} of designs X (see :meth:`full`), ok (n,), messages.

        Tests are run in groups sharing an amplitude and grid (one batched call each),
        in chunks of :attr:`chunk` designs."""
        t0 = time.perf_counter()
        calls = [(s, kw, names, self.travel_drive) for s, kw, names in self._groups]
        out = self._solve(X, calls, None, self.chunk)
        self.stats["designs"] += out[1].size
        self.stats["calls"] += 1
        self.stats["seconds"] += time.perf_counter() - t0
        return out

    def _solve(
        self,
        X: np.ndarray,
        calls: Sequence[tuple[int, Mapping[str, float], tuple[str, ...], str]],
        effects: Sequence[Effect] | None,
        chunk: int | None,
    ) -> tuple[dict[str, KCResult], np.ndarray, list[str]]:
        """The rig ``calls`` (steps, amplitude keywords, tests, travel drive) of designs X:
        rows sharing the fitted effect values and constants are solved together (the
        solver takes one value per effect parameter, an axle one set of constants),
        ``chunk`` rows per call (None: all); ``effects`` held (None: each group's
        :meth:`effects_at`). Returns the results, ok (n,) and each row's first failure."""
        X = self.full(X)
        out: dict[str, list[KCResult]] = {t: [] for call in calls for t in call[2]}
        ok = np.ones(X.shape[0], bool)
        msgs = [""] * X.shape[0]
        order: list[int] = []
        for rows in same_rows(X[:, self.sides :]):
            held = self.effects_at(X[rows[0]]) if effects is None else effects
            for a in range(0, len(rows), chunk or len(rows)):
                part = rows[a : a + (chunk or len(rows))]
                order += part
                axle = self.axle(X[part])
                for steps, kw, names, drive in calls:
                    for t, r in rig_run(axle, names, steps, held, kw, drive).items():
                        out[t].append(r)
                        for i in np.flatnonzero(~r.ok):
                            if ok[part[i]]:
                                msgs[part[i]] = f"{t}: {r.messages[i]}"
                            ok[part[i]] = False
        back = np.argsort(order)
        return {t: _concat(parts, back) for t, parts in out.items()}, ok, msgs

    def predict(self, results: Mapping[str, KCResult]) -> np.ndarray:
        """Simulated values at the measured samples, scaled by sigma: (n, size)."""
        parts = []
        by_test = {t.test: t for t in self.tests}
        for test, c, _ in self.blocks:
            v = by_test[test].read(results[test], c)
            parts.append(v.reshape(v.shape[0], -1) / self.sigma[c])
        return np.concatenate(parts, axis=1)

    def residuals_x(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """Residuals (n, size) of designs X (see :meth:`full`; NaN rows where the rig
        fails)."""
        res, ok, msgs = self.simulate(self.full(X))
        R = self.predict(res) - self.measured
        R[~ok] = np.nan
        bad = ok & ~np.isfinite(R).all(axis=1)
        for i in np.flatnonzero(bad):
            msgs[i] = "EvaluationError: a simulated channel is not finite"
        ok &= ~bad
        R[~ok] = np.nan
        return R, ok, msgs

    def residual_at(self, x: np.ndarray, what: str = "the design") -> np.ndarray:
        """Residual (size,) of one design ``x`` (see :meth:`full`); a design the rig
        cannot solve is refused, naming ``what`` it is."""
        R, ok, msgs = self.residuals_x(self.full(x))
        if not ok[0]:
            raise ValidationError(f"the rig cannot solve {what}: {msgs[0]}")
        return R[0]

    # ----------------------------------------------------------------- reading
    def loops(self) -> list[np.ndarray]:
        """Residual rows (indices) of each measured loop: one test and wheel, every
        channel recorded over it."""
        out: dict[tuple[str, int], list[np.ndarray]] = {}
        for test, _, s in self.blocks:
            rows = np.arange(s.start, s.stop)
            for wheel in (0, 1):  # samples (P, 2) flattened: left, right
                out.setdefault((test, wheel), []).append(rows[wheel::2])
        return [np.concatenate(parts) for parts in out.values()]

    def by_test(self, J: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
        """Rows of ``J`` (size, ...), a residual's or its Jacobian's, per measured test and
        channel: {test: {channel: rows}}."""
        out: dict[str, dict[str, np.ndarray]] = {}
        for test, channel, s in self.blocks:
            out.setdefault(test, {})[channel] = J[s]
        return out

    def block_rms(self, r: np.ndarray) -> dict[tuple[str, str], float]:
        """RMS of the scaled residual ``r`` (size,) per (test, channel): 1 = noise level."""
        return {(t, c): float(np.sqrt(np.mean(r[s] ** 2))) for t, c, s in self.blocks}


def _call_groups(
    tests: Sequence[MeasuredCurves],
) -> list[tuple[int, dict[str, float], tuple[str, ...]]]:
    """Tests grouped into rig calls: one call takes one grid (``steps``) and one value per
    amplitude keyword, so tests of different kinds (travel, force, ...) share a call."""
    groups: list[tuple[int, dict[str, float], list[str]]] = []
    for t in tests:
        kw = amplitude_kwargs(t.test, t.amplitude)
        for steps, have, names in groups:
            if steps == t.steps and all(have.get(k, v) == v for k, v in kw.items()):
                have.update(kw)
                names.append(t.test)
                break
        else:
            groups.append((t.steps, dict(kw), [t.test]))
    return [(s, kw, tuple(names)) for s, kw, names in groups]


def _concat(parts: list[KCResult], order: np.ndarray) -> KCResult:
    """The rows of ``parts`` stacked, then taken in ``order``: channels and the static
    hard points (what the geometric roll centre reads) alike."""
    if len(parts) == 1 and np.array_equal(order, np.arange(order.size)):
        return parts[0]
    p0 = parts[0]
    msgs = [m for p in parts for m in p.messages]

    def stack(name: str) -> dict[str, np.ndarray]:
        first = getattr(p0, name)
        return {k: np.concatenate([getattr(p, name)[k] for p in parts])[order] for k in first}

    return KCResult(
        p0.test,
        p0.grid,
        p0.path,
        stack("channels"),
        np.concatenate([p.ok for p in parts])[order],
        [msgs[i] for i in order],
        static_points=stack("static_points") if all(p.static_points for p in parts) else {},
    )


#: owner of a fitted value that is a vehicle constant (``constants.<name>``)
CONSTANTS = "constants"


def _own_value(effects: Sequence[Effect], constants: AxleConstants, name: str) -> float:
    """Value of the fitted ``<effect>.<parameter>`` among ``effects``, or of the vehicle
    constant ``constants.<name>``."""
    owner, _, param = name.partition(".")
    if owner == CONSTANTS:
        if not hasattr(constants, param):
            raise ValidationError(f"fitted constant {name!r}: no axle constant named {param!r}")
        return float(getattr(constants, param))
    for e in effects:
        if e.name == owner:
            return float(np.ravel(e.params[param])[0])
    raise ValidationError(
        f"fitted effect parameter {name!r}: no effect named {owner!r} among "
        f"{[e.name for e in effects]}"
    )


def _effect_parameters(
    effects: Sequence[Effect], constants: AxleConstants, params: Sequence[Parameter]
) -> list[Parameter]:
    """The fitted effect parameters and constants (named ``<effect>.<parameter>``,
    ``constants.<name>``), checked against ``effects`` and ``constants``; a positive
    range is mapped to the unit cube logarithmically."""
    out = []
    for p in params:
        _own_value(effects, constants, p.name)
        out.append(effect_scale(p))
    if len({p.name for p in out}) != len(out):
        raise ValidationError(f"fitted effect parameters must be unique, but got {params}")
    return out


def global_stage(
    model: CurveModel,
    u0: np.ndarray,
    sigma0: float = 0.2,
    popsize: int | None = None,
    max_evaluations: int = 4000,
    seed: int = 1,
    tolfun: float = 1e-3,
    progress: bool = False,
) -> StageResult:
    """CMA-ES on ``sum(r^2)`` in the unit cube from ``u0`` (step ``sigma0``).

    Each generation is one batched rig call. Failed designs get the generation's worst
    valid cost times 10 plus their distance from the mean (so CMA-ES moves away).
    Stops at ``max_evaluations`` or a pycma criterion (``tolfun`` on the cost change,
    a cost unit being one squared noise level)."""
    import cma

    t0 = time.perf_counter()
    opts: dict[str, Any] = {
        "bounds": [0.0, 1.0],
        "seed": int(seed) + 1,  # pycma treats 0 as "random"
        "verbose": -9,
        "maxfevals": int(max_evaluations),
        "tolfun": float(tolfun),
        "tolx": 1e-6,
    }
    if popsize:
        opts["popsize"] = int(popsize)
    es = cma.CMAEvolutionStrategy(np.clip(u0, 0, 1).tolist(), float(sigma0), opts)
    best_u, best_f = np.clip(np.asarray(u0, float), 0, 1), np.inf
    history: list[float] = []
    evals = 0
    gen = 0
    while not es.stop():
        sols = es.ask()
        U = np.clip(np.array(sols), 0, 1)
        R, ok, _ = model.residuals(U)
        f = np.where(ok, np.nansum(R**2, axis=1), np.nan)
        worst = np.nanmax(f) if ok.any() else 1e30
        dist = np.linalg.norm(U - es.mean, axis=1)
        f = np.where(ok, f, 10 * worst * (1 + dist))
        es.tell(sols, f.tolist())
        evals += len(sols)
        gen += 1
        i = int(np.argmin(f))
        if ok[i] and f[i] < best_f:
            best_f, best_u = float(f[i]), U[i].copy()
        history.append(best_f)
        if gen % 10 == 0:
            say(
                progress,
                f"  global  gen {gen:4d}  evaluations {evals:5d}  best cost {best_f:.4g}  "
                f"({time.perf_counter() - t0:.0f} s)",
            )
    stop = ", ".join(f"{k}={v}" for k, v in es.stop().items())
    return StageResult(
        "global (CMA-ES)", best_u, best_f, evals, stop, time.perf_counter() - t0, history
    )


@dataclass
class CurveFit:
    """Answer of :func:`fit_curves`: the fitted design and what the stages did."""

    model: CurveModel
    u: np.ndarray  # (dim,) unit point of the free parameters
    x: np.ndarray  # (49,) physical design
    residual: np.ndarray  # (size,) scaled residual at x
    jacobian: np.ndarray  # (size, dim) d residual / d u
    stages: list[StageResult]
    answer: StageResult | None = None  # the polish whose answer this is (default: last)

    @classmethod
    def of(
        cls,
        model: CurveModel,
        polished: tuple[StageResult, np.ndarray, np.ndarray],
        stages: list[StageResult] | None = None,
    ) -> CurveFit:
        """The fit whose answer is a polish's ``(stage, residual, Jacobian)`` (:func:`polish`);
        ``stages``: every stage of the fit (default: that one)."""
        stage, r, J = polished
        return cls(model, stage.u, model.designs(stage.u[None])[0], r, J, stages or [stage], stage)

    @property
    def cost(self) -> float:
        return float(self.residual @ self.residual)

    @property
    def final(self) -> StageResult:
        """The stage that gave the answer."""
        return self.answer if self.answer is not None else self.stages[-1]

    @property
    def converged(self) -> bool:
        return self.final.stop.startswith("converged")

    @property
    def valleys(self) -> list[np.ndarray]:
        """Unit points the fit's polishes reached, the answer (``u``) first, the others
        once each: the valleys a later stage can start from."""
        out = [self.u]
        for s in self.stages:
            if s.name.startswith("polish") and not any(np.array_equal(s.u, v) for v in out):
                out.append(s.u)
        return out


def fit_curves(
    model: CurveModel,
    x0: np.ndarray,
    global_evaluations: int = 640,
    popsize: int | None = None,
    sigma0: float = 0.2,
    polish_nfev: int = 150,
    seed: int = 1,
    progress: bool = False,
    on_stage: Callable[[StageResult], None] | None = None,
    workers: int = 2,
) -> CurveFit:
    """Global stage (skipped when ``global_evaluations == 0``) then the polish, from
    the physical design ``x0`` (49,). ``workers >= 2``: the polish from ``x0`` runs in a
    second process while the global stage and the polish from its best run in this
    one (same numbers, about half the wall time on two cores).

    With a global stage the polish runs to convergence twice, from the CMA-ES best and
    from ``x0`` itself, and the lower final cost is the answer: a global stage in 49
    dimensions within a budget of hundreds of evaluations is not converged, and its best
    point can lie in a worse valley than the start (springs in series trade along
    curved valleys), so the answer is never worse than the polish from the start alone,
    and better wherever the global stage found a better valley.
    """
    u = model.unit(x0)
    prior = u.copy()  # the polish's weak pull: towards the start design
    stages: list[StageResult] = []
    polished: list[tuple[str, np.ndarray, Any]] = [("start design", u, None)]
    with contextlib.ExitStack() as stack:
        if global_evaluations > 0:
            if workers >= 2:  # the polish from the start needs no global stage: run it beside
                from suspenv.runs.executors import ProcessPool

                pool = stack.enter_context(ProcessPool(1))
                polished[0] = (
                    "start design",
                    u,
                    pool.submit(polish, model, u, polish_nfev, prior=prior),
                )
                say(progress, "polish from the start design: in a second process")
            say(
                progress,
                f"global stage: CMA-ES, {model.dim} parameters, budget {global_evaluations}",
            )
            g = global_stage(model, u, sigma0, popsize, global_evaluations, seed, progress=progress)
            stages.append(g)
            if on_stage:
                on_stage(g)
            say(progress, f"  stopped: {g.stop} (cost {g.cost:.6g})")
            polished.insert(0, ("CMA-ES best", g.u, None))
        best: tuple[StageResult, np.ndarray, np.ndarray] | None = None
        for label, u_start, done in polished:
            if done is None:
                say(progress, f"polish from the {label}: least squares with the batched Jacobian")
                done = polish(model, u_start, polish_nfev, progress=progress, prior=prior)
            else:
                done = done.result()  # the polish from the start, run beside the global stage
            p, r, J = done
            p.name = f"polish from the {label}"
            stages.append(p)
            if on_stage:
                on_stage(p)
            say(progress, f"  {p.name} stopped: {p.stop} (cost {p.cost:.6g})")
            if best is None or p.cost < best[0].cost:
                best = (p, r, J)
    assert best is not None  # at least the start was polished
    return CurveFit.of(model, best, stages)
