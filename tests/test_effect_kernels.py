"""The compiled sample loops of the effect elements against the float loops of
``tests/effects_reference.py``.

References: ``effects_reference.bouc_wen_row``, the exact n = 1 Bouc-Wen path written as a
Python float loop, and ``effects_reference.recurrence``, the float loop of
``z[k+1] = a[k] + b[k] z[k]`` (the product, which must equal them, is checked against
closed forms and time integrations in ``test_effects_elements.py``). The compiled loops
must give the same states: to rounding for Bouc-Wen, on random paths with reversals,
pauses, shapes from 0 to 1 (``beta - gamma`` of either sign and zero) and states starting
anywhere in the band; bit for bit for the recurrence (the same two operations per step).
"""

import effects_reference as ref
import numpy as np
import pytest

import suspenv.models.effects._util as util
import suspenv.models.effects.hysteresis as hysteresis
from suspenv.models.effects import kernels
from suspenv.models.effects.hysteresis import dahl_path
from suspenv.models.effects.viscoelastic import maxwell_series


@pytest.mark.parametrize("shape", [0.0, 0.25, 0.5, 1.0])
def test_compiled_rows_equal_the_float_loop(shape):
    rng = np.random.default_rng(5)
    t = np.linspace(0.0, 4.0, 3001)
    x = 0.01 * np.sin(2 * np.pi * 1.3 * t) + 0.004 * np.sin(2 * np.pi * 5.1 * t)
    x = np.vstack([x, np.cumsum(rng.normal(scale=2e-4, size=t.size))])
    x[1, 1000:1100] = x[1, 1000]  # a pause: zero increments
    # each path with each yield displacement
    x, z0 = np.vstack([x, x]), np.array([0.3, -0.9, 0.3, -0.9])
    x_y = np.array([2e-3, 2e-3, 5e-4, 5e-4])
    fast = hysteresis.bouc_wen_force_path(x, 1.0, x_y, shape, 1.0, z0)
    slow = ref.bouc_wen_force_path(x, 1.0, x_y, shape, z0)
    assert np.ptp(slow) > 1.0  # the loops travel through the band
    assert np.allclose(fast, slow, rtol=0.0, atol=1e-13), np.abs(fast - slow).max()


def test_compiled_rows_keep_the_lower_fixed_point():
    # closed form: for w = sign(dx) z < 0 and gamma > beta, dw/du = A - (beta - gamma) w
    # vanishes at w = A / (beta - gamma); a state there stays (the loop's fixed-point
    # branch, where the travel to w = 0 is infinite)
    A, beta, gamma = 2.0, 0.5, 1.5
    z0 = A / (beta - gamma)
    x = np.linspace(0.0, 0.01, 11)
    z = hysteresis.bouc_wen_path(x, A, beta, gamma, 1.0, z0)
    np.testing.assert_allclose(z, z0, rtol=1e-12)
    np.testing.assert_allclose(ref.bouc_wen_row(np.diff(x).tolist(), A, beta, gamma, z0), z0)


def test_compiled_recurrence_is_the_float_loop_bit_for_bit():
    rng = np.random.default_rng(6)
    a = rng.normal(size=(3, 500))
    b = rng.uniform(0.5, 1.0, size=(1, 500))  # broadcast over the rows
    z0 = rng.normal(size=3)
    fast = util.linear_recurrence(a, b, z0)
    assert np.array_equal(fast, ref.recurrence(a, np.broadcast_to(b, a.shape), z0))


def test_elements_on_the_recurrence_are_unchanged(monkeypatch):
    # the Dahl and Maxwell elements (callers of the recurrence): the same forces with
    # the reference loop in place of the compiled one
    t = np.linspace(0.0, 2.0, 2001)
    x = 0.01 * np.sin(2 * np.pi * 2.0 * t)
    fast = (dahl_path(x, 1.5e5, 300.0), maxwell_series(x, t, 2e4, 800.0))

    def reference_loop(a, b, z0, out):
        out[:] = ref.recurrence(a, b, z0)

    monkeypatch.setattr(kernels, "recurrence", reference_loop)
    slow = (dahl_path(x, 1.5e5, 300.0), maxwell_series(x, t, 2e4, 800.0))
    for f, r in zip(fast, slow, strict=True):
        assert np.ptp(r) > 10.0
        assert np.array_equal(f, r)
