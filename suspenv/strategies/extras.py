"""Optional packages of the strategy adapters, and the values told to libraries that take
no failed or infeasible designs.

An adapter imports its optional package when it is built, never when its module is
imported: ``suspenv list`` and the registry name every adapter whether or not its package
is installed, and building one without it raises :class:`MissingExtraError`, a
:class:`~suspenv.core.errors.ValidationError` naming the package and the pip extra::

    optuna_gp: needs the optional package 'torch' (No module named 'torch'); install it
        with `pip install 'suspenv[optuna-gp]'`
"""

from __future__ import annotations

import importlib
from types import ModuleType

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.result import EvaluationBatch

#: loss told for a failed design (every objective): large and finite, far below the values
#: where libraries clip or overflow (nevergrad clips at 5e20)
FAILED_LOSS = 1e12
#: an infeasible design is told ``INFEASIBLE_LOSS * (2 - 1 / (1 + violation))``: in
#: [1e9, 2e9), growing with the total violation, above any objective below 1e9 and below
#: FAILED_LOSS
INFEASIBLE_LOSS = 1e9


class MissingExtraError(ValidationError):
    """An adapter's optional package is not importable; the message names the pip extra."""

    def __init__(self, owner: str, package: str, extra: str, reason: str = ""):
        self.owner, self.package, self.extra = owner, package, extra
        why = f" ({reason})" if reason else ""
        super().__init__(
            f"{owner}: needs the optional package {package!r}{why}; install it with "
            f"`pip install 'suspenv[{extra}]'`"
        )


def require(owner: str, package: str, extra: str) -> ModuleType:
    """Import ``package`` (a module name) for strategy ``owner``, or raise
    :class:`MissingExtraError` naming the pip ``extra`` that installs it."""
    try:
        return importlib.import_module(package)
    except ImportError as exc:
        raise MissingExtraError(owner, package, extra, str(exc)) from exc


def told_losses(batch: EvaluationBatch) -> np.ndarray:
    """Finite losses (n, m) for libraries that compare values across batches.

    Feasible designs keep their objectives; an infeasible design gets
    ``INFEASIBLE_LOSS * (2 - 1 / (1 + violation))`` in every objective (ordered by its total
    violation, worse than any objective below 1e9; an unknown constraint value counts as
    an infinite violation); a failed design (or one with a non-finite objective) gets
    ``FAILED_LOSS``. The values depend on the row alone, never on
    the rest of the batch, so a value told in one batch compares with one told in another.
    """
    F = np.asarray(batch.objectives, dtype=float)
    ok = batch.rankable
    # an unknown (NaN) constraint value counts as infeasible, as in EvaluationBatch.feasible
    v = np.where(ok, np.nan_to_num(np.asarray(batch.violation, dtype=float), nan=np.inf), 0.0)
    infeasible = ok & (v > 0)
    out = np.where(ok[:, None], F, FAILED_LOSS)
    penalty = INFEASIBLE_LOSS * (2.0 - 1.0 / (1.0 + v))
    out[infeasible] = penalty[infeasible, None]
    return np.asarray(out, dtype=float)
