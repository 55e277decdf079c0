"""Wall-clock time of the consecutive stages of a job (the ``timings_s`` of its JSON)."""

from __future__ import annotations

import time


class Laps:
    """Wall-clock time [s] of a job's consecutive stages, by name, in :attr:`times`.

    ``laps("stage")`` records the time since the previous lap (or since construction or
    :meth:`restart`) as ``times["stage"]``; a name recorded again is overwritten.
    """

    def __init__(self) -> None:
        self.times: dict[str, float] = {}
        self._tick = time.perf_counter()

    def __call__(self, name: str) -> None:
        now = time.perf_counter()
        self.times[name] = now - self._tick
        self._tick = now

    def restart(self) -> None:
        """Start the next lap now (the time since the last one is counted elsewhere)."""
        self._tick = time.perf_counter()
