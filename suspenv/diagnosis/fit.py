"""Least-squares fit of a component model to one or more recordings.

Units: residuals are formed in each output channel's own SI unit and divided by a
per-channel scale (the measured channel's standard deviation) so channels weigh
equally. Parameter covariance comes from the Jacobian at the optimum,
``cov = s^2 (J^T J)^-1`` with ``s^2`` the scaled residual variance; standard errors
are also given corrected for serially correlated residuals (effective sample size
from the lag-1 autocorrelation), because neighbouring samples of a recording are not
independent.

A *model* is anything with the component-model interface: ``parameter_names``,
``bounds()``, ``initial_guess(rec)`` and ``simulate(theta, rec) -> dict``; optionally
``refine_start(theta0, recordings, masks) -> theta0``, a cheap model-specific
improvement of the start point (used when it lowers the residual), and
``jacobian_model()``, a cheaper twin of the model (same parameters) used for the
finite-difference Jacobians of the iterations (the Jacobian at the optimum, behind the
standard errors, is the model's own).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from suspenv.core.errors import EvaluationError, ValidationError


def as_list(recordings: Any) -> list[Any]:
    """A single recording or a sequence of them -> list."""
    if isinstance(recordings, list | tuple):
        return list(recordings)
    return [recordings]


def fitted_channels(model: Any, rec: Any, theta: np.ndarray) -> list[str]:
    """Output channels both simulated by ``model`` and present in ``rec`` (the model's
    declared ``output_channels`` where ``theta`` cannot be simulated, e.g. a start
    point at which a softening element diverges; the fit then moves away from it)."""
    try:
        names_pred = list(model.simulate(theta, rec))
    except EvaluationError:
        names_pred = list(getattr(model, "output_channels", ()))
        if not names_pred:
            raise
    pred = dict.fromkeys(names_pred)
    names = [c for c in pred if c in rec.outputs]
    if not names:
        raise ValidationError(
            "the model and the recording must share an output channel, but got model "
            f"outputs {sorted(pred)} and recording outputs {sorted(rec.outputs)}"
        )
    return names


@dataclass
class FitResult:
    """Outcome of :func:`fit_model`.

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
        seconds: wall time of the fit.
    """

    model: Any
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

    @property
    def n_params(self) -> int:
        return int(self.theta.size)

    @property
    def n_samples(self) -> int:
        return int(sum(self.n.values()))

    def rms(self) -> dict[str, float]:
        """Per-channel RMS residual over the fit samples (channel unit)."""
        return {c: float(np.sqrt(self.ssr[c] / max(self.n[c], 1))) for c in self.channels}

    def log_likelihood(self) -> float:
        """Gaussian log-likelihood with each channel's noise variance at its MLE."""
        total = 0.0
        for c in self.channels:
            n = self.n[c]
            var = max(self.ssr[c] / max(n, 1), 1e-300)
            total += -0.5 * n * (np.log(2.0 * np.pi * var) + 1.0)
        return float(total)

    def aic(self) -> float:
        return 2.0 * self.n_params - 2.0 * self.log_likelihood()

    def bic(self) -> float:
        return self.n_params * np.log(max(self.n_samples, 1)) - 2.0 * self.log_likelihood()

    def params(self) -> dict[str, dict[str, float]]:
        """``{name: {"value", "stderr", "stderr_corrected"}}`` (JSON-friendly)."""
        return {
            name: {
                "value": float(v),
                "stderr": float(s),
                "stderr_corrected": float(sc),
            }
            for name, v, s, sc in zip(
                self.names, self.theta, self.stderr, self.stderr_corrected, strict=True
            )
        }


def residuals(
    model: Any,
    theta: np.ndarray,
    recordings: Sequence[Any],
    channels: Sequence[str],
    masks: Sequence[np.ndarray | None] | None = None,
) -> list[dict[str, np.ndarray]]:
    """Measured minus predicted, per recording and channel (channel unit).

    Where ``masks`` is given, only the masked samples are returned.
    """
    out = []
    for i, rec in enumerate(recordings):
        pred = model.simulate(theta, rec)
        m = None if masks is None else masks[i]
        r = {}
        for c in channels:
            d = np.asarray(rec.outputs[c], float) - np.asarray(pred[c], float)
            r[c] = d if m is None else d[m]
        out.append(r)
    return out


def lag1_autocorrelation(r: np.ndarray) -> float:
    """Sample lag-1 autocorrelation of a residual series (0 for fewer than 3 samples)."""
    r = np.asarray(r, float) - np.mean(r)
    den = float(np.dot(r, r))
    if r.size < 3 or den <= 0.0:
        return 0.0
    return float(np.dot(r[1:], r[:-1]) / den)


