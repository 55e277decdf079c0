"""The quarter car's exact-linear / implicit-element integrator against independent references."""

import numpy as np
import pytest

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.measurements import Recording
from suspenv.models.components import QuarterCarRigModel
from suspenv.models.components.rig_integrator import step_matrices
from suspenv.models.effects import make_effect
from suspenv.models.effects.viscoelastic import maxwell_dfdt

BASE = {"k_s": 2.5e4, "c_s": 1500.0, "k_t": 2e5}


def _rel_err(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.std(a - b) / np.std(b))


def test_step_matrices_match_the_free_response_closed_form():
    # reference: with no input, Phi = expm(A h) must equal the modal solution V e^{Lh} V^-1
    m_s, m_u, k_s, c_s, k_t, h = 300.0, 40.0, 2e4, 1500.0, 2e5, 2e-3
    phi, g0, g1 = step_matrices(m_s, m_u, k_s, c_s, k_t, h)
    A = np.array(
        [
            [0, 1, 0, 0],
            [-k_s / m_s, -c_s / m_s, k_s / m_s, c_s / m_s],
            [0, 0, 0, 1],
            [k_s / m_u, c_s / m_u, -(k_s + k_t) / m_u, -c_s / m_u],
        ]
    )
    lam, V = np.linalg.eig(A)
    modal = (V @ np.diag(np.exp(lam * h)) @ np.linalg.inv(V)).real
    np.testing.assert_allclose(phi, modal, atol=1e-12)
    # a constant road height held over the step: the static gain of the tyre input is
    # (G0 + G1) = A^-1 (Phi - I) B, the exact zero-order-hold integral
    B = np.array([0.0, 0.0, 0.0, k_t / m_u])
    np.testing.assert_allclose(
        g0[:, 0] + g1[:, 0], np.linalg.solve(A, (phi - np.eye(4)) @ B), atol=1e-12
    )


def test_linear_rig_at_the_recording_step_matches_frequency_response(quarter_car_sine_response):
    # reference: steady-state response of the linear 2-DOF system,
    # (-w^2 M + i w C + K) Z = F; the step is exact for a road linear between samples,
    # so at the 2 ms recording step only the interpolation of the sine itself differs
    m_s, m_u, k_s, c_s, k_t = 300.0, 40.0, 2e4, 1500.0, 2e5
    model = QuarterCarRigModel(m_s=m_s, m_u=m_u, dt_max=2e-3)
    for f in (1.25, 10.0):  # whole numbers of samples per period
        amp = 0.005
        t = np.arange(0.0, 6.0, 2e-3)
        road = amp * np.sin(2 * np.pi * f * t)
        rec = Recording("sine", "rig_sine", t, {"road": road}, {}, {"road": "m"})
        out = model.simulate(np.array([k_s, c_s, k_t]), rec)
        w = 2 * np.pi * f
        Z = quarter_car_sine_response(m_s, m_u, k_s, c_s, k_t, f, amp)
        # the last whole periods (transients, about 0.4 s time constant, have died out)
        per = int(round(1.0 / (f * 2e-3)))
        tail = slice(t.size - per * int(2.0 * f), t.size)
        ph = np.exp(-1j * w * t[tail])
        got = 2 * np.mean(out["body_acceleration"][tail] * ph)
        # the road is held linear between samples: the fundamental of a linearly
        # interpolated sine is the sine scaled by sinc^2(f h) (triangle kernel, no phase)
        hold = np.sinc(f * 2e-3) ** 2
        assert abs(got) == pytest.approx(hold * abs(-(w**2) * Z[0]), rel=2e-5)
        # a sine input: complex amplitude -i times that of the cosine the closed form uses
        assert np.angle(got) == pytest.approx(np.angle(-1j * -(w**2) * Z[0]), abs=1e-4)


