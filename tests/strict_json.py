"""A strict JSON reader for tests: RFC 8259 has no NaN or Infinity tokens."""

import json
from typing import Any


def _refuse(token: str) -> None:
    raise ValueError(f"{token} is not JSON (RFC 8259); write null")


def strict_loads(text: str) -> Any:
    """``json.loads`` that refuses NaN, Infinity and -Infinity."""
    return json.loads(text, parse_constant=_refuse)
