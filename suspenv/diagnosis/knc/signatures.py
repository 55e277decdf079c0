"""Residual signatures of K&C loops: what the generic (time-series) signatures cannot say.

Every signature is a *score test* on the baseline's scaled residual ``r`` (channel
residual divided by its noise level, estimated from the residual's roughness by
:func:`suspenv.diagnosis.knc.locate.residual_map`, so ``r`` is about unit white noise
where the model is right): ``r`` is projected onto the pattern the effect would leave, and the
projection's chi-square ``q`` with ``k`` basis columns is turned into
``score = (q - k) / sqrt(2 k)`` (about N(0, 1) under pure noise; large when the
pattern is there). The score is taken per recorded channel (sides and tests pooled)
and the family's score is the largest over the channels, so an effect that shows in
one channel only (a wheel-load loop) is not diluted by the quiet ones. Patterns, in
each side's own drive ``p`` (pad travel, or contact-point force in the wheel's own
sense, over the amplitude: :func:`~suspenv.measurements.knc.drive`) and along
the loop's branch (``b = +1`` rising, ``-1`` falling):

* ``loop`` (hysteresis, friction): ``b`` and ``b p`` per channel and side: the two
  half-loops differ (a loop opens between bump and rebound);
* ``lr_asymmetry``: ``+-1, +-p, +-p^2`` (+ on the left, - on the right) per channel: left
  and right residuals differ although the model is symmetric;
* ``progressive``: ``p^3`` per channel and side, same sign on both sides;
* ``sensor_gain``: the wheel-load prediction itself (residual proportional to signal);
* ``sensor_offset``: a constant on the wheel-load channels.

Units: dimensionless (residuals are in noise units).
"""

from __future__ import annotations

from collections.abc import Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.diagnosis.record import Record
from suspenv.measurements.knc import CHANNELS, SIDES, drive, reading_drive

#: signature family -> effect kinds it points to
FAMILY_KINDS = {
    "loop": ("dahl_hysteresis", "coulomb_friction"),
    "lr_asymmetry": ("lr_asymmetry",),
    "progressive": ("cubic_stiffness",),
    "sensor_gain": ("sensor_gain",),
    "sensor_offset": ("sensor_offset",),
}
#: effect kind -> K&C signature family (the screen's grouping)
SCREEN_FAMILY = {k: fam for fam, kinds in FAMILY_KINDS.items() for k in kinds}
FAMILY_WORDS = {
    "loop": "bump and rebound half-loops differ (a hysteresis loop)",
    "lr_asymmetry": "left and right residuals differ",
    "progressive": "residual grows with the cube of the travel",
    "sensor_gain": "wheel-load residual proportional to the load",
    "sensor_offset": "constant wheel-load residual",
}


@dataclass
class KncSignature(Record):
    """Score of one signature family (see the module docstring)."""

    kind: str
    score: float
    chi2: float
    dof: int
    evidence: str
    numbers: dict[str, float] = field(default_factory=dict)


def _fitted(cols: Sequence[np.ndarray], r: np.ndarray) -> tuple[np.ndarray, int]:
    """Least-squares projection of ``r`` on the span of ``cols`` and that span's rank."""
    A = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(A, r, rcond=None)
    return A @ coef, int(np.linalg.matrix_rank(A))


@dataclass(frozen=True)
class PatternBlock:
    """One block of a family's pattern: the residual series ``keys`` (stacked in that
    order) and the basis columns ``cols`` the effect would leave in them."""

    family: str
    channel: str
    keys: tuple[str, ...]
    cols: list[np.ndarray]


