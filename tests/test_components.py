"""Component models: planted-parameter recovery, independent physics checks, API rules."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.fitting import fit
from suspenv.measurements import Recording
from suspenv.models.components import (
    DamperDynoModel,
    FrictionGuideModel,
    QuarterCarRigModel,
    make_component,
    simulate_truth,
)
from suspenv.models.effects import dahl_path, effect_kinds, make_effect


def assert_recovered(model, res, truth_theta, rel):
    for name, got, want in zip(model.parameter_names, res.theta, truth_theta, strict=True):
        assert got == pytest.approx(want, rel=rel), name


# ------------------------------------------------------------------ planted parameters
def test_damper_recovers_digressive_and_asymmetry():
    effects = [
        make_effect("digressive_damping", c_low=3000.0, v_knee=0.08),
        make_effect("damper_asymmetry", dc_rebound=800.0),
    ]
    model = DamperDynoModel(effects)
    theta = model.theta_from({"c": 1200.0})
    rec = simulate_truth(model, theta, model.example_recording(seed=3), noise_std=0.01, seed=4)
    res = fit(model, rec)
    assert_recovered(model, res, theta, rel=0.03)
    # the base-only model leaves a much larger residual (20x here)
    base_fit = fit(DamperDynoModel(), rec)
    assert base_fit.rms()["force"] > 10 * res.rms()["force"]


def test_mr_damper_recovers_bouc_wen():
    model = make_component(
        "mr_damper", [make_effect("bouc_wen_hysteresis", f_y=150.0, x_y=0.002, shape=0.5)]
    )
    theta = model.theta_from({"c": 800.0, "k": 2000.0, "f_0": 90.0})
    rec = simulate_truth(model, theta, model.example_recording(seed=1), noise_std=0.01, seed=2)
    res = fit(model, rec)
    assert_recovered(model, res, theta, rel=0.05)


def test_friction_guide_recovers_coulomb_and_offset():
    effects = [
        make_effect("coulomb_friction", f_c=20.0, v_eps=1e-3),
        make_effect("force_offset", offset=-3.2),
    ]
    model = FrictionGuideModel(effects)
    theta = model.theta_from({"m": 95.0, "c": 204.0})
    rec = simulate_truth(model, theta, model.example_recording(seed=0), noise_std=0.02, seed=1)
    res = fit(model, rec)
    assert_recovered(model, res, theta, rel=0.05)
    # without friction the viscous coefficient is inflated (the EMPS lesson)
    base = fit(FrictionGuideModel(), rec)
    assert base.params()["c"]["value"] > 1.1 * 204.0


def test_quarter_car_recovers_friction():
    model = QuarterCarRigModel([make_effect("coulomb_friction", f_c=80.0, v_eps=0.01)])
    theta = model.theta_from({"k_s": 2.5e4, "c_s": 1800.0, "k_t": 2.2e5})
    rec = simulate_truth(
        model, theta, model.example_recording(seed=1, duration=2.0), noise_std=0.01, seed=2
    )
    res = fit(model, rec, max_nfev=30)
    assert_recovered(model, res, theta, rel=0.03)


@pytest.mark.slow
def test_quarter_car_recovers_friction_and_bump_stop():
    effects = [
        make_effect("coulomb_friction", f_c=80.0, v_eps=0.01),
        make_effect("bump_stop", gap=0.012, k_stop=2e5),
    ]
    model = QuarterCarRigModel(effects)
    theta = model.theta_from({"k_s": 2.5e4, "c_s": 1800.0, "k_t": 2.2e5})
    rec = simulate_truth(model, theta, model.example_recording(seed=1), noise_std=0.01, seed=2)
    res = fit(model, rec)
    assert_recovered(model, res, theta, rel=0.05)


# ------------------------------------------------------------------ independent physics
def test_quarter_car_linear_matches_frequency_response(quarter_car_sine_response):
    m_s, m_u, k_s, c_s, k_t = 300.0, 40.0, 2e4, 1500.0, 2e5
    model = QuarterCarRigModel(m_s=m_s, m_u=m_u, dt_max=5e-4)
    f, amp = 2.0, 0.005
    t = np.arange(0.0, 6.0, 1e-3)
    road = amp * np.sin(2 * np.pi * f * t)
    rec = Recording("sine", "rig_sine", t, {"road": road}, {}, {"road": "m"})
    out = model.simulate(np.array([k_s, c_s, k_t]), rec)
    # closed form: steady-state response of the linear 2-DOF system, (-w^2 M + i w C + K) Z = F
    w = 2 * np.pi * f
    Z = quarter_car_sine_response(m_s, m_u, k_s, c_s, k_t, f, amp)
    acc_amp = abs(-(w**2) * Z[0])
    defl_amp = abs(Z[1] - Z[0])
    tail = t > 4.0  # transients (about 1 s time constant) have died out
    ph = np.exp(-1j * w * t[tail])
    got_acc = abs(2 * np.mean(out["body_acceleration"][tail] * ph))
    got_defl = abs(2 * np.mean(out["suspension_deflection"][tail] * ph))
    assert got_acc == pytest.approx(acc_amp, rel=2e-3)
    assert got_defl == pytest.approx(defl_amp, rel=2e-3)


def test_quarter_car_dahl_state_matches_exact_path_form():
    m_s = 300.0
    model = QuarterCarRigModel(
        [make_effect("dahl_hysteresis", f_c=60.0, sigma=3e4)], m_s=m_s, dt_max=5e-4
    )
    # fine sampling: the path form assumes deflection linear between samples
    rec = model.example_recording(seed=5, duration=1.0, dt=5e-4)
    theta = model.theta_from({"k_s": 2e4, "c_s": 0.0, "k_t": 2e5})
    out = model.simulate(theta, rec)
    x = out["suspension_deflection"]
    # force balance on the body: m_s a = k_s x + F_dahl, F_dahl compared with the exact
    # piecewise-exponential path solution along the simulated deflection
    f_dahl = m_s * out["body_acceleration"] - 2e4 * x
    assert np.max(np.abs(f_dahl - dahl_path(x, 3e4, 60.0))) < 0.02 * 60.0


def test_batch_simulation_equals_single_runs():
    model = make_component("damper", [make_effect("dahl_hysteresis", f_c=40.0, sigma=2e5)])
    rec = model.example_recording(seed=0)
    th = np.array([[1000.0, 40.0, 2e5], [1500.0, 60.0, 1e5]])
    batch = model.simulate(th, rec)["force"]
    assert batch.shape == (2, rec.n_samples)
    for i in range(2):
        assert batch[i] == pytest.approx(model.simulate(th[i], rec)["force"])


# ------------------------------------------------------------------ truth generator
def test_truth_noise_level_seed_and_blindness():
    model = make_component("friction_guide", [make_effect("coulomb_friction", f_c=20.0)])
    rec = model.example_recording(seed=0)
    theta = model.theta_from({"m": 95.0, "c": 204.0})
    clean = model.simulate(theta, rec)["force"]
    a = simulate_truth(model, theta, rec, noise_std=0.05, seed=7)
    b = simulate_truth(model, theta, rec, noise_std=0.05, seed=7)
    assert np.array_equal(a.outputs["force"], b.outputs["force"])
    noise = a.outputs["force"] - clean
    assert np.std(noise) == pytest.approx(0.05 * np.sqrt(np.mean(clean**2)), rel=0.05)
    absolute = simulate_truth(model, theta, rec, noise_std={"force": 2.0}, seed=1)
    assert np.std(absolute.outputs["force"] - clean) == pytest.approx(2.0, rel=0.05)
    text = repr(a.meta) + a.name
    assert "coulomb" not in text and "20.0" not in text


def test_truth_of_the_field_damper_keeps_its_coil_current():
    # reference: the planted parameters; a noise-free recording of the model is fitted
    # exactly by the model, so the refit stops at them to the solver's tolerance
    model = make_component("mr_damper", field="coil_current")
    sines = model.example_recording(seed=1)
    current = (np.sin(2 * np.pi * 0.2 * sines.time) > 0).astype(float)  # 0 / 1 A switching
    rec = Recording(
        sines.name,
        sines.test,
        sines.time,
        {**sines.inputs, "coil_current": current},
        {},
        {**sines.units, "coil_current": "A"},
    )
    planted = {"c": 800.0, "k": 500.0, "f_0": 5.0, "c_field": 1500.0, "f_y": 40.0}
    theta = model.theta_from({**planted, "f_field": 300.0, "x_y": 1.5e-3, "shape": 0.5})
    truth = simulate_truth(model, theta, rec)
    assert np.array_equal(truth.inputs["coil_current"], current)
    assert truth.units["coil_current"] == "A"
    res = fit(model, truth, tol=1e-12)
    assert_recovered(model, res, theta, rel=1e-6)


# ------------------------------------------------------------------ interface rules
def test_parameter_names_bounds_and_fixed_parameters():
    model = make_component(
        "quarter_car_rig",
        [make_effect("coulomb_friction", v_eps=0.02), make_effect("bump_stop", name="stop")],
    )
    assert model.parameter_names == (
        "k_s",
        "c_s",
        "k_t",
        "coulomb_friction.f_c",
        "stop.gap",
        "stop.k_stop",
    )
    lo, hi = model.bounds()
    assert lo.shape == hi.shape == (6,) and np.all(lo < hi)
    rec = model.example_recording(seed=0, duration=1.0)
    guess = model.initial_guess(rec)
    assert np.all((lo <= guess) & (guess <= hi))
    # recordings with time gaps (interleaved estimation blocks) still give a start point
    truth = simulate_truth(model, model.theta_from({"k_s": 2e4, "c_s": 1500.0, "k_t": 2e5}), rec)
    est, _ = truth.split_blocks(4, validation=(1,))
    assert np.all(np.isfinite(model.initial_guess(est)))
    again = model.with_effects(model.effects[:1])
    assert again.options == model.options and len(again.parameter_names) == 4
    for fam in ("damper", "mr_damper", "friction_guide", "quarter_car_rig"):
        m = make_component(fam)
        assert set(m.candidate_effects) <= set(effect_kinds())


def test_effect_words_use_the_model_location():
    model = make_component("friction_guide", [make_effect("coulomb_friction")])
    assert model.effect_words(model.effects[0]) == "Coulomb friction in the guide"
    placed = make_effect("dahl_hysteresis", location="lower arm bush")
    assert model.effect_words(placed) == "rubber bushing hysteresis (Dahl) in the lower arm bush"
    assert "coulomb_friction" in repr(model)


def test_interface_errors_name_the_rule():
    with pytest.raises(ValidationError, match="unknown component family 'dampr'"):
        make_component("dampr")
    with pytest.raises(ValidationError, match="unique"):
        make_component("damper", [make_effect("force_offset"), make_effect("force_offset")])
    with pytest.raises(ValidationError, match="output channel"):
        make_component("damper", [make_effect("sensor_gain", location="velocity")])
    with pytest.raises(ValidationError, match="LuGre: too stiff"):
        make_component("quarter_car_rig", [make_effect("lugre_friction")], integrator="rk4")
    with pytest.raises(ValidationError, match="Berg: path memory only"):
        make_component("quarter_car_rig", [make_effect("berg_hysteresis")])
    model = make_component("damper")
    rec = model.example_recording()
    with pytest.raises(ValidationError, match=r"theta must have shape \(1,\)"):
        model.simulate(np.array([1.0, 2.0]), rec)
    bad = Recording(
        "r", "t", rec.time, {"displacement": rec.inputs["displacement"]}, {}, {"displacement": "m"}
    )
    with pytest.raises(ValidationError, match="missing input channel 'velocity'"):
        model.simulate(np.array([1000.0]), bad)


# ------------------------------------------------------------------ quarter car speed paths
def _rig_case():
    effects = [
        make_effect("dahl_hysteresis", f_c=150.0, sigma=1e5),
        make_effect("coulomb_friction", f_c=60.0, v_eps=0.01),
        make_effect("bump_stop", gap=0.01, k_stop=1e5),
    ]
    model = QuarterCarRigModel(effects)
    rec = model.example_recording(seed=4, duration=1.0)
    theta = model.theta_from({"k_s": 2.5e4, "c_s": 1500.0, "k_t": 2e5})
    return model, rec, theta


@pytest.mark.parametrize("integrator", ["exact", "rk4"])
def test_quarter_car_batch_integration_equals_row_by_row(integrator):
    # reference: one parameter set at a time (for RK4 a separate scalar loop of the same
    # scheme; the batched RK4 integrates all rows as arrays at once)
    model, rec, theta = _rig_case()
    model = QuarterCarRigModel(model.effects, integrator=integrator)
    thetas = np.vstack([theta * (1.0 + 0.03 * i) for i in range(4)])
    batch = model.simulate(thetas, rec)
    for i, th in enumerate(thetas):
        row = model.simulate(th, rec)
        for c in row:
            np.testing.assert_allclose(batch[c][i], row[c], rtol=1e-9, atol=1e-12)


def test_quarter_car_equation_error_start_recovers_truth():
    # reference: the planted parameters; the body equation m_s a = F_s holds exactly
    model, rec, theta = _rig_case()
    rec = simulate_truth(model, theta, rec, noise_std=0.0, seed=0)
    start = model.initial_guess(rec)
    refined = model.refine_start(start, [rec])
    for name, got, want in zip(model.parameter_names, refined, theta, strict=True):
        if name != "k_t":  # the tyre does not enter the body equation
            assert got == pytest.approx(want, rel=0.1), name
    view = model.force_view(theta, rec)
    # the truth's force view leaves only the derivative-smoothing error (few % of the force)
    resid = view["measured"] - view["predicted"]
    assert np.std(resid) < 0.05 * np.std(view["measured"])


def test_quarter_car_rk4_refuses_elements_too_stiff_for_it():
    # the fixed-step RK4 scheme (integrator="rk4") refuses what it cannot integrate
    # stably; the default implicit-element scheme integrates it (see
    # tests/test_components_rig_integrator.py)
    from suspenv.core.errors import EvaluationError

    model = QuarterCarRigModel(
        [make_effect("coulomb_friction", f_c=500.0, v_eps=1e-5)], integrator="rk4"
    )
    rec = model.example_recording(seed=1, duration=0.2)
    theta = model.theta_from({"k_s": 2e4, "c_s": 1500.0, "k_t": 2e5})
    with pytest.raises(EvaluationError, match="max_substeps"):
        model.simulate(theta, rec)
    with pytest.raises(ValidationError, match="max_substeps >= 1"):
        QuarterCarRigModel(max_substeps=0)
