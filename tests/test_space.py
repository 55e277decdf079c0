"""DesignSpace: unit-cube maps, log scale, and bad-input messages."""

import numpy as np
import pytest

from suspenv.core import DesignSpace, Parameter
from suspenv.core.errors import ValidationError


def _space():
    return DesignSpace(
        [
            Parameter("k", 1e3, 5e3, "N/mm"),
            Parameter("c", 0.6, 1.8),
            Parameter("r", 30.0, 3000.0, "N*mm/deg", log=True),
        ]
    )


def test_round_trip_and_endpoints():
    s = _space()
    U = np.random.default_rng(0).uniform(size=(20, 3))
    np.testing.assert_allclose(s.to_unit(s.to_physical(U)), U, atol=1e-12)
    np.testing.assert_allclose(s.to_physical(np.zeros((1, 3)))[0], [1e3, 0.6, 30.0])
    np.testing.assert_allclose(s.to_physical(np.ones((1, 3)))[0], [5e3, 1.8, 3000.0])


def test_log_scale_midpoint_is_geometric_mean():
    # closed form: low * (high/low)^0.5 = sqrt(low*high)
    x = _space().to_physical(np.full((1, 3), 0.5))[0]
    assert x[2] == pytest.approx(np.sqrt(30.0 * 3000.0))
    assert x[0] == pytest.approx(3e3)


def test_slope_is_the_maps_derivative():
    # reference: central differences of to_physical (step 1e-6; the map is smooth, so the
    # difference's error is O(h^2) relative, ~1e-12, plus round-off ~1e-10 relative)
    s, h = _space(), 1e-6
    for u in np.random.default_rng(1).uniform(0.1, 0.9, size=(5, 3)):
        fd = [
            (s.to_physical((u + h * e)[None])[0, i] - s.to_physical((u - h * e)[None])[0, i])
            / (2 * h)
            for i, e in enumerate(np.eye(3))
        ]
        np.testing.assert_allclose(s.slope(u), fd, rtol=1e-7)
    # linear parameters: the range, wherever u is
    np.testing.assert_allclose(s.slope(np.zeros(3))[:2], [4e3, 1.2], rtol=1e-15)


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        (
            {"name": "a", "low": 3.0, "high": 1.0},
            "`low < high` must hold, but got (low=3.0, high=1.0)",
        ),
        ({"name": "a", "low": 0.0, "high": 1.0, "log": True}, "log scale needs `low > 0`"),
        ({"name": "a", "low": 0.0, "high": 1.0, "default": 2.0}, "`low <= default <= high`"),
        ({"name": "a", "low": 0.0, "high": float("inf")}, "bounds must be finite"),
    ],
)
def test_parameter_errors_name_rule_and_values(kwargs, needle):
    with pytest.raises(ValidationError) as e:
        Parameter(**kwargs)
    assert needle in str(e.value)


def test_nan_design_rejected_with_row_and_name():
    s = _space()
    X = s.to_physical(np.full((3, 3), 0.5))
    X[1, 2] = np.nan
    with pytest.raises(ValidationError, match=r"row 1 parameter 'r' is nan"):
        s.check_batch(X)


def test_wrong_shape_and_unknown_name():
    s = _space()
    with pytest.raises(ValidationError, match=r"shape \(n, 3\), but got \(2, 4\)"):
        s.check_batch(np.zeros((2, 4)))
    with pytest.raises(ValidationError, match="did you mean"):
        s.index("kk")
    with pytest.raises(ValidationError, match="unique"):
        DesignSpace([Parameter("a", 0, 1), Parameter("a", 0, 1)])
