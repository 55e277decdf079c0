"""Markdown helpers shared by every report and ``compare.md``: one cell formatter, one
table builder, one escaping rule for text taken from data (:func:`inline` within a line,
:func:`text` anywhere)."""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np


def fmt(v: Any, digits: int = 4, missing: str = "n/a", *, inf: str | None = None) -> str:
    """A table cell: ``digits`` significant digits for floats (``missing`` when not
    finite, but ``inf`` for +inf when given: a target never reached), ``yes`` / blank
    for booleans, anything else as ``str``."""
    if isinstance(v, bool):
        return "yes" if v else ""
    if isinstance(v, float | np.floating):
        if np.isfinite(v):
            return f"{v:.{digits}g}"
        return inf if inf is not None and v > 0 else missing
    return str(v)


#: characters that Markdown or HTML would read as markup in text taken from data files
_MARKUP = {c: f"&#{ord(c)};" for c in "&<>[]`*|\\"}
#: what starts a Markdown block (heading, list, quote, setext underline) at a line's start
_BLOCK_START = re.compile(r"\s*([#+=-]|\d+[.)])")


def one_line(value: object) -> str:
    """``str(value)`` with every line break and control character (Unicode categories
    Cc, Zl, Zp) replaced by a space: text from data cannot start a new line."""
    return "".join(" " if unicodedata.category(c) in ("Cc", "Zl", "Zp") else c for c in str(value))


def inline(value: object) -> str:
    """Text from data as literal Markdown inside a line (a table cell, a heading's text):
    on one line (:func:`one_line`), HTML and Markdown markup characters as character
    references, so it cannot inject tags, images, links or code spans."""
    return "".join(_MARKUP.get(c, c) for c in one_line(value))


def text(value: object) -> str:
    """Text from a data file (a recording name, a file name, a path) as literal Markdown
    anywhere, also at a line's start: :func:`inline`, and a block marker at its start
    (``#``, ``-``, ``+``, ``=``, ``1.``) as a character reference, so a name cannot
    start a heading or a list either."""
    out = inline(value)
    start = _BLOCK_START.match(out)
    if start:
        i = start.end() - 1
        out = f"{out[:i]}&#{ord(out[i])};{out[i + 1 :]}"
    return out


def table_lines(head: Sequence[object], rows: Iterable[Sequence[object]]) -> list[str]:
    """A GitHub-flavoured Markdown table of cells written as ``str``, one string per line:
    the header, the delimiter row and one line per row (no rows: the header alone).

    Every cell and header is kept on one line and a ``|`` in it becomes a character
    reference, so that no value can break the table (markup a writer puts in a cell stays:
    escape data with :func:`text`).
    """

    def line(cells: Iterable[object]) -> str:
        return "| " + " | ".join(one_line(c).replace("|", "&#124;") for c in cells) + " |"

    return [line(head), "|" + "---|" * len(head), *map(line, rows)]


def markdown_table(
    rows: Sequence[Mapping[str, Any]],
    columns: Sequence[str] | None = None,
    missing: str = "–",
) -> str:
    """A Markdown table (:func:`table_lines`) of dict rows, cells by :func:`fmt`,
    newline-ended.

    ``columns`` defaults to the first row's keys; a row without a column gets a blank cell;
    no rows give ``"(none)"``.
    """
    if not rows:
        return "(none)\n"
    cols = list(columns or rows[0])
    cells = [[fmt(r.get(c, ""), missing=missing) for c in cols] for r in rows]
    return "\n".join(table_lines(cols, cells)) + "\n"
