"""A plain least-squares fit of a component model to one recording.

Residuals are ``(predicted - measured) / scale`` per output channel, with ``scale``
the standard deviation of the measured channel, stacked over channels. The
Jacobian is formed by forward differences evaluated as one batched simulation
(``theta`` of shape ``(p + 1, p)``), which the component models vectorise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from suspenv.models.components.base import ComponentModel
from suspenv.recordings import Recording


@dataclass
class LeastSquaresFit:
    """Result of :func:`fit_least_squares` (``theta`` in SI units, ``rms`` per channel)."""

    theta: np.ndarray
    names: tuple[str, ...]
    rms: dict[str, float]
    success: bool
    message: str
    nfev: int

    def values(self) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.names, self.theta, strict=True)}


def fit_least_squares(
    model: ComponentModel,
    rec: Recording,
    theta0: np.ndarray | None = None,
    max_nfev: int = 100,
) -> LeastSquaresFit:
    """Fit ``model`` to ``rec`` with :func:`scipy.optimize.least_squares` (trust region)."""
    lo, hi = model.bounds()
    x0 = model.initial_guess(rec) if theta0 is None else np.asarray(theta0, dtype=float)
    span = hi - lo
    x0 = np.clip(x0, lo + 1e-9 * span, hi - 1e-9 * span)
    chans = list(model.output_channels)
    scale = {c: float(np.std(rec.outputs[c])) or 1.0 for c in chans}
    typical = np.maximum(np.abs(x0), 1e-6 * np.maximum(np.abs(lo), np.abs(hi)) + 1e-12)

    def stacked(pred: dict[str, np.ndarray]) -> np.ndarray:
        return np.concatenate([(pred[c] - rec.outputs[c]) / scale[c] for c in chans], axis=-1)

    def fun(th: np.ndarray) -> np.ndarray:
        return stacked(model.simulate(th, rec))

    def jac(th: np.ndarray) -> np.ndarray:
        h = 1e-6 * np.maximum(np.abs(th), typical)
        room = hi - th
        h = np.where(room < h, -h, h)  # step inward at the upper bound
        batch = np.vstack([th, th + np.diag(h)])
        r = stacked(model.simulate(batch, rec))
        return ((r[1:] - r[0]) / h[:, None]).T

    sol = least_squares(fun, x0, jac=jac, bounds=(lo, hi), x_scale=typical, max_nfev=max_nfev)
    pred = model.simulate(sol.x, rec)
    rms = {c: float(np.sqrt(np.mean((pred[c] - rec.outputs[c]) ** 2))) for c in chans}
    return LeastSquaresFit(
        sol.x, model.parameter_names, rms, bool(sol.success), sol.message, sol.nfev
    )
