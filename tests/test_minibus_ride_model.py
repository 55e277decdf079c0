"""Minibus ride model: linear time domain vs an independent frequency-domain computation,
quarter-car natural frequencies, static equilibrium, effects."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.metrics.iso2631 import weighted_rms_fft, weighting_magnitude
from suspenv.models.effects.effect import make_effect
from suspenv.models.minibus import (
    REFERENCE_MINIBUS,
    STUDY_PICK,
    LoadCase,
    design_space,
    vehicle_parameters,
)
from suspenv.models.minibus.ride_model import RideModel, SeatMount
from suspenv.models.minibus.suspension import damper_mean_coefficient
from suspenv.models.road import RandomRoad, displacement_psd, track_coherence
from suspenv.rigs.ride import random_road_run


# ---------------------------------------------------------------- independent FD model
def _hand_assembled_matrices(p, measure_y):
    """M, C, K (7x7) in CoM coordinates [z, theta (nose down), phi (left up), zFL, zFR,
    zRL, zRR], written out from the free-body geometry (not from the model's matrices)."""
    v, d, ld = p.vehicle, p.design, p.load
    a, b = p.a, p.b
    tf, tr, s, sd = v.track_front, v.track_rear, v.leaf_spacing, v.rear_damper_spacing
    kf, kr = d.front_wheel_rate[0], p.rear_static_rate[0]
    cf = damper_mean_coefficient(v.damper_front) * d.front_damper_scale[0]
    cr = damper_mean_coefficient(v.damper_rear) * d.rear_damper_scale[0]
    kt, ct = v.tyre_vertical_stiffness, v.tyre_vertical_damping
    K = np.zeros((7, 7))
    C = np.zeros((7, 7))

    def add(mat, k, g):
        g = np.asarray(g, float)
        mat += k * np.outer(g, g)

    for y, w in ((tf / 2, 3), (-tf / 2, 4)):
        g = np.zeros(7)
        g[:3] = [-1.0, a, -y]  # body point z - a*theta + y*phi, with minus sign
        g[w] = 1.0
        add(K, kf, g)
        add(C, cf, g)
    for spacing, mat, k in ((s, K, kr), (sd, C, cr)):
        for y in (spacing / 2, -spacing / 2):
            g = np.zeros(7)
            g[:3] = [-1.0, -b, -y]  # body point z + b*theta + y*phi
            g[5], g[6] = 0.5 + y / tr, 0.5 - y / tr
            add(mat, k, g)
    add(K, d.front_roll_arb[0], [0, 0, 1, -1 / tf, 1 / tf, 0, 0])
    add(K, d.rear_roll_arb[0], [0, 0, 1, 0, 0, -1 / tr, 1 / tr])
    for w in range(3, 7):
        g = np.zeros(7)
        g[w] = -1.0
        add(K, kt, g)
        add(C, ct, g)
    M = np.diag(
        [ld.sprung_mass, ld.pitch_inertia, ld.roll_inertia]
        + [v.unsprung_front] * 2
        + [v.unsprung_rear] * 2
    )
    out_f = np.array([1.0, -a, measure_y, 0, 0, 0, 0])
    out_r = np.array([1.0, b, measure_y, 0, 0, 0, 0])
    return M, C, K, out_f, out_r


def _frequency_domain_aw(p, road, measure_y=0.35):
    """Weighted RMS from H(f) x road cross-spectral matrix x Wk^2 (ISO 8608 + coherency)."""
    M, C, K, out_f, out_r = _hand_assembled_matrices(p, measure_y)
    v, veh = road.speed, p.vehicle
    kt, ct = veh.tyre_vertical_stiffness, veh.tyre_vertical_damping
    f = np.linspace(0.5, min(2.83 * v, road.sample_rate / 2), 6000)
    n = f / v
    gq = displacement_psd(n, road.road_class) / v  # temporal PSD, m^2/Hz
    rho = track_coherence(n, veh.track_front)
    delay = np.array([0.0, 0.0, 1.0, 1.0]) * veh.wheelbase / v
    same_track = np.array([[1, 0, 1, 0], [0, 1, 0, 1], [1, 0, 1, 0], [0, 1, 0, 1]], bool)
    w = 2 * np.pi * f
    A = -(w**2)[:, None, None] * M + 1j * w[:, None, None] * C + K  # (F, 7, 7)
    Bw = np.zeros((f.size, 7, 4), complex)
    Bw[:, 3:7, :] = np.eye(4) * (kt + 1j * w * ct)[:, None, None]
    X = np.linalg.solve(A, Bw)  # wheel-road to DOF transfer matrices
    coh = np.where(same_track, 1.0, rho[:, None, None])
    S = gq[:, None, None] * coh * np.exp(-1j * w[:, None, None] * (delay[:, None] - delay))
    wk2 = weighting_magnitude(f, "Wk") ** 2
    res = []
    for out in (out_f, out_r):
        h = -(w**2)[:, None] * np.einsum("i,fij->fj", out, X)  # acceleration / road input
        psd = np.real(np.einsum("fi,fij,fj->f", h, S, h.conj()))
        res.append(np.sqrt(np.trapezoid(psd * wk2, f)))
    return res


def test_linear_time_domain_matches_frequency_domain():
    X = np.vstack([STUDY_PICK, design_space().lower])
    loads = ("no_load", "full_load")
    ms_f, ms_r = np.zeros(4), np.zeros(4)  # rows: load case 0 designs 0, 1; load case 1 ...
    seeds = (11, 3, 5)  # mean square over three road records of 40 s each
    for seed in seeds:
        road = RandomRoad(road_class="B", speed_kmh=80, duration_s=40, settle_s=2, seed=seed)
        rec = random_road_run(X, loads, road, linear=True)
        ms_f += weighted_rms_fft(rec.acc_front, road.sample_rate, "Wk") ** 2 / len(seeds)
        ms_r += weighted_rms_fft(rec.acc_rear, road.sample_rate, "Wk") ** 2 / len(seeds)
    for j, load in enumerate(loads):
        for i in range(2):
            ref_f, ref_r = _frequency_domain_aw(vehicle_parameters(X[i : i + 1], load), road)
            # independent reference: H(f) from hand-assembled M, C, K; ISO 8608 PSD;
            # isotropic coherency; rear delay L/v; Wk^2. A few percent: finite records.
            assert np.sqrt(ms_f[2 * j + i]) == pytest.approx(ref_f, rel=0.04)
            assert np.sqrt(ms_r[2 * j + i]) == pytest.approx(ref_r, rel=0.04)


# ---------------------------------------------------------------- quarter car
def _quarter_car_vehicle():
    """A minibus whose four corners decouple: CoM mid-wheelbase, pitch inertia m a b,
    roll inertia m (t/2)^2, leaves at the wheels, no stabilisers."""
    veh = REFERENCE_MINIBUS.with_(leaf_spacing=1.465, rear_damper_spacing=1.465)
    lc = LoadCase("quarter", 2000.0, 1.30, 0.8, 1.465 / 2, 1.30, 1.3)
    X = STUDY_PICK.copy()[None, :]
    X[0, 4] = X[0, 5] = 1e-9  # stabilisers off
    return veh, lc, X


def test_quarter_car_natural_frequencies_closed_form():
    veh, lc, X = _quarter_car_vehicle()
    p = vehicle_parameters(X, lc, veh)
    model = RideModel(p, linear=True)
    M, _, K, _, _ = model.linear_system()
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(M[0], K[0])).real)
    ms = lc.sprung_mass / 4  # corner share of the body
    for ks, mu in ((p.design.front_wheel_rate[0], veh.unsprung_front),
                   (p.rear_static_rate[0], veh.unsprung_rear)):  # fmt: skip
        kt = veh.tyre_vertical_stiffness
        # closed form: ms mu w^4 - (ms (ks + kt) + mu ks) w^2 + ks kt = 0
        bq = ms * (ks + kt) + mu * ks
        disc = np.sqrt(bq**2 - 4 * ms * mu * ks * kt)
        body, hop = (bq - disc) / (2 * ms * mu), (bq + disc) / (2 * ms * mu)
        assert np.min(np.abs(w2 / body - 1)) < 1e-9
        assert np.min(np.abs(w2 / hop - 1)) < 1e-9


