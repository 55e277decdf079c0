"""Effect elements against closed forms and second solvers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from suspenv.core.errors import ValidationError
from suspenv.models import effects as fx


def sine(amplitude: float, freq: float, cycles: int = 3, per_cycle: int = 2000):
    """Displacement, velocity and time of ``cycles`` periods of ``A sin(wt)``."""
    w = 2 * np.pi * freq
    t = np.linspace(0.0, cycles / freq, cycles * per_cycle + 1)
    return amplitude * np.sin(w * t), amplitude * w * np.cos(w * t), t, w


def last_cycle_work(x: np.ndarray, f: np.ndarray, per_cycle: int = 2000) -> np.ndarray:
    """Energy absorbed over the last full cycle, ∮ F dx (trapezoid) [J]."""
    xs, fs = x[..., -per_cycle - 1 :], f[..., -per_cycle - 1 :]
    return np.sum(0.5 * (fs[..., 1:] + fs[..., :-1]) * np.diff(xs, axis=-1), axis=-1)


def harmonic(y: np.ndarray, t: np.ndarray, w: float, k: int) -> complex:
    """Complex amplitude of harmonic ``k`` over an integer number of periods."""
    tt, yy = t[:-1], y[:-1]
    return 2.0 * np.mean(yy * np.exp(-1j * k * w * tt))


# ------------------------------------------------------------------ friction
def test_coulomb_energy_per_cycle_is_4_fc_A():
    x, v, t, _ = sine(0.02, 1.0)
    f = fx.coulomb_smooth(v, 20.0, v_eps=1e-5)
    # closed form: Coulomb friction dissipates 4 F_c A per cycle
    assert last_cycle_work(x, f) == pytest.approx(4 * 20.0 * 0.02, rel=2e-3)


def test_viscous_energy_per_cycle_is_pi_c_w_A2():
    x, v, t, w = sine(0.01, 3.0)
    f = fx.kelvin_voigt(x, v, 5e4, 800.0)
    # closed form: viscous damping dissipates pi c w A^2; the spring stores none over a cycle
    assert last_cycle_work(x, f) == pytest.approx(np.pi * 800.0 * w * 0.01**2, rel=1e-4)


def test_directional_friction_levels_and_offset_equivalence():
    v = np.array([-1.0, 1.0])
    f = fx.coulomb_directional(v, f_pos=25.0, f_neg=15.0, v_eps=1e-6)
    assert f == pytest.approx([-15.0, 25.0])
    # away from v = 0 it equals symmetric friction (mean level) plus a constant offset
    sym = fx.coulomb_smooth(v, 20.0, 1e-6) + 5.0
    assert f == pytest.approx(sym)


def test_stribeck_limits():
    # g(0) = f_s and g(v >> v_s) = f_c (definition of the Stribeck curve)
    assert fx.stribeck_level(0.0, 20.0, 35.0, 0.01) == pytest.approx(35.0)
    assert fx.stribeck_level(1.0, 20.0, 35.0, 0.01) == pytest.approx(20.0)
    assert fx.stribeck_friction(-1.0, 20.0, 35.0, 0.01) == pytest.approx(-20.0)


def test_lugre_steady_sliding_equals_stribeck_curve():
    # steady state dz/dt = 0 gives z = g(v)/sigma0 sign(v) and F = g(v) (Canudas de Wit 1995)
    t = np.linspace(0, 3.0, 3001)
    for vel in (-0.2, 0.005, 0.05):
        v = np.full((1, t.size), vel)
        f = fx.lugre_series(v, t, 1e5, 300.0, 20.0, 35.0, 0.01)
        ref = fx.stribeck_friction(vel, 20.0, 35.0, 0.01, 1e-9)
        assert f[0, -1] == pytest.approx(ref, rel=1e-6)


def test_lugre_series_matches_stiff_ode_solver():
    x, v, t, w = sine(0.005, 2.0, cycles=1, per_cycle=2000)
    p = dict(sigma0=1e4, sigma1=50.0, f_c=20.0, f_s=30.0, v_s=0.01)
    f = fx.lugre_series(v, t, **p)

    def rhs(tt, z):
        vv = 0.005 * w * np.cos(w * tt)
        return fx.lugre_dzdt(z, vv, p["sigma0"], p["f_c"], p["f_s"], p["v_s"])

    # second solver: implicit Radau on the state-derivative form
    sol = solve_ivp(rhs, (t[0], t[-1]), [0.0], method="Radau", t_eval=t, rtol=1e-9, atol=1e-12)
    f_ref = fx.lugre_force(sol.y[0], v, p["sigma0"], p["sigma1"], p["f_c"], p["f_s"], p["v_s"])
    assert np.max(np.abs(f - f_ref)) < 0.02 * 30.0


# ------------------------------------------------------------------ hysteresis
def dahl_energy_closed_form(f_c: float, sigma: float, A: float) -> float:
    """Steady Dahl loop area 4 f_c (A - L tanh(A/L)), L = f_c/sigma (exponential branches)."""
    L = f_c / sigma
    return 4 * f_c * (A - L * np.tanh(A / L))


@pytest.mark.parametrize("A", [0.0005, 0.002, 0.02])
def test_dahl_loop_energy_closed_form(A):
    x, _, _, _ = sine(A, 1.0)
    f = fx.dahl_path(x, sigma=5e4, f_c=40.0)
    assert last_cycle_work(x, f) == pytest.approx(dahl_energy_closed_form(40.0, 5e4, A), rel=1e-3)


def test_dahl_turning_point_force_closed_form():
    # steady loop: force at x = A is f_c tanh(A sigma / f_c) (from the exponential branches)
    x, _, _, _ = sine(0.001, 1.0)
    f = fx.dahl_path(x, sigma=5e4, f_c=40.0)
    assert f[..., -1500] == pytest.approx(40.0 * np.tanh(0.001 * 5e4 / 40.0), rel=1e-4)


def test_dahl_is_rate_independent_and_matches_time_integration():
    sigma, f_c, A = 3e4, 30.0, 0.003
    loops = []
    for freq in (0.5, 5.0):
        x, v, t, w = sine(A, freq, cycles=2, per_cycle=500)

        def rhs(tt, z, w=w):
            return fx.dahl_dzdt(z, A * w * np.cos(w * tt), sigma, f_c)

        # second solver: the time form integrated by an adaptive RK method
        sol = solve_ivp(rhs, (t[0], t[-1]), [0.0], t_eval=t, rtol=1e-10, atol=1e-10, max_step=t[1])
        loops.append(sol.y[0])
        assert np.max(np.abs(sol.y[0] - fx.dahl_path(x, sigma, f_c))) < 1e-3 * f_c
    # the same displacement path at a 10x different rate gives the same loop
    assert np.max(np.abs(loops[0] - loops[1])) < 1e-3 * f_c


def test_bouc_wen_monotone_loading_closed_form_and_ultimate():
    A, beta, gamma = 2.0, 1.5, 0.5
    x = np.linspace(0, 5.0, 2001)
    z = fx.bouc_wen_path(x, A, beta, gamma, n=1.0)
    # n = 1 loading from rest: dz/dx = A - (beta+gamma) z  =>  z = z_u (1 - exp(-(beta+gamma) x))
    zu = A / (beta + gamma)
    assert z == pytest.approx(zu * (1 - np.exp(-(beta + gamma) * x)), abs=1e-7)
    # for n = 2 the state saturates at z_u = (A/(beta+gamma))^(1/n)
    z2 = fx.bouc_wen_path(x, A, beta, gamma, n=2.0)
    assert z2[-1] == pytest.approx(fx.bouc_wen_ultimate(A, beta, gamma, 2.0), rel=1e-6)
    assert np.sqrt(zu) == pytest.approx(fx.bouc_wen_ultimate(A, beta, gamma, 2.0))


def test_bouc_wen_with_gamma_zero_and_n_one_is_dahl():
    # n = 1, shape b = 1 (gamma = 0): dz/dx = (1 - s z)/x_y, exactly Dahl with x_y = f_c/sigma
    x, _, _, _ = sine(0.004, 1.0, cycles=2, per_cycle=1000)
    f_bw = fx.bouc_wen_force_path(x, f_y=50.0, x_y=50.0 / 2e4, shape=1.0, n=1.0)
    f_dahl = fx.dahl_path(x, sigma=2e4, f_c=50.0)
    assert np.max(np.abs(f_bw - f_dahl)) < 1e-6 * 50.0


def test_bouc_wen_time_form_matches_path_form():
    A, beta, gamma, n = 1.0 / 0.002, 0.3 / 0.002, 0.7 / 0.002, 2.0
    x, v, t, w = sine(0.004, 1.0, cycles=2, per_cycle=1000)

    def rhs(tt, z):
        return fx.bouc_wen_dzdt(z, 0.004 * w * np.cos(w * tt), A, beta, gamma, n)

    # second solver: the time form integrated by an adaptive RK method
    sol = solve_ivp(rhs, (t[0], t[-1]), [0.0], t_eval=t, rtol=1e-10, atol=1e-12, max_step=t[1])
    assert np.max(np.abs(sol.y[0] - fx.bouc_wen_path(x, A, beta, gamma, n))) < 1e-4


@pytest.mark.parametrize("shape", [0.2, 0.5, 0.9])
def test_bouc_wen_exact_n1_path_matches_time_integration(shape):
    x_y, f_y = 0.002, 80.0
    A, beta, gamma = 1 / x_y, shape / x_y, (1 - shape) / x_y
    x, v, t, w = sine(0.005, 1.0, cycles=2, per_cycle=400)

    def rhs(tt, z):
        return fx.bouc_wen_dzdt(z, 0.005 * w * np.cos(w * tt), A, beta, gamma, 1.0)

    # second solver: the time form integrated by an adaptive RK method
    sol = solve_ivp(rhs, (t[0], t[-1]), [0.0], t_eval=t, rtol=1e-10, atol=1e-12, max_step=t[1])
    f = fx.bouc_wen_force_path(x, f_y, x_y, shape, 1.0)
    assert np.max(np.abs(f - f_y * sol.y[0])) < 1e-5 * f_y


def test_berg_virgin_curve_and_steady_loop_closed_form():
    f_max, x2 = 80.0, 0.001
    x = np.linspace(0.0, 0.01, 1001)
    f = fx.berg_path(x, f_max, x2)
    # virgin curve F = x/(x2 + x) f_max: half the limit force at x = x2 (Berg 1998)
    assert f[100] == pytest.approx(0.5 * f_max, rel=1e-9)
    assert f == pytest.approx(x / (x2 + x) * f_max)
    # symmetric steady loop between +-A: the turning force F_A solves
    # (x2/f_max) F_A^2 + (x2 + A) F_A - A f_max = 0 (closing the branch from +A to -A)
    A = 0.003
    xs, _, _, _ = sine(A, 1.0, cycles=8, per_cycle=400)
    fs = fx.berg_path(xs, f_max, x2)
    qa, qb, qc = x2 / f_max, x2 + A, -A * f_max
    f_a = (-qb + np.sqrt(qb**2 - 4 * qa * qc)) / (2 * qa)
    assert np.max(fs[-400:]) == pytest.approx(f_a, rel=1e-3)
    assert np.min(fs[-400:]) == pytest.approx(-f_a, rel=1e-3)
    # path form: the loop does not depend on the rate at which it is travelled
    slow, _, _, _ = sine(A, 0.1, cycles=8, per_cycle=400)
    assert fx.berg_path(slow, f_max, x2) == pytest.approx(fs)


def test_hysteresis_is_vectorised_over_batch():
    x, _, _, _ = sine(0.003, 1.0, cycles=1, per_cycle=500)
    xb = np.stack([x, 2 * x])
    sig = np.array([1e4, 3e4])
    fb = fx.dahl_path(xb, sigma=sig, f_c=np.array([20.0, 40.0]))
    assert fb[1] == pytest.approx(fx.dahl_path(2 * x, 3e4, 40.0))
    bw = fx.bouc_wen_force_path(xb, f_y=[10.0, 20.0], x_y=[1e-3, 2e-3], shape=0.4, n=[1.0, 2.0])
    assert bw[1] == pytest.approx(fx.bouc_wen_force_path(2 * x, 20.0, 2e-3, 0.4, 2.0), rel=1e-9)


# ------------------------------------------------------------------ stiffness and stops
def test_cubic_stiffness_third_harmonic():
    x, _, t, w = sine(0.03, 1.0, cycles=1, per_cycle=4096)
    f = fx.cubic_stiffness(x, 2e6)
    # sin^3 = (3 sin - sin 3wt)/4: fundamental 3 k3 A^3/4, third harmonic k3 A^3/4
    a3 = 2e6 * 0.03**3 / 4
    assert abs(harmonic(f, t, w, 3)) == pytest.approx(a3, rel=1e-6)
    assert abs(harmonic(f, t, w, 1)) == pytest.approx(3 * a3, rel=1e-6)
    assert abs(harmonic(f, t, w, 2)) < 1e-9 * a3  # odd symmetric: no even harmonics


def test_progressive_spring_odd_and_free_range():
    x = np.array([-0.05, -0.01, 0.0, 0.01, 0.05])
    f = fx.progressive_spring(x, 1e6, x0=0.02)
    assert f == pytest.approx([-1e6 * 0.03**2, 0, 0, 0, 1e6 * 0.03**2])


def test_end_stops_are_one_sided_with_threshold():
    x = np.linspace(-0.1, 0.1, 2001)
    fb = fx.bump_stop(x, gap=0.04, k_stop=2e5, p=2.0)
    fr = fx.rebound_stop(x, gap=0.06, k_stop=1e5)
    assert np.all(fb[x <= 0.04] == 0.0) and np.all(fb[x > 0.04] > 0)
    assert fb[-1] == pytest.approx(2e5 * 0.06**2)
    assert np.all(fr[x >= -0.06] == 0.0) and np.all(fr[x < -0.06] < 0)
    assert fr[0] == pytest.approx(-1e5 * 0.04)
    # the laws check nothing; an effect checks its parameters' domain before its force
    with pytest.raises(ValidationError, match="gap >= 0"):
        fx.make_effect("bump_stop", gap=-0.01, k_stop=1.0).force(x, x)


def test_bump_and_rebound_stops_act_on_their_own_side_with_their_own_onset():
    x = np.linspace(-0.1, 0.1, 2001)
    f = fx.bump_and_rebound_stops(x, gap_bump=0.04, k_bump=2e5, gap_rebound=0.06, k_rebound=1e5)
    # golden values by hand: compression (x > 0) pushes back (+), extension pulls back (-)
    assert np.all(f[(x >= -0.06) & (x <= 0.04)] == 0.0)
    assert f[-1] == pytest.approx(2e5 * (0.1 - 0.04))
    assert f[0] == pytest.approx(-1e5 * (0.1 - 0.06))
    assert np.all(f[x > 0.04] > 0) and np.all(f[x < -0.06] < 0)
    # the two one-sided stops summed
    both = fx.bump_stop(x, 0.04, 2e5) + fx.rebound_stop(x, 0.06, 1e5)
    assert np.array_equal(f, both)
    # equal sides with p = 2: the progressive spring beyond a free range (its closed form)
    sym = fx.bump_and_rebound_stops(x, 0.02, 1e6, 0.02, 1e6, p=2.0)
    assert sym == pytest.approx(1e6 * np.sign(x) * np.maximum(np.abs(x) - 0.02, 0.0) ** 2)
    with pytest.raises(ValidationError, match="gap_rebound >= 0"):
        fx.make_effect("bump_and_rebound_stops", gap_rebound=-0.01).force(x, x)
    with pytest.raises(ValidationError, match="`p >= 1` must hold, but got p=0.5"):
        fx.make_effect("bump_and_rebound_stops", p=0.5).force(x, x)


# ------------------------------------------------------------------ damper curves
def test_damper_curves_limits_and_energy():
    v = np.array([-2.0, -0.01, 0.0, 0.01, 2.0])
    # digressive: slope c_low at rest, force -> c_low v_knee at high speed
    d = fx.damper_digressive(np.array([1e-6, 100.0]), 3000.0, 0.1)
    assert d[0] / 1e-6 == pytest.approx(3000.0, rel=1e-4)
    assert d[1] == pytest.approx(3000.0 * 0.1, rel=2e-3)
    # energy per cycle of a bilinear damper (1000 N s/m plus 2000 extra in rebound):
    # pi w A^2 (c_bump + c_rebound)/2
    x, vv, t, w = sine(0.02, 2.0)
    work = last_cycle_work(x, 1000.0 * vv + fx.extra_rebound_damping(vv, 2000.0))
    assert work == pytest.approx(np.pi * w * 0.02**2 * 2000.0, rel=1e-4)
    assert fx.extra_rebound_damping(v, 500.0) == pytest.approx([-1000.0, -5.0, 0, 0, 0])


# ------------------------------------------------------------------ viscoelastic
def test_maxwell_phase_and_energy_closed_form():
    k_m, c_m = 2e4, 400.0  # tau = 0.02 s
    tau = c_m / k_m
    for freq in (1.0, 8.0):
        x, _, t, w = sine(0.01, freq, cycles=6)
        f = fx.maxwell_series(x, t, k_m, c_m)
        tail = slice(-2001, None)
        h_f = harmonic(f[tail], t[tail], w, 1)
        h_x = harmonic(x[tail], t[tail], w, 1)
        lead = np.angle(h_f / h_x)
        # complex stiffness K* = k_m i w tau / (1 + i w tau)
        kstar = k_m * 1j * w * tau / (1 + 1j * w * tau)
        assert lead == pytest.approx(np.arctan2(1.0, w * tau), abs=2e-3)
        assert lead == pytest.approx(np.angle(kstar), abs=2e-3)
        assert last_cycle_work(x, f) == pytest.approx(np.pi * 0.01**2 * kstar.imag, rel=2e-3)


def test_maxwell_series_matches_ode_solver():
    x, v, t, w = sine(0.01, 3.0, cycles=1, per_cycle=3000)

    def rhs(tt, f):
        return fx.maxwell_dfdt(f, 0.01 * w * np.cos(w * tt), 2e4, 400.0)

    sol = solve_ivp(rhs, (t[0], t[-1]), [0.0], t_eval=t, rtol=1e-10, atol=1e-10)
    assert np.max(np.abs(fx.maxwell_series(x, t, 2e4, 400.0) - sol.y[0])) < 1e-3 * 100


# ------------------------------------------------------------------ sensor
def test_sensor_lag_amplitude_and_phase_closed_form():
    tau = 0.01
    y, _, t, w = sine(1.0, 10.0, cycles=8)
    yr = fx.sensor_lag(y, t, tau)
    tail = slice(-2001, None)
    ratio = harmonic(yr[tail], t[tail], w, 1) / harmonic(y[tail], t[tail], w, 1)
    # first-order low pass: |H| = 1/sqrt(1 + (w tau)^2), phase -atan(w tau)
    assert abs(ratio) == pytest.approx(1 / np.sqrt(1 + (w * tau) ** 2), rel=1e-4)
    assert np.angle(ratio) == pytest.approx(-np.arctan(w * tau), abs=1e-4)
    assert fx.sensor_lag(y, t, 0.0) == pytest.approx(y)


def test_sensor_offset_gain_and_delay():
    t = np.linspace(0, 1, 1001)
    y = np.sin(2 * np.pi * t)
    assert fx.sensor_offset_gain(y, 0.5, 1.1) == pytest.approx(1.1 * y + 0.5)
    d = fx.sensor_delay(y, t, 0.1)
    assert d[500:] == pytest.approx(np.sin(2 * np.pi * (t[500:] - 0.1)), abs=1e-4)


# ------------------------------------------------------------------ asymmetry
def test_lr_perturbation_reproducible_and_within_tolerance():
    a = fx.perturb_pair(1000.0, 0.05, seed=3)
    assert a == fx.perturb_pair(1000.0, 0.05, seed=3)
    assert all(950.0 <= v <= 1050.0 for v in a)
    assert fx.split_pair(100.0, 0.1) == pytest.approx((95.0, 105.0))
    with pytest.raises(ValidationError, match="tolerance >= 0"):
        fx.perturb_pair(1.0, -0.1)


def test_bad_inputs_name_rule_and_value():
    with pytest.raises(ValidationError, match=r"`sigma > 0` must hold, but got sigma=-1"):
        fx.dahl_path(np.zeros(5), sigma=-1.0, f_c=1.0)
    with pytest.raises(ValidationError, match="strictly increasing"):
        fx.maxwell_series(np.zeros(3), np.array([0.0, 0.2, 0.1]), 1.0, 1.0)
    with pytest.raises(ValidationError, match="finite"):
        fx.dahl_path(np.array([0.0, np.nan]), 1.0, 1.0)


def test_asymmetric_digressive_curve_branches_and_symmetric_limit():
    v = np.array([-100.0, -1e-6, 0.0, 1e-6, 100.0])
    f = fx.damper_digressive_asymmetric(v, 2000.0, 0.1, 5000.0, 0.05)
    # closed form per branch: slope c at rest, force -> c v_knee at high speed
    assert f[3] / 1e-6 == pytest.approx(2000.0, rel=1e-4)
    assert f[1] / -1e-6 == pytest.approx(5000.0, rel=1e-4)
    assert f[4] == pytest.approx(2000.0 * 0.1, rel=2e-3)
    assert f[0] == pytest.approx(-5000.0 * 0.05, rel=2e-3)
    assert np.all(f * v >= 0.0)  # absorbs power in both directions
    # equal branches are the symmetric digressive curve (identity of the formulas)
    vv = np.linspace(-0.5, 0.5, 41)
    same = fx.damper_digressive_asymmetric(vv, 3000.0, 0.08, 3000.0, 0.08)
    assert same == pytest.approx(fx.damper_digressive(vv, 3000.0, 0.08), rel=1e-12)
    with pytest.raises(ValidationError, match="`v_knee_rebound > 0` must hold, but got"):
        fx.make_effect("asymmetric_digressive_damping", v_knee_rebound=0.0).force(vv, vv)


def test_bouc_wen_state_at_the_lower_regime_fixed_point_stays_there():
    # closed form: for w = sign(dx) z < 0, dw/du = A - (beta - gamma) w is zero at
    # w = A / (beta - gamma) (gamma > beta); a state there never reaches zero
    from suspenv.models.effects.hysteresis import bouc_wen_path

    A, beta, gamma = 2.0, 0.5, 1.5
    z0 = A / (beta - gamma)
    z = bouc_wen_path(np.linspace(0.0, 0.01, 11), A, beta, gamma, 1.0, z0)
    np.testing.assert_allclose(z, z0, rtol=1e-12)
