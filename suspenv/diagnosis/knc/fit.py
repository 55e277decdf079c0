"""Weighted least-squares fit of the K&C axle model, returning the engine's ``FitResult``.

The generic fit (:func:`suspenv.diagnosis.fit.fit_model`) weighs each channel by the
measured channel's spread. On a K&C rig that spread is the travel response itself
(a wheel load sweeps kN while its cell resolves about a newton), so it would let the
coarse channels dominate. Here each channel is weighed by its *noise*: the scales are
given (the baseline's per-channel RMS residual, :func:`noise_scales`) and stay the
same for every model compared on the same data, so likelihoods and held-out errors
are comparable.

Units: residuals in each channel's SI unit divided by its scale (dimensionless).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.diagnosis.fit import FitResult, lag1_autocorrelation, residuals

PENALTY = 1e3


def _masked(rec: Any, mask: np.ndarray | None) -> int:
    return int(np.count_nonzero(mask)) if mask is not None else rec.n_samples


def stacked_residual(
    model: Any,
    theta: np.ndarray,
    recs: Sequence[Any],
    channels: Sequence[str],
    scales: Mapping[str, float],
    masks: Sequence[np.ndarray | None] | None = None,
) -> np.ndarray:
    """Scaled residuals ``(B, N)`` (or ``(N,)``) of every channel of every recording."""
    cols = []
    for i, rec in enumerate(recs):
        pred = model.simulate(theta, rec)
        m = None if masks is None else masks[i]
        for c in channels:
            d = np.asarray(rec.outputs[c], float) - np.asarray(pred[c], float)
            d = d if m is None else d[..., m]
            cols.append(d / scales[c])
    out = np.concatenate(cols, axis=-1)
    return np.where(np.isfinite(out), out, PENALTY)


def noise_scales(fit: FitResult, floor: float = 1e-12) -> dict[str, float]:
    """Per-channel scale = the fit's RMS residual (channel unit)."""
    return {c: max(v, floor) for c, v in fit.rms().items()}


def spread_scales(recs: Sequence[Any], channels: Sequence[str]) -> dict[str, float]:
    """Per-channel standard deviation of the measured channel (a first-pass scale)."""
    out = {}
    for c in channels:
        s = float(np.std(np.concatenate([np.asarray(r.outputs[c], float) for r in recs])))
        out[c] = s if s > 0 else 1.0
    return out


def evaluate(
    model: Any,
    theta: np.ndarray,
    recs: Sequence[Any],
    scales: Mapping[str, float],
    masks: Sequence[np.ndarray | None] | None = None,
    jacobian: np.ndarray | None = None,
    seconds: float = 0.0,
    nfev: int = 0,
    message: str = "evaluated",
) -> FitResult:
    """A :class:`FitResult` of ``model`` at ``theta`` (no optimisation)."""
    channels = list(scales)
    theta = np.asarray(theta, float)
    parts = residuals(model, theta, recs, channels, masks)
    ssr = {c: float(sum(np.sum(p[c] ** 2) for p in parts)) for c in channels}
    n = {c: int(sum(p[c].size for p in parts)) for c in channels}
    p = theta.size
    stderr = np.full(p, np.nan)
    cov = np.full((p, p), np.nan)
    if jacobian is not None and jacobian.shape[1] == p:
        r = stacked_residual(model, theta, recs, channels, scales, masks)
        dof = max(r.size - p, 1)
        cov = np.linalg.pinv(jacobian.T @ jacobian) * float(np.sum(r**2)) / dof
        stderr = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    rho = np.mean([lag1_autocorrelation(q[c]) for q in parts for c in channels if q[c].size > 2])
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
        success=True,
        message=message,
        nfev=nfev,
        seconds=seconds,
        extra={"lag1_autocorrelation": rho, "jacobian": jacobian},
    )


def fit(
    model: Any,
    recs: Sequence[Any],
    scales: Mapping[str, float] | None = None,
    masks: Sequence[np.ndarray | None] | None = None,
    theta0: np.ndarray | Mapping[str, float] | None = None,
    max_nfev: int = 30,
    tol: float = 1e-4,
) -> FitResult:
    """Bounded least squares of ``model`` on ``recs``; channels weighed by ``scales``.

    ``scales`` default to the measured spread (:func:`spread_scales`) of every
    channel the model predicts and the recordings hold. The Jacobian is a forward
    difference with all columns in one batched simulation. ``tol`` is the relative
    change of cost and parameters that ends the search (a change of 1e-4 in the
    residual sum moves the log-likelihood by far less than one unit).
    """
    t0 = time.perf_counter()
    recs = list(recs)
    if masks is not None and len(masks) != len(recs):
        raise ValidationError(
            f"one mask per recording must be given, but got ({len(masks)}, {len(recs)})"
        )
    names = tuple(model.parameter_names)
    lo, hi = model.bounds()
    x0 = np.asarray(model.initial_guess(recs[0]), float)
    if isinstance(theta0, Mapping):
        for k, v in theta0.items():
            if k in names:
                x0[names.index(k)] = v
    elif theta0 is not None:
        x0 = np.asarray(theta0, float).copy()
    span = hi - lo
    x0 = np.clip(x0, lo + 1e-6 * span, hi - 1e-6 * span)
    if scales is None:
        chans = [c for c in model.output_channels if c in recs[0].outputs]
        scales = spread_scales(recs, chans)
    channels = list(scales)
    n_res = sum(_masked(r, None if masks is None else masks[i]) for i, r in enumerate(recs)) * len(
        channels
    )

    def fun(theta: np.ndarray) -> np.ndarray:
        try:
            return stacked_residual(model, theta, recs, channels, scales, masks)
        except EvaluationError:
            return np.full(n_res, PENALTY)

    def jac(theta: np.ndarray) -> np.ndarray:
        h = np.maximum(3e-3 * np.abs(theta), 1e-3 * span)
        step = np.where(theta + h <= hi, h, -h)
        R = stacked_residual(
            model, np.vstack([theta, theta + np.diag(step)]), recs, channels, scales, masks
        )
        return ((R[1:] - R[0]) / step[:, None]).T

    if names:
        sol = least_squares(
            fun,
            x0,
            jac=jac,
            bounds=(lo, hi),
            x_scale="jac",
            max_nfev=max_nfev,
            ftol=tol,
            xtol=tol,
        )
        theta, J, nfev, msg = sol.x, np.asarray(sol.jac, float), int(sol.nfev), str(sol.message)
    else:
        theta, J, nfev, msg = x0, np.zeros((n_res, 0)), 1, "no free parameters"
    return evaluate(model, theta, recs, scales, masks, J, time.perf_counter() - t0, nfev, msg)
