"""The records of locating and screening, shared by every diagnosis family.

* :class:`Share` / :class:`Location`: where the residual energy lives. Every partition
  of the samples reports, per part, the *share* of residual energy (each channel
  divided by its scale so channels compare), the *fraction* of samples in the part and
  their ratio, the *enrichment* (1: spread like the samples; 3: three times its fair
  share).
* :class:`Signature`: a screening score of a signature family or a candidate, with its
  p-value, evidence in words and numbers in the channel's units.
* :func:`effective_n`: the effective sample size of a serially correlated residual;
  :func:`orthonormal_basis`: the span of a baseline Jacobian a screen projects off.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from suspenv.diagnosis.fitting import lag1_autocorrelation

#: a part is a hotspot when it holds this much more than its fair share ...
HOTSPOT_ENRICHMENT = 1.5
#: ... and at least this share of the residual energy
HOTSPOT_SHARE = 0.2


@dataclass
class Share:
    """One part of one partition."""

    dimension: str
    part: str
    share: float
    fraction: float

    @property
    def enrichment(self) -> float:
        return self.share / self.fraction if self.fraction > 0 else float("nan")

    def to_dict(self) -> dict[str, float | str]:
        d = asdict(self)
        d["enrichment"] = self.enrichment
        return d


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
class Signature:
    """A detector's verdict: score in [0, 1], p-value, evidence sentence and numbers;
    ``channel``: the recorded channel it was scored in ("" where it is the model's own
    output or force view)."""

    kind: str
    score: float
    p_value: float
    evidence: str
    numbers: dict[str, float] = field(default_factory=dict)
    channel: str = ""

    def to_dict(self) -> dict[str, object]:
        return asdict(self)


def effective_n(r: np.ndarray) -> float:
    """Effective number of independent samples of a serially correlated series (AR(1))."""
    rho = float(np.clip(lag1_autocorrelation(r), 0.0, 0.999))
    return max(r.size * (1.0 - rho) / (1.0 + rho), 2.0)


def orthonormal_basis(J: np.ndarray | None) -> np.ndarray | None:
    """Orthonormal columns spanning the columns of the Jacobian ``J`` (n, p) (singular
    values above 1e-8 of the largest), or None for no Jacobian."""
    if J is None or J.size == 0:
        return None
    U, s, _ = np.linalg.svd(J, full_matrices=False)
    keep = s > s[0] * 1e-8 if s.size else np.zeros(0, bool)
    return U[:, keep]
