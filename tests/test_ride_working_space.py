"""Spectral RMS suspension deflection and dynamic tyre load (working-space and road-
holding constraints): a quarter car against closed forms and a direct solve, the full
model against its own time-domain run, and the problem option."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import ndtr

from suspenv.core.errors import ValidationError
from suspenv.metrics.ride import (
    exceedance_probability,
    modal_form,
    modal_response,
    ride_spectral,
    tyre_load_response,
    working_space,
)
from suspenv.models.minibus import BASELINE_DESIGN, STUDY_PICK, design_space
from suspenv.models.minibus.ride_model import RideModel
from suspenv.models.minibus.vehicle import (
    LOAD_CASES,
    REFERENCE_MINIBUS,
    stacked_vehicle_parameters,
)
from suspenv.models.road import RandomRoad
from suspenv.problems.minibus import MinibusRideHandling
from suspenv.rigs.ride import random_road_inputs, random_road_run

# 2-DOF quarter cars (sprung, unsprung mass kg; spring N/m, damper N s/m, tyre N/m)
QUARTER_CARS = [(400.0, 45.0, 3.0e4, 2500.0, 2.23e5), (900.0, 75.0, 8.0e4, 6000.0, 2.23e5)]


def _quarter_car(ms, mu, ks, cs, kt):
    """q = [z_s, z_u]; road displacement u on the tyre (no tyre damping)."""
    M = np.diag([ms, mu])[None]
    K = np.array([[ks, -ks], [-ks, ks + kt]])[None]
    C = np.array([[cs, -cs], [-cs, cs]])[None]
    return M, C, K, np.array([[[0.0], [kt]]]), np.zeros((1, 2, 1))


def _white_velocity_variance(H: np.ndarray, f: np.ndarray, s0: float) -> float:
    """Variance of a response H (per m of road displacement) to a road velocity of
    two-sided PSD s0 (per rad/s): integral over f >= 0 of 4 pi s0 |H / (i w)|^2 df."""
    y = 4 * np.pi * s0 * np.abs(H / (2j * np.pi * f)) ** 2
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(f)))


@pytest.mark.parametrize("ms, mu, ks, cs, kt", QUARTER_CARS)
def test_quarter_car_deflection_and_tyre_load(ms, mu, ks, cs, kt):
    """Deflection: the classic white-road-velocity result for the 2-DOF quarter car,
    var(z_u - z_s) = pi S0 (m_s + m_u)/c_s, independent of both springs (e.g. Gobbi &
    Mastinu, J. Sound Vib. 245, 2001). Tyre load: a direct 2x2 complex solve per
    frequency written here, k_t (u - z_u), integrated the same way. The modal path and
    :func:`tyre_load_response` must give both; the log grid resolves the modes to 1e-6."""
    s0 = 0.37
    f = np.geomspace(1e-5, 1e5, 200001)
    Co = np.array([[-1.0, 1.0], [0.0, 1.0]])  # suspension compression, wheel centre
    G = modal_response(*modal_form(*_quarter_car(ms, mu, ks, cs, kt), Co), f)
    var_d = _white_velocity_variance(G[0, :, 0, 0], f, s0)
    assert var_d == pytest.approx(np.pi * s0 * (ms + mu) / cs, rel=1e-5)
    Gt = tyre_load_response(G[:, :, 1:2], f, kt, 0.0, (0,))[0, :, 0, 0]
    w = 2 * np.pi * f
    M, C, K, Kin, _ = _quarter_car(ms, mu, ks, cs, kt)
    Z = K - (w**2)[:, None, None] * M + 1j * w[:, None, None] * C
    zu = np.linalg.solve(Z, np.broadcast_to(Kin[0], (f.size, 2, 1)))[:, 1, 0]
    ref = _white_velocity_variance(kt * (1.0 - zu), f, s0)
    assert _white_velocity_variance(Gt, f, s0) == pytest.approx(ref, rel=1e-8)
    # a tyre damper adds i w c_t (u - z_u)
    Gc = tyre_load_response(G[:, :, 1:2], f, kt, 300.0, (0,))[0, :, 0, 0]
    # (at low frequency 1 - z_u cancels: absolute round-off of k_t x float eps x modes)
    np.testing.assert_allclose(Gc, (kt + 300.0j * w) * (1.0 - zu), rtol=1e-7, atol=1e-8 * kt)


def test_exceedance_probability_definition():
    """Two-sided Gaussian tail 2 (1 - Phi(x/sigma)): 1 sigma 31.73 %, 2.576 sigma 1 %
    (normal table)."""
    p = exceedance_probability(np.array([1.0, 2.5758293]), np.array([1.0, 1.0]))
    np.testing.assert_allclose(p, [0.31731051, 0.01], rtol=1e-6)
    assert exceedance_probability(0.075, np.array([0.03]))[0] == pytest.approx(
        2 * (1 - ndtr(2.5)), rel=1e-12
    )


def test_full_model_matches_linear_time_domain_run():
    """The plain linearised model: spectral mean squares equal the mean over seeds of
    the time-domain run's (spring compression from the recorded states, tyre load from
    the road input it was driven with) within 3.5 standard errors (from the seeds) plus
    1 % (RK4 at 100 Hz, record line grid)."""
    X = np.vstack([STUDY_PICK, design_space().lower])
    params = stacked_vehicle_parameters(X, LOAD_CASES)
    lin = RideModel(params, linear=True)
    v = REFERENCE_MINIBUS
    ms = []
    for seed in range(4):
        road = RandomRoad(duration_s=60.0, seed=60 + seed)
        rec = random_road_run(X, LOAD_CASES, road, linear=True, record_states=True)
        assert rec.states is not None
        q = rec.states[:, : lin.nq]
        qd = rec.states[:, lin.nq : 2 * lin.nq]
        z, zd = random_road_inputs(road, v)
        n_rec = q.shape[-1]
        z, zd = z[-2 * n_rec - 1 : -1 : 2].T, zd[-2 * n_rec - 1 : -1 : 2].T
        defl_f = np.einsum("i,nit->nt", lin.E[: lin.nq, 0], q)
        defl_r = np.einsum("i,nit->nt", lin.E[: lin.nq, 2], q)
        k_t, c_t = v.tyre_vertical_stiffness, v.tyre_vertical_damping
        tyre_f = k_t * (z[0] - q[:, 3]) + c_t * (zd[0] - qd[:, 3])
        tyre_r = k_t * (z[2] - q[:, 5]) + c_t * (zd[2] - qd[:, 5])
        ms.append([np.mean(a**2, axis=-1) for a in (defl_f, defl_r, tyre_f, tyre_r)])
    ms = np.array(ms)  # (seeds, 4, rows)
    mean, se = ms.mean(0), ms.std(0, ddof=1) / np.sqrt(len(ms))
    ws = working_space(X, LOAD_CASES, damper_c=lin.d_bl.T, leaf_k=lin.K[:, 2:4])
    static = np.array(
        [
            [
                p.front_static_load + v.unsprung_front * 9.81,
                p.rear_static_load + v.unsprung_rear * 9.81,
            ]
            for p in params
            for _ in range(p.n)
        ]
    ).T
    spec = (
        np.array(
            [
                ws["defl_front"],
                ws["defl_rear"],
                ws["tyre_front"] * static[0],
                ws["tyre_rear"] * static[1],
            ]
        )
        ** 2
    )
    assert np.all(np.abs(spec - mean) <= 3.5 * se + 0.01 * mean), (spec, mean, se)


def test_working_space_reuses_the_spectral_rates():
    X = np.vstack([STUDY_PICK, BASELINE_DESIGN])
    sp = ride_spectral(X)
    a = working_space(X)
    b = working_space(X, damper_c=sp["damper_c"], leaf_k=sp["leaf_k"])
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
        assert np.all((a[key] > 0) & np.isfinite(a[key]))


def test_problem_working_space_option():
    X = np.vstack([STUDY_PICK, BASELINE_DESIGN])
    plain = MinibusRideHandling()
    p = MinibusRideHandling(working_space=True, road_class="D")
    assert len(p.constraint_names) == len(plain.constraint_names) + 4
    batch = p.evaluate(X)
    m = p.measures(X)
    for lc in LOAD_CASES:
        worse = np.maximum(m[f"bump_stop_front_{lc}"], m[f"bump_stop_rear_{lc}"])
        i = p.constraint_names.index(f"bump_stop_{lc}")
        np.testing.assert_allclose(batch.constraints[:, i], worse - 0.01, rtol=1e-12)
        i = p.constraint_names.index(f"tyre_load_{lc}")
        worse = np.maximum(m[f"tyre_front_{lc}"], m[f"tyre_rear_{lc}"])
        np.testing.assert_allclose(batch.constraints[:, i], worse - 0.3, rtol=1e-12)
    # the default problem's constraints are unchanged by the option
    base = MinibusRideHandling(road_class="D").evaluate(X).constraints
    np.testing.assert_array_equal(batch.constraints[:, : base.shape[1]], base)
    with pytest.raises(ValidationError, match="bump_stop_limit"):
        MinibusRideHandling(bump_stop_limit=1.0)
    with pytest.raises(ValidationError, match="working_space"):
        MinibusRideHandling(working_space="yes")  # type: ignore[arg-type]
