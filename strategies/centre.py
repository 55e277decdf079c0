"""The README's example strategy: four designs a batch, scattered around the centre.

A plug-in strategy is a module with a :class:`~suspenv.strategies.base.Strategy`
subclass. Name it in a config (``suspenv run --allow-code``)::

    [strategy]
    name = "strategies/centre.py:Centre"

or on the command line: ``suspenv suite run --strategies strategies/centre.py:Centre``.
"""

from __future__ import annotations

import numpy as np

from suspenv.core.result import EvaluationBatch
from suspenv.strategies.base import Strategy


class Centre(Strategy):
    """Designs drawn around the centre of the unit cube (a baseline that never learns)."""

    name = "centre"

    def _ask(self) -> np.ndarray:
        """(4, d) designs in the unit cube; the problem's DesignSpace maps them to units.
        Seeded by the seed and the designs told so far: same seed, same designs."""
        rng = np.random.default_rng([self.seed, self.n_told])
        return np.clip(rng.normal(0.5, 0.1, (4, self.dim)), 0.0, 1.0)

    def _tell(self, U: np.ndarray, batch: EvaluationBatch) -> None:
        """Results of the designs asked: objectives, constraints (<= 0 feasible), ok."""
