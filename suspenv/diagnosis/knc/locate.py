"""Where the residual of a K&C fit lives: test x channel x branch x side.

A cell is one rig test, one recorded channel, one half-loop (``rising`` = rebound ->
bump, ``falling`` = bump -> rebound) and one side. Its value is the RMS of the
residual divided by the channel's noise level (1 = at noise level). The noise level
is estimated from the residual itself, independent of the fit: from the second
differences along the loop, ``d_k = r_k - (r_{k-1} + r_{k+1}) / 2`` (variance
``1.5 sigma^2`` for white noise; a smooth missing effect barely contributes), robustly
``sigma = 1.4826 median|d| / sqrt(1.5)``. The map also
gives the loop opening (RMS of half the difference between the two half-loops on
the grid) and the left-right difference per test and channel, both in noise units.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suspenv.measurements.knc import CHANNELS, SIDES, half_loops, rig_test

BRANCHES = ("rising", "falling")


@dataclass
class ResidualMap:
    """RMS of the scaled residual per (test, channel, branch, side), plus loop and L-R cells."""

    cells: dict[tuple[str, str, str, str], float] = field(default_factory=dict)
    loop: dict[tuple[str, str, str], float] = field(default_factory=dict)
    left_right: dict[tuple[str, str], float] = field(default_factory=dict)
    noise: dict[str, float] = field(default_factory=dict)

    def strongest(self, n: int = 5) -> list[tuple[tuple[str, str, str, str], float]]:
        return sorted(self.cells.items(), key=lambda kv: -kv[1])[:n]

    def summary(self) -> str:
        if not self.cells:
            return "no residual"
        (test, ch, br, side), v = self.strongest(1)[0]
        lp = max(self.loop.items(), key=lambda kv: kv[1], default=(("", "", ""), 0.0))
        lr = max(self.left_right.items(), key=lambda kv: kv[1], default=(("", ""), 0.0))
        return (
            f"largest residual: {test} {ch} {side} {br} half-loop ({v:.2f} x noise); "
            f"widest loop opening: {lp[0][0]} {lp[0][1]} {lp[0][2]} ({lp[1]:.2f}); "
            f"largest left-right difference: {lr[0][0]} {lr[0][1]} ({lr[1]:.2f})"
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "cells": [
                {"test": t, "channel": c, "branch": b, "side": s, "rms": v}
                for (t, c, b, s), v in self.cells.items()
            ],
            "loop_opening": [
                {"test": t, "channel": c, "side": s, "rms": v} for (t, c, s), v in self.loop.items()
            ],
            "left_right": [
                {"test": t, "channel": c, "rms": v} for (t, c), v in self.left_right.items()
            ],
            "noise": self.noise,
            "summary": self.summary(),
        }


def residual_map(
    recs: Sequence[Any],
    residual: Sequence[Mapping[str, np.ndarray]],
    scales: Mapping[str, float],
    floor: Mapping[str, float] | None = None,
) -> ResidualMap:
    """The :class:`ResidualMap` of residuals ``residual[i][channel]`` (channel unit).

    Each channel's noise is estimated from the residual's roughness (second differences);
    ``scales`` stand in where that estimate is 0. ``floor`` (channel -> sigma, channel
    unit): the noise is never taken below it, e.g. the measurement noise a fit was
    weighted by, so a residual smoother than the measurement's noise (round-off of a fit
    to noise-free curves) is not read as tens of thousands of noise units."""
    out = ResidualMap()
    d2: dict[str, list[np.ndarray]] = {}
    for res in residual:
        for key, r in res.items():
            r = np.asarray(r, float)
            d2.setdefault(key, []).append(r[1:-1] - 0.5 * (r[:-2] + r[2:]))
    noise = {}
    for key, parts in d2.items():
        est = 1.4826 * float(np.median(np.abs(np.concatenate(parts)))) / np.sqrt(1.5)
        noise[key] = est if est > 0 else float(scales[key])
        if floor is not None and key in floor:
            noise[key] = max(noise[key], float(floor[key]))
    out.noise = noise
    for rec, res in zip(recs, residual, strict=True):
        test = rig_test(rec)
        rising = rec.inputs["branch"] != 1
        for c in CHANNELS:
            per_side = {}
            for s in SIDES:
                key = f"{c}_{s}"
                if key not in res:
                    continue
                r = np.asarray(res[key], float) / noise[key]
                per_side[s] = r
                for br, sel in zip(BRANCHES, (rising, ~rising), strict=True):
                    out.cells[(test, c, br, s)] = float(np.sqrt(np.mean(r[sel] ** 2)))
                down, up = half_loops(rec, r)
                out.loop[(test, c, s)] = float(np.sqrt(np.nanmean((0.5 * (up - down)) ** 2)))
            if len(per_side) == 2:
                d = (per_side["left"] - per_side["right"]) / np.sqrt(2.0)
                out.left_right[(test, c)] = float(np.sqrt(np.mean(d**2)))
    return out
