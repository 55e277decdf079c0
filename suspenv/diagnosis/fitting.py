"""The one least-squares fit of a diagnosable model to one or more recordings.

Units: residuals are formed in each output channel's own SI unit (measured minus
predicted) and divided by a per-channel scale, so the fit's residual vector is
dimensionless. The scales are either given (e.g. each channel's noise level from a
first fit, :func:`noise_scales`, held fixed for every model compared on the same data
so that likelihoods stay comparable) or the measured channel's standard deviation
(:func:`spread_scales`).

Parameter covariance comes from the Jacobian at the optimum, ``cov = s^2 (J^T J)^+``
with ``s^2`` the scaled residual variance; standard errors are also given corrected for
serially correlated residuals (effective sample size from the lag-1 autocorrelation),
because neighbouring samples of a recording are not independent.

What differs between models is a property of the model, read through the typed seam
(:class:`suspenv.diagnosis.protocols.DiagnosableModel`: ``difference_step``,
``refine_start``, ``jacobian_model``), never probed for; the Jacobian at the optimum,
behind the standard errors, is the model's own.

The Jacobian's columns are simulated as one batch (``theta`` of shape ``(p + 1, p)``),
column by column where the batch cannot be simulated.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np
from numpy.polynomial import legendre
from scipy.optimize import least_squares

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.diagnosis.protocols import DiagnosableModel, EffectLike, RecordingLike
from suspenv.diagnosis.split import as_recordings

#: scaled residual that stands for a sample the model cannot predict (failed
#: simulation, non-finite output): large against the O(1) scaled residuals
PENALTY = 1e3
#: highest Legendre order of a zero drift of more shape than the component baseline's
#: (P0-P3): the drift judged beside (:mod:`~suspenv.diagnosis.component.drift_check`) and
#: the slow trend the missing-input check removes (:mod:`~suspenv.diagnosis.checks.missing_input`)
DRIFT_ORDER = 8

R = TypeVar("R", bound=RecordingLike)
E = TypeVar("E", bound=EffectLike)
Masks = Sequence[np.ndarray | None]


def fitted_channels(model: DiagnosableModel[R, E], rec: R, theta: np.ndarray) -> list[str]:
    """Output channels both simulated by ``model`` and present in ``rec`` (the model's
    declared ``output_channels`` where ``theta`` cannot be simulated, e.g. a start
    point at which a softening element diverges; the fit then moves away from it)."""
    try:
        names_pred = list(model.simulate(theta, rec))
    except EvaluationError:
        names_pred = list(model.output_channels)
        if not names_pred:
            raise
    pred = dict.fromkeys(names_pred)
    if not (names := [c for c in pred if c in rec.outputs]):
        raise ValidationError(
            "the model and the recording must share an output channel, but got model "
            f"outputs {sorted(pred)} and recording outputs {sorted(rec.outputs)}"
        )
    return names


@dataclass
class FitResult:
    """Outcome of :func:`fit` (or :func:`evaluate`).

    Attributes:
        model: the fitted model (with its effects).
        names: parameter names, in the order of ``theta``.
        theta: fitted parameters (SI units).
        stderr: standard errors from the Jacobian (independent-samples assumption).
        stderr_corrected: standard errors inflated for serially correlated residuals.
        covariance: parameter covariance (SI units squared).
        channels: fitted output channels.
        scales: per-channel residual scale used in the fit (channel unit).
        ssr: per-channel sum of squared residuals over the fit samples (unit^2).
        n: per-channel number of fit samples.
        success: the solver's convergence flag.
        message: the solver's message.
        nfev: residual evaluations spent.
        seconds: wall time of the fit.
        extra: ``lag1_autocorrelation``, ``jacobian`` (of the scaled residual), and
            what callers add (e.g. ``effect``).
        log_lik: the log-likelihood under the family's own noise law where it is not
            Gaussian (a spectral family's Whittle likelihood); None: Gaussian.
        deviance: per sample, the deviance of a residual (channel unit squared) under
            that law, for the held-out comparison (None: Gaussian, ``r^2``).
    """

    model: DiagnosableModel[Any, Any]
    names: tuple[str, ...]
    theta: np.ndarray
    stderr: np.ndarray
    stderr_corrected: np.ndarray
    covariance: np.ndarray
    channels: list[str]
    scales: dict[str, float]
    ssr: dict[str, float]
    n: dict[str, int]
    success: bool
    message: str
    nfev: int
    seconds: float
    extra: dict[str, Any] = field(default_factory=dict)
    log_lik: float | None = None
    deviance: Callable[[np.ndarray], np.ndarray] | None = None

    @property
    def n_params(self) -> int:
        return int(self.theta.size)

    @property
    def n_samples(self) -> int:
        return int(sum(self.n.values()))

    def element(self, kind: str) -> Any | None:
        """The model's element of ``kind`` at its fitted values (None when the model holds
        none)."""
        _, effects = self.model.unpack(self.theta)
        return next((e for e in effects if e.kind == kind), None)

    def predict(self, rec: Any) -> dict[str, np.ndarray]:
        """The fitted model's predicted output channels of ``rec`` (channel units)."""
        return self.model.simulate(self.theta, rec)

    def main_channel(self) -> str:
        """The channel holding the largest scaled residual (``ssr / scale^2``)."""
        return max(self.channels, key=lambda c: self.ssr[c] / (self.scales[c] ** 2))

    def rms(self) -> dict[str, float]:
        """Per-channel RMS residual over the fit samples (channel unit)."""
        return {c: float(np.sqrt(self.ssr[c] / max(self.n[c], 1))) for c in self.channels}

    def log_likelihood(self) -> float:
        """The family's log-likelihood (:attr:`log_lik`) where it set one; else Gaussian
        with each channel's noise variance at its MLE (the AIC, the BIC and the
        likelihood-ratio test of :func:`~suspenv.diagnosis.evidence.compare` read this)."""
        if self.log_lik is not None:
            return self.log_lik
        total = 0.0
        for c in self.channels:
            n = self.n[c]
            var = max(self.ssr[c] / max(n, 1), 1e-300)
            total += -0.5 * n * (np.log(2.0 * np.pi * var) + 1.0)
        return float(total)

    def aic(self) -> float:
        return 2.0 * self.n_params - 2.0 * self.log_likelihood()

    def bic(self) -> float:
        return float(self.n_params * np.log(max(self.n_samples, 1)) - 2.0 * self.log_likelihood())

    def covariance_corrected(self) -> np.ndarray:
        """The parameter covariance (SI units squared) inflated for serially correlated
        residuals like ``stderr_corrected`` (its diagonal is ``stderr_corrected**2``)."""
        infl = np.where(
            self.stderr > 0, self.stderr_corrected / np.maximum(self.stderr, 1e-300), 1.0
        )
        return np.asarray(self.covariance) * np.outer(infl, infl)

    def params(self) -> dict[str, dict[str, float]]:
        """``{name: {"value", "stderr", "stderr_corrected"}}`` (JSON-friendly)."""
        return {
            name: {"value": float(v), "stderr": float(s), "stderr_corrected": float(sc)}
            for name, v, s, sc in zip(
                self.names, self.theta, self.stderr, self.stderr_corrected, strict=True
            )
        }


