"""What the measured curves identify: covariance of the fitted parameters, a verdict per
parameter, and the rig test that would identify the rest.

Inputs are the noise-scaled residual ``r`` (dimensionless: ``(simulated - measured) /
sigma``) and its Jacobian ``J = dr/du`` in the fit's unit cube (:mod:`suspenv.methods.
curve_fit`; stiffnesses on a log scale). For residuals of unit-variance independent
noise the covariance of ``u`` is ``(J' J)^-1``; it is multiplied by ``s^2 =
max(1, |r|^2 / (N - p))`` so a fit that leaves more than noise (model error) widens
its own error bars instead of claiming the noise floor.

``J' J`` is inverted through its eigen-decomposition; eigenvalues below
:data:`RCOND` x the largest are raised to that value (pseudo-inverse with a floor:
a direction known 1e5 times less well than the best-known one is treated as not
known at all, and gets a variance of order the whole range rather than zero).

Physical standard errors follow by the delta method: ``dx/du = high - low`` on a
linear scale, ``x ln(high / low)`` on a log scale. A parameter is **identified** when
``K_SIGMA * stderr <= TOLERANCE_PCT`` % of its range ``high - low`` (3 standard errors
within 2 %: for Gaussian errors the estimate then lies within 2 % of the range of the
truth with probability 99.7 %) *and* the same holds on the fit's own scale (the unit
cube: for a log-scale stiffness 2 % of the log range, a factor ``(high/low)^0.02``).
The second condition guards the delta method where it fails: springs in series (a
soft anti-roll-bar bush and a stiff bar) trade along a curved valley, and at the soft
end the physical slope ``dx/du`` is so small that a physical standard error looks
tiny although the valley is long. Otherwise the verdict says why:

* **flat**: even alone (every other parameter known) the measured tests would leave
  it more uncertain than that (``stderr_alone = sqrt(s^2) / |J_i|``); no measured curve
  sees it;
* **correlated**: alone it would be identified, but other parameters can make up for
  its change; the verdict names those with the largest correlation.

:func:`rank_tests` predicts the standard errors with a further rig test's Jacobian
stacked under ``J`` (same noise model, same ``s^2``) and orders the candidate tests.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.core.space import DesignSpace

#: eigenvalues of J'J below RCOND x the largest are raised to it
RCOND = 1e-10
#: identified: K_SIGMA standard errors within TOLERANCE_PCT % of the range
K_SIGMA = 3.0
TOLERANCE_PCT = 2.0
#: correlations reported in a "correlated" verdict: at most this many, |rho| above
CORRELATION_NAMES = 3
CORRELATION_MIN = 0.5


def unit_covariance(J: np.ndarray, scale2: float = 1.0, rcond: float = RCOND) -> np.ndarray:
    """``scale2 * (J' J)^-1`` (dim, dim) with eigenvalues floored at ``rcond`` x the largest."""
    H = J.T @ J
    w, V = np.linalg.eigh(0.5 * (H + H.T))
    top = float(max(w.max(), 0.0))
    floor = rcond * top if top > 0 else 1.0
    w = np.maximum(w, floor)
    return scale2 * (V / w) @ V.T


def sandwich_covariance(
    J: np.ndarray, r: np.ndarray, clusters: Sequence[np.ndarray], rcond: float = RCOND
) -> np.ndarray:
    """Cluster-robust covariance ``A^-1 B A^-1`` (dim, dim) of the unit-cube fit: ``A =
    J' J`` (inverted as :func:`unit_covariance`), ``B = sum_c s_c s_c'`` with ``s_c =
    J_c' r_c`` the score of cluster ``c`` (the residual rows ``clusters[c]``, e.g. one
    measured loop). Under independent unit noise ``E[B] = A`` and this is ``(J' J)^-1``
    again; a misfit correlated within each cluster (physics the model lacks) makes the
    clusters disagree about the parameters and widens it in the directions they
    disagree on, where ``s^2`` spreads a misfit over every direction alike."""
    J, r = np.asarray(J, float), np.asarray(r, float)
    scores = np.array([J[rows].T @ r[rows] for rows in clusters])
    A_inv = unit_covariance(J, 1.0, rcond)
    return A_inv @ (scores.T @ scores) @ A_inv


def determined_directions(
    J: np.ndarray, scale2: float = 1.0, names: Sequence[str] = (), top: int = 3
) -> tuple[int, list[tuple[float, list[tuple[str, float]]]]]:
    """How many independent combinations of the parameters the data determine.

    The eigenvectors ``v_k`` of ``J' J`` are the combinations ``v_k . u`` of the unit-cube
    parameters that the data see independently, each with standard error
    ``sqrt(s^2 / w_k)`` (``w_k`` its eigenvalue). A combination is **determined** when
    ``K_SIGMA`` standard errors lie within ``TOLERANCE_PCT`` % of the unit interval (the
    rule of a single parameter, applied along ``v_k``). Returns the number determined and
    the ``top`` best-determined combinations that mix at least two parameters, each as
    (standard error in % of the unit interval, [(name, loading)] with ``|loading| >= 0.3``,
    largest first, sign fixed so the largest loading is positive)."""
    H = np.asarray(J, float).T @ np.asarray(J, float)
    w, V = np.linalg.eigh(0.5 * (H + H.T))
    with np.errstate(divide="ignore"):
        se_pct = np.where(w > 0, 100.0 * np.sqrt(scale2 / np.where(w > 0, w, 1.0)), np.inf)
    limit = TOLERANCE_PCT / K_SIGMA
    count = int((se_pct <= limit).sum())
    out: list[tuple[float, list[tuple[str, float]]]] = []
    for k in np.argsort(se_pct):
        if se_pct[k] > limit or len(out) >= top:
            break
        v = V[:, k] * np.sign(V[np.argmax(np.abs(V[:, k])), k])
        big = [i for i in np.argsort(-np.abs(v)) if abs(v[i]) >= 0.3]
        if len(big) >= 2 and names:
            out.append((float(se_pct[k]), [(str(names[i]), float(v[i])) for i in big]))
    return count, out


@dataclass
class Verdict:
    """One parameter's identification verdict (file units)."""

    name: str
    unit: str
    value: float
    stderr: float
    stderr_pct: float  # of the range high - low
    identified: bool
    reason: str  # "" when identified, else "flat: ..." or "correlated: ..."
    stderr_alone_pct: float
    stderr_unit_pct: float  # on the fit's scale (% of the unit interval)
    correlated_with: list[tuple[str, float]] = field(default_factory=list)
    at_bound: bool = False
    truth: float | None = None

    @property
    def kind(self) -> str:
        """``"identified"``, ``"flat"`` or ``"correlated"``."""
        return "identified" if self.identified else self.reason.split(":")[0]

    @property
    def error_pct(self) -> float | None:
        """|value - truth| in % of the range (None without a truth)."""
        if self.truth is None:
            return None
        return 100.0 * abs(self.value - self.truth) / self._range

    _range: float = 1.0

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "unit": self.unit,
            "value": self.value,
            "stderr": self.stderr,
            "stderr_pct_range": self.stderr_pct,
            "identified": self.identified,
            "verdict": self.kind,
            "reason": self.reason,
            "stderr_alone_pct_range": self.stderr_alone_pct,
            "stderr_pct_fit_scale": self.stderr_unit_pct,
            "correlated_with": [[n, r] for n, r in self.correlated_with],
            "at_bound": self.at_bound,
            "truth": self.truth,
            "error_pct_range": self.error_pct,
        }


