"""The one least-squares fit of an axle to K&C curves, shared by curve identification
(:mod:`suspenv.methods.curves.curve_fit`) and the K&C diagnosis
(:mod:`suspenv.diagnosis.knc.family`).

Parametrisation: every fitted value is mapped to the unit cube, stiffnesses (and
positive effect parameters) logarithmically (:func:`fit_space`, :func:`effect_scale`),
so equal steps are equal ratios of stiffness. A problem (:class:`UnitFit`) gives the
residual of designs, dimensionless (each channel divided by its noise level); the
Jacobian is a forward difference in the unit cube, all ``dim + 1`` designs in one
batched rig call.

Driver: trust-region least squares (:func:`scipy.optimize.least_squares`, ``trf``,
bounds ``[0, 1]``) with a weak pull towards the start design (:data:`PRIOR_WEIGHT`),
restarted from its own answer until a restart lowers the cost by less than
:data:`RESTART_GAIN` (:func:`polish`). Costs are sums of squared residuals (squared
noise units; half a cost unit is one unit of log-likelihood).

The two axle models it fits share the rig call (:func:`rig_run`) and the batching of
designs by effect values (:func:`same_rows`), not what they read of it:
:class:`~suspenv.rigs.knc_axle.KncAxleModel`
(diagnosis) replays recordings' own samples with left/right and load-cell effects,
keeping solved rows for refits; :class:`~suspenv.methods.curves.curve_fit.CurveModel`
(identify) reads loops at measured drives, with both sides, fitted constants and
orientations, in bounded chunks.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.space import DesignSpace, Parameter
from suspenv.measurements.knc import DRIVE_UNIT, STEER_TESTS
from suspenv.models.effects import Effect
from suspenv.rigs.knc import (
    FORCE_AMPLITUDE,
    MOMENT_AMPLITUDE,
    RACK_AMPLITUDE,
    KCResult,
    run_tests,
)

#: stiffness units: these parameters are mapped to the unit cube logarithmically
STIFFNESS_UNITS = ("N/mm", "N*mm/deg", "N*m/rad")
#: forward-difference step in the unit cube (0.01 % of a parameter's range)
FD_STEP = 1e-4
#: residual of a design the rig cannot solve (noise units), so the polish steps back
FAILED_RESIDUAL = 1e4
#: the polish restarts until a restart lowers the cost by less than this (squared noise
#: units; half of it is the change of the log-likelihood)
RESTART_GAIN = 1.0
#: weight of the polish's pull towards the start design: residual rows
#: ``PRIOR_WEIGHT * (u - u_start)``, so moving a parameter across its whole range costs
#: one squared noise unit. Directions the curves do not see stop wandering (the trust
#: region converges in tens of steps instead of crawling along them); an identified
#: parameter (standard error below 0.67 % of its range: information above 2e4 per unit
#: squared) is moved by less than 1e-4 of its range
PRIOR_WEIGHT = 1.0


def fit_space(space: DesignSpace) -> DesignSpace:
    """``space`` with every stiffness (units :data:`STIFFNESS_UNITS`, lower bound > 0)
    on a log scale: equal steps of the unit cube are equal ratios of stiffness."""
    return DesignSpace(
        replace(p, log=True) if p.unit in STIFFNESS_UNITS and p.low > 0 else p
        for p in space.parameters
    )


def effect_scale(p: Parameter) -> Parameter:
    """A fitted effect parameter with a positive range on a log scale."""
    return replace(p, log=True) if p.low > 0 else p


def same_rows(V: np.ndarray) -> list[list[int]]:
    """Row indices of ``V`` (n, k) grouped by equal rows, in order of first appearance:
    the designs that share their effect values (the solver takes one value per effect
    parameter), each group one batch of the rig."""
    groups: dict[bytes, list[int]] = {}
    for i, row in enumerate(np.ascontiguousarray(V)):
        groups.setdefault(row.tobytes(), []).append(i)
    return list(groups.values())


def amplitude_kwargs(test: str, amplitude: float) -> dict[str, float]:
    """Keyword of :func:`suspenv.rigs.knc.run_tests` that carries ``test``'s amplitude
    (``amplitude`` in the drive's SI unit)."""
    if test in STEER_TESTS:
        return {"rack_amplitude": amplitude}
    unit = DRIVE_UNIT.get(test, "m")
    return {{"N": "force_amplitude", "N*m": "moment_amplitude"}.get(unit, "amplitude"): amplitude}


def rig_run(
    axle: Any,
    tests: Sequence[str],
    steps: int,
    effects: Sequence[Effect],
    amplitudes: Mapping[str, float],
    travel_drive: str = "pad",
) -> dict[str, KCResult]:
    """:func:`suspenv.rigs.knc.run_tests` with the amplitude keywords of ``amplitudes``
    (:func:`amplitude_kwargs`; a keyword not given keeps the rig's default) and the
    travel tests' ``travel_drive`` (pads or wheel centres): the one rig call of both
    axle models."""
    return run_tests(
        axle,
        tuple(tests),
        amplitude=float(amplitudes.get("amplitude", 0.040)),
        steps=int(steps),
        effects=effects,
        force_amplitude=float(amplitudes.get("force_amplitude", FORCE_AMPLITUDE)),
        moment_amplitude=float(amplitudes.get("moment_amplitude", MOMENT_AMPLITUDE)),
        rack_amplitude=float(amplitudes.get("rack_amplitude", RACK_AMPLITUDE)),
        travel_drive=travel_drive,
    )


class UnitFit:
    """A least-squares problem in the unit cube: the fitted values ``free_index`` of a
    design, in the space ``sub``, the others held at ``base``'s; subclasses give
    :attr:`size` (residuals) and :meth:`residuals_x` (residuals of designs, rows ok,
    failure messages)."""

    #: forward-difference step of :meth:`jacobian` in the unit cube
    fd_step: ClassVar[float] = FD_STEP
    size: int
    base: np.ndarray
    free_index: np.ndarray
    sub: DesignSpace

    def residuals_x(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
        raise NotImplementedError

    def full(self, X: np.ndarray) -> np.ndarray:
        """Designs as the problem's (n, width)."""
        return np.atleast_2d(np.asarray(X, float))

    @property
    def dim(self) -> int:
        """Number of fitted values."""
        return int(self.free_index.size)

    def designs(self, U: np.ndarray) -> np.ndarray:
        """Designs (n, width) of unit-cube points U (n, dim)."""
        U = np.atleast_2d(np.asarray(U, float))
        X = np.tile(self.base, (U.shape[0], 1))
        X[:, self.free_index] = self.sub.to_physical(U)
        return X

    def unit(self, x: np.ndarray) -> np.ndarray:
        """Unit-cube point (dim,) of the fitted values of a design (see :meth:`full`)."""
        x = self.full(x)[0]
        return np.clip(self.sub.to_unit(x[self.free_index][None])[0], 0, 1)

    def residuals(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """Residuals (n, size) of unit-cube points U (n, dim)."""
        return self.residuals_x(self.designs(U))

    def jacobian(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(r (size,), J (size, dim)) at ``u`` by forward differences of :attr:`fd_step`
        in the unit cube (backward at the upper bound), the ``dim + 1`` designs in one batch.

        A perturbed design the rig cannot solve gives a zero column (that parameter is
        then held for this step)."""
        u, step = np.asarray(u, float), self.fd_step
        h = np.where(u + step <= 1.0, step, -step)
        U = np.tile(u, (self.dim + 1, 1))
        U[1:] += np.diag(h)
        R, ok, msgs = self.residuals(U)
        if not ok[0]:
            raise ValidationError(f"the rig cannot solve the design being fitted: {msgs[0]}")
        J = (R[1:] - R[0]).T / h
        J[:, ~ok[1:]] = 0.0
        return R[0], J


@dataclass
class StageResult:
    """Outcome of one stage: best unit point, its cost (sum of squared residuals),
    evaluations, the stopping reason, seconds, and the cost after each step."""

    name: str
    u: np.ndarray
    cost: float
    evaluations: int
    stop: str
    seconds: float
    history: list[float] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {
            "stage": self.name,
            "cost": self.cost,
            "evaluations": self.evaluations,
            "stop": self.stop,
            "seconds": self.seconds,
        }


def say(progress: bool, msg: str) -> None:
    """Print a progress line ``msg`` to stderr when ``progress``."""
    if progress:
        print(msg, file=sys.stderr, flush=True)


@dataclass
class _PolishCalls:
    """The residual and Jacobian callbacks of :func:`polish_stage` and what they share:
    ``cache`` (residual, Jacobian) by the unit point's bytes, cleared at each new
    Jacobian; ``history`` of the data's sum of squares; ``last`` (u, r, J) Jacobian taken.
    ``weight``: the prior's (0: none), about ``centre`` (dim,); ``t0``: progress clock."""

    model: UnitFit
    weight: float
    centre: np.ndarray
    broyden: bool
    progress: bool
    t0: float
    cache: dict[bytes, tuple[np.ndarray, np.ndarray | None]] = field(default_factory=dict)
    history: list[float] = field(default_factory=list)
    counter: dict[str, int] = field(default_factory=lambda: {"fun": 0, "jac": 0})
    last: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)

    def with_prior(self, r: np.ndarray, u: np.ndarray) -> np.ndarray:
        w = self.weight
        return np.concatenate([r, w * (u - self.centre)]) if w > 0 else r

    def fun(self, u: np.ndarray) -> np.ndarray:
        key = np.asarray(u, float).tobytes()
        if key in self.cache:
            return self.with_prior(self.cache[key][0], u)
        self.counter["fun"] += 1
        R, ok, _ = self.model.residuals(u[None])
        r = R[0] if ok[0] else np.full(self.model.size, FAILED_RESIDUAL)
        self.cache[key] = (r, None)
        self.history.append(float(r @ r))
        return self.with_prior(r, u)

    def jac(self, u: np.ndarray) -> np.ndarray:
        w, last = self.weight, self.last
        key = np.asarray(u, float).tobytes()
        hit = self.cache.get(key)
        if hit is not None and hit[1] is not None:
            J = hit[1]
            last[:] = [(np.array(u, float), hit[0], J)]
            return np.vstack([J, w * np.eye(self.model.dim)]) if w > 0 else J
        secant = self.broyden and bool(last) and hit is not None
        if secant and hit is not None:
            r, J = hit[0], secant_update(*last[0], u, hit[0])
        else:
            self.counter["jac"] += 1
            r, J = self.model.jacobian(u)
        last[:] = [(u.copy(), r, J)]
        self.cache.clear()
        self.cache[key] = (r, J)
        say(
            self.progress,
            f"  polish  Jacobian {self.counter['jac']:3d}{' + secant' * secant}"
            f"  cost {float(r @ r):.6g}  "
            f"({time.perf_counter() - self.t0:.0f} s)",
        )
        return np.vstack([J, w * np.eye(self.model.dim)]) if w > 0 else J


def polish_stage(
    model: UnitFit,
    u0: np.ndarray,
    max_nfev: int = 150,
    ftol: float = 1e-5,
    progress: bool = False,
    prior: np.ndarray | None = None,
    at_start: tuple[np.ndarray, np.ndarray] | None = None,
    broyden: bool = False,
) -> tuple[StageResult, np.ndarray, np.ndarray]:
    """Trust-region least squares from ``u0`` with the batched Jacobian.

    ``prior`` (dim,): a weak pull towards this unit point, the residual rows
    ``PRIOR_WEIGHT * (u - prior)``; None: none; the trust region's step and gradient
    tolerances are ``1e-8``;
    ``at_start``: the residual and Jacobian at ``u0`` when known (not recomputed).
    Returns (stage, residual at the answer (size,), Jacobian there (size, dim)), both
    without the prior's rows; the stage's cost and history are the data's sum of
    squares. The answer is a point the trust region accepted, whose Jacobian it
    evaluated: that one is returned, not recomputed.

    ``broyden``: the Jacobian is differenced at ``u0`` only (or taken from
    ``at_start``); at each later accepted point it is the previous one with Broyden's
    rank-one update (the secant through the step just taken), so a step costs one
    evaluation instead of ``dim + 1``. The returned Jacobian is then that update, not a
    differenced one (:func:`polish` differences it again)."""
    from scipy.optimize import least_squares

    t0 = time.perf_counter()
    calls = _PolishCalls(
        model,
        PRIOR_WEIGHT if prior is not None else 0.0,
        np.zeros(model.dim) if prior is None else np.asarray(prior, float),
        broyden,
        progress,
        t0,
    )
    u0 = np.clip(np.asarray(u0, float), 0.0, 1.0)
    if at_start is not None:
        calls.cache[u0.tobytes()] = at_start
    sol = least_squares(
        calls.fun,
        u0,
        jac=calls.jac,
        bounds=(0.0, 1.0),
        method="trf",
        x_scale=1.0,
        max_nfev=max_nfev,
        ftol=ftol,
        xtol=1e-8,
        gtol=1e-8,
    )
    r, J_hit = calls.cache.get(np.asarray(sol.x, float).tobytes(), (None, None))
    if r is None or J_hit is None:
        r, J = model.jacobian(sol.x)
    else:
        J = J_hit
    stage = StageResult(
        "polish (least squares)",
        sol.x.copy(),
        float(r @ r),
        int(calls.counter["fun"] + calls.counter["jac"] * (model.dim + 1)),
        _stop_reason(sol, max_nfev, ftol),
        time.perf_counter() - t0,
        calls.history,
    )
    return stage, r, J


def _stop_reason(sol: Any, max_nfev: int, ftol: float) -> str:
    """Why scipy's trust region (result ``sol``) stopped, in words."""
    reasons = {
        -1: "improper input",
        0: f"evaluation budget (max_nfev={max_nfev}) used up: not converged",
        1: "converged: gradient below gtol=1e-08",
        2: f"converged: relative cost change below ftol={ftol:g}",
        3: "converged: relative step below xtol=1e-08",
        4: "converged: ftol and xtol both met",
    }
    return reasons.get(int(sol.status), str(sol.message))


def secant_update(
    u: np.ndarray, r: np.ndarray, J: np.ndarray, u2: np.ndarray, r2: np.ndarray
) -> np.ndarray:
    """Broyden's rank-one update of the Jacobian ``J`` (size, dim) at ``u`` (residual
    ``r``) to the point ``u2`` (residual ``r2``): the least change of ``J`` for which
    ``J2 (u2 - u) = r2 - r``."""
    du = u2 - u
    n2 = float(du @ du)
    if n2 == 0.0:
        return J
    return J + np.outer(r2 - r - J @ du, du / n2)


def polish(
    model: UnitFit,
    u0: np.ndarray,
    max_nfev: int = 150,
    restarts: int = 3,
    min_gain: float = RESTART_GAIN,
    progress: bool = False,
    prior: np.ndarray | None = None,
    ftol: float = 1e-5,
    at_start: tuple[np.ndarray, np.ndarray] | None = None,
    broyden: bool = False,
) -> tuple[StageResult, np.ndarray, np.ndarray]:
    """:func:`polish_stage` restarted from its own answer (a fresh trust region) until a
    restart lowers the cost by less than ``min_gain`` (squared noise units: a change of
    the log-likelihood below ``min_gain / 2``), at most ``restarts`` runs in all, within
    ``max_nfev`` evaluations in all; ``at_start``: the residual and Jacobian at ``u0``
    when known. One stage in the result; ``stop`` says which criterion ended it.

    ``broyden``: each run updates its start's Jacobian by secants (:func:`polish_stage`);
    every restart, and the answer, get a differenced one, so the restart rule and the
    returned Jacobian are the differenced model's."""
    t0 = time.perf_counter()
    stage, r, J = polish_stage(
        model,
        u0,
        max_nfev,
        ftol,
        progress=progress,
        prior=prior,
        at_start=at_start,
        broyden=broyden,
    )
    evals, history, runs = stage.evaluations, list(stage.history), 1
    left = max_nfev - len(stage.history)
    stop = stage.stop
    exact = not broyden
    while runs < restarts and left > 2 and stage.stop.startswith("converged"):
        if not exact:
            r, J = model.jacobian(stage.u)
            evals, exact = evals + model.dim + 1, True
        again, r2, J2 = polish_stage(
            model,
            stage.u,
            left,
            ftol,
            progress=progress,
            prior=prior,
            at_start=(r, J),
            broyden=broyden,
        )
        runs += 1
        evals += again.evaluations
        history += again.history
        left -= len(again.history)
        gain = stage.cost - again.cost
        if gain > 0:
            stage, r, J, exact = again, r2, J2, not broyden
        stop = again.stop
        if gain < min_gain:
            stop = (
                f"converged: a restart of the least squares lowered the cost by {max(gain, 0):.3g} "
                f"< {min_gain:g} ({runs} runs; last: {again.stop.removeprefix('converged: ')})"
            )
            break
    if not exact:
        r, J = model.jacobian(stage.u)
        evals += model.dim + 1
    return (
        StageResult(
            stage.name, stage.u, stage.cost, evals, stop, time.perf_counter() - t0, history
        ),
        r,
        J,
    )
