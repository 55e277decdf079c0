"""Reading TOML files (configs, vehicle and geometry files) with named errors; writing them.

Every failure is a :class:`~suspenv.core.errors.ValidationError` naming the file: too
large (a TOML input file is small; the limit bounds memory), not UTF-8 text, not valid
TOML (the parser's line and column), or nested too deeply for the parser.
:func:`toml_value` and :func:`dump_toml` write the small subset the project stores
(resolved configs, measured-K&C manifests).
"""

from __future__ import annotations

import json
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


def toml_value(v: Any) -> str:
    """The inline TOML text of a bool, number, string, list/tuple or dict of those."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | float):
        return repr(float(v)) if isinstance(v, float) else str(v)
    if isinstance(v, str):
        # a JSON string is a TOML basic string once DEL, which TOML forbids raw, is escaped
        return json.dumps(v).replace("\x7f", "\\u007f")
    if isinstance(v, list | tuple):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def dump_toml(config: dict[str, Any]) -> str:
    """A small TOML writer for resolved configs (scalars, arrays, nested tables; no None)."""
    lines: list[str] = []

    def table(prefix: str, d: dict[str, Any]) -> None:
        scalars = {k: v for k, v in d.items() if not isinstance(v, dict) and v is not None}
        subs = {k: v for k, v in d.items() if isinstance(v, dict)}
        if prefix and (scalars or not subs):
            lines.append(f"\n[{prefix}]")
        for k, v in scalars.items():
            lines.append(f"{k} = {toml_value(v)}")
        for k, v in subs.items():
            table(f"{prefix}.{k}" if prefix else k, v)

    table("", config)
    text = "\n".join(lines).lstrip() + "\n"
    tomllib.loads(text)  # what we write must read back
    return text
