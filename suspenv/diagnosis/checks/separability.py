"""Look-alikes: what the data cannot tell apart from each element the search named.

For every round of the search, in order: the significant runners-up of another
signature family that fit as well as the round's best, or that an input the recording
does not carry makes inseparable from it where the fits profile that input out
(:func:`~suspenv.diagnosis.decision.ambiguities`); then, where the best was named, the
family's own look-alike pairs (``family.ambiguities(winner, ranked, parent, setup)``,
e.g. a component element and the combination of two others it equals on most data, a
K&C element at another location), each with the test that would separate them. The
check reads the search's record as the search left it (it runs before the checks that
name or withdraw elements): each round's hypotheses in rank order and the model each
winner was added to.
"""

from __future__ import annotations

from suspenv.diagnosis.checks.finding import Context
from suspenv.diagnosis.decision import ambiguities
from suspenv.diagnosis.family import Conclusion


def run(ctx: Context) -> Conclusion | None:
    """The look-alikes of every round, in the order of the rounds."""
    o, found = ctx.outcome, Conclusion()
    own = getattr(ctx.family, "ambiguities", None)
    parent = o.base
    stretches = getattr(o.base.model, "stretches", None)  # the profile, on every model
    profiled = None if stretches is None else str(stretches.channel)
    for round_ in sorted({h.round for h in o.hypotheses}):
        # refits that failed carry no fit; the others are in rank order
        ranked = [h for h in o.hypotheses if h.round == round_ and h.fit is not None]
        found.ambiguities += ambiguities(ranked, profiled)
        if not ranked or not ranked[0].significant:
            break
        winner = ranked[0]
        if own is not None:
            found.ambiguities += own(winner, ranked, parent, ctx.setup)
        assert winner.fit is not None
        parent = winner.fit
    return found if found.ambiguities else None
