"""Shared test fixtures."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")


@pytest.fixture
def shared_data() -> Path:
    """The shared data folder (:func:`suspenv.measurements.data_dir`: ``$SUSPENV_DATA`` or
    ``../shared/data``; read in place, never copied into the repository); the test is
    skipped (with a message) where it is absent."""
    from suspenv.measurements import data_dir

    root = data_dir()
    if not root.is_dir():
        pytest.skip(f"real recordings not available at {root}")
    return root


def _quarter_car_sine_response(m_s, m_u, k_s, c_s, k_t, f, amp) -> np.ndarray:
    """Complex steady-state amplitudes [m] (body, wheel) of the linear 2-DOF quarter car
    to a road ``amp * cos(2 pi f t)``: the closed form (-w^2 M + i w C + K) Z = F."""
    w = 2 * np.pi * f
    M = np.diag([m_s, m_u])
    C = np.array([[c_s, -c_s], [-c_s, c_s]])
    K = np.array([[k_s, -k_s], [-k_s, k_s + k_t]])
    return np.linalg.solve(-(w**2) * M + 1j * w * C + K, np.array([0.0, k_t * amp]))


@pytest.fixture
def quarter_car_sine_response() -> Callable[..., np.ndarray]:
    """The closed-form steady-state response of the linear quarter car (a reference
    independent of any integrator)."""
    return _quarter_car_sine_response
