"""The defaults used for what the recordings do not say, and the inputs left unread.

The family lists its defaults (``family.assumptions(setup)``, the setup holding the
final model: sentences such as "the sprung mass 300 kg (not declared)", and an estimate
as the final model holds it); this check puts them on the verdict's record, with
every recorded input channel the model does not read (:func:`unread_inputs`: its effect,
if it has one, stays in the residual), so that a report shows them on its first screen.
They never change the verdict's confidence.
"""

from __future__ import annotations

from dataclasses import replace

from suspenv.diagnosis.checks.finding import Context, Finding
from suspenv.diagnosis.family import Setup


def unread_inputs(setup: Setup) -> list[str]:
    """Input channels of the recordings the model does not read (none for a model that
    does not list its inputs)."""
    model = setup.model
    reads = set(getattr(model, "reads_inputs", getattr(model, "input_channels", ())))
    recs = setup.split.recordings()
    return sorted({k for rec in recs for k in rec.inputs} - reads) if reads else []


def run(ctx: Context) -> Finding | None:
    """The assumptions finding (None when the family made none and every input is read)."""
    ask = getattr(ctx.family, "assumptions", None)
    final = replace(ctx.setup, model=ctx.outcome.current.model)
    said = list(ask(final)) if ask is not None else []
    units = {k: u for rec in ctx.setup.split.recordings() for k, u in rec.units.items()}
    said += [
        f"the recorded input {k} [{units.get(k, '?')}] is not read by the "
        f"{ctx.setup.model.family} model (its effect, if any, stays in the residual)"
        for k in unread_inputs(ctx.setup)
    ]
    if not said:
        return None
    return Finding(
        "assumptions",
        sentence="assumed where the recordings do not say: " + "; ".join(said),
        numbers={"assumptions": said},
    )
