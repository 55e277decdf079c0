"""Parameters that ended on a fit bound: an element stretched to absorb something else.

A base parameter or a named element's parameter on its bound says the model is used
outside its range; the verdict then names nothing with confidence. A bound at zero is a
physical limit (no friction, no extra damping) and does not count.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from suspenv.diagnosis.checks.finding import Context, Finding
from suspenv.diagnosis.fitting import FitResult
from suspenv.diagnosis.hypothesis import Hypothesis

#: relative distance (of the bound span; in log(value) for positive bounds) within which
#: a fitted parameter counts as on its bound
BOUND_TOLERANCE = 1e-3


def parameters_at_bounds(fit: FitResult, named: Sequence[Hypothesis]) -> list[str]:
    """Base parameters and the named elements' parameters that ended on a fit bound, in
    words (``"c = 1e+06 N s/m at its upper bound"``)."""
    lo, hi = fit.model.bounds()
    names = list(fit.model.parameter_names)
    own = {k for h in named for k in h.params}
    base = set(fit.model.base_names) if hasattr(fit.model, "base_names") else set()
    units = list(getattr(fit.model, "parameter_units", [""] * len(names)))
    out = []
    for i, name in enumerate(names):
        if name not in own and name not in base:
            continue
        th, a, b = float(fit.theta[i]), float(lo[i]), float(hi[i])
        if not (np.isfinite(a) and np.isfinite(b) and b > a):
            continue
        if a > 0 and th > 0:
            # positive bounds span decades: distance measured in log(value)
            span = float(np.log(b / a))
            near_lo = np.log(th / a) <= BOUND_TOLERANCE * span
            near_hi = np.log(b / th) <= BOUND_TOLERANCE * span
        else:
            # a bound at zero is a physical limit (module docstring)
            near_lo = False
            near_hi = b - th <= BOUND_TOLERANCE * (b - a)
        if near_lo or near_hi:
            side = "lower" if near_lo else "upper"
            out.append(f"{name} = {th:.4g} {units[i]} at its {side} bound".replace("  ", " "))
    return out


def run(ctx: Context) -> Finding | None:
    """The bounds finding of the final model (None when nothing sits on a bound)."""
    if not (at_bound := parameters_at_bounds(ctx.outcome.current, ctx.outcome.named)):
        return None
    return Finding(
        "at_bounds",
        confident=False,
        sentence="parameter(s) ended at a bound, so the element is used outside its range "
        "to absorb something else: " + "; ".join(at_bound),
        numbers={"at_bounds": at_bound},
    )
