"""Markdown helpers shared by every report: one cell formatter, one table builder."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np


def fmt(v: Any, digits: int = 4, missing: str = "n/a") -> str:
    """A table cell: ``digits`` significant digits for floats (``missing`` when not
    finite), ``yes`` / blank for booleans, anything else as ``str``."""
    if isinstance(v, bool):
        return "yes" if v else ""
    if isinstance(v, float | np.floating):
        return f"{v:.{digits}g}" if np.isfinite(v) else missing
    return str(v)


#: characters that Markdown or HTML would read as markup in text taken from data files
_MARKUP = {c: f"&#{ord(c)};" for c in "&<>[]`*|\\"}


def text(value: object) -> str:
    """Text from a data file (a recording name, a file name, a path) as literal Markdown:
    HTML and Markdown markup characters become character references, so a name cannot
    inject tags, images or links into a report."""
    return "".join(_MARKUP.get(c, c) for c in str(value))


def markdown_table(
    rows: Sequence[Mapping[str, Any]],
    columns: Sequence[str] | None = None,
    missing: str = "–",
) -> str:
    """A GitHub-flavoured Markdown table of dict rows (cells by :func:`fmt`), newline-ended.

    ``columns`` defaults to the first row's keys; a row without a column gets a blank cell;
    no rows give ``"(none)"``.
    """
    if not rows:
        return "(none)\n"
    cols = list(columns or rows[0])
    out = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    out += [
        "| " + " | ".join(fmt(r.get(c, ""), missing=missing) for c in cols) + " |" for r in rows
    ]
    return "\n".join(out) + "\n"
