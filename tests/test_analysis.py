"""suspenv.analysis: indicators, fixed-target and fixed-budget views, rank tests, IOH lines.

Every number is checked against an independent reference: a hand computation, a closed
form, another implementation (pymoo's hypervolume, a numerical distance minimisation) or
a textbook value.
"""

from __future__ import annotations

import subprocess
import sys
from math import comb, exp

import numpy as np
import pytest

from suspenv.analysis.indicators import (
    KNOWN_FRONTS,
    hypervolume,
    hypervolume_2d,
    hypervolume_curve,
    igd,
    reference_point,
)
from suspenv.analysis.ioh import dat_lines
from suspenv.analysis.performance import (
    as_curve,
    curve_matrix,
    curve_quantiles,
    ecdf_area,
    ert,
    fixed_budget,
    make_targets,
    performance_profile,
    quantile_inf,
    runtime_ecdf,
    runtimes,
)
from suspenv.analysis.stats import holm, min_two_sided_p, rank_tests
from suspenv.core.errors import ValidationError


# ---------------------------------------------------------------- hypervolume
def test_hypervolume_2d_of_a_hand_computed_front():
    # (1,3), (2,2), (3,1) up to (4,4): columns of width 1 and heights 1, 2, 3 -> 6;
    # a dominated point, a point outside the box and a NaN row add nothing
    F = np.array([[1, 3], [2, 2], [3, 1], [2.5, 2.5], [5, 0], [np.nan, 0]], float)
    ref = np.array([4.0, 4.0])
    assert hypervolume_2d(F, ref) == pytest.approx(6.0, abs=1e-15)
    assert hypervolume(F, ref) == pytest.approx(6.0, abs=1e-15)
    assert hypervolume(np.array([[5.0, 5.0]]), ref) == 0.0


def test_hypervolume_2d_agrees_with_pymoo_on_random_fronts():
    from pymoo.indicators.hv import HV

    rng = np.random.default_rng(3)
    for _ in range(20):
        F = rng.uniform(0, 1, (rng.integers(1, 60), 2))
        ref = np.array([1.1, 1.2])
        assert hypervolume_2d(F, ref) == pytest.approx(HV(ref_point=ref)(F), rel=1e-12)


def hypervolume_slicing(F: np.ndarray, ref: np.ndarray) -> float:
    """Independent exact hypervolume (minimisation) by slicing along the last objective
    (HSO), any m: sorted by the last objective, the slab between the i-th and (i+1)-th
    value (the last one up to ``ref``) is covered by the (m-1)-objective hypervolume of
    the first i+1 points; m = 1: ``ref - min f``. Rows not strictly inside add nothing."""
    F, ref = np.asarray(F, float), np.asarray(ref, float)
    P = F[np.isfinite(F).all(axis=1) & (ref > F).all(axis=1)]
    if not len(P):
        return 0.0
    if P.shape[1] == 1:
        return float(ref[0] - P[:, 0].min())
    P = P[np.argsort(P[:, -1], kind="stable")]
    z = np.r_[P[:, -1], ref[-1]]
    slabs = [
        (z[i + 1] - z[i]) * hypervolume_slicing(P[: i + 1, :-1], ref[:-1]) for i in range(len(P))
    ]
    return float(sum(slabs))


def test_hypervolume_3d_by_hand_and_slicing_agrees_with_pymoo():
    # boxes [0,2]^2 x [1,2] (4) and [1,2]^2 x [0,2] (2) overlap in [1,2]^3 (1): 5
    F = np.array([[0, 0, 1], [1, 1, 0]], float)
    ref = np.full(3, 2.0)
    assert hypervolume_slicing(F, ref) == pytest.approx(5.0)
    assert hypervolume(F, ref) == pytest.approx(5.0)
    rng = np.random.default_rng(5)
    for m in (3, 4):
        X = rng.uniform(0.05, 1, (25, m))
        F = X / np.linalg.norm(X, axis=1, keepdims=True)  # points near a sphere: many kept
        ref = reference_point(m)
        assert hypervolume(F, ref) == pytest.approx(hypervolume_slicing(F, ref), rel=1e-10)


