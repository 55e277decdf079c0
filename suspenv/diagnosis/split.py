"""Fit data and held-out data of a diagnosis.

The held-out data are what a named element must predict without having been fitted to
them. Each family offers its own ways to choose them (a fraction or interleaved cycles
of a component recording, rig tests of a K&C set, repeat runs of a ride test); all end
as one :class:`Split`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass
class Split:
    """Fit data and held-out data.

    Attributes:
        fit_recordings / heldout_recordings: the recordings of each part (a recording
            may be in both, with complementary masks).
        fit_masks / heldout_masks: boolean sample masks, one per recording (None: every
            sample).
        description: the split in words, for the report.
        cycles_every: for an interleaved-cycle split, one cycle in this many is held out.
    """

    fit_recordings: list[Any]
    fit_masks: list[np.ndarray] | None
    heldout_recordings: list[Any]
    heldout_masks: list[np.ndarray] | None
    description: str
    cycles_every: int | None = None

    @classmethod
    def separate(cls, fit: Sequence[Any], heldout: Sequence[Any], words: str = "") -> Split:
        """Whole recordings fitted, other whole recordings held out."""
        names = ", ".join(str(r.name) for r in heldout)
        return cls(list(fit), None, list(heldout), None, words or f"separate recording(s): {names}")


def as_recordings(recordings: Any) -> list[Any]:
    """One recording, a sequence of them or a mapping name -> recording, as a list."""
    if isinstance(recordings, Mapping):
        return list(recordings.values())
    if isinstance(recordings, list | tuple):
        return list(recordings)
    return [recordings]
