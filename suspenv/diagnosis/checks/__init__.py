"""The checks after the search: what a verdict may say, for every family.

Each check is a module with ``run(ctx) -> Finding`` (:class:`Context` in,
:class:`Finding` out). A check never imports a family: it asks the family through the
optional steps of :mod:`suspenv.diagnosis.family` (``residual_left``, ``assumptions``,
``ambiguities``), so a new family gets honest verdicts the day it joins. The other
checks read only the final fit and the recordings (:mod:`.missing_input`,
:mod:`.switched_element`, :mod:`.bounds`, :mod:`.misfit`).

:func:`run` runs them in order, each result folded (:func:`fold`) before the next reads
the model it leaves; :func:`refuse` runs a family's refit checks during the search.
"""

from __future__ import annotations

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.checks import (
    assumptions,
    bounds,
    misfit,
    missing_input,
    residual_left,
    separability,
    switched_element,
)
from suspenv.diagnosis.checks.finding import Check, Context, Finding, fold, revise

__all__ = ["Check", "Context", "Finding", "fold", "refuse", "revise", "run"]


def _checks() -> tuple[Check, ...]:
    # their leading sentences follow the family's in this order (the misfit's last)
    return (
        residual_left.run,
        missing_input.run,
        switched_element.run,
        bounds.run,
        assumptions.run,
        misfit.run,
    )


def run(ctx: Context) -> None:
    """Run the look-alikes, the family's own checks, then this package's others on
    ``ctx`` in order; a check with nothing to say returns None."""
    own = getattr(ctx.family, "checks", tuple)
    for check in [separability.run, *own(), *_checks()]:
        fold(ctx, check(ctx))


def refuse(ctx: Context) -> None:
    """Run the family's refit checks (``family.refit_checks()``) on the refit of
    ``ctx`` in order; the first that returns a :class:`Finding` refuses the refit:
    :class:`~suspenv.core.errors.ValidationError` with its sentence (the loop records
    the hypothesis as failed with it)."""
    for check in getattr(ctx.family, "refit_checks", tuple)():
        found = check(ctx)
        if isinstance(found, Finding):
            raise ValidationError(found.sentence)
