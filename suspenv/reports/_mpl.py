"""The one place that chooses matplotlib's backend: Agg (files only, no display), lazily;
figures saved atomically and closed; and parallel-coordinate lines drawn as one collection."""

from __future__ import annotations

from functools import cache
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from suspenv.core.atomic import atomic_path


@cache
def pyplot() -> ModuleType:
    """``matplotlib.pyplot`` with the Agg backend, selected on the first call only."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, path: Path | str, tight: bool = False, **savefig: Any) -> Path:
    """``fig.savefig`` to ``path`` atomically (:func:`suspenv.core.atomic.atomic_path`:
    the old figure or the new one whole, never a part), its folder made first, after
    ``fig.tight_layout()`` when ``tight``; then pyplot closes the figure, also when the
    write fails (it can still be saved again). ``savefig``: its keywords."""
    try:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        if tight:
            fig.tight_layout()
        with atomic_path(path) as tmp:
            fig.savefig(tmp, **savefig)
    finally:
        pyplot().close(fig)
    return Path(path)


def save_cropped(fig: Any, path: Path | str) -> Path:
    """:func:`save_figure` at 100 dpi, cropped to what is drawn (``bbox_inches="tight"``)."""
    return save_figure(fig, path, dpi=100, bbox_inches="tight")


def add_polylines(ax: Any, values: np.ndarray, **style: Any) -> Any:
    """Draw each row of ``values`` (k, m) as a line through ``(j, values[:, j])``,
    ``j = 0 .. m-1``, as one ``LineCollection`` (one artist, not k: thousands of lines
    draw in a fraction of the time); ``style``: its keywords (``colors``, ``alpha``,
    ``lw``). The axes' data limits take the lines in; returns the collection."""
    from matplotlib.collections import LineCollection

    values = np.asarray(values, dtype=float)
    x = np.arange(values.shape[-1], dtype=float)
    segments = np.stack([np.broadcast_to(x, values.shape), values], axis=-1)
    lines = LineCollection(list(segments), **style)
    ax.add_collection(lines, autolim=True)
    ax.autoscale_view()
    return lines
