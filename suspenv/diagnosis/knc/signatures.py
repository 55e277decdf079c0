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

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.measurements.knc import CHANNELS, SIDES, drive, reading_drive

#: signature family -> effect kinds it points to
FAMILY_KINDS = {
    "loop": ("dahl_hysteresis", "coulomb_friction"),
    "lr_asymmetry": ("lr_asymmetry",),
    "progressive": ("cubic_stiffness",),
    "sensor_gain": ("sensor_gain",),
    "sensor_offset": ("sensor_offset",),
}
FAMILY_WORDS = {
    "loop": "bump and rebound half-loops differ (a hysteresis loop)",
    "lr_asymmetry": "left and right residuals differ",
    "progressive": "residual grows with the cube of the travel",
    "sensor_gain": "wheel-load residual proportional to the load",
    "sensor_offset": "constant wheel-load residual",
}


@dataclass
class KncSignature:
    """Score of one signature family (see the module docstring)."""

    kind: str
    score: float
    chi2: float
    dof: int
    evidence: str
    numbers: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def _score(r: np.ndarray, cols: list[np.ndarray]) -> tuple[float, int]:
    """Chi-square of the projection of ``r`` on the span of ``cols`` and its rank."""
    A = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(A, r, rcond=None)
    fitted = A @ coef
    k = int(np.linalg.matrix_rank(A))
    return float(fitted @ fitted), max(k, 1)


def score_signatures(
    recs: Sequence[Any],
    residual: Sequence[Mapping[str, np.ndarray]],
    prediction: Sequence[Mapping[str, np.ndarray]],
    scales: Mapping[str, float],
) -> list[KncSignature]:
    """Signatures of the residual ``residual[i][channel]`` (channel unit) of each K&C
    recording ``recs[i]``, strongest first; ``prediction`` holds the model's channels."""
    blocks: dict[str, list[tuple[str, np.ndarray, list[np.ndarray]]]] = {
        f: [] for f in FAMILY_KINDS
    }
    loop_width = []
    for rec, res, pred in zip(recs, residual, prediction, strict=True):
        b = np.where(rec.inputs["branch"] == 1, -1.0, 1.0)
        chans = [c for c in CHANNELS if all(f"{c}_{s}" in res for s in SIDES)]
        for c in chans:
            r = {s: np.asarray(res[f"{c}_{s}"], float) / scales[f"{c}_{s}"] for s in SIDES}
            p = {s: drive(rec, s) for s in SIDES}
            for s in SIDES:
                blocks["loop"].append((c, r[s], [b, b * p[s]]))
                blocks["progressive"].append((c, r[s], [p[s] ** 3]))
            # left/right: one stacked series, +pattern on the left, -pattern on the right
            rr = np.concatenate([r["left"], r["right"]])
            # pattern in each side's own drive (opposite travel and the lateral force
            # mirror the right side); single-wheel travel: the left pad's travel
            pr = reading_drive(rec, "right")
            cols = [
                np.concatenate([np.ones_like(p["left"]), -np.ones_like(pr)]),
                np.concatenate([p["left"], -pr]),
                np.concatenate([p["left"] ** 2, -(pr**2)]),
            ]
            blocks["lr_asymmetry"].append((c, rr, cols))
            if c == "tyre_fz":
                for s in SIDES:
                    y = np.asarray(pred[f"tyre_fz_{s}"], float) / scales[f"tyre_fz_{s}"]
                    blocks["sensor_gain"].append((c, r[s], [y]))
                    blocks["sensor_offset"].append((c, r[s], [np.ones_like(y)]))
                    up = b > 0
                    raw = np.asarray(res[f"tyre_fz_{s}"], float)
                    loop_width.append(float(np.mean(raw[up]) - np.mean(raw[~up])))
    # one joint projection per family: the blocks are disjoint series, so chi2 and k add
    out = []
    for fam, items in blocks.items():
        if not items:
            continue
        per: dict[str, list[float]] = {}
        for c, resid, cols in items:
            qi, ki = _score(resid, cols)
            acc = per.setdefault(c, [0.0, 0])
            acc[0] += qi
            acc[1] += ki
        scores = {c: float((q - k) / np.sqrt(2.0 * k)) for c, (q, k) in per.items()}
        where = max(scores, key=lambda c: scores[c])
        q, k = per[where]
        score = scores[where]
        numbers = {f"score_{c}": float(v) for c, v in scores.items()}
        if fam == "loop" and loop_width:
            numbers["tyre_fz_loop_width_n"] = float(np.mean(loop_width))
        out.append(
            KncSignature(
                fam,
                float(score),
                float(q),
                int(k),
                f"{FAMILY_WORDS[fam]}: strongest in {where}, chi2 {q:.1f} on {k} dof",
                numbers,
            )
        )
    return sorted(out, key=lambda s: -s.score)
