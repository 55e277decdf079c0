"""Minibus handling: tyre, handling model, steady circle, slalom, metrics.

Every physics check names its independent reference in a comment.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from suspenv.core.errors import ValidationError
from suspenv.models.minibus.handling_model import (
    HandlingState,
    LeafAxleGeometry,
    handling_parameters,
    rates,
    roll_centre_heights,
    step,
    wheel_loads,
)
from suspenv.models.minibus.tyre import LIGHT_TRUCK_TYRE, LateralTyre
from suspenv.models.minibus.vehicle import (
    REFERENCE_MINIBUS,
    STUDY_PICK,
    G,
    design_space,
    design_to_si,
    vehicle_parameters,
)
from suspenv.rigs.handling import (
    SlalomConfig,
    SteadyCircleConfig,
    WindowedPeaks,
    slalom,
    slalom_run,
    steady_circle,
    steady_state_sweep,
)

TYRE = LIGHT_TRUCK_TYRE
#: leaf geometry without any compliance or roll steer (pure bicycle model + roll)
NO_STEER = LeafAxleGeometry(
    axle_from_front_eye=0.65,
    shackle_lateral_ratio=1.0,
    shackle_angle_deg=0.0,
    front_roll_steer=0.0,
    steering_trail=0.0,
)


# ---------------------------------------------------------------------- tyre
@pytest.mark.parametrize("fz", [1500.0, 4500.0, 6500.0, 9500.0])
def test_tyre_slope_at_zero_is_the_closed_form_cornering_stiffness(fz):
    # reference: Pacejka's MF 5.2 closed form Ky = pKy1 Fz0 sin(2 atan(Fz / (pKy2 Fz0)))
    # against a central finite difference of the force curve
    h = 1e-6
    slope = (TYRE.lateral_force(h, fz) - TYRE.lateral_force(-h, fz)) / (2 * h)
    closed = TYRE.pKy1 * TYRE.fz0 * np.sin(2 * np.arctan(fz / (TYRE.pKy2 * TYRE.fz0)))
    assert slope == pytest.approx(closed, rel=1e-6)
    assert TYRE.cornering_stiffness(fz) == pytest.approx(closed, rel=1e-12)


@pytest.mark.parametrize("fz", [2000.0, 6500.0, 11000.0])
def test_tyre_peak_is_mu_times_load(fz):
    # reference: for C > 1 the Magic Formula peaks at exactly D = mu(Fz) Fz (sin = 1)
    alpha = np.linspace(0.0, np.radians(30.0), 300001)
    fy = TYRE.lateral_force(alpha, fz)
    mu = TYRE.pDy1 * (1 + TYRE.pDy2 * (fz - TYRE.fz0) / TYRE.fz0)
    assert fy.max() == pytest.approx(mu * fz, rel=1e-9)


def test_tyre_load_sensitivity_odd_symmetry_and_lifted_wheel():
    fz = np.array([2000.0, 4000.0, 6500.0, 9000.0, 12000.0])
    # load sensitivity: the friction coefficient and Ky/Fz fall with load
    peak_per_load = TYRE.factors(fz)[0] / fz  # D = mu_y Fz
    assert np.all(np.diff(peak_per_load) < 0)
    assert np.all(np.diff(TYRE.cornering_stiffness(fz) / fz) < 0)
    # two half-loaded tyres give more than one tyre at the summed load (concavity)
    assert 2 * TYRE.factors(3250.0)[0] > TYRE.factors(6500.0)[0]
    a = np.radians(np.linspace(-20, 20, 41))
    np.testing.assert_allclose(TYRE.lateral_force(-a, 5000.0), -TYRE.lateral_force(a, 5000.0))
    assert TYRE.lateral_force(0.1, 0.0) == 0.0
    assert TYRE.lateral_force(0.1, -100.0) == 0.0


def test_tyre_rejects_bad_coefficients_naming_the_rule():
    with pytest.raises(ValidationError, match="1 < pCy1 < 2"):
        LateralTyre(pCy1=0.9)
    with pytest.raises(ValidationError, match="fz0 > 0"):
        LateralTyre(fz0=0.0)


# ---------------------------------------------------------------------- model
def _steady_constant_steer(P, u, delta, t_end=4.0, dt=0.005):
    s = HandlingState.zeros(P.n)
    cmd = np.full(P.n, delta)
    s.delta[:] = delta
    for _ in range(int(t_end / dt)):
        k = step(P, s, u, cmd, dt, 0.0)
    return s, k


def _bicycle_k(P):
    # closed form: K = m/L (b/Cf - a/Cr), axle cornering stiffness from the tyre's Ky
    cf = 2 * TYRE.cornering_stiffness(P.fz_front)
    cr = 2 * TYRE.cornering_stiffness(P.fz_rear)
    L = P.a + P.b
    return P.m / L * (P.b / cf - P.a / cr)


def _roll_stiffness(X, load_case, vehicle=REFERENCE_MINIBUS):
    # springs + stabiliser in series with the tyres, from the vehicle data directly
    vp = vehicle_parameters(X, load_case, vehicle)
    d = design_to_si(X, vehicle)
    kt = vehicle.tyre_vertical_stiffness * vehicle.track_front**2 / 2
    kf = d.front_wheel_rate * vehicle.track_front**2 / 2 + d.front_roll_arb
    kr = vp.rear_static_rate * vehicle.leaf_spacing**2 / 2 + d.rear_roll_arb
    return kf * kt / (kf + kt) + kr * kt / (kr + kt)


@pytest.mark.parametrize("load_case", ["no_load", "full_load"])
def test_linear_yaw_gain_and_roll_gradient_match_closed_forms_without_compliance(load_case):
    # references: bicycle model r/delta = u / (L + K u^2), K = m/L (b/Cf - a/Cr);
    # roll gradient phi/a_y = ms h' / (K_phi - ms g h')
    space = design_space()
    X = np.vstack([STUDY_PICK, space.lower, space.upper])
    vehicle = REFERENCE_MINIBUS.with_(rear_roll_steer=0.0)
    P = handling_parameters(X, load_case, vehicle, leaf=NO_STEER)
    u, delta = 16.0, np.radians(0.2)
    s, k = _steady_constant_steer(P, u, delta)
    L = P.a + P.b
    r_closed = u / (L + _bicycle_k(P) * u**2) * delta
    np.testing.assert_allclose(s.r, r_closed, rtol=3e-3)
    kphi = _roll_stiffness(X, load_case, vehicle)
    msh = P.ms * P.h_prime
    np.testing.assert_allclose(s.phi / k.ay, msh / (kphi - msh * G), rtol=3e-3)


def test_linear_yaw_gain_with_roll_and_compliance_steer_matches_extended_closed_form():
    # reference: K = m/L (b/Cf - a/Cr) + (eps_r - eps_f) dphi/da_y + (c_F a - c_Ff b) m / L
    # (steer balance of the single-track model with axle steer terms, written out here)
    space = design_space()
    X = np.vstack([STUDY_PICK, space.lower, space.upper])
    P = handling_parameters(X, "full_load")
    vp = vehicle_parameters(X, "full_load")
    geo = LeafAxleGeometry()
    Ls, l1 = REFERENCE_MINIBUS.leaf_length, geo.axle_from_front_eye
    k3 = X[:, 2] * 1e3
    eps_r = (
        REFERENCE_MINIBUS.rear_roll_steer
        + vp.rear_static_rate * (l1 / Ls) * np.tan(np.radians(geo.shackle_angle_deg)) / k3
    )
    c_r = ((Ls - l1) / (2 * k3) - l1 / (2 * geo.shackle_lateral_ratio * k3)) / Ls**2
    c_f = -geo.steering_trail / geo.steering_stiffness
    kphi = _roll_stiffness(X, "full_load")
    msh = P.ms * P.h_prime
    grad = msh / (kphi - msh * G)
    L = P.a + P.b
    K = _bicycle_k(P) + eps_r * grad + (c_r * P.a - c_f * P.b) * P.m / L
    np.testing.assert_allclose(P.understeer_gradient(), K, rtol=1e-9)
    u, delta = 16.0, np.radians(0.2)
    s, _ = _steady_constant_steer(P, u, delta)
    np.testing.assert_allclose(s.r, u / (L + K * u**2) * delta, rtol=3e-3)
    # a softer bush (lower K3) makes the axle less understeering (compliance oversteer)
    soft, stiff = X.copy(), X.copy()
    soft[:, 2], stiff[:, 2] = 1.0e3, 5.0e3
    k_soft = handling_parameters(soft, "full_load").understeer_gradient()
    k_stiff = handling_parameters(stiff, "full_load").understeer_gradient()
    assert np.all(k_soft < k_stiff)


def test_stepper_matches_an_adaptive_solver_with_the_algebraic_loops_resolved():
    # reference: scipy's RK45 on the same equations with the a_y / axle-force loops
    # solved exactly by fixed-point iteration (the stepper lags them by one step)
    P = handling_parameters(STUDY_PICK[None, :], "full_load")
    u = 16.67
    amp, f = np.radians(2.0), 0.3

    def steer(t):
        return amp * np.sin(2 * np.pi * f * t)

    def rhs(t, y):
        s = HandlingState.zeros(1)
        s.v[:], s.r[:], s.phi[:], s.p[:] = y[0], y[1], y[2], y[3]
        s.delta[:] = steer(t)
        for _ in range(6):
            k = rates(P, s, u)
            s.ay, s.fy_front, s.fy_rear = k.ay, k.fy_front, k.fy_rear
        return [k.v_dot[0], k.r_dot[0], y[3], k.p_dot[0]]

    t_end = 4.0
    t_eval = np.arange(0.5, t_end, 0.05)
    ref = solve_ivp(rhs, (0, t_end), [0, 0, 0, 0], t_eval=t_eval, rtol=1e-6, atol=1e-9)
    dt = 0.01
    s = HandlingState.zeros(1)
    r_hist, phi_hist, times = [], [], []
    for i in range(int(t_end / dt)):
        t = i * dt
        step(P, s, u, np.array([steer(t + dt)]), dt, 0.0)
        times.append(t + dt)
        r_hist.append(s.r[0])
        phi_hist.append(s.phi[0])
    r_i = np.interp(t_eval, times, r_hist)
    phi_i = np.interp(t_eval, times, phi_hist)
    assert np.max(np.abs(r_i - ref.y[1])) < 0.03 * np.max(np.abs(ref.y[1]))
    assert np.max(np.abs(phi_i - ref.y[2])) < 0.03 * np.max(np.abs(ref.y[2]))


def test_steady_lateral_load_transfer_balances_the_overturning_moment():
    # reference: moment balance of the whole vehicle about the ground centre line in a
    # steady turn: sum_i dFz_i t_i = ms a_y h_s + ms g h' phi + m_u a_y r_w
    space = design_space()
    X = np.vstack([STUDY_PICK, space.lower, space.upper])
    for lc in ("no_load", "full_load"):
        P = handling_parameters(X, lc)
        ay = np.full(3, 3.0)
        phi = P.roll_gradient() * ay
        fl, fr, rl, rr, _, _ = wheel_loads(P, phi, np.zeros(3), ay)
        moment = 0.5 * (fr - fl) * P.track_front + 0.5 * (rr - rl) * P.track_rear
        load = REFERENCE_MINIBUS.load_case(lc)
        unsprung = P.mu_front + P.mu_rear
        expected = (
            P.ms * ay * load.cg_z + P.ms * G * P.h_prime * phi + unsprung * ay * P.wheel_radius
        )
        np.testing.assert_allclose(moment, expected, rtol=1e-10)
        # and the wheel loads still carry the weight
        np.testing.assert_allclose(fl + fr + rl + rr, P.m * G, rtol=1e-10)


def test_static_axle_cornering_stiffness_is_the_given_tyres():
    # reference: the tyre's closed-form Ky at the static wheel loads, two tyres per axle;
    # a softer tyre on the same designs and load cases must give its own (the load-case
    # table is kept per tyre)
    soft = LateralTyre(pKy1=TYRE.pKy1 / 2)
    X = np.stack([STUDY_PICK, 1.1 * STUDY_PICK])
    for tyre in (TYRE, soft, TYRE):
        P = handling_parameters(X, ("no_load", "full_load"), tyre=tyre)
        cf, cr = P.axle_cornering_stiffness()
        np.testing.assert_array_equal(cf, 2 * tyre.cornering_stiffness(P.fz_front))
        np.testing.assert_array_equal(cr, 2 * tyre.cornering_stiffness(P.fz_rear))


def test_handling_parameters_reject_a_cg_below_the_roll_axis():
    low = REFERENCE_MINIBUS.with_(rear_roll_centre_height=2.0)
    with pytest.raises(ValidationError, match="above the roll axis"):
        handling_parameters(STUDY_PICK[None, :], "no_load", low)


def test_front_roll_centre_height_from_the_instant_centre():
    # reference: similar triangles from the contact patch through the swing-arm instant
    # centre (0.15 m high, 2.0 m inboard) to the centreline (half track 1.465 / 2 m)
    front, rear = roll_centre_heights()
    assert front == pytest.approx(0.15 * (1.465 / 2) / 2.0)
    assert rear == REFERENCE_MINIBUS.rear_roll_centre_height


# ---------------------------------------------------------------------- steady circle
def test_circle_limit_without_load_transfer_is_the_tyre_friction_closed_form():
    # reference: with (almost) no lateral load transfer each axle carries at most
    # 2 mu(Fz) Fz = mu(Fz) x its weight, so a_y,max = g min(mu(Fz_front), mu(Fz_rear))
    wide = REFERENCE_MINIBUS.with_(track_front=200.0, track_rear=200.0, front_ic_inboard=200.0)
    X = np.vstack([STUDY_PICK, design_space().lower])
    P = handling_parameters(X, "full_load", wide)
    res = steady_circle(P, SteadyCircleConfig(tolerance=1e-5))
    # mu(Fz) = pDy1 (1 + pDy2 dfz), dfz = (Fz - Fz0) / Fz0 (Pacejka's MF 5.2 D factor)
    fz = np.stack([P.fz_front, P.fz_rear])
    mu = (TYRE.pDy1 * (1.0 + TYRE.pDy2 * (fz - TYRE.fz0) / TYRE.fz0)).min(axis=0)
    np.testing.assert_allclose(res.ay_max, mu * G, rtol=2e-3)


def test_circle_limit_is_plausible_and_moves_with_the_roll_stiffness_split():
    space = design_space()
    X = np.vstack([STUDY_PICK] * 3)
    i_t2, i_t3 = space.index("T2"), space.index("T3")
    X[1, i_t2] = space.upper[i_t2]  # stiffer front bar: more front load transfer
    X[2, i_t3] = space.upper[i_t3]  # stiffer rear bar: more rear load transfer
    for lc in ("no_load", "full_load"):
        res = steady_circle(handling_parameters(X, lc))
        # a minibus slides or tips well below 1 g and above 0.5 g on dry asphalt
        assert np.all((res.ay_max > 0.5 * G) & (res.ay_max < TYRE.pDy1 * G * 1.1))
        if res.limit[0] == "front":
            assert res.ay_max[1] < res.ay_max[0] < res.ay_max[2]
        elif res.limit[0] == "rear":
            assert res.ay_max[2] < res.ay_max[0] < res.ay_max[1]


def test_quasi_steady_sweep_agrees_with_the_dynamic_model_on_the_circle():
    # reference: the time-domain model held at constant speed and steer settles on the
    # state the quasi-steady solver predicts for the same a_y (two different solvers)
    P = handling_parameters(STUDY_PICK[None, :], "no_load")
    radius = 15.0
    for ay_target in (2.0, 5.0):
        sweep = steady_state_sweep(P, np.array([ay_target]), SteadyCircleConfig(radius=radius))
        u = np.sqrt(ay_target * radius)
        s, k = _steady_constant_steer(P, u, sweep.steer[0, 0], t_end=8.0)
        assert k.ay[0] == pytest.approx(ay_target, rel=2e-3)
        assert s.phi[0] == pytest.approx(sweep.roll[0, 0], rel=2e-3)
    # and the linear-range understeer gradient of the sweep is the closed form
    ay = np.linspace(0.05, 0.5, 6)
    sw = steady_state_sweep(P, ay, SteadyCircleConfig(radius=1e4))
    steer = sw.steer[:, 0] - (P.a + P.b)[0] / 1e4
    grad = np.dot(ay, steer) / np.dot(ay, ay)  # least squares through the origin
    assert grad == pytest.approx(P.understeer_gradient()[0], rel=1e-2)


def _circle_speed_ramp(P, radius=15.0, rate=0.25, dt=0.005, tolerance=0.5, start=0.6):
    """Time-domain steady-circle test: speed raised so that a_y grows by ``rate`` m/s^2
    per second, a fast path-holding driver (no steering lag); returns the largest
    0.5 s-smoothed a_y reached before the vehicle strays ``tolerance`` m off the circle."""
    lim = steady_circle(P).ay_max
    L = P.a + P.b
    K = P.understeer_gradient()
    u = np.sqrt(start * lim * radius)
    s = HandlingState.zeros(P.n)  # at the origin heading +x; circle centre (0, R)
    held = np.zeros(P.n)
    lost = np.zeros(P.n, bool)
    ay_smooth = np.zeros(P.n)
    for _ in range(int((1.15 - start) * lim.max() / rate / dt)):
        dy = s.y - radius
        off = np.hypot(s.x, dy) - radius  # > 0 outside the circle
        tangent = np.arctan2(dy, s.x) + np.pi / 2
        course = s.psi + np.arctan2(s.v, u)
        heading_error = np.angle(np.exp(1j * (tangent - course)))
        look = 2.0 * u
        predicted = -off + look * np.tan(heading_error)
        cmd = (L + K * u**2) / radius + 2 * L * predicted / look**2 - 1.0 * (s.r - u / radius)
        k = step(P, s, u, cmd, dt, 0.0)
        ay_smooth += (k.ay - ay_smooth) * dt / 0.5
        lost |= np.abs(off) > tolerance
        held = np.where(lost, held, np.maximum(held, ay_smooth))
        u = u + dt * rate * radius / (2 * u)
    return held, lim


def test_time_domain_speed_ramp_never_holds_the_circle_beyond_the_quasi_steady_limit():
    # reference: a second, time-domain version of the test (GB/T 6323 speed ramp at
    # 0.25 m/s^2 per second with a path-holding driver) on the same vehicle model
    space = design_space()
    X = np.vstack([STUDY_PICK, space.lower, space.upper])
    P = handling_parameters(X, ("no_load", "full_load"))
    held, lim = _circle_speed_ramp(P)
    # no run holds the circle above the defined maximum (small ramp/smoothing overshoot)
    assert np.all(held <= 1.02 * lim)
    # the empty vehicle is held right up to it; at full load the rear-limited steady
    # states near the limit are unstable and even this driver loses them a bit earlier
    np.testing.assert_allclose(held[:3], lim[:3], rtol=0.02)
    assert np.all(held[3:] > 0.85 * lim[3:])


# ---------------------------------------------------------------------- slalom
def test_slalom_response_is_mirror_symmetric_and_follows_the_path():
    X = np.vstack([STUDY_PICK, design_space().upper])
    P = handling_parameters(X, "no_load")
    cfg = SlalomConfig(record_every=5)
    left = slalom(P, cfg, side=1.0)
    right = slalom(P, cfg, side=-1.0)
    # reference: mirror symmetry of the vehicle, the course and the driver
    np.testing.assert_allclose(right.channels["r"], -left.channels["r"], atol=1e-12)
    np.testing.assert_allclose(right.roll_amplitude, left.roll_amplitude, rtol=1e-12)
    # positive and negative half-cycles of the steady part are alike
    rp = left.yaw_rate_peaks
    assert np.all(np.abs(rp[0::2].mean(0) / rp[1::2].mean(0) - 1) < 0.03)
    # reference: kinematics of the path y = A cos(pi x / s): peak yaw rate u A (pi/s)^2
    r_path = cfg.speed * cfg.amplitude * (np.pi / cfg.spacing) ** 2
    assert np.all(np.abs(left.yaw_rate_amplitude / r_path - 1) < 0.1)
    # 0.28 Hz is far below the roll mode: roll ~ quasi-static gradient x a_y amplitude
    np.testing.assert_allclose(left.roll_amplitude, P.roll_gradient() * left.ay_amplitude, rtol=0.1)
    assert np.all(left.completed)
    assert np.all(left.path_error_rms < 0.2 * cfg.amplitude)


@pytest.mark.slow
def test_slalom_driver_completes_the_course_for_random_designs_of_the_box():
    # the driver's gains were chosen on this claim (docs/minibus_handling.md)
    rng = np.random.default_rng(11)
    X = design_space().to_physical(rng.random((300, 8)))
    P = handling_parameters(X, ("no_load", "full_load"))
    res = slalom(P)
    assert res.completed.all()
    assert np.all(res.path_error_rms < 0.2 * SlalomConfig().amplitude)


def test_slalom_default_step_is_converged():
    # reference: the same run with a four times smaller step
    X = np.vstack([STUDY_PICK, design_space().lower])
    P = handling_parameters(X, ("no_load", "full_load"))
    coarse = slalom(P, SlalomConfig())
    fine = slalom(P, SlalomConfig(dt=0.005))
    np.testing.assert_allclose(coarse.yaw_rate_amplitude, fine.yaw_rate_amplitude, rtol=0.01)
    np.testing.assert_allclose(coarse.roll_amplitude, fine.roll_amplitude, rtol=0.01)


def test_slalom_flags_a_vehicle_that_cannot_follow_the_course():
    icy = LateralTyre(pDy1=0.15)
    P = handling_parameters(STUDY_PICK[None, :], "full_load", tyre=icy)
    res = slalom(P, SlalomConfig())
    assert not res.completed[0]


def test_slalom_rig_hands_every_step_to_the_callers_accumulator():
    # reference: the per-cone peaks recomputed from every step the rig handed over
    class Keep:
        def __init__(self):
            self.x, self.values = [], []

        def update(self, x, values):
            self.x.append(np.array(x))
            self.values.append(np.array(values))

    P = handling_parameters(STUDY_PICK[None, :], "no_load")
    cfg = SlalomConfig()
    keep = Keep()
    run = slalom_run(P, cfg, accumulator=keep)
    res = slalom(P, cfg)
    np.testing.assert_array_equal(run.completed, res.completed)
    np.testing.assert_allclose(run.path_error_rms, res.path_error_rms, rtol=0, atol=0)
    x, v = np.array(keep.x), np.array(keep.values)  # (T, n), (T, 4, n)
    first, stop = cfg.measure_cones
    for k, c in enumerate(cfg.cone_x[first:stop]):
        inside = (x >= c - cfg.spacing / 2) & (x < c + cfg.spacing / 2)
        peak = np.where(inside, np.abs(v[:, 0]), 0.0).max(axis=0)
        np.testing.assert_allclose(res.yaw_rate_peaks[k], peak, rtol=0, atol=0)


def test_slalom_config_rules():
    with pytest.raises(ValidationError, match="measure_cones"):
        SlalomConfig(measure_cones=(3, 12))
    with pytest.raises(ValidationError, match="run_in >= spacing"):
        SlalomConfig(run_in=10.0)


# ---------------------------------------------------------------------- metrics
def test_windowed_peaks_match_a_direct_computation():
    # reference: direct masks over the stored histories
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.uniform(0.1, 0.3, size=(400, 3)), axis=0) - 10.0
    v = rng.normal(size=(400, 3))
    centres = np.array([5.0, 15.0, 25.0])
    wp = WindowedPeaks(centres, 5.0, 3)
    for xi, vi in zip(x, v, strict=True):
        wp.update(xi, vi)
    for k, c in enumerate(centres):
        mask = (x >= c - 5) & (x < c + 5)
        np.testing.assert_allclose(wp.result()[k], np.where(mask, np.abs(v), 0).max(axis=0))
    with pytest.raises(ValidationError, match="must not overlap"):
        WindowedPeaks(centres, 6.0, 3)