def test_quarter_car_free_decay_frequency_in_time_domain():
    # the integrated response of a lightly damped corner rings at the closed-form body
    # frequency sqrt(k_ride/ms)(1 - zeta^2)^0.5 (reference: damped 1-DOF closed form)
    veh, lc, X = _quarter_car_vehicle()
    X[0, 6] = X[0, 7] = 0.05  # light damping
    p = vehicle_parameters(X, lc, veh)
    model = RideModel(p, linear=True, measure_y=0.0)
    dt, n = 0.002, 6000
    z = np.zeros((2 * n + 1, 4))
    z[:, 0:2] = 0.01  # a 10 mm step under both front wheels at t = 0
    rec = model.simulate(z, np.zeros_like(z), dt)
    a = rec.acc_front[0]
    spec = np.abs(np.fft.rfft(a * np.hanning(a.size)))
    f = np.fft.rfftfreq(a.size, dt)
    sel = (f > 0.5) & (f < 4)
    f_peak = f[sel][np.argmax(spec[sel])]
    ks, kt, ms = p.design.front_wheel_rate[0], veh.tyre_vertical_stiffness, lc.sprung_mass / 4
    f_body = np.sqrt(ks * kt / (ks + kt) / ms) / (2 * np.pi)
    assert f_peak == pytest.approx(f_body, rel=0.05)