class _NoBatchError(Exception):
    """The model cannot be simulated for a batch of parameter rows (or its batch
    disagrees with its single-row simulation)."""


def residuals(
    model: DiagnosableModel[R, E],
    theta: np.ndarray,
    recordings: Sequence[R],
    channels: Sequence[str],
    masks: Masks | None = None,
) -> list[dict[str, np.ndarray]]:
    """Measured minus predicted, per recording and channel (channel unit); ``(n,)`` per
    channel for ``theta`` ``(p,)``, ``(B, n)`` for a batch ``(B, p)``.

    Where ``masks`` is given, only the masked samples are returned.
    """
    out = []
    for i, rec in enumerate(recordings):
        pred = model.simulate(theta, rec)
        m = None if masks is None else masks[i]
        d = {c: np.asarray(rec.outputs[c], float) - np.asarray(pred[c], float) for c in channels}
        out.append(d if m is None else {c: v[..., m] for c, v in d.items()})
    return out


def drift_basis(time: np.ndarray, order: int = DRIFT_ORDER, lowest: int = 4) -> np.ndarray:
    """The Legendre polynomials P``lowest`` ... P``order`` of ``u = 2 (t - t0) / T - 1``
    over a recording's times ``time`` [s] (``T`` its duration), one column each
    (n, order - lowest + 1); by default the drift's shape beyond the baseline's P0-P3."""
    t = np.asarray(time, float)
    span = float(t[-1] - t[0]) if t.size > 1 and t[-1] > t[0] else 1.0
    u = 2.0 * (t - t[0]) / span - 1.0
    return legendre.legvander(u, order)[:, lowest:]


