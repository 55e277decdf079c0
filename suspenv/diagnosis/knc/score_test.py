"""Score (Lagrange-multiplier) tests of candidate elements against the fitted model.

The residual signatures (:mod:`~suspenv.diagnosis.knc.signatures`) look for each
effect's *pattern* in the residual. When the fitted base parameters can follow most
of an effect (a wheel-load cell offset is largely mimicked by the bushing positions
and the top-mount rate), what is left in the residual is the unabsorbed remainder,
which no longer looks like the pattern. The score test asks the model instead: with
``r`` the scaled residual of the current fit, ``J`` its Jacobian in the fitted
parameters and ``G`` the sensitivity of the scaled residual to the candidate's
parameters at their null value (no effect), the part ``P G`` of ``G`` that the fitted
parameters cannot follow (``P = I - J J^+``) gives

``LM = r' P G (G' P G)^+ G' P r / s^2``,  ``s^2 = |r|^2 / (N - p)``,

chi-square with ``k = rank(P G)`` degrees of freedom when the candidate is absent;
``score = (LM - k) / sqrt(2 k)`` is on the signatures' scale (about N(0, 1) under
noise). Only cheap (elastic and sensor) candidates are tested: their sensitivities
need no path-dependent solves.

Units: dimensionless (residuals in units of the fit's channel scales).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from suspenv.diagnosis.fitting import stacked_residual
from suspenv.diagnosis.knc.signatures import SCREEN_FAMILY, KncSignature
from suspenv.diagnosis.screening import orthonormal_basis, partial_r2
from suspenv.rigs.knc_axle import KncAxleModel, fitted_parameters, make_candidate

#: candidates tested by the score test (their signature family: ``SCREEN_FAMILY``)
SCORE_TESTED = ("sensor_offset", "sensor_gain", "cubic_stiffness", "lr_asymmetry")
#: effect parameters' null values (no effect) where they differ from the default
NULL_VALUES = {("cubic_stiffness", "ratio"): 1e-3}


def score_test(fit_: Any, recs: Sequence[Any], candidate: str) -> tuple[float, int]:
    """``(LM, k)`` of adding ``candidate`` to the model of ``fit_`` (see the module docstring)."""
    model: KncAxleModel = fit_.model
    recs = list(recs)
    channels = list(fit_.scales)
    r = stacked_residual(model, fit_.theta, recs, channels, fit_.scales)
    base, current = model.parts(fit_.theta)
    new = make_candidate(candidate)
    specs = fitted_parameters(new)
    null = {q.name: NULL_VALUES.get((new.kind, q.name), q.reference) for q in specs}
    ext = model.with_effects([*current, new.with_params(null)])
    theta0 = ext.theta_from(base, [*current, new.with_params(null)])
    n0 = theta0.size - len(specs)
    steps = np.array([0.02 * (q.high - q.low) for q in specs])
    thetas = np.tile(theta0, (len(specs) + 1, 1))
    thetas[1:, n0:] += np.diag(steps)
    R = stacked_residual(ext, thetas, recs, channels, fit_.scales)
    G = ((R[1:] - R[0]) / steps[:, None]).T  # (N, k)
    J = fit_.extra.get("jacobian")
    Q = orthonormal_basis(J if J is not None and J.shape[0] == r.size else None)
    if Q is not None:
        G = G - Q @ (Q.T @ G)
    k = int(np.linalg.matrix_rank(G, tol=1e-9 * max(np.abs(G).max(), 1e-300)))
    if k == 0:
        return 0.0, 1
    fitted = partial_r2(r, G, None)[2]
    s2 = float(r @ r) / max(r.size - fit_.theta.size, 1)
    return float(fitted @ fitted) / s2, k


def score_signatures_by_model(
    fit_: Any, recs: Sequence[Any], candidates: Sequence[str]
) -> list[KncSignature]:
    """A :class:`KncSignature` per score-tested candidate among ``candidates``."""
    out = []
    for cand in [c for c in candidates if c in SCORE_TESTED]:
        lm, k = score_test(fit_, recs, cand)
        words = (
            f"score test of the element against the fitted model: chi2 {lm:.1f} on {k} dof "
            "(the part the fitted parameters cannot follow)"
        )
        out.append(KncSignature(SCREEN_FAMILY[cand], (lm - k) / np.sqrt(2.0 * k), lm, k, words))
    return sorted(out, key=lambda s: -s.score)
