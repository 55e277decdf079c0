"""Minibus handling, fast paths: the linear frequency response against the time-domain
model, the tabulated steady circle against the grid search, and the reference vehicle's
handling balance (understeer through the linear range)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.minibus_speed import steady_circle_bisection, steady_loads
from suspenv.metrics.handling import yaw_response
from suspenv.models.minibus.handling_kernel import tabulated
from suspenv.models.minibus.handling_model import (
    HandlingParams,
    HandlingState,
    handling_parameters,
    linear_system,
    steer_response,
    step,
)
from suspenv.models.minibus.vehicle import BASELINE_DESIGN, LOAD_CASES, STUDY_PICK, G
from suspenv.models.minibus.vehicle import design_space as minibus_space
from suspenv.rigs.handling import (
    SlalomConfig,
    SteadyCircleConfig,
    _capacity_table,
    axle_capacity,
    secant_axle_stiffness,
    slalom_linear,
    steady_circle,
    steady_state_sweep,
    understeer_gradients,
)

U = 60.0 / 3.6


def _designs(n: int, seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    space = minibus_space()
    return np.vstack([STUDY_PICK, BASELINE_DESIGN, space.to_physical(rng.random((n, 8)))])


def _params(X: np.ndarray) -> HandlingParams:
    return handling_parameters(X, LOAD_CASES)


@pytest.mark.parametrize("freq", [0.2778, 1.0])
def test_frequency_response_matches_the_time_domain_model(freq):
    # independent check: the nonlinear time-domain equations of motion (the study's
    # slalom integrator, rates + step) driven open loop by a small sinusoidal steer;
    # the amplitude and phase of a_y, yaw rate and roll over the last two cycles,
    # fitted at the input frequency, against the closed-form linear response.
    # Tolerances 1 % on the gain and 1 deg on the phase: the integrator's 2 ms step,
    # its one-step-delayed compliance steer and load transfer, and the tyres' curvature
    # at 0.1 m/s^2.
    P = _params(np.vstack([STUDY_PICK, BASELINE_DESIGN]))
    H = steer_response(P, U, freq)
    amp = 0.1 / np.abs(H.ay[:, 0])  # rad of steer for 0.1 m/s^2 lateral acceleration
    dt = 0.002
    w = 2 * np.pi * freq
    t_end = 14.0 + 2.0 / freq
    s = HandlingState.zeros(P.n)
    rows = []
    for i in range(int(round(t_end / dt))):
        t = (i + 1) * dt
        cmd = amp * np.sin(w * t)
        k = step(P, s, U, cmd, dt, 0.0)
        rows.append((t, k.ay, s.r, s.phi))
    t = np.array([r[0] for r in rows])
    keep = t >= t_end - 2.0 / freq
    basis = np.column_stack([np.sin(w * t[keep]), np.cos(w * t[keep])])
    for j, h in enumerate((H.ay, H.yaw_rate, H.roll)):
        y = np.array([r[j + 1] for r in rows])[keep]  # (T, n)
        coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
        # steer amp*sin(wt) -> response amp*|H| sin(wt + arg H) = a sin + b cos
        measured = (coef[0] + 1j * coef[1]) / amp
        # the state reacts to the steer of the step before (semi-implicit Euler):
        # half a step of delay at the input, removed here
        measured = measured * np.exp(1j * w * 0.5 * dt)
        np.testing.assert_allclose(np.abs(measured), np.abs(h[:, 0]), rtol=0.01)
        # phase within 1 deg: the time-domain model feeds the compliance steer and the
        # load transfer with the previous step's forces (0.7 deg of lag at 1 Hz)
        lag = np.degrees(np.angle(measured / h[:, 0]))
        assert np.all(np.abs(lag) < 1.0), lag


def test_steady_state_response_is_the_closed_forms():
    # f = 0: a_y / delta = u^2 / (L + K u^2) (ISO 4138 understeer gradient K) and
    # roll / a_y = the roll gradient, both closed forms of HandlingParams
    P = _params(_designs(10))
    H = steer_response(P, U, 0.0)
    L = P.wheelbase
    np.testing.assert_allclose(H.ay[:, 0].real, U**2 / (L + P.understeer_gradient() * U**2))
    np.testing.assert_allclose((H.roll / H.ay)[:, 0].real, P.roll_gradient(), rtol=1e-12)
    A, _ = linear_system(P, U)
    assert np.all(np.linalg.eigvals(A).real < 0)


def test_slalom_linear_follows_the_course():
    # the path's lateral acceleration A (pi u / s)^2 and yaw rate near a_y / u
    # (small-amplitude linearisation: at the course's 0.39 g the secant tyres slip more
    # and the sideslip rate moves the yaw rate further, up to 10 % loaded)
    cfg = SlalomConfig()
    P = _params(_designs(5))
    lin = slalom_linear(P, cfg, working_point=False)
    ay = cfg.amplitude * (np.pi * cfg.speed / cfg.spacing) ** 2
    np.testing.assert_allclose(lin.ay_amplitude, ay)
    # r = (a_y - dv/dt) / u: the sideslip rate moves it a few per cent off a_y / u
    np.testing.assert_allclose(lin.yaw_rate_amplitude, ay / cfg.speed, rtol=0.08)
    assert lin.stable.all()
    # steering-wheel angle = ratio * road-wheel steer; grows with understeer
    np.testing.assert_allclose(lin.steering_wheel_amplitude, 20.0 * lin.steer_amplitude)
    K = P.understeer_gradient()
    assert np.corrcoef(K, lin.steering_wheel_amplitude)[0, 1] > 0.7


def _limits_numpy(
    P: HandlingParams, ay: np.ndarray, cfg: SteadyCircleConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Reference of the compiled circle search's conditions in plain numpy: (front axle
    carries its share, not rolled over) at lateral accelerations ay (n,), the capacity
    interpolated bilinearly in its table by fancy indexing."""
    _, fl, fr, rl, rr = steady_loads(P, ay)
    h, table = _capacity_table(P.tyre, cfg.alpha_max_deg, cfg.alpha_points)
    ta, tb = np.clip(fl, 0.0, None) / h, np.clip(fr, 0.0, None) / h
    ia = np.minimum(ta.astype(np.intp), table.shape[0] - 2)
    ib = np.minimum(tb.astype(np.intp), table.shape[0] - 2)
    wa, wb = np.minimum(ta - ia, 1.0), np.minimum(tb - ib, 1.0)
    c00, c10 = table[ia, ib], table[ia + 1, ib]
    c01, c11 = table[ia, ib + 1], table[ia + 1, ib + 1]
    cap_f = c00 + wa * (c10 - c00) + wb * (c01 - c00 + wa * (c11 - c10 - c01 + c00))
    return cap_f >= P.m * ay * P.b / P.wheelbase, (fl > 0) | (rl > 0)