@dataclass
class Identifiability:
    """Covariance and verdicts of a fit (see the module docstring)."""

    names: list[str]
    cov_unit: np.ndarray  # (dim, dim) covariance of u
    scale2: float  # s^2 applied
    verdicts: list[Verdict]
    rcond: float = RCOND
    #: independent parameter combinations the data determine (determined_directions)
    n_determined: int = 0
    directions: list[tuple[float, list[tuple[str, float]]]] = field(default_factory=list)

    @property
    def identified(self) -> np.ndarray:
        return np.array([v.identified for v in self.verdicts])

    def not_identified(self) -> list[str]:
        return [v.name for v in self.verdicts if not v.identified]

    def to_dict(self) -> dict[str, Any]:
        return {
            "rule": (
                f"identified when {K_SIGMA:g} x stderr <= {TOLERANCE_PCT:g} % of the parameter's "
                "range"
            ),
            "covariance": "s^2 (J'J)^-1 in the unit cube, s^2 = max(1, chi2 / (N - p)); "
            f"eigenvalues below {self.rcond:g} x the largest raised to it",
            "s2": self.scale2,
            "n_identified": int(self.identified.sum()),
            "n_determined_combinations": self.n_determined,
            "best_determined_combinations": [
                {"stderr_pct_unit": se, "loadings": dict(v)} for se, v in self.directions
            ],
            "parameters": [v.to_dict() for v in self.verdicts],
        }


