"""The compiled rig loop (``rig_kernel``) against the Python loop of ``rig_reference``.

Reference: ``tests/rig_reference.py``, the same scheme written as closures over plain
floats (the integrator's accuracy is tested against closed forms and a fine RK4 in
``test_components_rig_integrator.py``). The compiled loop must give the same outputs to
rounding for every element kind, combinations of stateless and stateful elements, an
actuator force, uneven sample steps and sub-steps, and must report divergence the same way.
"""

import numpy as np
import pytest
from rig_reference import integrate_reference

from suspenv.core import compiled
from suspenv.core.errors import EvaluationError
from suspenv.models.components import rig_integrator, rig_kernel
from suspenv.models.effects import make_effect
from suspenv.models.effects.laws import STATELESS

pytestmark = pytest.mark.skipif(not compiled.AVAILABLE, reason="numba not installed")

BASE = {"k_s": 25_000.0, "c_s": 1500.0, "k_t": 200_000.0}

ONE_OF_EACH = [
    make_effect("coulomb_friction", f_c=120.0, v_eps=0.01),
    make_effect("stribeck_friction", f_c=100.0, f_s=180.0, v_s=0.05, v_eps=0.01),
    make_effect("directional_friction", f_pos=90.0, f_neg=60.0, v_eps=0.01),
    make_effect("bump_stop", gap=0.01, k_stop=1e5),
    make_effect("rebound_stop", gap=0.01, k_stop=1e5),
    make_effect(
        "bump_and_rebound_stops", gap_bump=0.008, k_bump=1e5, gap_rebound=0.012, k_rebound=2e5
    ),
    make_effect("cubic_stiffness", k3=3e7, x_0=0.002),  # about a neutral position
    make_effect("progressive_stiffness", x0=0.005, k_p=3e6),
    make_effect("damper_asymmetry", dc_rebound=-800.0),
    make_effect("digressive_damping", c_low=3000.0, v_knee=0.2),
    make_effect("gas_spring", f_0=50.0, k_gas=2000.0),
    make_effect("force_offset", offset=-12.0),
    make_effect(
        "asymmetric_digressive_damping",
        c_bump=2000.0,
        v_knee_bump=0.3,
        c_rebound=3500.0,
        v_knee_rebound=0.2,
    ),
    make_effect("kelvin_voigt", k=5000.0, c=300.0),
    make_effect("low_speed_deficit", f_d=80.0, v_band=0.05),
    make_effect("dahl_hysteresis", f_c=300.0, sigma=1.5e5),
    make_effect("maxwell_viscoelastic", k_m=2e4, c_m=800.0),
    make_effect("lugre_friction", sigma0=2e5, sigma1=300.0, f_c=150.0, f_s=250.0, v_s=0.05),
]


def _of(kind: str):
    return next(e for e in ONE_OF_EACH if e.kind == kind)


def _road(n: int = 1500, dt: float = 0.002, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(n) * dt
    rng = np.random.default_rng(seed)
    road = 0.02 * np.sin(2 * np.pi * 1.5 * t) + 0.008 * np.sin(2 * np.pi * 7.0 * t + 1.0)
    return t, road + 1e-4 * rng.standard_normal(n)


def _both(effects, t, road, **kw):
    py = integrate_reference(300.0, 40.0, BASE, effects, t, road, **kw)
    co = rig_integrator.integrate(300.0, 40.0, BASE, effects, t, road, **kw)
    return py, co


def _assert_same(py, co):
    for a, b in zip(py, co, strict=True):
        scale = np.max(np.abs(a))
        assert np.max(np.abs(a - b)) <= 1e-9 * scale, np.max(np.abs(a - b)) / scale


def test_every_element_kind_has_a_compiled_law():
    # every stateless law of the effect library, and every stateful kind tested here
    assert set(rig_kernel.LAW_CODES) == set(STATELESS)
    assert {e.kind for e in ONE_OF_EACH} == set(rig_kernel.LAW_CODES) | set(rig_kernel.STATE_CODES)


@pytest.mark.parametrize("effect", ONE_OF_EACH, ids=lambda e: e.kind)
def test_compiled_loop_equals_the_python_loop_for_each_kind(effect):
    t, road = _road()
    py, co = _both([effect], t, road, nsub=2)
    _assert_same(py, co)
    assert np.ptp(py[1]) > 1e-3  # the rig moved


@pytest.mark.parametrize(
    "effects",
    [
        [],
        ONE_OF_EACH[:3],  # three stateless laws (summed in order)
        [_of("coulomb_friction"), _of("dahl_hysteresis")],
        [_of("digressive_damping"), _of("maxwell_viscoelastic"), _of("lugre_friction")],
        ONE_OF_EACH,
    ],
    ids=["linear", "three_laws", "law_and_state", "two_states", "all"],
)
def test_compiled_loop_equals_the_python_loop_for_combinations(effects):
    t, road = _road(seed=1)
    _assert_same(*_both(effects, t, road))


def test_uneven_steps_and_an_actuator_force_agree():
    t, road = _road(800, seed=2)
    rng = np.random.default_rng(3)
    t = np.cumsum(np.r_[0.0, 0.002 * (1.0 + 0.3 * rng.random(t.size - 1))])
    actuator = 300.0 * np.sin(2 * np.pi * 2.0 * t)
    effects = [_of("coulomb_friction"), _of("dahl_hysteresis")]
    py, co = _both(effects, t, road, nsub=3, actuator=actuator)
    _assert_same(py, co)
    # the actuator moved the rig: without it the deflection differs
    no_act = rig_integrator.integrate(300.0, 40.0, BASE, effects, t, road, nsub=3)
    assert np.max(np.abs(no_act[1] - co[1])) > 1e-4


def test_divergence_is_reported_as_by_the_python_loop():
    t, road = _road(400)
    unstable = [make_effect("cubic_stiffness", k3=-1e12)]  # a spring that pushes away
    messages = []
    for integrate in (integrate_reference, rig_integrator.integrate):
        with pytest.raises((EvaluationError, OverflowError)) as err:
            integrate(300.0, 40.0, BASE, unstable, t, road * 20)
        messages.append(str(err.value))
    assert "diverged" in messages[1]


def test_the_loop_runs_as_plain_python_without_numba(monkeypatch):
    # without numba, rig_kernel.run is _run itself: the same outputs to rounding
    t, road = _road(300, seed=4)
    effects = [_of("stribeck_friction"), _of("lugre_friction")]
    co = rig_integrator.integrate(300.0, 40.0, BASE, effects, t, road)
    monkeypatch.setattr(rig_kernel, "run", rig_kernel._run)
    _assert_same(rig_integrator.integrate(300.0, 40.0, BASE, effects, t, road), co)