@pytest.mark.parametrize(
    "effects",
    [
        [make_effect("coulomb_friction", f_c=250.0, v_eps=0.01)],
        [make_effect("stribeck_friction", f_c=150.0, f_s=300.0, v_s=0.1, v_eps=0.01)],
        [make_effect("dahl_hysteresis", f_c=300.0, sigma=1.5e5)],
        [make_effect("bump_stop", gap=0.01, k_stop=1e5), make_effect("cubic_stiffness", k3=3e7)],
        [make_effect("digressive_damping", c_low=3000.0, v_knee=0.2)],
        [make_effect("maxwell_viscoelastic", k_m=2e4, c_m=800.0)],
    ],
    ids=lambda effs: "+".join(e.kind for e in effs),
)
def test_exact_scheme_agrees_with_fine_rk4(effects):
    # reference: the classical RK4 scheme at 20 sub-steps per 2 ms sample (a second,
    # independent integrator); the implicit scheme at its default 1 ms step agrees to
    # about 1 % of the signal (friction steps are the hardest case)
    model = QuarterCarRigModel(effects)
    rk4 = QuarterCarRigModel(effects, integrator="rk4", dt_max=1e-4, max_substeps=50)
    rec = model.example_recording(seed=3, duration=1.5)
    theta = model.theta_from(BASE)
    got, ref = model.simulate(theta, rec), rk4.simulate(theta, rec)
    for ch in got:
        assert _rel_err(got[ch], ref[ch]) < 1e-2, ch


def test_maxwell_step_is_the_exact_lag_of_a_linear_velocity():
    # reference: scipy's adaptive ODE solver on F' = k_m (v - F / c_m) with v linear in t
    from rig_reference import _Maxwell
    from scipy.integrate import solve_ivp

    eff = make_effect("maxwell_viscoelastic", k_m=2e4, c_m=800.0)
    el = _Maxwell(eff)
    v0, v1, h, z0 = 0.3, -0.2, 5e-3, 40.0

    def rhs(s, z):
        return maxwell_dfdt(z, v0 + (v1 - v0) * s / h, 2e4, 800.0)

    sol = solve_ivp(rhs, (0.0, h), [z0], rtol=1e-11, atol=1e-11)
    assert el.step(z0, 0.0, 0.0, v0, v1, h) == pytest.approx(sol.y[0, -1], rel=1e-8)


def test_exact_scheme_is_stable_where_rk4_refuses():
    # a friction step of 10 um/s would need thousands of RK4 sub-steps; the implicit
    # element force keeps the scheme stable. Reference: the same friction at a 100x
    # wider step, whose sliding force (f_c away from reversals) is physically the same
    sharp = [make_effect("coulomb_friction", f_c=500.0, v_eps=1e-5)]
    wide = [make_effect("coulomb_friction", f_c=500.0, v_eps=1e-3)]
    rec = QuarterCarRigModel().example_recording(seed=1, duration=1.0)
    theta = QuarterCarRigModel(sharp).theta_from({"k_s": 2e4, "c_s": 1500.0, "k_t": 2e5})
    with pytest.raises(EvaluationError, match="max_substeps"):
        QuarterCarRigModel(sharp, integrator="rk4").simulate(theta, rec)
    a = QuarterCarRigModel(sharp).simulate(theta, rec)
    b = QuarterCarRigModel(wide).simulate(theta, rec)
    assert np.all(np.isfinite(a["body_acceleration"]))
    assert _rel_err(a["suspension_deflection"], b["suspension_deflection"]) < 0.02
    with pytest.raises(ValidationError, match="`integrator` must be one of"):
        QuarterCarRigModel(integrator="euler")


def test_bouc_wen_falls_back_to_rk4():
    # Bouc-Wen has no exact state step here: the model integrates it with RK4 whatever
    # the integrator option (reference: the explicit rk4 option gives identical output)
    eff = [make_effect("bouc_wen_hysteresis", f_y=100.0, x_y=2e-3)]
    rec = QuarterCarRigModel().example_recording(seed=2, duration=0.5)
    theta = QuarterCarRigModel(eff).theta_from(BASE)
    a = QuarterCarRigModel(eff).simulate(theta, rec)
    b = QuarterCarRigModel(eff, integrator="rk4").simulate(theta, rec)
    np.testing.assert_array_equal(a["body_acceleration"], b["body_acceleration"])