def assess(
    J: np.ndarray,
    r: np.ndarray,
    u: np.ndarray,
    space: DesignSpace,
    truth: Mapping[str, float] | None = None,
    rcond: float = RCOND,
    scale2: float | None = None,
) -> Identifiability:
    """Covariance and verdicts at the fitted unit point ``u`` of the free parameters
    ``space`` (their fit space: the same order as ``J``'s columns)."""
    J = np.asarray(J, float)
    n, d = J.shape
    if scale2 is None:
        scale2 = max(1.0, float(r @ r) / max(n - d, 1))
    cov = unit_covariance(J, scale2, rcond)
    slope = np.abs(space.slope(u))
    rng = space.upper - space.lower
    se_u = np.sqrt(np.maximum(np.diag(cov), 0.0))
    se_pct = 100.0 * se_u * slope / rng
    judged = np.maximum(se_pct, 100.0 * se_u)  # physical range and fit scale
    col = np.linalg.norm(J, axis=0)
    with np.errstate(divide="ignore"):
        alone_u = np.where(col > 0, np.sqrt(scale2) / col, np.inf)
    alone_pct = np.maximum(100.0 * alone_u * slope / rng, 100.0 * alone_u)
    corr = cov / np.outer(se_u, se_u)
    x = space.to_physical(np.clip(u, 0, 1)[None])[0]
    limit = TOLERANCE_PCT / K_SIGMA
    verdicts = []
    for i, p in enumerate(space.parameters):
        ok = bool(judged[i] <= limit)
        others = [
            (space.names[j], float(corr[i, j]))
            for j in np.argsort(-np.abs(corr[i]))
            if j != i and abs(corr[i, j]) >= CORRELATION_MIN
        ][:CORRELATION_NAMES]
        if ok:
            reason = ""
        elif alone_pct[i] > limit:
            reason = (
                f"flat: the measured curves barely see it (even with every other parameter "
                f"known, +-{K_SIGMA:g} stderr = {K_SIGMA * alone_pct[i]:.3g} % of its range)"
            )
        else:
            names = ", ".join(f"{nm} ({rho:+.2f})" for nm, rho in others) or "several parameters"
            reason = (
                f"correlated: alone it would be known to +-{K_SIGMA * alone_pct[i]:.2g} % of its "
                f"range, but {names} can make up for its change"
            )
        verdicts.append(
            Verdict(
                p.name,
                p.unit,
                float(x[i]),
                float(se_pct[i] * rng[i] / 100.0),
                float(se_pct[i]),
                ok,
                reason,
                float(alone_pct[i]),
                float(100.0 * se_u[i]),
                others,
                bool(u[i] <= 1e-6 or u[i] >= 1 - 1e-6),
                None if truth is None or p.name not in truth else float(truth[p.name]),
                float(rng[i]),
            )
        )
    count, directions = determined_directions(J, float(scale2), space.names)
    return Identifiability(
        list(space.names), cov, float(scale2), verdicts, rcond, count, directions
    )


@dataclass
class CandidateGain:
    """Predicted effect of adding one rig test (see :func:`rank_tests`)."""

    test: str
    newly_identified: list[str]
    stderr_pct_after: dict[str, float]  # every parameter, % of range (larger of the scales)
    mean_log_gain: float  # mean log10(stderr before / after) over the not identified
    still_not: list[str]
    n_determined_after: int = 0  # determined parameter combinations with the test added

    def to_dict(self) -> dict[str, Any]:
        return {
            "test": self.test,
            "newly_identified": self.newly_identified,
            "n_newly_identified": len(self.newly_identified),
            "mean_log10_stderr_reduction": self.mean_log_gain,
            "still_not_identified": self.still_not,
            "n_determined_combinations_after": self.n_determined_after,
            "stderr_pct_range_after": self.stderr_pct_after,
        }


def rank_tests(
    ident: Identifiability,
    J: np.ndarray,
    extra: Mapping[str, np.ndarray],
    u: np.ndarray,
    space: DesignSpace,
) -> list[CandidateGain]:
    """Candidate tests ``extra`` (test -> its Jacobian (N_t, dim), noise-scaled) ranked by
    the parameters they would newly identify, then by the parameter combinations they
    would newly determine (:func:`determined_directions`), then by the mean log
    reduction of the standard errors of the parameters not identified (best first)."""
    slope = np.abs(space.slope(u))
    rng = space.upper - space.lower
    before = np.array([max(v.stderr_pct, v.stderr_unit_pct) for v in ident.verdicts])
    was = ident.identified
    limit = TOLERANCE_PCT / K_SIGMA
    out = []
    for test, Jt in extra.items():
        stacked = np.vstack([J, Jt])
        cov = unit_covariance(stacked, ident.scale2, ident.rcond)
        se_u = np.sqrt(np.maximum(np.diag(cov), 0.0))
        after = np.maximum(100.0 * se_u * slope / rng, 100.0 * se_u)
        now = after <= limit
        new = [n for n, a, b in zip(space.names, was, now, strict=True) if b and not a]
        still = [n for n, b in zip(space.names, now, strict=True) if not b]
        gain = float(np.mean(np.log10(before[~was] / after[~was]))) if (~was).any() else 0.0
        out.append(
            CandidateGain(
                test,
                new,
                {n: float(a) for n, a in zip(space.names, after, strict=True)},
                gain,
                still,
                determined_directions(stacked, ident.scale2)[0],
            )
        )
    return sorted(
        out,
        key=lambda g: (-len(g.newly_identified), -g.n_determined_after, -g.mean_log_gain),
    )


def summary_counts(verdicts: Sequence[Verdict]) -> dict[str, int]:
    """Number of parameters per verdict kind."""
    out = {"identified": 0, "flat": 0, "correlated": 0}
    for v in verdicts:
        out[v.kind] = out.get(v.kind, 0) + 1
    return out