def test_tabulated_capacity_matches_the_grid_search():
    # the steady circle's axle capacity table (interpolated by the compiled loop's
    # helper) against the grid search it tabulates, at the loads the circle visits
    # (0 .. 1.2 g, both loads, random designs)
    P = _params(_designs(30))
    cfg = SteadyCircleConfig()
    h, table = _capacity_table(P.tyre, cfg.alpha_max_deg, cfg.alpha_points)
    ay = np.linspace(0.0, 1.2 * G, 25)[:, None] * np.ones(P.n)
    _, fl, fr, rl, rr = steady_loads(P, ay)
    for a, b in ((fl, fr), (rl, rr)):
        exact, _ = axle_capacity(P.tyre, a, b, cfg)
        interp = [tabulated(table, h, x, y) for x, y in zip(a.ravel(), b.ravel(), strict=True)]
        np.testing.assert_allclose(np.reshape(interp, a.shape), exact, rtol=2e-5, atol=1.0)


def test_steady_circle_matches_the_bisection_on_the_grid_search():
    # independent check of the fast search (tabulated capacity, compiled bisection):
    # the limit within one search step (1e-3 m/s^2 tolerance) of the original
    X = _designs(60)
    P = _params(X)
    cfg = SteadyCircleConfig()
    res = steady_circle(P, cfg)
    fast = res.ay_max
    slow = steady_circle_bisection(P, cfg)
    step_size = cfg.ay_upper / 2 ** int(np.ceil(np.log2(cfg.ay_upper / cfg.tolerance)))
    assert np.max(np.abs(fast - slow)) <= step_size * 1.0001
    # a row's result does not depend on its batch
    single = [steady_circle(handling_parameters(X[i : i + 1]), cfg) for i in range(6)]
    np.testing.assert_array_equal([r.ay_max[0] for r in single], fast[:6])
    assert [r.limit[0] for r in single] == list(res.limit[:6])
    # the limit's name: the condition that fails one search step above the limit
    f_ok, up = _limits_numpy(P, res.ay_max + step_size, cfg)
    np.testing.assert_array_equal(
        res.limit, np.where(~up, "rollover", np.where(~f_ok, "front", "rear"))
    )
    assert {"front", "rear"} <= set(res.limit)