@pytest.mark.parametrize(
    "effect",
    [
        make_effect("coulomb_friction", f_c=120.0, v_eps=0.01),
        make_effect("stribeck_friction", f_c=100.0, f_s=180.0, v_s=0.05, v_eps=0.01),
        make_effect("directional_friction", f_pos=90.0, f_neg=60.0, v_eps=0.01),
        make_effect("bump_stop", gap=0.01, k_stop=1e5),
        make_effect("rebound_stop", gap=0.01, k_stop=1e5),
        make_effect("cubic_stiffness", k3=-2e7),
        make_effect("progressive_stiffness", x0=0.005, k_p=3e6),
        make_effect("damper_asymmetry", dc_rebound=-800.0),
        make_effect("digressive_damping", c_low=3000.0, v_knee=0.2),
        make_effect("gas_spring", f_0=50.0, k_gas=2000.0),
        make_effect("force_offset", offset=-12.0),
    ],
    ids=lambda e: e.kind,
)
def test_float_element_laws_equal_the_array_laws(effect):
    # reference: the array form of each law (the effect's series form)
    from rig_reference import _element_law

    rng = np.random.default_rng(0)
    x = rng.uniform(-0.04, 0.04, 200)
    v = rng.uniform(-1.0, 1.0, 200)
    law = _element_law(effect)
    got = np.array([law(float(a), float(b)) for a, b in zip(x, v, strict=True)])
    want = effect.force(x, v) + 0.0 * x
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)


def test_lugre_friction_on_the_rig_agrees_with_fine_rk4():
    # LuGre is refused by the explicit scheme but integrated by the implicit one (at its
    # default 1 ms step). Reference: the same pointwise LuGre law integrated by RK4 at
    # 40 sub-steps per 2 ms sample (the RK4 path's stiffness check does not know the
    # bristle rate, so the step is set by hand well below g / (sigma0 |v|))
    from suspenv.models.components.quarter_car import QuarterCarRigModel as Q

    eff = [make_effect("lugre_friction", sigma0=2e5, sigma1=300.0, f_c=150.0, f_s=250.0, v_s=0.05)]
    with pytest.raises(ValidationError, match="LuGre"):
        Q(eff, integrator="rk4")
    model = Q(eff)
    rec = model.example_recording(seed=3, duration=0.6)
    theta = model.theta_from(BASE)
    got = model.simulate(theta, rec)
    ref_model = Q([], integrator="rk4")
    ref_model.effects = tuple(eff)  # bypass the refusal: a reference run at a tiny step
    ref_model.options.update(dt_max=5e-5, max_substeps=100)
    ref = ref_model.simulate(theta, rec)
    for ch in got:
        assert _rel_err(got[ch], ref[ch]) < 2e-3, ch


def test_jacobian_twin_steers_the_fit_to_the_same_optimum():
    # reference: the planted parameters of a noise-free run of the default-step model;
    # the once-per-sample twin (sensitivities within about 25 % here) only steers the
    # fit, so the optimum is the default step's own, and the reported standard errors
    # come from the default step's Jacobian
    from suspenv.diagnosis.fitting import fit
    from suspenv.models.components import simulate_truth

    eff = [make_effect("coulomb_friction", f_c=250.0, v_eps=0.01)]
    model = QuarterCarRigModel(eff)
    twin = model.jacobian_model()
    assert twin.options["dt_max"] >= 2e-3 and twin.parameter_names == model.parameter_names
    theta = model.theta_from(BASE)
    rec = simulate_truth(model, theta, model.example_recording(seed=2, duration=1.0), 0.0)
    res = fit(model, rec, theta0=theta * 1.1, max_nfev=30)
    np.testing.assert_allclose(res.theta, theta, rtol=1e-3)
    h = 1e-6 * theta
    for i in range(theta.size):
        d = model.simulate(theta + np.eye(theta.size)[i] * h, rec)["body_acceleration"]
        d = (d - model.simulate(theta, rec)["body_acceleration"]) / h[i]
        # the fit's residual is (measured - predicted) / scale
        col = -res.extra["jacobian"][: rec.n_samples, i] * res.scales["body_acceleration"]
        assert _rel_err(col, d) < 0.02, model.parameter_names[i]