def test_zdt1_exact_hypervolume_is_the_limit_of_dense_fronts():
    known = KNOWN_FRONTS["ZDT1"]
    ref = reference_point(2)
    exact = known.exact_hypervolume(ref)
    assert exact == pytest.approx(1.21 - 1 / 3)
    # a sampled front lies on the true one, so it dominates slightly less
    coarse = hypervolume(known.sample(101), ref)
    dense = hypervolume(known.sample(100001), ref)
    assert coarse < dense < exact and exact - dense < 1e-4


def test_hypervolume_curve_is_the_prefix_hypervolume():
    from pymoo.indicators.hv import HV

    rng = np.random.default_rng(1)
    F = rng.uniform(0, 1.2, (80, 2))
    feasible = rng.uniform(size=80) > 0.2
    ref = reference_point(2)
    c = hypervolume_curve(F, feasible, ref)
    assert (np.diff(c) >= 0).all()
    for i in (1, 10, 37, 80):
        inside = feasible[:i] & (F[:i] < ref).all(axis=1)
        want = HV(ref_point=ref)(F[:i][inside]) if inside.any() else 0.0
        assert c[i - 1] == pytest.approx(want, abs=1e-12)
    # three objectives: exact at the checkpoints, never above the exact prefix value
    G = rng.uniform(0, 1.2, (50, 3))
    ok = np.ones(50, bool)
    r3 = reference_point(3)
    c3 = hypervolume_curve(G, ok, r3, checkpoints=8)
    assert c3[-1] == pytest.approx(hypervolume(G, r3))
    for i in (5, 20, 50):
        assert c3[i - 1] <= hypervolume(G[:i], r3) + 1e-12


# ------------------------------------------------------------------------ IGD
def test_igd_of_the_zdt1_front_to_itself_is_zero_and_to_a_shift_the_distance():
    R = KNOWN_FRONTS["ZDT1"].sample(1001)
    assert igd(R, R) == 0.0
    # a straight front shifted along its normal by d: every nearest point is at d
    t = np.linspace(0, 1, 501)
    line = np.c_[t, 1 - t]
    d = 0.05
    assert igd(line + d / np.sqrt(2), line) == pytest.approx(d, abs=1e-12)
    # ZDT1 shifted up by d: the distance to the shifted curve, found by a numerical
    # minimisation per reference point (independent of the k-d tree and the sampling)
    from scipy.optimize import minimize_scalar

    ref_pts = KNOWN_FRONTS["ZDT1"].sample(101)

    def dist(p):
        def f(s):
            return np.hypot(s - p[0], 1 - np.sqrt(s) + d - p[1])

        return min(
            minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": 1e-12}).fun
            for lo, hi in ((0, 0.01), (0.0, 1.0), (max(0, p[0] - 0.1), min(1, p[0] + 0.1)))
        )

    want = np.mean([dist(p) for p in ref_pts])
    shifted = KNOWN_FRONTS["ZDT1"].sample(200001) + np.array([0.0, d])
    assert igd(shifted, ref_pts) == pytest.approx(want, abs=2e-5)
    assert want < d  # a curved front comes closer than the shift itself
    assert igd(np.zeros((0, 2)), R) == np.inf


# ------------------------------------------------------------- best-so-far
def test_median_best_so_far_never_rises_where_a_nan_median_does():
    # the reported bug: one run has no feasible value for 50 evaluations, then a poor one
    good = np.full(100, 1.0)
    late = np.r_[np.full(50, np.inf), np.full(50, 100.0)]
    M = curve_matrix([good, late])
    old = np.nanmedian(np.where(np.isfinite(M), M, np.nan), axis=0)  # what compare did
    assert old[50] > old[49]  # 50.5 after 1.0: the curve rose
    med = curve_quantiles(M)[0.5]
    assert np.isinf(med[49]) and med[50] == 50.5
    assert (np.diff(med[np.isfinite(med)]) <= 0).all()
    # any set of non-increasing curves: every quantile is non-increasing
    rng = np.random.default_rng(2)
    curves = []
    for _ in range(7):
        v = rng.lognormal(size=200)
        v[: rng.integers(0, 60)] = np.inf
        curves.append(as_curve(v))
    Q = curve_quantiles(curve_matrix(curves))
    for q in Q.values():
        assert not np.isnan(q).any()
        fin = np.isfinite(q)
        assert (np.diff(q[fin]) <= 0).all()
        assert fin[np.argmax(fin) :].all()  # once finite, stays finite