# ---------------------------------------------------------------- equilibrium, effects
def test_static_equilibrium_is_at_rest_and_symmetric_roads_give_no_roll():
    X = np.vstack([STUDY_PICK, design_space().upper])
    model = RideModel([vehicle_parameters(X, lc) for lc in ("no_load", "full_load")])
    z = np.zeros((401, 4))
    rec = model.simulate(z, z, 0.005)
    assert np.max(np.abs(rec.body_acc)) < 1e-12
    # identical left and right inputs: by symmetry no roll (reference: mirror symmetry)
    z[:, :] = 0.02 * np.sin(np.linspace(0, 20, 401))[:, None]
    rec = model.simulate(z, np.gradient(z, 0.0025, axis=0), 0.005)
    assert np.max(np.abs(rec.body_acc[:, 2])) < 1e-9
    assert np.max(np.abs(rec.body_acc[:, 0])) > 0.1


def test_hysteretic_leaf_and_friction_change_the_response_and_are_validated():
    X = STUDY_PICK[None, :]
    road = RandomRoad(duration_s=3, settle_s=0.5)
    base = random_road_run(X, "no_load", road)
    effects = [
        make_effect("dahl_hysteresis", location="rear_leaf", f_c=300.0, sigma=2e5),
        make_effect("coulomb_friction", location="front_damper", f_c=80.0, v_eps=0.005),
        make_effect("bump_stop", location="rear_suspension", gap=0.02, k_stop=2e5),
    ]
    rich = random_road_run(X, "no_load", road, effects=effects, seat=SeatMount())
    assert np.all(np.isfinite(rich.acc_rear))
    assert not np.allclose(rich.acc_rear, base.acc_rear)
    with pytest.raises(ValidationError, match="not supported"):
        RideModel(vehicle_parameters(X), effects=[make_effect("bump_stop", location="roof")])
    with pytest.raises(ValidationError, match="linearised"):
        RideModel(vehicle_parameters(X), effects=effects[:1], linear=True)


def test_seat_mount_transmissibility_is_base_excited_sdof():
    # reference: the seat is a mass on a spring-damper driven by the body point, so
    # seat/body acceleration = (k + j w c) / (k - m w^2 + j w c) (base-excited 1-DOF)
    from scipy.signal import csd, welch

    seat = SeatMount(mass=90.0, frequency=4.0, damping_ratio=0.25)
    road = RandomRoad(duration_s=20, settle_s=1)
    rec = random_road_run(STUDY_PICK[None, :], "no_load", road, seat=seat)
    fs = road.sample_rate
    body = rec.body_acc[0, 0] + 0.35 * rec.body_acc[0, 2]  # body point under the seat
    f, pxy = csd(body, rec.acc_front[0], fs=fs, nperseg=512)
    _, pxx = welch(body, fs=fs, nperseg=512)
    w = 2 * np.pi * f
    k, c, m = seat.stiffness, seat.damping, seat.mass
    expected = np.abs((k + 1j * w * c) / (k - m * w**2 + 1j * w * c))
    sel = (f > 2) & (f < 8)
    np.testing.assert_allclose(np.abs(pxy / pxx)[sel], expected[sel], rtol=0.05)
