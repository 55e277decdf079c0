"""How a component is driven, and the component family's fit/held-out split.

The motion that drives a component is its deflection ``x`` [m] (positive =
compression / bump) and its velocity ``v`` [m/s], found among a recording's inputs by
name, or the measured deflection of a rig that imposes a road input (:func:`motion`).
The held-out data are the last part of each recording, interleaved motion cycles, or
separate recordings (:func:`split`). Its data suffice when the motion reverses often
enough (:func:`check_cycles`, the component families' ``check_data``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from scipy.integrate import cumulative_trapezoid

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.family import Setup
from suspenv.diagnosis.protocols import RecordingLike
from suspenv.diagnosis.split import Holdout, Recordings, Split, as_recordings, heldout_recordings
from suspenv.diagnosis.sufficiency import plural, recording_names

DISPLACEMENT_KEYS = ("x", "displacement", "deflection", "stroke", "position", "q", "travel")
VELOCITY_KEYS = ("v", "velocity", "speed", "qd", "stroke_velocity")
#: centre passes of the excitation needed in the fitted part of a component's recordings
MIN_FIT_PASSES = 3
#: centre passes needed in the held-out part (the motion reaches both sides)
MIN_HELDOUT_PASSES = 1
#: dead band of a centre pass, as a fraction of the motion's amplitude (half its 1-99 %
#: range): measured displacement noise stays below 1 % of a test's stroke
CYCLE_BAND = 0.05


def _find(d: Mapping[str, np.ndarray], keys: Sequence[str]) -> np.ndarray | None:
    lowered = {k.lower(): k for k in d}
    for k in keys:
        if k in lowered:
            return np.asarray(d[lowered[k]], float)
    for k in keys:  # prefix match, e.g. "position_measured"
        for low, orig in lowered.items():
            if low.startswith(k + "_") or low.startswith(k + " "):
                return np.asarray(d[orig], float)
    return None


def motion(rec: RecordingLike) -> tuple[np.ndarray, np.ndarray]:
    """Deflection ``x`` [m] and velocity ``v`` [m/s] driving the component in ``rec``."""
    t = np.asarray(rec.time, float)
    x = _find(rec.inputs, DISPLACEMENT_KEYS)
    v = _find(rec.inputs, VELOCITY_KEYS)
    if x is None and v is None:
        # a rig that imposes a road input and measures the deflection (quarter car)
        measured = [k for k in rec.outputs if "deflection" in k.lower()]
        if measured:
            x = np.asarray(rec.outputs[measured[0]], float)
    if x is None and v is None:
        if not rec.inputs:
            raise ValidationError(
                f"recording {rec.name!r} must have a motion input, but got no inputs"
            )
        x = np.asarray(next(iter(rec.inputs.values())), float)
    if x is None:
        assert v is not None  # one of the two was found above
        x = cumulative_trapezoid(v, t, initial=0.0)
    if v is None:
        v = np.gradient(x, t)
    return x, v


def stroke(sp: Split) -> tuple[float, float]:
    """Half the stroke [m] and the largest speed [m/s] of the fitted motion of ``sp``."""
    x_all = np.concatenate([motion(r)[0] for r in sp.fit_recordings])
    v_all = np.concatenate([motion(r)[1] for r in sp.fit_recordings])
    return 0.5 * float(np.ptp(x_all)), float(np.max(np.abs(v_all)))


def cycle_index(x: np.ndarray) -> np.ndarray:
    """Index of the motion cycle each sample belongs to (cycles start at the upward
    crossings of the deflection ``x`` [m] through its median; samples before the
    first crossing are cycle 0)."""
    xc = np.asarray(x, float) - float(np.median(x))
    starts = np.flatnonzero((xc[:-1] < 0.0) & (xc[1:] >= 0.0)) + 1
    return np.searchsorted(starts, np.arange(xc.size), side="right")


def interleaved_cycles(rec: RecordingLike, every: int = 4) -> np.ndarray:
    """Held-out mask: every ``every``-th motion cycle of ``rec`` (cycles 3, 7, 11, ...
    for ``every=4``), so fit and held-out data span the same amplitudes and speeds and
    each held-out block is a whole cycle (longer than the residual's correlation)."""
    if not (isinstance(every, int) and every >= 2):
        raise ValidationError(f"`every >= 2` (an integer) must hold, but got every={every!r}")
    cyc = cycle_index(motion(rec)[0])
    if cyc.max() + 1 < every:
        raise ValidationError(
            f"interleaved cycle hold-out needs at least {every} motion cycles, but recording "
            f"{rec.name!r} has {int(cyc.max()) + 1}"
        )
    return (cyc % every) == every - 1


def split(recordings: Recordings, holdout: Holdout) -> Split:
    """``holdout``: a fraction in (0, 1) (the last part of each recording is held
    out), ``"cycles"`` / ``"cycles:N"`` (every N-th motion cycle held out, N = 4 by
    default: see :func:`interleaved_cycles`), or one or more recordings not used for
    fitting."""
    recs = as_recordings(recordings)
    if holdout is None:
        holdout = 0.3
    if isinstance(holdout, str):
        head, _, num = holdout.partition(":")
        if head != "cycles":
            raise ValidationError(
                f"a text hold-out must be 'cycles' or 'cycles:N', but got holdout={holdout!r}"
            )
        try:
            every = int(num) if num else 4
        except ValueError:
            raise ValidationError(
                f"'cycles:N' needs an integer N, but got holdout={holdout!r}"
            ) from None
        hold_m = [interleaved_cycles(r, every) for r in recs]
        return Split(
            recs,
            [~m for m in hold_m],
            recs,
            hold_m,
            f"one motion cycle in {every} of each recording (interleaved: same speeds as the fit)",
            cycles_every=every,
        )
    if isinstance(holdout, float | int) and not isinstance(holdout, bool):
        f = float(holdout)
        if not 0.0 < f < 1.0:
            raise ValidationError(f"`0 < holdout < 1` must hold, but got holdout={f}")
        fit_m = [np.arange(len(r.time)) < int(round(len(r.time) * (1.0 - f))) for r in recs]
        hold_m = [~m for m in fit_m]
        return Split(recs, fit_m, recs, hold_m, f"last {100 * f:.0f} % of each recording")
    return Split.separate(recs, heldout_recordings(holdout))


def centre_passes(x: np.ndarray, band: float = CYCLE_BAND) -> int:
    """How often the motion ``x`` passes from one side of its median to the other,
    outside a dead band of ``band`` times its amplitude (half its 1-99 % range)."""
    xc = np.asarray(x, float) - float(np.median(x)) if np.size(x) else np.zeros(0)
    if xc.size < 2:
        return 0
    lo, hi = np.percentile(xc, [1.0, 99.0])
    amp = 0.5 * float(hi - lo)
    if not amp > 0.0:
        return 0
    side = np.where(xc > band * amp, 1, np.where(xc < -band * amp, -1, 0))
    side = side[side != 0]
    return int(np.count_nonzero(side[1:] != side[:-1])) if side.size else 0


def _part_passes(recs: Sequence[RecordingLike], masks: Sequence[np.ndarray | None] | None) -> int:
    xs = [motion(rec)[0] for rec in recs]
    parts = [x if masks is None or masks[i] is None else x[masks[i]] for i, x in enumerate(xs)]
    return sum(centre_passes(x) for x in parts)


def check_cycles(setup: Setup) -> None:
    """Refuse a component's recordings whose excitation (the deflection driving it)
    passes its centre fewer than :data:`MIN_FIT_PASSES` times in the fitted part (two
    full cycles: ``k`` periods of a sine pass their centre ``2k - 1`` times) or
    :data:`MIN_HELDOUT_PASSES` time in the held-out part (it reaches both sides of the
    motion): hysteresis, friction and bump/rebound asymmetry show only where the motion
    reverses, both ways, more than once. A pass is the motion crossing from one side of
    its median to the other, outside a dead band of :data:`CYCLE_BAND` of its amplitude,
    so that noise is not counted (:func:`centre_passes`). Raises
    :class:`~suspenv.core.errors.ValidationError` naming the recordings and the counts."""
    sp = setup.split
    fit = _part_passes(sp.fit_recordings, sp.fit_masks)
    held = _part_passes(sp.heldout_recordings, sp.heldout_masks)
    if fit >= MIN_FIT_PASSES and held >= MIN_HELDOUT_PASSES:
        return
    raise ValidationError(
        f"{recording_names(sp)}: the excitation passes its centre {plural(fit, 'time')} in the "
        f"fitted part and {plural(held, 'time')} in the held-out part ({sp.description}); "
        f"a diagnosis of the {setup.model.family} model needs at least {MIN_FIT_PASSES} "
        f"(two full cycles: k periods of a sine pass their centre 2k - 1 times) and "
        f"{MIN_HELDOUT_PASSES} (both sides of the motion): friction, hysteresis and "
        "bump/rebound asymmetry show only where the motion reverses, both ways, more than "
        "once (a pass: the deflection crossing its median, outside a dead band of "
        f"{100 * CYCLE_BAND:g} % of its amplitude)"
    )