def test_quantile_matches_numpy_on_finite_data_and_counts_inf_as_worst():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(9, 4))
    for q in (0, 0.25, 0.5, 0.75, 1):
        np.testing.assert_allclose(quantile_inf(a, q, axis=0), np.quantile(a, q, axis=0))
    assert quantile_inf(np.array([1.0, 2.0, np.inf, np.inf]), 0.5) == np.inf
    assert quantile_inf(np.array([1.0, 2.0, 3.0, np.inf]), 0.5) == 2.5


def test_curve_matrix_keeps_the_final_value_of_a_run_that_stopped():
    M = curve_matrix([np.array([3.0, 2.0]), np.array([5.0, 4.0, 1.0])], 4)
    np.testing.assert_array_equal(M, [[3, 2, 2, 2], [5, 4, 1, 1]])
    rows = fixed_budget(M, [1, 4])
    assert rows[0]["median"] == 4.0 and rows[1]["min"] == 1.0 and rows[1]["n_with_value"] == 2
    with pytest.raises(ValidationError, match=r"lie in \[1, 4\]"):
        fixed_budget(M, [5])


# --------------------------------------------------------------- fixed target
def test_runtimes_are_first_hitting_evaluations():
    c = as_curve([None, 5, 6, 3, 1])  # 6 is not an improvement: best stays 5
    np.testing.assert_array_equal(runtimes(c, np.array([5, 4, 1, 0.5])), [2, 4, 5, np.inf])


def test_ert_by_hand():
    rt = np.array([[10, np.inf, np.inf], [np.inf, np.inf, np.inf], [30, 50, np.inf]])
    e = ert(rt, [100, 100, 80])
    # target 0: (10 + 100 + 30) / 2; target 1: (100 + 100 + 50) / 1; target 2: never
    np.testing.assert_array_equal(e, [70.0, 250.0, np.inf])


def test_runtime_ecdf_steps():
    rt = np.array([[1, 3], [np.inf, 3]])
    np.testing.assert_array_equal(
        runtime_ecdf(rt, np.array([0, 1, 2, 3, 1e9])), [0, 0.25, 0.25, 0.75, 0.75]
    )
    # area over log10 evaluations 1..100: pairs at 1 (area 1) and at 10 (area 1/2), a miss
    assert ecdf_area(np.array([1.0, 10.0, np.inf]), 100) == pytest.approx((1 + 0.5) / 3)


def test_targets_log_spaced_from_worst_to_best_final():
    np.testing.assert_allclose(
        make_targets([1e-2, 1e-6, None], f_opt=0.0, n_targets=5), [1e-2, 1e-3, 1e-4, 1e-5, 1e-6]
    )
    np.testing.assert_allclose(
        make_targets([11.0, 10.001], f_opt=10.0, n_targets=4), [11, 10.1, 10.01, 10.001]
    )
    np.testing.assert_allclose(make_targets([100.0, 1.0], n_targets=3), [100, 10, 1])
    np.testing.assert_allclose(make_targets([2.0, -2.0], n_targets=3), [2, 0, -2])
    assert make_targets([np.inf, None]).size == 0
    # the ends are the finals exactly: the best run reaches the hardest target it defines
    finals = [0.086298079084, 0.059114615191408815, 0.1149912761602]
    for f_opt in (None, 0.0):
        t = make_targets(finals, f_opt=f_opt)
        assert t[0] == max(finals) and t[-1] == min(finals)