@pytest.mark.parametrize("load_case", LOAD_CASES)
def test_reference_minibus_understeers_through_the_linear_range(load_case):
    # Handling balance (docs/minibus_handling.md): the reference minibus understeers
    # in the linear range, empty and loaded, for the study's pick, the baseline and
    # random designs of the box. Plausible range of the road-wheel understeer gradient
    # of a van: 1-3 deg/g in the linear range (more than a passenger car's, mostly
    # from steering compliance). Secant gradient (steer - L/R) / a_y of the nonlinear
    # steady states (ISO 4138, constant radius 15 m) up to 0.3 g, and it stays
    # understeering (> 0) up to 0.4 g.
    P = handling_parameters(_designs(20), load_case)
    K_lin = np.degrees(P.understeer_gradient()) * G
    assert np.all((K_lin > 1.0) & (K_lin < 3.0)), K_lin
    ays = np.array([1.0, 2.0, 3.0, 4.0])
    sw = steady_state_sweep(P, ays)
    secant = np.degrees((sw.steer - P.wheelbase / 15.0) / ays[:, None]) * G
    assert np.all(secant[:3] > 0.5), secant[:3].min()
    assert np.all(secant[3] > 0.0), secant[3].min()


# ------------------------------------------------------------------ where the course runs
def _independent_understeer(X: np.ndarray, load_case: str, ay: float) -> np.ndarray:
    """Secant understeer (steer - L/R) / a_y (rad per m/s^2) of designs X at lateral
    acceleration ``ay``, written here from the vehicle data alone: a textbook steady
    load transfer per axle (Milliken & Milliken, *Race Car Vehicle Dynamics*, 1995,
    ch. 18: elastic part by the axles' share of the roll stiffness, geometric part by
    the roll-centre height, unsprung part at wheel-centre height), each axle's slip
    angle solved by scipy's brentq on the tyre curve at the two wheel loads, plus the
    roll and compliance steers; none of the rigs' or the handling model's functions."""
    from scipy.optimize import brentq

    from suspenv.models.minibus.handling_model import DEFAULT_LEAF_GEOMETRY
    from suspenv.models.minibus.tyre import LIGHT_TRUCK_TYRE
    from suspenv.models.minibus.vehicle import REFERENCE_MINIBUS, vehicle_parameters

    leaf, tyre, v = DEFAULT_LEAF_GEOMETRY, LIGHT_TRUCK_TYRE, REFERENCE_MINIBUS

    vp = vehicle_parameters(X, load_case, v)
    lc = v.load_case(load_case)
    L, ms = v.wheelbase, lc.sprung_mass
    muf, mur = 2 * v.unsprung_front, 2 * v.unsprung_rear
    m = ms + muf + mur
    a_s = np.broadcast_to(vp.a, (X.shape[0],))  # sprung CoM behind the front axle
    a = (ms * a_s + mur * L) / m
    h_rf = v.front_ic_height * (v.track_front / 2) / v.front_ic_inboard
    h_rr = v.rear_roll_centre_height
    h_prime = lc.cg_z - (h_rf + (h_rr - h_rf) * a_s / L)
    kt = v.tyre_vertical_stiffness * v.track_front**2 / 2  # both tracks alike
    ks_f = vp.design.front_wheel_rate * v.track_front**2 / 2 + vp.design.front_roll_arb
    ks_r = vp.rear_static_rate * v.leaf_spacing**2 / 2 + vp.design.rear_roll_arb
    k_f, k_r = ks_f * kt / (ks_f + kt), ks_r * kt / (ks_r + kt)
    phi = ms * h_prime * ay / (k_f + k_r - ms * h_prime * G)
    out = []
    for i in range(X.shape[0]):
        ms_f, ms_r = ms * (L - a_s[i]) / L, ms * a_s[i] / L
        dfz_f = (k_f[i] * phi[i] + (ms_f * h_rf + muf * v.tyre_loaded_radius) * ay) / v.track_front
        dfz_r = (k_r[i] * phi[i] + (ms_r * h_rr + mur * v.tyre_loaded_radius) * ay) / v.track_rear
        fz_f = ms_f * G / 2 + v.unsprung_front * G
        fz_r = ms_r * G / 2 + v.unsprung_rear * G
        fy_f, fy_r = m * ay * (L - a[i]) / L, m * ay * a[i] / L

        def slip(fz: float, dfz: float, fy: float) -> float:
            return brentq(
                lambda al: float(
                    tyre.lateral_force(al, fz - dfz) + tyre.lateral_force(al, fz + dfz) - fy
                ),
                0.0,
                0.1,
                xtol=1e-14,
            )

        k3 = vp.design.leaf_bush_radial[i]
        l1, ls = leaf.axle_from_front_eye, v.leaf_length
        eps_r = (
            v.rear_roll_steer
            + vp.rear_static_rate[i] * (l1 / ls) * np.tan(np.radians(leaf.shackle_angle_deg)) / k3
        )
        c_r = ((ls - l1) / (2 * k3) - l1 / (2 * leaf.shackle_lateral_ratio * k3)) / ls**2
        c_f = -leaf.steering_trail / leaf.steering_stiffness
        steer_minus_kinematic = (
            slip(fz_f, dfz_f, fy_f)
            - slip(fz_r, dfz_r, fy_r)
            - leaf.front_roll_steer * phi[i]
            - c_f * fy_f
            + eps_r * phi[i]
            + c_r * fy_r
        )
        out.append(steer_minus_kinematic / ay)
    return np.array(out)


