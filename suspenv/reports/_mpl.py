"""The one place that chooses matplotlib's backend: Agg (files only, no display), lazily."""

from __future__ import annotations

from functools import cache
from types import ModuleType


@cache
def pyplot() -> ModuleType:
    """``matplotlib.pyplot`` with the Agg backend, selected on the first call only."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
