"""The Effect descriptor and the registry of effect kinds."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from suspenv.core.errors import ValidationError
from suspenv.models.effects import (
    Effect,
    bouc_wen_force_path,
    coulomb_smooth,
    dahl_path,
    effect_kinds,
    lugre_series,
    make_effect,
    maxwell_series,
)
from suspenv.models.effects.pointwise import PATH_ONLY, STATEFUL, STATELESS, PointwiseElement

REQUIRED_KINDS = {
    "coulomb_friction",
    "directional_friction",
    "stribeck_friction",
    "lugre_friction",
    "dahl_hysteresis",
    "bouc_wen_hysteresis",
    "cubic_stiffness",
    "progressive_stiffness",
    "bump_stop",
    "rebound_stop",
    "bump_and_rebound_stops",
    "digressive_damping",
    "damper_asymmetry",
    "maxwell_viscoelastic",
    "kelvin_voigt",
    "sensor_offset",
    "sensor_gain",
    "sensor_lag",
    "lr_asymmetry",
}


def test_registry_covers_the_spec_families_with_words_and_bounds():
    kinds = effect_kinds()
    assert set(kinds) >= REQUIRED_KINDS
    for k in kinds.values():
        # a pair kind's parameters are its host's (one difference per left/right pair)
        assert k.words and k.signature and (k.parameters or k.host_parameters)
        for p in k.parameters:
            assert p.low <= p.reference <= p.high


def test_force_effects_run_on_a_sweep_with_batch_parameters():
    t = np.linspace(0, 1, 501)
    x = 0.01 * np.sin(2 * np.pi * t)
    xb = np.stack([x, 2 * x])
    for kind in effect_kinds().values():
        if kind.role != "force":
            continue
        e = make_effect(kind.kind)
        f1 = e.force(x, t=t)
        assert f1.shape == x.shape and np.all(np.isfinite(f1)), kind.kind
        # batch-shaped parameters: row b uses parameter set b (same as running it alone)
        twice = {n: np.array([v, v]) for n, v in e.params.items()}
        fb = e.with_params(twice).force(xb, t=t)
        assert fb.shape == xb.shape, kind.kind
        assert fb[1] == pytest.approx(e.force(2 * x, t=t), rel=1e-9, abs=1e-9), kind.kind


def test_effect_force_equals_the_element_function():
    t = np.linspace(0, 1, 1001)
    x = 0.004 * np.sin(2 * np.pi * t)
    v = 0.004 * 2 * np.pi * np.cos(2 * np.pi * t)
    e = make_effect("coulomb_friction", location="strut", f_c=15.0, v_eps=1e-3)
    assert e.force(x, v) == pytest.approx(coulomb_smooth(v, 15.0, 1e-3))
    d = make_effect("dahl_hysteresis", f_c=30.0, sigma=2e4)
    assert d.force(x, v) == pytest.approx(dahl_path(x, 2e4, 30.0))
    assert e.words == "Coulomb friction in the strut"
    assert "f_c=15 N" in e.describe()


def test_effect_validation_messages():
    with pytest.raises(ValidationError, match="unknown effect kind 'coulomb'.*coulomb_friction"):
        Effect("coulomb", "f")
    with pytest.raises(ValidationError, match=r"unknown parameter\(s\) \['fc'\]"):
        Effect("coulomb_friction", "f", {"fc": 1.0})
    with pytest.raises(ValidationError, match="needs the time vector"):
        make_effect("maxwell_viscoelastic").force(np.zeros(4), np.zeros(4))
    with pytest.raises(ValidationError, match="not 'force'"):
        make_effect("sensor_gain").force(np.zeros(3), np.zeros(3))


def test_effect_roundtrip_and_values():
    e = make_effect("bouc_wen_hysteresis", name="bush", location="lower arm", f_y=80.0)
    again = Effect.from_dict(e.to_dict())
    assert again == e
    lo, hi = e.bounds()
    values = [e.params[p] for p in e.spec.parameter_names]
    assert np.all(lo <= values) and np.all(values <= hi)
    assert e.with_params({"n": 2.0}).params == {**e.params, "n": 2.0}


def test_sensor_effect_applies_to_channel():
    t = np.linspace(0, 1, 101)
    y = np.sin(2 * np.pi * t)
    assert make_effect("sensor_offset", offset=0.2).sensor(y) == pytest.approx(y + 0.2)
    assert make_effect("sensor_gain", gain=1.1).sensor(y) == pytest.approx(1.1 * y)
    assert make_effect("sensor_lag", tau=0.0).sensor(y, t) == pytest.approx(y)


def test_pointwise_forms_cover_all_force_kinds_and_match_series_forms():
    force_kinds = {k for k, spec in effect_kinds().items() if spec.role == "force"}
    assert force_kinds == set(STATELESS) | set(STATEFUL) | set(PATH_ONLY)
    with pytest.raises(ValidationError, match="no pointwise form"):
        PointwiseElement(make_effect("berg_hysteresis"))
    x = np.linspace(-0.05, 0.05, 41)
    v = np.linspace(-1.0, 1.0, 41)
    for kind in STATELESS:
        e = make_effect(kind)
        assert PointwiseElement(e).force(x, v) == pytest.approx(e.force(x, v), abs=1e-9), kind


def test_pointwise_state_forms_integrate_to_series_forms():
    # second solver: scipy's ODE solvers on the pointwise state equation vs the series forms
    w = 2 * np.pi * 2.0
    t = np.linspace(0.0, 1.0, 2001)
    x = 0.004 * np.sin(w * t)
    v = 0.004 * w * np.cos(w * t)
    cases = {
        "maxwell_viscoelastic": (dict(k_m=2e4, c_m=400.0), maxwell_series(x, t, 2e4, 400.0)),
        "lugre_friction": (
            dict(sigma0=1e4, sigma1=50.0, f_c=20.0, f_s=30.0, v_s=0.01),
            lugre_series(v, t, 1e4, 50.0, 20.0, 30.0, 0.01),
        ),
        "dahl_hysteresis": (dict(f_c=30.0, sigma=2e4), dahl_path(x, 2e4, 30.0)),
        "bouc_wen_hysteresis": (
            dict(f_y=30.0, x_y=1e-3, shape=0.3, n=1.0),
            bouc_wen_force_path(x, 30.0, 1e-3, 0.3, 1.0),
        ),
    }
    for kind, (params, ref) in cases.items():
        el = PointwiseElement(make_effect(kind, **params))

        def rhs(tt, z, el=el):
            return el.dzdt(0.004 * np.sin(w * tt), 0.004 * w * np.cos(w * tt), z)

        method = "Radau" if kind == "lugre_friction" else "RK45"  # LuGre bristles are stiff
        sol = solve_ivp(rhs, (0.0, 1.0), [0.0], method=method, t_eval=t, rtol=1e-7, atol=1e-9)
        f = el.force(x, v, sol.y[0])
        assert np.max(np.abs(f - ref)) < 0.02 * np.max(np.abs(ref)), kind
    with pytest.raises(ValidationError, match="only force effects"):
        PointwiseElement(make_effect("sensor_gain"))


def test_zero_level_is_the_absent_element():
    # nested-model comparisons need each element to vanish inside its bounds
    zero = {
        "coulomb_friction": {"f_c": 0.0},
        "directional_friction": {"f_pos": 0.0, "f_neg": 0.0},
        "stribeck_friction": {"f_c": 0.0, "f_s": 0.0},
        "dahl_hysteresis": {"f_c": 0.0},
        "bouc_wen_hysteresis": {"f_y": 0.0},
        "berg_hysteresis": {"f_max": 0.0},
        "cubic_stiffness": {"k3": 0.0},
        "progressive_stiffness": {"k_p": 0.0},
        "bump_stop": {"k_stop": 0.0},
        "rebound_stop": {"k_stop": 0.0},
        "bump_and_rebound_stops": {"k_bump": 0.0, "k_rebound": 0.0},
        "digressive_damping": {"c_low": 0.0},
        "damper_asymmetry": {"dc_rebound": 0.0},
        "kelvin_voigt": {"k": 0.0, "c": 0.0},
        "gas_spring": {"f_0": 0.0, "k_gas": 0.0},
        "force_offset": {"offset": 0.0},
        "low_speed_deficit": {"f_d": 0.0},
    }
    t = np.linspace(0, 1, 201)
    x = 0.1 * np.sin(2 * np.pi * 2 * t)
    for kind, params in zero.items():
        e = make_effect(kind, **params)
        lo, hi = e.bounds()
        values = [e.params[p] for p in e.spec.parameter_names]
        assert np.all((lo <= values) & (values <= hi)), kind
        assert np.all(e.force(x, t=t) == 0.0), kind
        if kind in STATEFUL or kind in STATELESS:
            assert PointwiseElement(e).force(0.05, 0.3, 0.0) == 0.0, kind


def test_host_declared_parameters_of_a_pair_effect():
    # reference: lr_asymmetry perturbs the host's own pairs; the host names them d_<name>
    e = make_effect("lr_asymmetry", d_static_toe=0.04, d_top_mount_kz=0.1)
    assert e.host_parameter_names == ("d_static_toe", "d_top_mount_kz")
    assert e.bounds()[1][-2:].tolist() == [np.inf, np.inf]  # the host's to bound
    assert "d_static_toe=0.04" in e.describe()
    assert e.spec.apply(100.0, 0.1) == pytest.approx((95.0, 105.0))
    with pytest.raises(ValidationError, match=r"unknown parameter\(s\) \['toe'\].*d_<name>"):
        make_effect("lr_asymmetry", toe=0.1)
    with pytest.raises(ValidationError, match=r"unknown parameter\(s\) \['d_x'\]"):
        make_effect("coulomb_friction", d_x=1.0)