def pattern_blocks(
    rec: Any, keys: Collection[str], pred: Mapping[str, np.ndarray], scales: Mapping[str, float]
) -> Iterator[PatternBlock]:
    """The pattern blocks (module docstring) of K&C recording ``rec`` over the channels
    whose residual ``keys`` (``"channel_side"``) hold both sides; ``pred`` holds the
    model's channels (channel unit), divided by ``scales`` for the gain pattern."""
    b = np.where(rec.inputs["branch"] == 1, -1.0, 1.0)
    p = {s: drive(rec, s) for s in SIDES}
    for c in [c for c in CHANNELS if all(f"{c}_{s}" in keys for s in SIDES)]:
        for s in SIDES:
            yield PatternBlock("loop", c, (f"{c}_{s}",), [b, b * p[s]])
            yield PatternBlock("progressive", c, (f"{c}_{s}",), [p[s] ** 3])
        # left/right: one stacked series, +pattern on the left, -pattern on the right,
        # in each side's own drive (opposite travel and the lateral force mirror the
        # right side); single-wheel travel: the left pad's travel
        pr = reading_drive(rec, "right")
        cols = [
            np.concatenate([np.ones_like(p["left"]), -np.ones_like(pr)]),
            np.concatenate([p["left"], -pr]),
            np.concatenate([p["left"] ** 2, -(pr**2)]),
        ]
        yield PatternBlock("lr_asymmetry", c, (f"{c}_left", f"{c}_right"), cols)
        if c == "tyre_fz":
            for s in SIDES:
                y = np.asarray(pred[f"tyre_fz_{s}"], float) / scales[f"tyre_fz_{s}"]
                yield PatternBlock("sensor_gain", c, (f"tyre_fz_{s}",), [y])
                yield PatternBlock("sensor_offset", c, (f"tyre_fz_{s}",), [np.ones_like(y)])


def without_pattern(
    recs: Sequence[Any],
    residual: Sequence[Mapping[str, np.ndarray]],
    prediction: Sequence[Mapping[str, np.ndarray]],
    scales: Mapping[str, float],
    family: str,
) -> list[dict[str, np.ndarray]]:
    """The residuals (channel unit) with ``family``'s pattern blocks projected out (least
    squares per block, :func:`pattern_blocks`); the other series are copied as they are."""
    out = []
    for rec, res, pred in zip(recs, residual, prediction, strict=True):
        r = {k: np.asarray(v, float).copy() for k, v in res.items()}
        for blk in pattern_blocks(rec, r, pred, scales):
            if blk.family != family:
                continue
            y = np.concatenate([r[k] for k in blk.keys])
            rest = np.split(y - _fitted(blk.cols, y)[0], len(blk.keys))
            r.update(zip(blk.keys, rest, strict=True))
        out.append(r)
    return out


def score_signatures(
    recs: Sequence[Any],
    residual: Sequence[Mapping[str, np.ndarray]],
    prediction: Sequence[Mapping[str, np.ndarray]],
    scales: Mapping[str, float],
) -> list[KncSignature]:
    """Signatures of the residual ``residual[i][channel]`` (channel unit) of each K&C
    recording ``recs[i]``, strongest first; ``prediction`` holds the model's channels."""
    # chi2 and rank per family and channel: the blocks are disjoint series, so they add
    per: dict[str, dict[str, list[float]]] = {f: {} for f in FAMILY_KINDS}
    loop_width = []
    for rec, res, pred in zip(recs, residual, prediction, strict=True):
        for blk in pattern_blocks(rec, res, pred, scales):
            r = np.concatenate([np.asarray(res[k], float) / scales[k] for k in blk.keys])
            fitted, rank = _fitted(blk.cols, r)
            acc = per[blk.family].setdefault(blk.channel, [0.0, 0])
            acc[0] += float(fitted @ fitted)
            acc[1] += max(rank, 1)
        if all(f"tyre_fz_{s}" in res for s in SIDES):
            up = rec.inputs["branch"] != 1
            for s in SIDES:
                raw = np.asarray(res[f"tyre_fz_{s}"], float)
                loop_width.append(float(np.mean(raw[up]) - np.mean(raw[~up])))
    out = []
    for fam, chans in per.items():
        if not chans:
            continue
        scores = {c: float((q - k) / np.sqrt(2.0 * k)) for c, (q, k) in chans.items()}
        where = max(scores, key=lambda c: scores[c])
        q, k = chans[where]
        numbers = {f"score_{c}": float(v) for c, v in scores.items()}
        if fam == "loop" and loop_width:
            numbers["tyre_fz_loop_width_n"] = float(np.mean(loop_width))
        words = f"{FAMILY_WORDS[fam]}: strongest in {where}, chi2 {q:.1f} on {k} dof"
        out.append(KncSignature(fam, float(scores[where]), float(q), int(k), words, numbers))
    return sorted(out, key=lambda s: -s.score)
