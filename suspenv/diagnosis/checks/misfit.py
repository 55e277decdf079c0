"""The share of each output's variance the final model describes.

Below :data:`MIN_EXPLAINED_SHARE` in some channel the recording is not of this model
(or a channel is swapped, in another unit, of the other sign): no verdict on missing
physics is given, and the finding's sentence stands in for it. Where the family knows
its noise variance (``family.noise_variance``: a spectral family's periodogram lines
scatter by a known law), the share is of the variance above that noise.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from suspenv.diagnosis.checks.finding import Context, Finding
from suspenv.diagnosis.fitting import FitResult, residuals
from suspenv.diagnosis.split import Split

#: the final model must describe at least this share of each output's variance for any
#: verdict on missing physics (module docstring)
MIN_EXPLAINED_SHARE = 0.5


def explained_share(
    fit: FitResult, sp: Split, noise: Mapping[str, float] | None = None
) -> dict[str, float]:
    """Per output channel, ``1 - var(residual) / var(measured)`` of the final model over
    the fit samples (1: perfect; 0: no better than the mean), both less the channel's
    known noise variance ``noise`` (channel unit squared) where given."""
    parts = residuals(fit.model, fit.theta, sp.fit_recordings, fit.channels, sp.fit_masks)
    sel = sp.fit_selections()
    out = {}
    for ch in fit.channels:
        r = np.concatenate([p[ch] for p in parts])
        recorded = zip(sp.fit_recordings, sel, strict=True)
        meas = np.concatenate([np.asarray(rec.outputs[ch], float)[m] for rec, m in recorded])
        known = float((noise or {}).get(ch, 0.0))
        var = float(np.var(meas)) - known
        out[ch] = 1.0 - (float(np.var(r)) - known) / var if var > 0 else 1.0
    return out


def run(ctx: Context) -> Finding:
    """``misfit`` (leading, not confident) where some channel's share is below
    :data:`MIN_EXPLAINED_SHARE`; ``explained_share`` otherwise."""
    noise = getattr(ctx.family, "noise_variance", None)
    share = explained_share(ctx.outcome.current, ctx.setup.split, noise)
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
