"""The checks after the search: what a verdict may say, for every family.

Each check is a module with ``run(ctx) -> Finding`` (:class:`Context` in,
:class:`Finding` out). A check never imports a family: it asks the family questions
through optional methods (:class:`~suspenv.diagnosis.family.OptionalSteps` gives their
defaults), so a new family gets honest verdicts the day it joins:

* ``residual_left(outcome, setup, alpha)``: the family's noise model, views of the final
  model's residual in its noise units with the family's limit (:mod:`.residual_left`);
* ``assumptions(setup)``: the defaults used for what the recordings do not say
  (:mod:`.assumptions`).

* ``ambiguities(winner, ranked, parent, setup)``: the family's look-alike pairs of a
  named element, said beside the loop's own rule (:mod:`.separability`, which runs
  first: it reads the search's record as the search left it).

The other checks read only the final fit and the recordings: a residual driven by an
input the recording does not carry (:mod:`.missing_input`) and the elements whose
improvement rests on it (:mod:`.switched_element`), parameters on a bound
(:mod:`.bounds`), the share of each output the model describes (:mod:`.misfit`).

:func:`run` runs the look-alikes, a family's own checks (``family.checks()``), then
these, each result folded (:func:`fold`) before the next reads the model it leaves: a
family's check may return a :class:`~suspenv.diagnosis.family.Conclusion` that names or
withdraws elements. During the search, :func:`refuse` runs a family's refit checks
(``family.refit_checks()``, e.g. :mod:`.plausible`) on each refit.
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
