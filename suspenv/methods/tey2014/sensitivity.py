"""Global sensitivity by Spearman rank correlation (Tey et al. 2014, step 2).

For every parameter i and objective j, rho_ij is Spearman's rank correlation over the
design of experiments and p_ij the two-sided p-value of the test of no correlation
(Student t with n - 2 degrees of freedom, the usual large-sample test). Coefficients
whose p-value exceeds ``alpha`` (0.05 in the paper) are treated as 0.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from suspenv.core.errors import ValidationError
from suspenv.core.options import number


@dataclass
class SensitivityResult:
    """Spearman matrix of parameters (rows) against objectives (columns).

    Attributes:
        rho: (d, m) Spearman coefficients (0 where a column is constant).
        pvalue: (d, m) two-sided p-values of the no-correlation test (1 where constant).
        alpha: significance level; ``p > alpha`` is treated as no correlation.
        param_names, objective_names: labels of rows and columns.
        n_samples: number of designs used.
    """

    rho: np.ndarray
    pvalue: np.ndarray
    alpha: float
    param_names: tuple[str, ...]
    objective_names: tuple[str, ...]
    n_samples: int

    @property
    def significant(self) -> np.ndarray:
        """(d, m) True where ``p <= alpha``."""
        return self.pvalue <= self.alpha

    @property
    def rho_significant(self) -> np.ndarray:
        """(d, m) coefficients with the insignificant ones set to 0."""
        return np.where(self.significant, self.rho, 0.0)

    @property
    def objective_vectors(self) -> np.ndarray:
        """(m, d): each objective described by its vector of significant coefficients."""
        return self.rho_significant.T

    def insensitive_parameters(self) -> list[str]:
        """Parameters with no significant correlation to any objective."""
        any_significant = np.asarray(self.significant.any(axis=1))  # (d,)
        return [n for n, s in zip(self.param_names, any_significant, strict=True) if not s]


def column_names(
    names: Sequence[str] | None,
    n: int,
    prefix: str = "f",
    what: str = "names",
    count: str = "n_objectives",
) -> tuple[str, ...]:
    """``names`` as a tuple, one per column of ``n`` (None: ``<prefix>0``, ``<prefix>1``
    ...); another count is refused naming ``what`` and ``count``."""
    out = tuple(names) if names is not None else tuple(f"{prefix}{j}" for j in range(n))
    if len(out) != n:
        raise ValidationError(
            f"`len({what}) == {count}` must hold, but got (len({what})={len(out)}, {count}={n})"
        )
    return out


def _standardised_ranks(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Column ranks (ties averaged), centred, unit norm; also which columns are constant."""
    R = stats.rankdata(A, axis=0)
    R = R - R.mean(axis=0)
    norm = np.sqrt((R**2).sum(axis=0))
    constant = norm <= 1e-12 * max(1.0, A.shape[0])
    return R / np.where(constant, 1.0, norm), constant


def spearman_matrix(
    X: np.ndarray,
    F: np.ndarray,
    alpha: float = 0.05,
    param_names: Sequence[str] | None = None,
    objective_names: Sequence[str] | None = None,
) -> SensitivityResult:
    """Spearman rank correlation of every column of X (n, d) with every column of F (n, m).

    Rows of F that are not finite are dropped (failed evaluations) before ranking.
    """
    X = np.asarray(X, dtype=float)
    F = np.asarray(F, dtype=float)
    if X.ndim != 2 or F.ndim != 2 or X.shape[0] != F.shape[0]:
        raise ValidationError(
            "X and F must be 2-D with the same number of rows, but got "
            f"(X.shape={X.shape}, F.shape={F.shape})"
        )
    number("sensitivity", "alpha", alpha, 0.0, 1.0, lo_open=True, hi_open=True)
    keep = np.isfinite(F).all(axis=1) & np.isfinite(X).all(axis=1)
    n = int(keep.sum())
    if n < 4:
        raise ValidationError(
            f"Spearman sensitivity needs `n_valid_rows >= 4`, but got n_valid_rows={n}"
        )
    d, m = X.shape[1], F.shape[1]
    pn = column_names(param_names, d, "x", "param_names", "d")
    on = column_names(objective_names, m, "f", "objective_names", "m")
    Zx, cx = _standardised_ranks(X[keep])
    Zf, cf = _standardised_ranks(F[keep])
    rho = np.clip(Zx.T @ Zf, -1.0, 1.0)
    constant = cx[:, None] | cf[None, :]
    rho[constant] = 0.0
    dof = n - 2
    with np.errstate(divide="ignore", invalid="ignore"):
        t = rho * np.sqrt(dof / np.maximum((1.0 - rho) * (1.0 + rho), 0.0))
    p = 2.0 * stats.t.sf(np.abs(t), dof)
    p = np.where(np.abs(rho) >= 1.0, 0.0, p)
    p[constant] = 1.0
    return SensitivityResult(rho, p, float(alpha), pn, on, n)
