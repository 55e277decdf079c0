"""The defaults used for what the recordings do not say.

The family lists them (``family.assumptions(setup)``: sentences such as "the sprung
mass 300 kg (not declared)"); this check puts them on the verdict's record so that a
report shows them on its first screen. They never change the verdict's confidence.
"""

from __future__ import annotations

from suspenv.diagnosis.checks.finding import Context, Finding


def run(ctx: Context) -> Finding | None:
    """The assumptions finding (None when the family made none)."""
    ask = getattr(ctx.family, "assumptions", None)
    said = list(ask(ctx.setup)) if ask is not None else []
    if not said:
        return None
    return Finding(
        "assumptions",
        sentence="assumed where the recordings do not say: " + "; ".join(said),
        numbers={"assumptions": said},
    )