def fit_model(
    model: Any,
    recordings: Any,
    masks: Sequence[np.ndarray | None] | None = None,
    theta0: np.ndarray | dict[str, float] | None = None,
    max_nfev: int = 200,
) -> FitResult:
    """Fit ``model`` to ``recordings`` by bounded nonlinear least squares.

    Args:
        model: a component model (see module docstring).
        recordings: one recording or a list; all are fitted jointly.
        masks: optional boolean sample masks, one per recording (fit samples).
        theta0: start point: an array, or a dict of known values by parameter name
            (others from ``model.initial_guess``).
        max_nfev: budget of residual evaluations.
    """
    t_start = time.perf_counter()
    recs = as_list(recordings)
    if masks is not None and len(masks) != len(recs):
        raise ValidationError(
            "one mask per recording must be given, but got "
            f"(masks={len(masks)}, recordings={len(recs)})"
        )
    names = tuple(model.parameter_names)
    lo, hi = (np.asarray(b, float) for b in model.bounds())
    x0 = np.asarray(model.initial_guess(recs[0]), float)
    if isinstance(theta0, dict):
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
    x0 = np.clip(x0, lo + 1e-6 * span, hi - 1e-6 * span)

    channels = fitted_channels(model, recs[0], x0)
    refine = getattr(model, "refine_start", None)
    scales: dict[str, float] = {}
    for c in channels:
        y = np.concatenate([np.asarray(r.outputs[c], float) for r in recs])
        s = float(np.std(y))
        scales[c] = s if s > 0 else 1.0

    last: dict[bytes, np.ndarray] = {}

    def fun(theta: np.ndarray) -> np.ndarray:
        key = np.asarray(theta, float).tobytes()
        if key in last:  # the start point is asked for more than once
            return last[key].copy()
        try:
            parts = residuals(model, theta, recs, channels, masks)
        except EvaluationError:
            return np.full(n_res, 1e3)
        v = np.concatenate([p[c] / scales[c] for p in parts for c in channels])
        out = np.where(np.isfinite(v), v, 1e3)
        last.clear()
        last[key] = out
        return out.copy()

    n_res = sum(
        int(np.count_nonzero(m)) if m is not None else len(r.time)
        for r, m in zip(recs, masks or [None] * len(recs), strict=True)
    ) * len(channels)

    # a model may offer a cheaper twin for finite-difference Jacobians (same parameters,
    # e.g. a coarser integration step): the difference quotients need only be close
    make_jac_model = getattr(model, "jacobian_model", None)
    jac_model = make_jac_model() if callable(make_jac_model) else model

    def batch_residuals(thetas: np.ndarray, sim: Any = model) -> np.ndarray:
        """(B, n_res) scaled residuals from one batched simulation per recording."""
        cols = []
        for i, rec in enumerate(recs):
            pred = sim.simulate(thetas, rec)
            m = None if masks is None else masks[i]
            for c in channels:
                d = np.asarray(rec.outputs[c], float)[None, :] - np.asarray(pred[c], float)
                cols.append((d if m is None else d[:, m]) / scales[c])
        out = np.concatenate(cols, axis=1)
        if out.shape[0] != thetas.shape[0]:
            raise ValidationError("batched simulation returned the wrong number of rows")
        return np.where(np.isfinite(out), out, 1e3)

    def jac(theta: np.ndarray, sim: Any = None) -> np.ndarray:
        """Forward-difference Jacobian, all columns in one batched simulation (column
        by column where the batch as a whole cannot be simulated); ``sim`` defaults to
        the Jacobian twin."""
        h = 1e-6 * np.maximum(np.abs(theta), 1.0)
        step = np.where(theta + h <= hi, h, -h)
        thetas = np.vstack([theta, theta + np.diag(step)])
        try:
            R = batch_residuals(thetas, jac_model if sim is None else sim)
        except EvaluationError:
            R = np.vstack([fun(th) for th in thetas])
        return ((R[1:] - R[0]) / step[:, None]).T

    if callable(refine):
        # a model-specific fast start (e.g. an equation-error fit); kept only where it
        # lowers the simulation residual
        x1 = np.clip(np.asarray(refine(x0, recs, masks), float), lo + 1e-6 * span, hi - 1e-6 * span)
        if np.sum(fun(x1) ** 2) < np.sum(fun(x0) ** 2):
            x0 = x1
    use_batch = True
    try:
        probe = batch_residuals(np.vstack([x0, x0]))
        use_batch = probe.shape == (2, n_res) and np.allclose(probe[0], fun(x0))
    except Exception:  # noqa: BLE001 - any failure: fall back to one simulation per column
        use_batch = False
    sol = least_squares(
        fun,
        x0,
        jac=jac if use_batch else "2-point",
        bounds=(lo, hi),
        x_scale="jac",
        max_nfev=max_nfev,
    )
    theta = sol.x
    parts = residuals(model, theta, recs, channels, masks)
    ssr = {c: float(sum(np.sum(p[c] ** 2) for p in parts)) for c in channels}
    n = {c: int(sum(p[c].size for p in parts)) for c in channels}

    J = np.asarray(sol.jac, float)
    if use_batch and jac_model is not model:
        # the twin's sensitivities are close enough to steer the fit, not to report:
        # standard errors (and the residual basis of the signatures) use the model's own
        J = jac(theta, model)
    dof = max(J.shape[0] - J.shape[1], 1)
    s2 = float(np.sum(sol.fun**2)) / dof
    cov_scaled = np.linalg.pinv(J.T @ J) * s2
    stderr = np.sqrt(np.clip(np.diag(cov_scaled), 0.0, None))
    rho = np.mean([lag1_autocorrelation(p[c]) for p in parts for c in channels if p[c].size > 2])
    rho = float(np.clip(rho, -0.99, 0.99))
    inflation = np.sqrt((1.0 + rho) / (1.0 - rho)) if rho > 0 else 1.0
    return FitResult(
        model=model,
        names=names,
        theta=theta,
        stderr=stderr,
        stderr_corrected=stderr * inflation,
        covariance=cov_scaled,
        channels=channels,
        scales=scales,
        ssr=ssr,
        n=n,
        success=bool(sol.success),
        message=str(sol.message),
        nfev=int(sol.nfev),
        seconds=time.perf_counter() - t_start,
        extra={"lag1_autocorrelation": rho, "jacobian": J},
    )
