"""The records of locating and screening, shared by every diagnosis family.

* :class:`Share` / :class:`Location`: where the residual energy lives. Every partition
  of the samples reports, per part, the *share* of residual energy (each channel divided
  by its scale so channels compare), the *fraction* of samples in the part and their
  ratio, the *enrichment* (1: spread like the samples; 3: three times its fair share).
* :class:`Signature`: a screening score of a signature family or a candidate, with its
  p-value, evidence in words and numbers in the channel's units.
* :func:`effective_n`: the effective sample size of a serially correlated residual;
  :func:`orthonormal_basis`: the span of a baseline Jacobian a screen projects off;
  :func:`partial_r2` / :func:`score_p_value`: what features explain outside it, p-value.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from suspenv.diagnosis.fitting import ar1_effective_size, lag1_autocorrelation
from suspenv.diagnosis.record import Record

#: a part is a hotspot when it holds this much more than its fair share ...
HOTSPOT_ENRICHMENT = 1.5
#: ... and at least this share of the residual energy
HOTSPOT_SHARE = 0.2


@dataclass
class Share(Record):
    """One part of one partition."""

    dimension: str
    part: str
    share: float
    fraction: float
    derived = ("enrichment",)

    @property
    def enrichment(self) -> float:
        return self.share / self.fraction if self.fraction > 0 else float("nan")


@dataclass
class Location:
    """All partitions of the residual energy; see :func:`locate`."""

    shares: list[Share] = field(default_factory=list)

    def by_dimension(self, dimension: str) -> list[Share]:
        return [s for s in self.shares if s.dimension == dimension]

    def dimensions(self) -> list[str]:
        return list(dict.fromkeys(s.dimension for s in self.shares))

    def hotspots(self) -> list[Share]:
        """Parts holding a clearly unfair share of the residual, strongest first.

        Frequency bands are left out: a band's fair share is its share of spectral
        lines, against which any smooth residual looks concentrated.
        """
        hot = [
            s
            for s in self.shares
            if s.dimension != "frequency band"
            and s.share >= HOTSPOT_SHARE
            and s.fraction < 0.9
            and s.enrichment >= HOTSPOT_ENRICHMENT
        ]
        return sorted(hot, key=lambda s: -s.enrichment)

    def to_dict(self) -> dict[str, object]:
        return {
            "shares": [s.to_dict() for s in self.shares],
            "hotspots": [s.to_dict() for s in self.hotspots()],
        }


@dataclass
class Signature(Record):
    """A detector's verdict: score in [0, 1], p-value, evidence sentence and numbers;
    ``channel``: the recorded channel it was scored in ("" where it is the model's own
    output or force view)."""

    kind: str
    score: float
    p_value: float
    evidence: str
    numbers: dict[str, float] = field(default_factory=dict)
    channel: str = ""


def effective_n(r: np.ndarray) -> float:
    """Effective number of independent samples of a serially correlated series
    (:func:`~suspenv.diagnosis.fitting.ar1_effective_size`, lag-1 autocorrelation at most
    0.999), at least 2."""
    return max(ar1_effective_size(r.size, min(lag1_autocorrelation(r), 0.999)), 2.0)


def orthonormal_basis(J: np.ndarray | None) -> np.ndarray | None:
    """Orthonormal columns spanning the columns of the Jacobian ``J`` (n, p) (singular
    values above 1e-8 of the largest), or None for no Jacobian."""
    if J is None or J.size == 0:
        return None
    U, s, _ = np.linalg.svd(J, full_matrices=False)
    keep = s > s[0] * 1e-8 if s.size else np.zeros(0, bool)
    return U[:, keep]


def partial_r2(
    residual: np.ndarray, features: np.ndarray, basis: np.ndarray | None
) -> tuple[float, np.ndarray, np.ndarray]:
    """Partial R² of ``residual`` on ``features`` (n, q) outside span(basis) (orthonormal
    columns, :func:`orthonormal_basis`; None: no projection); a feature left with less than
    1e-6 of its norm explains nothing.

    Returns (r2, coefficients on the projected features, fitted part).
    """
    F = np.atleast_2d(features.T).T.astype(float)
    if basis is not None:
        F = F - basis @ (basis.T @ F)
    norms = np.linalg.norm(F, axis=0)
    raw = np.linalg.norm(np.atleast_2d(features.T).T, axis=0)
    ok = norms > 1e-6 * np.maximum(raw, 1e-300)
    coef = np.zeros(F.shape[1])
    den = float(np.dot(residual, residual))
    if not np.any(ok) or den <= 0:
        return 0.0, coef, np.zeros_like(residual)
    c, *_ = np.linalg.lstsq(F[:, ok], residual, rcond=None)
    coef[ok] = c
    fitted = F[:, ok] @ c
    r2 = float(np.clip(1.0 - np.sum((residual - fitted) ** 2) / den, 0.0, 1.0))
    return r2, coef, fitted


def score_p_value(r2: float, remainder: np.ndarray, q: int = 1) -> float:
    """Score-test p-value of a partial R² ``r2`` of ``q`` features: ``n_eff R²`` ~ chi2(q),
    ``n_eff`` (:func:`effective_n`) from what the features leave, ``remainder``."""
    return float(stats.chi2.sf(effective_n(remainder) * r2, max(q, 1)))