# ------------------------------------------------------- performance profile
def test_performance_profile_of_a_2x2_table_by_hand():
    # instance 1: A 1, B 2 -> ratios 1, 2; instance 2: A 4, B 2 -> 2, 1
    taus, rho, R = performance_profile(np.array([[1.0, 2.0], [4.0, 2.0]]))
    np.testing.assert_array_equal(R, [[1, 2], [2, 1]])
    np.testing.assert_array_equal(taus, [1, 2])
    np.testing.assert_array_equal(rho, [[0.5, 1.0], [0.5, 1.0]])
    # a failure never counts: A solves both, B only the second, 3 times slower there
    taus, rho, _ = performance_profile(np.array([[1.0, np.inf], [3.0, 1.0]]), np.array([1, 2, 3]))
    np.testing.assert_array_equal(rho, [[0.5, 0.5, 1.0], [0.5, 0.5, 0.5]])


# --------------------------------------------------------------- rank tests
def test_mann_whitney_exact_p_matches_the_table_and_holm_by_hand():
    res = rank_tests({"a": [1, 2, 3], "b": [4, 5, 6]})
    pair = res["pairs"][0]
    assert pair["p"] == pytest.approx(2 / comb(6, 3))  # 0.1: complete separation, n = 3, 3
    assert "not separable with 3 and 3 seeds" in pair["verdict"]
    assert pair["a12"] == 1.0
    res = rank_tests({"a": [1, 2, 3, 4, 5], "b": [6, 7, 8, 9, 10]})
    assert res["pairs"][0]["p"] == pytest.approx(2 / 252)  # textbook value 0.0079
    assert res["pairs"][0]["verdict"].startswith("a better")
    assert min_two_sided_p(3, 3) == pytest.approx(0.1)
    np.testing.assert_allclose(holm([0.01, 0.04, 0.03]), [0.03, 0.06, 0.06])


def test_friedman_by_hand():
    # three seeds, A always best, C always worst: rank sums 3, 6, 9,
    # chi2 = 12 / (n k (k + 1)) * sum R^2 - 3 n (k + 1) = 6; p = exp(-6 / 2) (2 d.o.f.)
    res = rank_tests(
        {"A": [1, 2, 3], "B": [4, 5, 6], "C": [7, 8, 9]},
        seeds={"A": [1, 2, 3], "B": [1, 2, 3], "C": [1, 2, 3]},
    )
    assert res["friedman"]["statistic"] == pytest.approx(6.0)
    assert res["friedman"]["p"] == pytest.approx(exp(-3))
    assert len(res["pairs"]) == 3 and "Holm" in res["correction"]
    skipped = rank_tests(
        {"A": [1, 2], "B": [3, 4], "C": [5, 6]}, seeds={"A": [1, 2], "B": [1, 2], "C": [1, 3]}
    )
    assert "skipped" in skipped["friedman"]


def test_runs_without_a_feasible_value_rank_last():
    res = rank_tests({"a": [None, np.nan, np.inf, np.inf, np.inf], "b": [1, 2, 3, 4, 5]})
    assert res["pairs"][0]["a12"] == 0.0 and res["pairs"][0]["verdict"].startswith("b better")


# ---------------------------------------------------------------- IOH lines
def test_ioh_dat_lines_are_improvements_and_the_last_evaluation():
    # a run starts at evaluation 1 (IOHprofiler's readers split runs there), inf if infeasible
    assert dat_lines(as_curve([None, 4, 4, 2, 2, 2])) == ["1 inf", "2 4.0", "4 2.0", "6 2.0"]
    assert dat_lines(as_curve([3, 1])) == ["1 3.0", "2 1.0"]
    # full precision: a tiny improvement is still an improvement after parsing
    lines = dat_lines(as_curve([0.1, 0.1 - 1e-15]))
    assert float(lines[1].split()[1]) < float(lines[0].split()[1])
    assert dat_lines(as_curve([None, None])) == []


def test_analysis_imports_neither_pandas_nor_matplotlib():
    code = (
        "import sys, suspenv.analysis, suspenv.analysis.compare, suspenv.analysis.ioh; "
        "print(sorted(m for m in ('pandas', 'matplotlib', 'xarray') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