def test_actuator_force_matches_the_steady_state_transfer_function():
    # reference: the closed-form harmonic response of the linear 2-DOF system to a force
    # F_a = A sin(w t) between body and wheel (positive pushing them apart), road at rest
    m_s, m_u = 320.0, 45.0
    k_s, c_s, k_t = BASE["k_s"], BASE["c_s"], BASE["k_t"]
    amp, f_hz, dt = 200.0, 3.0, 1e-3
    t = np.arange(int(12.0 / dt)) * dt
    w = 2 * np.pi * f_hz
    rec = Recording(
        "actuated",
        "rig_actuator",
        t,
        {"road": np.zeros_like(t), "actuator_force": amp * np.sin(w * t)},
        {},
        {"road": "m", "actuator_force": "N", "body_acceleration": "m/s^2",
         "suspension_deflection": "m"},
    )  # fmt: skip
    model = QuarterCarRigModel(m_s=m_s, m_u=m_u)
    out = model.simulate(model.theta_from(BASE), rec)
    # [-w^2 M + i w C + K] Z = B F with q = (z_s, z_u), B = (1, -1)
    s = 1j * w
    dyn = np.array(
        [
            [m_s * s**2 + c_s * s + k_s, -(c_s * s + k_s)],
            [-(c_s * s + k_s), m_u * s**2 + c_s * s + k_s + k_t],
        ]
    )
    z = np.linalg.solve(dyn, np.array([1.0, -1.0]) * amp)
    want_acc = np.abs(s**2 * z[0])
    want_defl = np.abs(z[1] - z[0])
    tail = t > 8.0  # transients (time constants below 0.5 s) have decayed
    got_acc = np.sqrt(2) * np.std(out["body_acceleration"][tail])
    got_defl = np.sqrt(2) * np.std(out["suspension_deflection"][tail])
    assert abs(got_acc - want_acc) / want_acc < 2e-3
    assert abs(got_defl - want_defl) / want_defl < 2e-3
    # the waveform, phase and sign included (F_a = Im(A e^{iwt}), so a = Im(s^2 Z_s e^{iwt})):
    # a wrong sign of the actuator force would give the negated waveform
    want = np.imag(s**2 * z[0] * np.exp(1j * w * t))
    err = out["body_acceleration"][tail] - want[tail]
    assert np.std(err) / np.std(want[tail]) < 5e-3


def test_rows_with_the_same_dynamics_are_integrated_once(monkeypatch):
    # a Jacobian-like batch: a centre row, a sensor-offset column (same dynamics) and a
    # friction column; reference: each row simulated alone
    import suspenv.models.components.rig_integrator as integrator

    effects = [
        make_effect("coulomb_friction", f_c=250.0, v_eps=0.01),
        make_effect("sensor_offset", location="body_acceleration"),
    ]
    model = QuarterCarRigModel(effects)
    rec = model.example_recording(seed=3, duration=0.5)
    theta = model.theta_from(BASE)
    names = list(model.parameter_names)
    rows = np.vstack([theta, theta, theta])
    rows[1, names.index(next(n for n in names if "offset" in n))] += 0.1
    rows[2, names.index(next(n for n in names if n.endswith("f_c")))] += 5.0
    calls = []
    real = integrator.integrate
    monkeypatch.setattr(integrator, "integrate", lambda *a, **k: calls.append(1) or real(*a, **k))
    batch = model.simulate(rows, rec)
    assert len(calls) == 2
    for i in range(3):
        alone = model.simulate(rows[i], rec)
        for ch, y in alone.items():
            np.testing.assert_array_equal(batch[ch][i], y)
    # the offset column differs from the centre by the offset only
    np.testing.assert_allclose(
        batch["body_acceleration"][1] - batch["body_acceleration"][0], 0.1, rtol=1e-12
    )
