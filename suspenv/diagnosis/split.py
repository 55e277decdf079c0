"""Fit data and held-out data of a diagnosis.

The held-out data are what a named element must predict without having been fitted to
them. Each family offers its own ways to choose them (a fraction or interleaved cycles
of a component recording, rig tests of a K&C set, repeat runs of a ride test); all end
as one :class:`Split`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TypeAlias, TypeVar, cast

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.measurements.recording import RecordingLike

R = TypeVar("R", bound=RecordingLike)


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

    fit_recordings: list[RecordingLike]
    fit_masks: list[np.ndarray] | None
    heldout_recordings: list[RecordingLike]
    heldout_masks: list[np.ndarray] | None
    description: str
    cycles_every: int | None = None

    def recordings(self) -> list[RecordingLike]:
        """Every recording of the split once, fit before held-out (a recording masked into
        both parts counts once)."""
        out: list[RecordingLike] = []
        for r in [*self.fit_recordings, *self.heldout_recordings]:
            if not any(r is q for q in out):
                out.append(r)
        return out

    def fit_selections(self) -> list[np.ndarray]:
        """Each fitted recording's fit samples as a boolean mask (all of an unmasked one)."""
        if self.fit_masks is not None:
            return list(self.fit_masks)
        return [np.ones(len(r.time), bool) for r in self.fit_recordings]

    @classmethod
    def separate(
        cls, fit: Sequence[RecordingLike], heldout: Sequence[RecordingLike], words: str = ""
    ) -> Split:
        """Whole recordings fitted, other whole recordings held out."""
        names = ", ".join(str(r.name) for r in heldout)
        return cls(list(fit), None, list(heldout), None, words or f"separate recording(s): {names}")


#: recordings as a diagnosis takes them: one, a sequence, or a mapping test -> recording
Recordings: TypeAlias = RecordingLike | Sequence[RecordingLike] | Mapping[str, RecordingLike]
#: held-out data in a family's terms: a fraction or ``"cycles[:N]"`` (components), rig
#: test names (K&C), or recordings not used for fitting; None: the family's default
Holdout: TypeAlias = float | str | Sequence[str] | Recordings | None


def as_recordings(recordings: R | Sequence[R] | Mapping[str, R]) -> list[R]:
    """One recording, a sequence of them or a mapping name -> recording, as a list."""
    if isinstance(recordings, list | tuple):
        return list(recordings)
    if isinstance(recordings, Mapping):
        return list(recordings.values())
    return [cast(R, recordings)]  # one recording (any object with the recording's members)


def heldout_recordings(holdout: Holdout) -> list[RecordingLike]:
    """``holdout`` as held-out recordings; anything else (a number, text) is an error
    that names the value (the family has already taken the forms it knows)."""
    if holdout is None or isinstance(holdout, float | int | str):
        raise ValidationError(f"held-out data must be recordings here, but got holdout={holdout!r}")
    if isinstance(holdout, RecordingLike | Mapping):
        return as_recordings(holdout)
    items = list(holdout)
    recs = [r for r in items if isinstance(r, RecordingLike)]
    if len(recs) < len(items) or not recs:
        bad = [type(r).__name__ for r in items if not isinstance(r, RecordingLike)]
        raise ValidationError(
            f"held-out data must be one or more recordings, but got {bad or 'none'}"
        )
    return recs
