"""The JSON form shared by the diagnosis's dataclass records (signatures, checks, probes)."""

from __future__ import annotations

from dataclasses import asdict
from typing import Any, ClassVar


class Record:
    """Base of a dataclass record: :meth:`to_dict` gives its fields
    (:func:`dataclasses.asdict`, nested records as dicts), then the properties named in
    :attr:`derived`."""

    #: properties said after the fields, in order
    derived: ClassVar[tuple[str, ...]] = ()

    def to_dict(self) -> dict[str, Any]:
        fields: dict[str, Any] = asdict(self)  # type: ignore[call-overload]
        return fields | {k: getattr(self, k) for k in self.derived}