def lag1_autocorrelation(r: np.ndarray) -> float:
    """Sample lag-1 autocorrelation of a residual series (0 for fewer than 3 samples)."""
    r = np.asarray(r, float) - np.mean(r)
    den = float(np.dot(r, r))
    return 0.0 if r.size < 3 or den <= 0.0 else float(np.dot(r[1:], r[:-1]) / den)


def ar1_effective_size(n: float, rho: float) -> float:
    """The effective number of independent samples among ``n`` samples of an AR(1)
    series of lag-1 autocorrelation ``rho`` (a negative ``rho`` counts as 0):
    ``n (1 - rho) / (1 + rho)``. ``n = 1`` gives the share ``n_eff / n`` that scales a
    likelihood-ratio statistic of serially correlated residuals."""
    r = max(float(rho), 0.0)
    return n * (1.0 - r) / (1.0 + r)


def stacked_residual(
    model: DiagnosableModel[R, E],
    theta: np.ndarray,
    recs: Sequence[R],
    channels: Sequence[str],
    scales: Mapping[str, float],
    masks: Masks | None = None,
) -> np.ndarray:
    """Scaled residuals of every channel of every recording, recording by recording:
    ``(N,)`` for ``theta`` ``(p,)``, ``(B, N)`` for a batch ``(B, p)``; non-finite
    values become :data:`PENALTY`."""
    parts = residuals(model, theta, recs, channels, masks)
    out = np.concatenate([p[c] / scales[c] for p in parts for c in channels], axis=-1)
    return np.where(np.isfinite(out), out, PENALTY)


def _unstacked(
    scaled: np.ndarray | None,
    recs: Sequence[R],
    channels: Sequence[str],
    scales: Mapping[str, float],
    masks: Masks | None,
) -> list[dict[str, np.ndarray]] | None:
    """The per-recording residuals (channel unit) of a :func:`stacked_residual` vector,
    without simulating again; None where there is none or it holds a :data:`PENALTY`
    (a non-finite sample: the simulation's own values are needed)."""
    if scaled is None or np.any(scaled == PENALTY):
        return None
    out, k = [], 0
    for n in sample_counts(recs, masks):
        part = {}
        for c in channels:
            part[c] = scaled[k : k + n] * scales[c]
            k += n
        out.append(part)
    return out if k == scaled.size else None


def sample_counts(recs: Sequence[RecordingLike], masks: Masks | None) -> list[int]:
    """Each recording's fitted samples: its masked samples (all of them where there is
    no mask)."""
    counts = []
    for i, rec in enumerate(recs):
        m = None if masks is None else masks[i]
        counts.append(len(rec.time) if m is None else int(np.count_nonzero(m)))
    return counts


def noise_scales(fit: FitResult, floor: float = 1e-12) -> dict[str, float]:
    """Per-channel scale = the fit's RMS residual (channel unit)."""
    return {c: max(v, floor) for c, v in fit.rms().items()}


def spread_scales(recs: Sequence[RecordingLike], channels: Sequence[str]) -> dict[str, float]:
    """Per-channel standard deviation of the measured channel over all recordings (1
    where the channel is constant)."""
    out = {}
    for c in channels:
        s = float(np.std(np.concatenate([np.asarray(r.outputs[c], float) for r in recs])))
        out[c] = s if s > 0 else 1.0
    return out


