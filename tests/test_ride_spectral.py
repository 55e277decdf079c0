"""Spectral ride method: closed forms, modal vs direct solve, grid convergence, agreement
with the time-domain model averaged over long road records, and the problem option."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.metrics.iso2631 import weighted_rms_fft
from suspenv.metrics.ride import _output_matrix, modal_form, modal_response, ride_spectral
from suspenv.models.minibus import BASELINE_DESIGN, STUDY_PICK, design_space
from suspenv.models.minibus.ride_model import RideModel
from suspenv.models.minibus.vehicle import LOAD_CASES, vehicle_parameters
from suspenv.models.road import RandomRoad
from suspenv.problems.minibus import MinibusRideHandling
from suspenv.problems.minibus_ride import ride_objectives_all
from suspenv.rigs.ride import random_road_run


def _one_dof(m: float, c: float, k: float, kin: float, cin: float):
    M, C, K = (np.array([[[x]]]) for x in (m, c, k))
    return M, C, K, np.array([[[kin]]]), np.array([[[cin]]])


def _white_velocity_variance(H: np.ndarray, f: np.ndarray, s0: float) -> float:
    """Variance of the response to a base velocity of two-sided PSD s0 (per rad/s):
    integral over f >= 0 of 4 pi s0 |H_v(f)|^2 df, trapezoid on the log grid."""
    y = 4 * np.pi * s0 * np.abs(H) ** 2
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(f)))


@pytest.mark.parametrize("m, c, k", [(300.0, 1500.0, 2.0e4), (40.0, 900.0, 2.2e5)])
def test_one_dof_white_noise_closed_forms(m, c, k):
    """Newland, An Introduction to Random Vibrations, Appendix 1 (table of the integrals
    I_n; James, Nichols & Phillips 1947): for H(w) = (B0 + i w B1)/(A0 + i w A1 - w^2 A2),
    integral_{-inf}^{inf} |H|^2 dw = pi (A0 B1^2 + A2 B0^2)/(A0 A1 A2).

    Base velocity u' white with two-sided PSD S0:
    - spring and damper to the base (m x'' = -k(x-u) - c(x'-u')): body velocity per base
      velocity H = (k + i w c)/(k + i w c - w^2 m), so var(x') = pi S0 (k/c + c/m);
    - spring to the base, damper to the ground (skyhook): body acceleration per base
      velocity H = i w k/(k + i w c - w^2 m) (B0 = 0, B1 = k), var(x'') = pi S0 k^2/(c m).
    """
    s0 = 0.37
    f = np.geomspace(1e-5, 1e6, 20001)
    w = 2 * np.pi * f
    Co = np.array([[1.0]])
    # displacement per base displacement; per base velocity divide by i w
    G = modal_response(*modal_form(*_one_dof(m, c, k, k, c), Co), f)[0, :, 0, 0]
    var_v = _white_velocity_variance(G, f, s0)  # (i w G)/(i w)
    assert var_v == pytest.approx(np.pi * s0 * (k / c + c / m), rel=5e-5)
    G = modal_response(*modal_form(*_one_dof(m, c, k, k, 0.0), Co), f)[0, :, 0, 0]
    var_a = _white_velocity_variance(-(w**2) * G / (1j * w), f, s0)
    assert var_a == pytest.approx(np.pi * s0 * k**2 / (c * m), rel=5e-5)


def test_modal_response_matches_direct_solve():
    X = np.vstack([STUDY_PICK, design_space().lower, design_space().upper])
    params = [vehicle_parameters(X, lc) for lc in LOAD_CASES]
    lin = RideModel(params, linear=True)
    rng = np.random.default_rng(3)
    c = lin.d_bl.T * rng.uniform(0.7, 1.5, (lin.n, 4))
    M, C, K, Kin, Cin = lin.linear_system(c, lin.K[:, 2:4] * 1.1)
    Co = _output_matrix(lin)
    f = np.array([0.3, 1.1, 1.7, 4.0, 11.5, 40.0])
    G = modal_response(*modal_form(M, C, K, Kin, Cin, Co), f)
    for j, fj in enumerate(f):
        w = 2 * np.pi * fj
        Z = K - w**2 * M + 1j * w * C
        direct = Co @ np.linalg.solve(Z, Kin + 1j * w * Cin)
        np.testing.assert_allclose(G[:, j], direct, rtol=1e-8, atol=1e-12 * np.abs(direct).max())


def test_linear_system_matches_the_time_domain_rhs():
    """M^-1 (-K q - C qd + Kin u + Cin ud) equals the model's own right-hand side."""
    params = [vehicle_parameters(STUDY_PICK[None, :], lc) for lc in LOAD_CASES]
    lin = RideModel(params, linear=True)
    M, C, K, Kin, Cin = lin.linear_system()
    rng = np.random.default_rng(0)
    q, qd, u, ud = (
        rng.normal(size=(lin.nq, 2)),
        rng.normal(size=(lin.nq, 2)),
        *rng.normal(size=(2, 4)),
    )
    out = np.zeros((2 * lin.nq, 2))
    lin.rhs(np.vstack([q, qd]), lin.road_vector(u[None], ud[None])[0], out)
    for i in range(2):
        expect = np.linalg.solve(M[i], -K[i] @ q[:, i] - C[i] @ qd[:, i] + Kin[i] @ u + Cin[i] @ ud)
        np.testing.assert_allclose(out[lin.nq :, i], expect, rtol=1e-9, atol=1e-9)


def test_frequency_grid_and_fixed_point_are_converged():
    X = np.vstack([STUDY_PICK, BASELINE_DESIGN, design_space().lower, design_space().upper])
    # the plain linear model: the 400-point grid against a 4800-point one
    a = ride_spectral(X, equivalent_linear=False)
    b = ride_spectral(X, n_freq=4800, equivalent_linear=False)
    for key in ("aw_front", "aw_rear", "rms_front", "rms_rear"):
        np.testing.assert_allclose(a[key], b[key], rtol=1e-4)
    # the defaults against the exact fixed point on fine grids
    a = ride_spectral(X)
    b = ride_spectral(X, n_freq=4800, n_freq_iter=2000, tol=1e-9, iterations=60)
    assert int(b["iterations"]) < 60  # converged
    for key in ("aw_front", "aw_rear", "rms_front", "rms_rear"):
        np.testing.assert_allclose(a[key], b[key], rtol=1e-3)


def test_spectral_equals_linear_time_domain_mean_over_long_records():
    """The plain linearised model: the spectral value is the expectation of the
    time-domain mean square (same road band, coherency and delay), so the mean over
    seeds of 100 s records must agree within the Monte Carlo error (3.5 standard
    errors, computed from the seeds) plus 0.5 % for RK4 at 100 Hz and the 0.01 Hz line
    grid."""
    X = np.vstack([STUDY_PICK, design_space().to_physical(np.random.default_rng(5).random((2, 8)))])
    seeds = range(5)
    ms = []
    for seed in seeds:
        rec = random_road_run(
            X, LOAD_CASES, RandomRoad(duration_s=100.0, seed=40 + seed), linear=True
        )
        ms.append(
            np.concatenate(
                [
                    weighted_rms_fft(rec.acc_front, 100.0) ** 2,
                    weighted_rms_fft(rec.acc_rear, 100.0) ** 2,
                ]
            )
        )
    ms = np.array(ms)
    mean, se = ms.mean(0), ms.std(0, ddof=1) / np.sqrt(len(ms))
    sp = ride_spectral(X, equivalent_linear=False)
    spec = np.concatenate([sp["aw_front"] ** 2, sp["aw_rear"] ** 2])
    assert np.all(np.abs(spec - mean) <= 3.5 * se + 0.005 * mean), (spec, mean, se)


def test_equivalent_linear_rates_and_method_option():
    X = np.vstack([STUDY_PICK, BASELINE_DESIGN])
    sp = ride_spectral(X)
    lin = RideModel([vehicle_parameters(X, lc) for lc in LOAD_CASES], linear=True)
    # the equivalent damping lies between the digressive high-speed and the low-speed
    # rebound slopes; the leaf rate between the primary and composite rates
    nl = RideModel([vehicle_parameters(X, lc) for lc in LOAD_CASES])
    assert np.all(sp["damper_c"] <= nl.d_rl.T + 1e-9) and np.all(sp["damper_c"] >= nl.d_bh.T)
    assert np.all(sp["leaf_k"] >= nl.K[:, 2:4] - 1e-9)
    assert np.all(sp["leaf_k"] <= nl.K[:, 2:4] + nl.leaf_dk.T + 1e-9)
    assert lin.n == sp["aw_front"].size
    # no seed, no record length: the spectral objectives ignore both
    a = ride_objectives_all(X, road=RandomRoad(seed=1, duration_s=3.0), method="spectral")
    b = ride_objectives_all(X, road=RandomRoad(seed=7, duration_s=30.0), method="spectral")
    for lc in LOAD_CASES:
        np.testing.assert_allclose(a[lc]["aw_rear"], b[lc]["aw_rear"], rtol=1e-12)
        assert a[lc]["ok"].all()
    with pytest.raises(ValidationError, match="ride method"):
        ride_objectives_all(X, method="fft")


def test_problem_ride_method_option():
    X = np.vstack([STUDY_PICK, BASELINE_DESIGN])
    p1 = MinibusRideHandling(ride_method="spectral", road_seed=1)
    p2 = MinibusRideHandling(ride_method="spectral", road_seed=2, ride_duration_s=4.0)
    assert p1.config()["ride_method"] == "spectral"
    m1, m2 = p1.measures(X), p2.measures(X)
    np.testing.assert_allclose(m1["aw_rear_full_load"], m2["aw_rear_full_load"], rtol=1e-12)
    with pytest.raises(ValidationError, match="ride_method"):
        MinibusRideHandling(ride_method="fft")


def test_plain_linear_spectral_matches_hand_assembled_reference():
    """Independent assembly (tests/test_minibus_ride_model.py: hand-written M, C, K in
    heave/pitch/roll coordinates, direct solve per frequency, 4x4 road cross-spectral
    matrix, 6000-point linear grid over 0.5-50 Hz) against the modal method."""
    from test_minibus_ride_model import _frequency_domain_aw

    road = RandomRoad()
    X = np.vstack([STUDY_PICK, design_space().lower])
    sp = ride_spectral(X, equivalent_linear=False)
    for j, load in enumerate(LOAD_CASES):
        for i in range(2):
            ref_f, ref_r = _frequency_domain_aw(vehicle_parameters(X[i : i + 1], load), road)
            assert sp["aw_front"][2 * j + i] == pytest.approx(ref_f, rel=2e-3)
            assert sp["aw_rear"][2 * j + i] == pytest.approx(ref_r, rel=2e-3)


def test_spectral_values_do_not_depend_on_the_batch():
    """Per-design convergence of the equivalent-linear rates and per-design chunks: a
    design's numbers are the same alone and inside a larger batch (across chunks)."""
    X = design_space().to_physical(np.random.default_rng(2).random((40, 8)))
    both = ride_objectives_all(X, method="spectral")
    for i in (0, 17, 39):
        alone = ride_objectives_all(X[i : i + 1], method="spectral")
        for lc in LOAD_CASES:
            for key in ("aw_front", "aw_rear", "rms_front", "rms_rear"):
                assert alone[lc][key][0] == both[lc][key][i]


# ------------------------------------------------------------------ split path
_KEYS = ("aw_front", "aw_rear", "rms_front", "rms_rear", "damper_c", "leaf_k")


def _assert_split_equals_full(X, rtol, **kw):
    """The default (split) path against ``split=False``, the modal expansion of the
    whole 14-state model over every wheel input (the previous algorithm, pinned above
    against direct complex solves, closed forms and the hand-assembled reference)."""
    a = ride_spectral(X, split=False, **kw)
    b = ride_spectral(X, **kw)
    assert int(a["iterations"]) == int(b["iterations"])
    for key in _KEYS:
        np.testing.assert_allclose(b[key], a[key], rtol=rtol, atol=0, err_msg=key)
    np.testing.assert_array_equal(a["ok"], b["ok"])


def test_split_halves_equal_the_full_model():
    """Same integral, other arithmetic: agreement to round-off (measured <= 3e-14)."""
    space = design_space()
    X = np.vstack(
        [
            STUDY_PICK,
            BASELINE_DESIGN,
            space.lower,
            space.upper,
            space.to_physical(np.random.default_rng(11).random((12, 8))),
        ]
    )
    _assert_split_equals_full(X, 1e-10)
    _assert_split_equals_full(X, 1e-10, equivalent_linear=False)
    _assert_split_equals_full(X, 1e-10, tol=1e-6, iterations=10)
    _assert_split_equals_full(X[:3], 1e-10, road=RandomRoad(road_class="D", speed_kmh=50.0))


def test_split_pairs_real_poles():
    """30x the mean damping for the one pass: overdamped modes give real poles, which the
    split path pairs among themselves (measured agreement 2e-13)."""
    X = np.vstack([STUDY_PICK, design_space().lower, design_space().upper])
    _assert_split_equals_full(X, 1e-9, iterations=1, init_damping=30.0)


def test_symmetric_and_antisymmetric_halves_decouple():
    """T_SYM^T (M, C, K) T_ANTI = 0 for left/right-equal rates, and each half's road
    input vanishes in the other half (the reason the split is exact)."""
    from suspenv.metrics.ride import J_ANTI, J_SYM, T_ANTI, T_SYM

    X = np.vstack([STUDY_PICK, design_space().upper])
    lin = RideModel([vehicle_parameters(X, lc) for lc in LOAD_CASES], linear=True)
    rng = np.random.default_rng(4)
    c = np.repeat(lin.d_bl.T[:, 0::2] * rng.uniform(0.5, 1.5, (lin.n, 2)), 2, axis=1)
    k = np.repeat(lin.K[:, 2:3] * rng.uniform(1.0, 1.5, (lin.n, 1)), 2, axis=1)
    M, C, K, Kin, Cin = lin.linear_system(c, k)
    for mat in (M, C, K):
        scale = np.abs(mat).max()
        assert np.abs(T_SYM.T @ mat @ T_ANTI).max() <= 1e-12 * scale
    for inp in (Kin, Cin):
        scale = np.abs(inp).max()
        assert np.abs(T_SYM.T @ inp @ J_ANTI).max() <= 1e-12 * scale
        assert np.abs(T_ANTI.T @ inp @ J_SYM).max() <= 1e-12 * scale


def test_split_values_do_not_depend_on_chunks(monkeypatch):
    """Chunks of 7 designs: every design's numbers are bitwise those it gets alone."""
    import suspenv.metrics.ride as ride

    X = design_space().to_physical(np.random.default_rng(9).random((16, 8)))
    monkeypatch.setattr(ride, "SPLIT_CHUNK", 7)
    both = ride_spectral(X)
    for i in (0, 6, 7, 15):
        alone = ride_spectral(X[i : i + 1])
        for key in ("aw_front", "aw_rear", "rms_front", "rms_rear"):
            for j in range(len(LOAD_CASES)):
                assert alone[key][j] == both[key][j * 16 + i]


def test_seat_model_uses_the_full_model():
    """A seat mount breaks the left/right symmetry: the full model serves."""
    from suspenv.models.minibus.ride_model import SeatMount

    X = np.vstack([STUDY_PICK, BASELINE_DESIGN])
    a = ride_spectral(X, seat=SeatMount())
    b = ride_spectral(X, seat=SeatMount(), split=False)
    for key in _KEYS:
        np.testing.assert_array_equal(a[key], b[key])
    assert np.all(a["aw_front"] != ride_spectral(X)["aw_front"])


def test_take_rates_rule():
    """The fixed point's update rule (``spectral_kernel.take_rates``, both paths): a
    design takes its new rates where their largest relative change is >= tol, keeps
    them where a change is NaN. Reference: the rule written in numpy here."""
    from suspenv.models.minibus import spectral_kernel

    rng = np.random.default_rng(5)
    r = rng.uniform(1.0, 2.0, (6, 4))
    new = r * (1.0 + rng.uniform(-1e-3, 1e-3, r.shape))
    new[1], new[2, 3], r[3, 0] = r[1], np.nan, 0.0  # unchanged; NaN; relative to 1e-300
    for tol in (0.0, 5e-4):
        change = np.max(np.abs(new - r) / np.maximum(np.abs(r), 1e-300), axis=1)
        expect = np.where((change >= tol)[:, None], new, r)
        got = r.copy()
        assert spectral_kernel.take_rates(new, got, tol) == np.sum(change >= tol)
        np.testing.assert_array_equal(got, expect)


def test_eig_equals_numpy_and_fails_only_the_non_finite_matrix():
    """The compiled eig of small matrices against :func:`numpy.linalg.eig` (LAPACK, the
    reference): the same eigenvalues (in another order) to round-off, ``A v = lam v`` to
    round-off, unit vectors parallel to numpy's; ``-I`` (a repeated eigenvalue, no
    unique null vector) takes LAPACK's numbers exactly, as :func:`lapack_eig` does
    numpy's; a matrix with a NaN entry gives NaN in its own rows only."""
    from suspenv.models.minibus.spectral_kernel import eig, lapack_eig

    A = np.random.default_rng(3).normal(size=(2, 3, 4, 4))
    A[1, 2] = -np.eye(4)
    w, v = eig(A)
    w_ref, v_ref = np.linalg.eig(A)
    nearest = np.abs(w[..., :, None] - w_ref[..., None, :]).argmin(axis=-1)
    np.testing.assert_allclose(w, np.take_along_axis(w_ref, nearest, -1), rtol=0, atol=1e-13)
    assert np.abs(A @ v - v * w[..., None, :]).max() <= 1e-13
    parallel = np.sum(v.conj() * np.take_along_axis(v_ref, nearest[..., None, :], -1), axis=-2)
    parallel = parallel.reshape(6, 4)  # the last matrix -I
    np.testing.assert_allclose(np.abs(parallel[np.arange(6) != 5]), 1.0, rtol=1e-12)
    np.testing.assert_array_equal(v[1, 2], np.eye(4))  # -I: every vector is one
    for got, ref in zip(lapack_eig(A), (w_ref, v_ref), strict=True):
        np.testing.assert_array_equal(got, ref)
    A[0, 1, 2, 3] = np.nan
    w, v = eig(A)
    assert np.isnan(w[0, 1]).all() and np.isnan(v[0, 1]).all()
    assert np.isfinite(w[0, [0, 2]]).all() and np.isfinite(w[1]).all()


@pytest.mark.parametrize("damping", [1.0, 30.0])
def test_halves_eigenvectors_solve_the_eigenproblem(damping):
    """The halves' modes from the compiled QR iteration and null vectors
    (``_Halves.modal``: ``spectral_kernel.eigen``) against :func:`numpy.linalg.eig` (the
    reference, LAPACK): the same eigenvalues to round-off, ``A v = lam v`` to round-off
    and each unit vector parallel to numpy's; 30x the mean damping gives real poles. A
    matrix with a NaN entry gives NaN in its own rows only, from the compiled loop and
    from ``modal``'s LAPACK fallback alike."""
    from suspenv.metrics.ride import _Halves, _split_geometry
    from suspenv.models.minibus import spectral_kernel

    X = np.vstack([STUDY_PICK, design_space().lower, design_space().upper])
    model = RideModel([vehicle_parameters(X, lc) for lc in LOAD_CASES])
    rates = model.K.astype(float)
    rates[:, 2:4] = model.leaf_static_rate
    rates[:, model.n_pos : model.n_pos + 4] = damping * model.damper_mean
    halves = _Halves(_split_geometry(model), model)
    lam, V = halves.modal(rates)
    A = halves._A
    lam_ref, V_ref = np.linalg.eig(A)
    scale = np.abs(A).max(axis=(1, 2))[:, None]
    np.testing.assert_allclose(
        np.sort_complex(lam), np.sort_complex(lam_ref), rtol=0, atol=1e-12 * scale.max()
    )
    residual = np.abs(A @ V - V * lam[:, None, :]).max(axis=1)
    assert (residual <= 1e-12 * scale).all()
    np.testing.assert_allclose(np.linalg.norm(V, axis=1), 1.0, rtol=1e-14)
    nearest = np.abs(lam[:, :, None] - lam_ref[:, None, :]).argmin(axis=2)
    ref = np.take_along_axis(V_ref, nearest[:, None, :], axis=2)
    np.testing.assert_allclose(np.abs(np.sum(V.conj() * ref, axis=1)), 1.0, rtol=1e-9)
    A[1, 5, 0] = np.nan
    w = np.empty(A.shape[:2], dtype=complex)
    vec = np.empty(A.shape, dtype=complex)
    spectral_kernel.eigen(A, w, vec)
    assert np.isnan(w[1]).all() and np.isnan(vec[1]).all()
    np.testing.assert_array_equal(w[[0, 2, 3]], lam[[0, 2, 3]])
    np.testing.assert_array_equal(vec[[0, 2, 3]], V[[0, 2, 3]])
    lam, V = halves.modal(rates + np.where(np.arange(len(rates)) == 1, np.nan, 0.0)[:, None])
    assert np.isnan(lam[[2, 3]]).all() and np.isnan(V[[2, 3]]).all()
    assert np.isfinite(lam[[0, 1]]).all() and np.isfinite(V[[0, 1]]).all()


def test_qr_eigenvalues_equal_lapack_on_general_matrices():
    """``spectral_kernel._eigenvalues`` (balancing, Hessenberg reduction, Francis QR; the
    plain form of the compiled loop's) against :func:`numpy.linalg.eigvals` (LAPACK, the
    reference) on random matrices of 2-8 rows spanning six decades of row scale, some
    with zero entries, real and complex eigenvalues: equal to round-off of the matrix's
    size; conjugate pairs adjacent, positive imaginary part first; NaN for a matrix
    with a non-finite entry."""
    from scipy.optimize import linear_sum_assignment

    from suspenv.models.minibus.spectral_kernel import _eigenvalues

    rng = np.random.default_rng(11)
    for m in (2, 3, 5, 8):
        for t in range(40):
            A = rng.normal(size=(m, m)) * 10.0 ** rng.uniform(-3, 3, (m, 1))
            A[rng.random((m, m)) < 0.3 * (t % 2)] = 0.0
            lam = np.empty(m, dtype=complex)
            _eigenvalues(A.copy(), lam)
            ref = np.linalg.eigvals(A)
            # matched one to one (repeated eigenvalues where rows are zero)
            _, match = linear_sum_assignment(np.abs(lam[:, None] - ref[None, :]))
            assert np.abs(lam - ref[match]).max() <= 1e-12 * np.abs(A).max()
            pos = np.flatnonzero(lam.imag > 0)
            np.testing.assert_array_equal(lam[pos + 1], lam[pos].conj())
    A[0, 1] = np.inf
    _eigenvalues(A, lam)
    assert np.isnan(lam).all()