@pytest.mark.parametrize("load_case", LOAD_CASES)
def test_bars_move_understeer_at_the_course_with_their_real_signs(load_case):
    # at the slalom's 0.39 g (3.8 m/s^2) a stiffer front bar moves load transfer to the
    # front axle, whose load-sensitive tyres then need more slip: more understeer; a
    # stiffer rear bar the other way. The reference: the independent steady load
    # transfer above. The model's secant (the course's linearisation) must carry the
    # same signs and values (1e-6 relative: brentq's and the Illinois solve's
    # tolerances), and so must the slalom objective built on it.
    cfg = SlalomConfig()
    ay = cfg.amplitude * (np.pi * cfg.speed / cfg.spacing) ** 2
    lo, hi = 2e5, 9e5
    X = np.tile(BASELINE_DESIGN, (4, 1))
    X[0, 4], X[1, 4], X[2, 5], X[3, 5] = lo, hi, lo, hi  # T2 front bar, T3 rear bar
    ref = _independent_understeer(X, load_case, ay)
    assert ref[1] > ref[0] and ref[3] < ref[2]
    P = handling_parameters(X, load_case)
    sw = steady_state_sweep(P, np.array([ay]), SteadyCircleConfig(radius=1e9))
    model = (sw.steer[0] - P.wheelbase / 1e9) / ay
    np.testing.assert_allclose(model, ref, rtol=1e-6)
    # the slalom objective at the working point moves the same way, the
    # small-amplitude one does not see the front bar's effect
    wheel = slalom_linear(P, cfg).steering_wheel_amplitude
    assert wheel[1] > wheel[0] and wheel[3] < wheel[2]
    small = slalom_linear(P, cfg, working_point=False).steering_wheel_amplitude
    assert small[1] < small[0]


def test_secant_linear_model_reproduces_the_steady_state_at_its_acceleration():
    # the linear model with the secant axle stiffnesses at a_y: its steady response
    # (f = 0) needs exactly the quasi-steady sweep's steer minus L/R for that a_y
    P = _params(_designs(6))
    for ay in (1.0, 3.8, 5.0):
        stiff = secant_axle_stiffness(P, ay)
        H = steer_response(P, U, 0.0, linear_system(P, U, stiff))
        sw = steady_state_sweep(P, np.array([ay]), SteadyCircleConfig(radius=U**2 / ay))
        np.testing.assert_allclose(ay / H.ay[:, 0].real, sw.steer[0], rtol=1e-9)


