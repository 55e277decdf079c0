"""Standard JSON from numpy results: the definition of ``core.jsonable.json_text``.

Reference: RFC 8259 has no NaN or Infinity tokens, so a strict reader
(``parse_constant`` refusing them) must accept every text written.
"""

import json
from pathlib import Path

import numpy as np
import pytest
from strict_json import strict_loads

from suspenv.core.jsonable import json_text


def test_json_text_is_standard_json():
    value = {
        "nan": float("nan"),
        "inf": np.float64(np.inf),
        "array": np.array([1.5, np.nan, -np.inf]),
        "flag": np.bool_(True),
        "count": np.int64(3),
        "path": Path("a") / "b",
        4: "key",
    }
    text = json_text(value)
    assert text.endswith("}\n")
    assert strict_loads(text) == {
        "nan": None,
        "inf": None,
        "array": [1.5, None, None],
        "flag": True,
        "count": 3,
        "path": str(Path("a") / "b"),
        "4": "key",
    }


def test_strict_reader_refuses_nan():
    with pytest.raises(ValueError, match="NaN"):
        strict_loads(json.dumps({"x": float("nan")}))
