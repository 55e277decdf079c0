"""A small cache keyed by the identity of objects, for per-evaluation lookups.

Hashing a frozen vehicle or load case costs more than the work a lookup saves, so the
models key their design-independent tables by ``id`` of the objects they depend on (plus
plain values). The cache holds those objects, so their ids cannot be reused by others
while an entry lives; a hit is checked object by object (``is``).
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Sequence
from typing import Any, Generic, TypeVar

T = TypeVar("T")


class IdentityCache(Generic[T]):
    """Values built by a callable, kept per (identity of ``held`` objects, ``values``);
    cleared whole when ``size`` entries are held (an evaluation repeats a few keys)."""

    def __init__(self, size: int = 16):
        self.size = size
        self._hits: dict[tuple, tuple[Sequence[object], T]] = {}

    def get(self, held: Sequence[object], values: tuple[Any, ...], build: Callable[[], T]) -> T:
        """The value for ``held`` (compared by identity) and ``values`` (by equality),
        built by ``build()`` on a miss."""
        key = (len(held), *map(id, held), *values)
        hit = self._hits.get(key)
        # (the key's length fixes the number of held objects: the same on a hit)
        if hit is None or not all(map(operator.is_, hit[0], held)):
            if len(self._hits) >= self.size:
                self._hits.clear()
            hit = self._hits[key] = (held, build())
        return hit[1]
