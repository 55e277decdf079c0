"""Measured-K&C data as rig results: :class:`~suspenv.measurements.knc_file.MeasuredTest`
-> :class:`~suspenv.rigs.knc.KCResult` of one design (n = 1), so the metrics
(:func:`suspenv.metrics.knc.objectives`, the K&C report) read a measurement as they
read a simulation.

The grid and the interpolation are :meth:`MeasuredTest.loop
<suspenv.measurements.knc_file.MeasuredTest.loop>` (exact when the samples already
are a uniform loop, as ``suspenv knc`` writes); this module only wraps them, because
the measurement layer sits below the rigs (tests/test_architecture.py). SI units, raw
ISO 8855, as in ``KCResult.channels``; a wheel that was not measured holds NaN.
"""

from __future__ import annotations

import numpy as np

from suspenv.measurements.knc_file import KncMeasurement, MeasuredTest
from suspenv.rigs.knc import KCResult


def on_grid(test: MeasuredTest, steps: int | None = None) -> KCResult:
    """``test`` as a rig result of one design on ``steps`` grid intervals (default: the
    test's own loop, or see :meth:`MeasuredTest.loop`)."""
    grid, path, channels = test.loop(steps)
    return KCResult(test.test, grid, path, channels, np.ones(1, bool), [""])


def measured_results(m: KncMeasurement, steps: int | None = None) -> dict[str, KCResult]:
    """{test: :func:`on_grid`} of every test of ``m``."""
    return {t: on_grid(mt, steps) for t, mt in m.tests.items()}
