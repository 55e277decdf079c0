"""Reading TOML files (configs, vehicle and geometry files) with named errors.

Every failure is a :class:`~suspenv.core.errors.ValidationError` naming the file: too
large (a TOML input file is small; the limit bounds memory), not UTF-8 text, not valid
TOML (the parser's line and column), or nested too deeply for the parser.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from suspenv.core.errors import ValidationError

#: largest TOML input file read (bytes); configs and vehicle files are a few KiB
MAX_TOML_BYTES = 1 << 20


def parse_toml(data: bytes | str, label: str) -> dict[str, Any]:
    """The table of TOML ``data``; ``label`` names its source in errors ("config 'x.toml'")."""
    try:
        text = data.decode("utf-8") if isinstance(data, bytes) else data
    except UnicodeDecodeError as exc:
        raise ValidationError(f"{label} is not UTF-8 text: {exc}") from None
    try:
        return tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError) as exc:
        raise ValidationError(f"{label} is not valid TOML: {exc}") from None


def read_toml(path: Path, label: str, max_bytes: int = MAX_TOML_BYTES) -> dict[str, Any]:
    """The table of the TOML file ``path`` (at most ``max_bytes``), see :func:`parse_toml`."""
    size = path.stat().st_size
    if size > max_bytes:
        raise ValidationError(
            f"{label}: {size} bytes, more than the {max_bytes} bytes a TOML input file may hold"
        )
    return parse_toml(path.read_bytes(), label)