def test_iso4138_gradient_is_the_slope_of_the_sweep():
    # central difference over 0.2 m/s^2 against one over 0.02 m/s^2 (steer solved to
    # round-off): they differ by the truncation term (step^2 / 24 times the third
    # derivative) only, measured below 5e-6 rad/(m/s^2) (0.003 deg/g) on these designs
    P = _params(_designs(4))
    ay = np.array([1.0, 2.0, 3.0])
    K = understeer_gradients(P, ay, step=0.2)
    fine = understeer_gradients(P, ay, step=0.02)
    np.testing.assert_allclose(K, fine, rtol=0, atol=1e-5)
    hi, lo = steady_state_sweep(P, ay + 0.01), steady_state_sweep(P, ay - 0.01)
    np.testing.assert_allclose(fine, (hi.steer - lo.steer) / 0.02, rtol=1e-12)


def test_yaw_response_of_a_second_order_system_is_the_textbook_one():
    # golden: yaw rate r/delta = w^2 / (s^2 + 2 z w s + w^2) (states v inert, r, q = r',
    # p inert): overshoot exp(-pi z / sqrt(1 - z^2)), peak time pi / w_d, bandwidth
    # (gain 1/sqrt 2) w sqrt(1 - 2 z^2 + sqrt(4 z^4 - 4 z^2 + 2)) / (2 pi), the 90 %
    # time by brentq on the textbook step response
    from scipy.optimize import brentq

    z, w = 0.4, 2 * np.pi * 1.2
    A = np.zeros((1, 4, 4))
    A[0, 0, 0] = A[0, 3, 3] = -5.0
    A[0, 1, 2] = 1.0
    A[0, 2, 1], A[0, 2, 2] = -(w**2), -2 * z * w
    B = np.array([[0.0, 0.0, w**2, 0.0]])
    res = yaw_response(A, B)
    wd = w * np.sqrt(1 - z**2)

    def step(t: float) -> float:
        return 1 - np.exp(-z * w * t) * (np.cos(wd * t) + z / np.sqrt(1 - z**2) * np.sin(wd * t))

    t90 = brentq(lambda t: step(t) - 0.9, 1e-6, np.pi / wd, xtol=1e-14)
    np.testing.assert_allclose(res.gain, 1.0, rtol=1e-12)
    np.testing.assert_allclose(res.response_time, t90, rtol=1e-9)
    np.testing.assert_allclose(res.peak_time, np.pi / wd, rtol=1e-9)
    np.testing.assert_allclose(res.overshoot, np.exp(-np.pi * z / np.sqrt(1 - z**2)), rtol=1e-9)
    band = w * np.sqrt(1 - 2 * z**2 + np.sqrt(4 * z**4 - 4 * z**2 + 2)) / (2 * np.pi)
    np.testing.assert_allclose(res.bandwidth, band, rtol=1e-7)


def test_compiled_handling_loops_equal_their_numpy_passes():
    # the compiled slip solve, capacity search and yaw-response searches
    # (suspenv.models.minibus.handling_kernel) against the numpy passes over the batch
    # they replaced (benchmarks.minibus_speed.numpy_loops): both solve to round-off, so
    # they agree to round-off times the conditioning: the ISO 4138 gradients, a central
    # difference over 0.2 m/s^2, amplify it about 1e3-fold
    from benchmarks.minibus_speed import numpy_loops
    from suspenv.problems.minibus import MinibusRideHandling

    problem = MinibusRideHandling()
    X = _designs(12)
    P = _params(X)
    ay = np.linspace(0.5, 1.2 * G, 12)  # up to beyond the limit: infeasible states too
    compiled = problem._standard_handling(P), steady_state_sweep(P, ay)
    with numpy_loops():
        numpy = problem._standard_handling(P), steady_state_sweep(P, ay)
    for key, value in compiled[0].items():
        np.testing.assert_allclose(value, numpy[0][key], rtol=1e-10, err_msg=key)
    np.testing.assert_array_equal(compiled[1].feasible, numpy[1].feasible)
    assert 0 < compiled[1].feasible.sum() < compiled[1].feasible.size
    ok = compiled[1].feasible
    np.testing.assert_allclose(compiled[1].steer[ok], numpy[1].steer[ok], rtol=1e-12)
