"""The share of each output's variance the final model describes.

Below :data:`MIN_EXPLAINED_SHARE` in some channel the recording is not of this model
(or a channel is swapped, in another unit, of the other sign): no verdict on missing
physics is given, and the finding's sentence stands in for it.
"""

from __future__ import annotations

import numpy as np

from suspenv.diagnosis.checks.finding import Context, Finding
from suspenv.diagnosis.fitting import FitResult, residuals
from suspenv.diagnosis.split import Split

#: the final model must describe at least this share of each output's variance for any
#: verdict on missing physics (below it the recording is not of this component, or a
#: channel is misread: no library effect can be meaningfully named)
MIN_EXPLAINED_SHARE = 0.5


def explained_share(fit: FitResult, sp: Split) -> dict[str, float]:
    """Per output channel, ``1 - var(residual) / var(measured)`` of the final model over
    the fit samples (1: perfect; 0: no better than the mean)."""
    parts = residuals(fit.model, fit.theta, sp.fit_recordings, fit.channels, sp.fit_masks)
    out = {}
    for ch in fit.channels:
        r = np.concatenate([p[ch] for p in parts])
        meas = np.concatenate(
            [
                np.asarray(rec.outputs[ch], float)[
                    slice(None) if sp.fit_masks is None else sp.fit_masks[i]
                ]
                for i, rec in enumerate(sp.fit_recordings)
            ]
        )
        var = float(np.var(meas))
        out[ch] = 1.0 - float(np.var(r)) / var if var > 0 else 1.0
    return out


def run(ctx: Context) -> Finding:
    """``misfit`` (leading, not confident) where some channel's share is below
    :data:`MIN_EXPLAINED_SHARE`; ``explained_share`` otherwise."""
    share = explained_share(ctx.outcome.current, ctx.setup.split)
    worst = min(share.values(), default=1.0)
    if worst >= MIN_EXPLAINED_SHARE:
        return Finding("explained_share", numbers={"share": share})
    ch = min(share, key=lambda c: share[c])
    return Finding(
        "misfit",
        confident=False,
        sentence=f"the model describes only {100 * max(worst, 0.0):.0f} % of the variance of "
        f"{ch}: the recording may not be of a {ctx.setup.model.family} on this rig, or a "
        "channel is swapped, in another unit or of the other sign; no verdict on "
        "missing physics is given",
        lead=True,
        numbers={"share": share},
    )