def parameter_covariance(jacobian: np.ndarray, s2: float) -> np.ndarray:
    """Covariance ``s2 (J^T J)^-1`` of least-squares parameters from the Jacobian ``J``
    ``(n_residuals, p)`` of the scaled residual and the residual variance ``s2``.

    The columns are equilibrated first (each divided by its norm) and the pseudo-inverse
    is taken of ``J`` itself, not of ``J^T J``: parameters in units decades apart (a tyre
    rate of 1e5 N/m beside a sensor offset of 1e-6 m) make ``J^T J`` so ill-conditioned
    that a pseudo-inverse of it drops its smallest singular values, i.e. the directions of
    largest variance, and reports standard errors thousands of times too small. A column
    of zeros (a parameter the residual does not depend on) gets zero variance, as the
    pseudo-inverse gives it.
    """
    J = np.asarray(jacobian, float)
    norms = np.linalg.norm(J, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    inverse = np.linalg.pinv(J / norms)  # (p, n) of the equilibrated columns
    return (inverse @ inverse.T) / np.outer(norms, norms) * s2


def evaluate(
    model: DiagnosableModel[R, E],
    theta: np.ndarray,
    recs: Sequence[R],
    scales: Mapping[str, float],
    masks: Masks | None = None,
    jacobian: np.ndarray | None = None,
    scaled_residual: np.ndarray | None = None,
    *,
    success: bool = True,
    message: str = "evaluated",
    nfev: int = 0,
    seconds: float = 0.0,
) -> FitResult:
    """A :class:`FitResult` of ``model`` at ``theta`` (no optimisation; :func:`fit`
    gives its optimum here) on the channels of ``scales``; standard errors from
    ``jacobian`` (NaN without one) and the scaled residual (computed when not given)."""
    theta, recs = np.asarray(theta, float), list(recs)
    channels = list(scales)
    if (parts := _unstacked(scaled_residual, recs, channels, scales, masks)) is None:
        parts = residuals(model, theta, recs, channels, masks)
    ssr = {c: float(sum(np.sum(p[c] ** 2) for p in parts)) for c in channels}
    n = {c: int(sum(p[c].size for p in parts)) for c in channels}
    p = theta.size
    stderr = np.full(p, np.nan)
    cov = np.full((p, p), np.nan)
    if jacobian is not None and jacobian.shape[1] == p:
        r = scaled_residual
        if r is None:
            r = stacked_residual(model, theta, recs, channels, scales, masks)
        dof = max(r.size - p, 1)
        cov = parameter_covariance(jacobian, float(np.sum(r**2)) / dof)
        stderr = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    rho = float(
        np.mean([lag1_autocorrelation(q[c]) for q in parts for c in channels if q[c].size > 2])
    )
    rho = float(np.clip(rho, -0.99, 0.99))
    inflation = np.sqrt((1.0 + rho) / (1.0 - rho)) if rho > 0 else 1.0
    return FitResult(
        model=model,
        names=tuple(model.parameter_names),
        theta=theta,
        stderr=stderr,
        stderr_corrected=stderr * inflation,
        covariance=cov,
        channels=channels,
        scales=dict(scales),
        ssr=ssr,
        n=n,
        success=success,
        message=message,
        nfev=nfev,
        seconds=seconds,
        extra={"lag1_autocorrelation": rho, "jacobian": jacobian},
    )


def _start_point(
    model: DiagnosableModel[R, E],
    recs: Sequence[R],
    theta0: np.ndarray | Mapping[str, float] | None,
    lo: np.ndarray,
    hi: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The start point (``theta0`` over ``model.initial_guess``) strictly inside the
    bounds, and the span used to keep points there."""
    names = tuple(model.parameter_names)
    x0 = np.asarray(model.initial_guess(recs[0]), float)
    if isinstance(theta0, Mapping):
        for k, v in theta0.items():
            if k in names:
                x0[names.index(k)] = v
    elif theta0 is not None:
        x0 = np.asarray(theta0, float).copy()
    if x0.shape != (len(names),):
        raise ValidationError(
            f"theta0 must have one value per parameter, but got (theta0={x0.shape}, "
            f"parameters={len(names)})"
        )
    # keep the start strictly inside the bounds (least_squares requires it)
    span = np.where(np.isfinite(hi - lo), hi - lo, np.abs(x0) + 1.0)
    return np.clip(x0, lo + 1e-6 * span, hi - 1e-6 * span), span


@dataclass
class _Problem:
    """The scaled residual of ``model`` on ``recs`` as ``least_squares`` asks for it:
    :meth:`fun` (the last point cached; :data:`PENALTY` where the model cannot be
    evaluated), :meth:`batch` (one batched simulation per recording) and :meth:`jac`
    (forward differences, all columns in one batch)."""

    model: Any
    recs: Sequence[Any]
    channels: list[str]
    weights: dict[str, float]
    masks: Masks | None
    n_res: int
    lo: np.ndarray
    hi: np.ndarray
    last: dict[bytes, np.ndarray] = field(default_factory=dict)
    #: the next Jacobian of the twin is the batch probe (:meth:`jac`)
    probing: bool = False

    def fun(self, theta: np.ndarray) -> np.ndarray:
        key = np.asarray(theta, float).tobytes()
        if key in self.last:  # the start point is asked for more than once
            return self.last[key].copy()
        try:
            out = stacked_residual(
                self.model, theta, self.recs, self.channels, self.weights, self.masks
            )
        except EvaluationError:
            return np.full(self.n_res, PENALTY)
        self.last.clear()
        self.last[key] = out
        return out.copy()

    def batch(self, thetas: np.ndarray, sim: Any) -> np.ndarray:
        """(B, n_res) scaled residuals from one batched simulation per recording."""
        out = stacked_residual(sim, thetas, self.recs, self.channels, self.weights, self.masks)
        if out.ndim != 2 or out.shape[0] != thetas.shape[0]:
            raise ValidationError("batched simulation returned the wrong number of rows")
        return out

    def jac(self, theta: np.ndarray, sim: Any) -> np.ndarray:
        """Forward-difference Jacobian, all columns in one batched simulation of ``sim``
        (column by column where the batch as a whole cannot be simulated). As the probe,
        the batch must run and its base row be the single-row residual (else
        :class:`_NoBatchError`)."""
        h = np.asarray(self.model.difference_step(theta, self.lo, self.hi), float)
        step = np.where(theta + h <= self.hi, h, -h)
        thetas = np.vstack([theta, theta + np.diag(step)])
        if self.probing:
            self.probing = False
            try:
                rows = self.batch(thetas, sim)
                same = rows.shape[1] == self.n_res and bool(np.allclose(rows[0], self.fun(theta)))
            except Exception as exc:  # noqa: BLE001 - any failure: least_squares' differences
                raise _NoBatchError(str(exc)) from exc
            if not same:
                raise _NoBatchError("the batch's base row is not the single-row residual")
        else:
            try:
                rows = self.batch(thetas, sim)
            except EvaluationError:
                rows = np.vstack([self.fun(th) for th in thetas])
        return ((rows[1:] - rows[0]) / step[:, None]).T


def _solve(
    pb: _Problem, jac_model: Any, x0: np.ndarray, max_nfev: int, tol: float | None
) -> tuple[Any, bool]:
    """``least_squares`` from ``x0`` with the batched Jacobian of the model's Jacobian
    twin ``jac_model`` where it runs, else its own differences. Returns (solution, batch
    used)."""
    model = pb.model
    # where the Jacobian model is the model itself, its first Jacobian is the batch probe
    pb.probing = jac_model is model
    f0 = pb.fun(x0)
    ls_options: dict[str, Any] = {} if tol is None else {"ftol": tol, "xtol": tol}

    def solve(how: Any) -> Any:
        return least_squares(
            pb.fun,
            x0,
            jac=how,
            bounds=(pb.lo, pb.hi),
            x_scale="jac",
            max_nfev=max_nfev,
            **ls_options,
        )

    def jac(theta: np.ndarray) -> np.ndarray:
        return pb.jac(theta, jac_model)

    if pb.probing:
        # the first Jacobian (at x0, cached residual) probes the batch; where it fails the
        # search starts again with least_squares' own differences (one batch saved a fit)
        try:
            return solve(jac), True
        except _NoBatchError:
            return solve("2-point"), False
    try:
        probe = pb.batch(np.vstack([x0, x0]), model)
        use_batch = probe.shape == (2, pb.n_res) and bool(np.allclose(probe[0], f0))
    except Exception:  # noqa: BLE001 - any failure: fall back to one simulation per column
        use_batch = False
    return solve(jac if use_batch else "2-point"), use_batch


def fit(
    model: DiagnosableModel[R, E],
    recordings: R | Sequence[R],
    masks: Masks | None = None,
    theta0: np.ndarray | Mapping[str, float] | None = None,
    scales: Mapping[str, float] | None = None,
    max_nfev: int = 200,
    tol: float | None = None,
) -> FitResult:
    """Fit ``model`` to ``recordings`` by bounded nonlinear least squares.

    Args:
        model: the model (see :class:`~suspenv.diagnosis.protocols.DiagnosableModel`).
        recordings: one recording or a sequence; all are fitted jointly.
        masks: optional boolean sample masks, one per recording (the fit samples).
        theta0: start point: an array, or known values by parameter name (the others
            from ``model.initial_guess`` of the first recording).
        scales: per-channel residual scales (channel unit); they also choose the fitted
            channels. Default: the measured spread (:func:`spread_scales`) of every
            channel the model simulates and the first recording holds.
        max_nfev: budget of residual evaluations.
        tol: relative change of cost and of parameters that ends the search
            (``least_squares``' ``ftol`` and ``xtol``); None: its defaults.
    """
    t_start = time.perf_counter()
    recs = as_recordings(recordings)
    if masks is not None and len(masks) != len(recs):
        raise ValidationError(
            "one mask per recording must be given, but got "
            f"(masks={len(masks)}, recordings={len(recs)})"
        )
    lo, hi = (np.asarray(b, float) for b in model.bounds())
    x0, span = _start_point(model, recs, theta0, lo, hi)
    weights = (
        spread_scales(recs, fitted_channels(model, recs[0], x0)) if scales is None else dict(scales)
    )
    n_res = sum(sample_counts(recs, masks)) * len(weights)
    pb = _Problem(model, recs, list(weights), weights, masks, n_res, lo, hi)

    def result(theta: np.ndarray, J: np.ndarray, r: np.ndarray, **how: Any) -> FitResult:
        """:func:`evaluate` at ``theta`` (Jacobian ``J``, scaled residual ``r``), timed."""
        seconds = time.perf_counter() - t_start
        return evaluate(model, theta, recs, weights, masks, J, r, seconds=seconds, **how)

    if not model.parameter_names:
        return result(x0, np.zeros((n_res, 0)), pb.fun(x0), message="no free parameters", nfev=1)
    jac_model = model.jacobian_model()
    x0 = _refined_start(pb, x0, span)
    # the single-row residual first (in _solve), then the batched probe: a model that
    # caches its solutions row by row (the K&C axle) then reuses the row instead of
    # solving it in another batch
    sol, use_batch = _solve(pb, jac_model, x0, max_nfev, tol)
    theta = np.asarray(sol.x, float)
    J = np.asarray(sol.jac, float)
    if use_batch and jac_model is not model:
        # the twin's sensitivities are close enough to steer the fit, not to report:
        # standard errors (and the residual basis of the signatures) use the model's own
        J = pb.jac(theta, model)
    how = {"success": bool(sol.success), "message": str(sol.message), "nfev": int(sol.nfev)}
    return result(theta, J, np.asarray(sol.fun, float), **how)


def _refined_start(pb: _Problem, x0: np.ndarray, span: np.ndarray) -> np.ndarray:
    """``x0``, or the model's cheap start (``model.refine_start``, e.g. an equation-error
    fit) kept strictly inside the bounds (``span``: the bounds' width) where it lowers the
    simulation residual."""
    if (refined := pb.model.refine_start(x0, pb.recs, pb.masks)) is None:
        return x0
    x1 = np.clip(np.asarray(refined, float), pb.lo + 1e-6 * span, pb.hi - 1e-6 * span)
    return x1 if np.sum(pb.fun(x1) ** 2) < np.sum(pb.fun(x0) ** 2) else x0
