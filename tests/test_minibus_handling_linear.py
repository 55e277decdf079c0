"""Minibus handling, fast paths: the linear frequency response against the time-domain
model, the tabulated steady circle against the grid search, and the reference vehicle's
handling balance (understeer through the linear range)."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.metrics.handling import slalom_linear
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
    _limits,
    _steady_loads,
    axle_capacity,
    axle_capacity_tabulated,
    steady_circle,
    steady_circle_bisection,
    steady_state_sweep,
)

U = 60.0 / 3.6


def _designs(n: int, seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    space = minibus_space()
    return np.vstack([STUDY_PICK, BASELINE_DESIGN, space.to_physical(rng.random((n, 8)))])


def _params(X: np.ndarray) -> HandlingParams:
    return HandlingParams.stack([handling_parameters(X, lc) for lc in LOAD_CASES])


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
    cfg = SlalomConfig()
    P = _params(_designs(5))
    lin = slalom_linear(P, cfg)
    ay = cfg.amplitude * (np.pi * cfg.speed / cfg.spacing) ** 2
    np.testing.assert_allclose(lin.ay_amplitude, ay)
    # r = (a_y - dv/dt) / u: the sideslip rate moves it a few per cent off a_y / u
    np.testing.assert_allclose(lin.yaw_rate_amplitude, ay / cfg.speed, rtol=0.08)
    assert lin.stable.all()
    # steering-wheel angle = ratio * road-wheel steer; grows with understeer
    np.testing.assert_allclose(lin.steering_wheel_amplitude, 20.0 * lin.steer_amplitude)
    K = P.understeer_gradient()
    assert np.corrcoef(K, lin.steering_wheel_amplitude)[0, 1] > 0.7


def test_tabulated_capacity_matches_the_grid_search():
    # the steady circle's axle capacity table against the grid search it tabulates, at
    # the loads the circle visits (0 .. 1.2 g, both loads, random designs)
    P = _params(_designs(30))
    cfg = SteadyCircleConfig()
    ay = np.linspace(0.0, 1.2 * G, 25)[:, None] * np.ones(P.n)
    _, fl, fr, rl, rr = _steady_loads(P, ay)
    for a, b in ((fl, fr), (rl, rr)):
        exact, _ = axle_capacity(P, a, b, cfg)
        table = axle_capacity_tabulated(P, a, b, cfg)
        np.testing.assert_allclose(table, exact, rtol=2e-5, atol=1.0)


def test_steady_circle_matches_the_bisection_on_the_grid_search():
    # independent check of the fast search (tabulated capacity, many candidates per
    # pass): the limit within one search step (1e-3 m/s^2 tolerance) of the original
    P = _params(_designs(60))
    cfg = SteadyCircleConfig()
    res = steady_circle(P, cfg)
    fast = res.ay_max
    slow = steady_circle_bisection(P, cfg)
    step_size = cfg.ay_upper / 2 ** int(np.ceil(np.log2(cfg.ay_upper / cfg.tolerance)))
    assert np.max(np.abs(fast - slow)) <= step_size * 1.0001
    # a row's result does not depend on its batch (one design at a time: other passes)
    single = [steady_circle(P.take(slice(i, i + 1)), cfg) for i in range(6)]
    np.testing.assert_array_equal([r.ay_max[0] for r in single], fast[:6])
    assert [r.limit[0] for r in single] == list(res.limit[:6])
    # the limit's name: the condition that fails one search step above the limit
    f_ok, _, up = _limits(P, res.ay_max + step_size, cfg)
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
