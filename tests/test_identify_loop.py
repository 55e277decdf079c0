"""The identification's loop (suspenv.methods.curves.model_loop): fitted effect parameters in
the whole-curve model, the place screen, the held-out test, the sheet's interval."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.methods.curves.curve_fit import CurveModel
from suspenv.methods.curves.identify import (
    build_model,
    measure_test_car,
    resolve_vehicle,
    split_held_out,
)
from suspenv.methods.curves.model_loop import _candidate_fit
from suspenv.rigs.knc_axle import effect_parameters


@pytest.fixture(scope="module")
def test_car():
    return measure_test_car(0)


def _two_sided_truth_model(m, truth, effects=(), effect_free=()):
    v = resolve_vehicle(None)
    base = build_model(m, v, truth.mean_design, None, True)
    return base.variant(
        base=np.r_[truth.left, truth.right], free=None, effects=effects, effect_free=effect_free
    )


def test_the_test_car_itself_fits_every_curve_to_its_noise(test_car):
    """Reference: the truth (both sides, its own hysteresis as a fitted effect
    parameter at its value) leaves only the sensor noise, so every curve's RMS / noise
    is about 1 (1.5 holds with margin for 61 x 2 samples per curve). Before the loop's
    start sample was read from the path's first state, the wheel load was 3 x noise
    here: a hysteretic axle's virgin state differs from its state after a cycle."""
    m, truth = test_car
    (eff,) = truth.effects
    (p,) = [q for q in effect_parameters(eff) if q.name.endswith(".f_c")]
    model = _two_sided_truth_model(m, truth, (eff,), (p,))
    assert model.width == 99 and model.sub.names[-1] == f"{eff.name}.f_c"
    x = model.full(np.r_[truth.left, truth.right])[0]
    assert x[-1] == pytest.approx(80.0)  # the effect's own value fills the column
    R, ok, _ = model.residuals_x(x[None])
    assert ok[0]
    rms = model.block_rms(R[0])
    assert max(rms.values()) < 1.5, rms


def test_rows_with_other_effect_values_are_solved_apart(test_car):
    """Two rows with different hysteresis levels in one batch give each row's own
    answer (reference: each row alone)."""
    m, truth = test_car
    (eff,) = truth.effects
    (p,) = [q for q in effect_parameters(eff) if q.name.endswith(".f_c")]
    model = _two_sided_truth_model(m, truth, (eff,), (p,))
    x = model.full(np.r_[truth.left, truth.right])[0]
    X = np.vstack([x, x])
    X[1, -1] = 20.0
    R, ok, _ = model.residuals_x(X)
    R1, _, _ = model.residuals_x(X[1:])
    np.testing.assert_allclose(R[1], R1[0], rtol=0, atol=1e-9)
    assert np.abs(R[0] - R[1]).max() > 1.0  # the loop's width differs


def test_the_place_screen_prefers_the_hysteresis_over_strut_friction(test_car):
    """At the test car's own design, Dahl hysteresis at the diagnosis' default place
    (lower-arm bushes and top mount, where the car has it) costs far less than strut
    friction, and its level comes out near the car's 80 N (the quadratic through three
    rig calls is a model of the loop's growth, so 25 %)."""
    m, truth = test_car
    model = _two_sided_truth_model(m, truth)
    x = model.base
    r0 = model.residuals_x(x[None])[0][0]
    dahl, _ = _candidate_fit(model, x, r0, "loop", "dahl_hysteresis")
    strut, _ = _candidate_fit(model, x, r0, "loop", "coulomb_friction")
    assert dahl.cost < 0.5 * strut.cost
    assert dahl.values["f_c"] == pytest.approx(80.0, rel=0.25)
    assert dahl.cost < 1.3 * model.size  # near the noise floor: chi2 about N


def test_a_held_out_test_is_taken_out_of_the_fit(test_car):
    m, truth = test_car
    rest, held, source = split_held_out(m, "single", None)
    assert "single" not in rest.tests and list(held.tests) == ["single"]
    assert source.startswith("measured")
    rest, held, source = split_held_out(m, "lateral", truth)  # the test car measures it
    assert rest is m and list(held.tests) == ["lateral"]
    with pytest.raises(ValidationError, match="held_out"):
        split_held_out(m, "lateral", None)
    one = dataclasses.replace(m, tests={"parallel": m.tests["parallel"]})
    with pytest.raises(ValidationError, match="no test to fit"):
        split_held_out(one, "parallel", None)


@pytest.mark.slow
def test_the_delta_method_interval_matches_a_parametric_bootstrap(test_car):
    """Reference: a parametric bootstrap. Four parameters free (noise-only test car), the
    sheet's delta-method standard error of bump steer and camber gain against the
    spread of the same metrics over 24 refits to the fitted model's curves with fresh
    noise (the spread's own sampling error with 24 draws is about 15 %: 35 %)."""
    from suspenv.methods.curves.identifiability import unit_covariance
    from suspenv.methods.curves.knc_sheet import Z95, knc_sheet
    from suspenv.rigs.knc_fit import polish

    m, truth = measure_test_car(0, ("noise",))
    free = ["static_toe", "static_camber", "tie_rod_inner_z", "top_mount_kz"]
    model = build_model(m, resolve_vehicle(None), truth.mean_design, free)
    u0 = model.unit(truth.mean_design)
    stage, r, J = polish(model, u0, 60)
    fit = _fit_of(model, stage, r, J)
    cov = unit_covariance(J, max(1.0, float(r @ r) / (r.size - J.shape[1])))
    rows = {row.name: row for row in knc_sheet(fit, cov)}
    names = ("bump_steer", "camber_gain")
    se = {n: rows[n].half_width[0] / Z95 for n in names}
    # symmetry: a one-sided model's sides are equal, so is every error the fit allows
    # (the two wheels' forward differences agree to the solver's tolerance, 1e-6 m and
    # 1e-5 rad over a step of 1e-4: a thousandth of the interval at most)
    for row in rows.values():
        d = row.to_dict()
        assert abs(d["asymmetry"]) <= 1e-9 * (1 + abs(row.identified[0]))
        if np.isfinite(row.half_width[0]):  # loop widths get no interval
            assert d["asymmetry_ci95_half_width"] <= 1e-3 * row.half_width[0] + 1e-8
    # bootstrap: the fitted model's curves plus fresh noise, refitted
    clean = model.predict(model.simulate(fit.x[None])[0])[0]
    rng = np.random.default_rng(7)
    values = {n: [] for n in names}
    for _ in range(24):
        boot = CurveModel.__new__(CurveModel)
        boot.__dict__.update(model.__dict__)
        boot.measured = clean + rng.normal(size=clean.size)
        st, rb, Jb = polish(boot, stage.u, 40)
        sheet = {row.name: row for row in knc_sheet(_fit_of(boot, st, rb, Jb), cov)}
        for n in names:
            values[n].append(sheet[n].identified[0])
    for n in names:
        assert np.std(values[n], ddof=1) == pytest.approx(se[n], rel=0.35), (n, values[n])


def _fit_of(model, stage, r, J):
    from suspenv.methods.curves.curve_fit import CurveFit

    return CurveFit(model, stage.u, model.designs(stage.u[None])[0], r, J, [stage], stage)


@pytest.mark.slow
def test_the_job_follows_its_screen_and_reports_before_and_after(test_car, tmp_path):
    """End to end on the test car with a few parameters free: the screen names the
    sides and the loop, the loop adds them, the fit improves, the held-out test is
    predicted, the report opens with before -> after and the sheet, and identified.toml
    is a vehicle file with the sides and the fitted effect."""
    import json

    from suspenv.methods.curves.identify import run_identify, write_outputs
    from suspenv.models.mcpherson.vehicle_file import load_vehicle

    m, truth = test_car
    free = ["static_toe", "static_camber", "tie_rod_inner_z", "top_mount_kz"]
    opts = {
        "free": free,
        "global_evaluations": 0,
        "next_test": False,
        "held_out": "lateral",
        "polish_nfev": 40,
        "loop_nfev": 8,
        "workers": 1,
    }
    res = run_identify(m, resolve_vehicle(None), opts, truth=truth, x0=truth.mean_design)
    assert res.loop is not None and res.held_out is not None
    assert res.loop.model.two_sided and res.loop.model.effect_free
    assert res.loop.fit.cost < 0.5 * res.fit.cost
    # the held-out test is judged by its worst channel: the camber of the sides apart
    # (the first fit's one design gives both wheels the mean camber, 21 x noise)
    before, after = res.held_out.before, res.held_out.after
    assert max(after.values()) < 0.5 * max(before.values())
    assert after["camber"] < 0.2 * before["camber"]
    files = write_outputs(res, tmp_path, figures=True)
    assert {"curves.png", "residual.png"} <= {f.name for f in files}
    text = (tmp_path / "report.md").read_text()
    head = text.split("## K&C sheet")[0]
    assert "before -> after the loop" in head and "Held-out test" in head
    assert text.index("## K&C sheet") < text.index("## Before and after the loop")
    s = json.loads((tmp_path / "identify.json").read_text())
    assert s["loop"]["curves_within_1_5_noise_after"] >= s["loop"]["curves_within_1_5_noise_before"]
    v = load_vehicle(tmp_path / "identified.toml")
    assert not np.allclose(v.left, v.right) and v.effects


def test_the_cluster_sandwich_of_a_mean_is_the_spread_between_clusters():
    """Reference: closed form. For a mean (J = ones) the sandwich variance is
    ``sum_c (sum_i r_ci)^2 / N^2``; with one row per cluster it is White's
    ``sum r_i^2 / N^2``. Curves that share an offset (a misfit correlated along each
    curve) widen it far beyond ``(J'J)^-1 = 1 / N``."""
    from suspenv.methods.curves.identifiability import sandwich_covariance

    rng = np.random.default_rng(3)
    N, n_c = 400, 8
    clusters = np.array_split(np.arange(N), n_c)
    shift = np.repeat(rng.normal(0.0, 3.0, n_c), N // n_c)
    r = rng.normal(size=N) + shift
    r -= r.mean()  # the residual at the fitted mean
    J = np.ones((N, 1))
    want = sum(r[c].sum() ** 2 for c in clusters) / N**2
    got = sandwich_covariance(J, r, clusters)[0, 0]
    assert got == pytest.approx(want, rel=1e-12)
    assert got > 10.0 / N  # the shared offsets: far wider than the noise's 1 / N
    single = [np.array([i]) for i in range(N)]
    assert sandwich_covariance(J, r, single)[0, 0] == pytest.approx((r**2).sum() / N**2)


def test_the_held_out_test_is_the_one_the_others_determine_best():
    """Reference: closed form, ``C = (J'J + I)^-1`` (the polish's unit pull). Test ``a``
    sees value 1 (4 samples), ``b`` value 2 and value 1 (a channel each), ``c`` (not
    measured) both at 3 x. Leaving ``a`` out, ``C = diag(1/5, 1/5)``: sd ``sqrt(1/5)``;
    leaving ``b`` out, value 2 is known to its prior only: sd 1 (worst channel); ``c``
    from both, ``C = diag(1/9, 1/5)``: ``sqrt(9/9 + 9/5)``."""
    from suspenv.methods.curves.identify import choose_held_out

    one, two = np.tile([1.0, 0.0], (4, 1)), np.tile([0.0, 1.0], (4, 1))
    blocks = {
        "a": {"toe": one},
        "b": {"toe": two, "camber": one},
        "c": {"toe": np.tile([3.0, 3.0], (4, 1))},
    }
    test, scores = choose_held_out(blocks, ["a", "b"], ["a", "b", "c"])
    assert test == "a"
    assert scores == pytest.approx({"a": np.sqrt(0.2), "b": 1.0, "c": np.sqrt(2.8)})
    test, scores = choose_held_out(blocks, ["a", "b"], ["c"])
    assert test == "c" and list(scores) == ["c"]
    with pytest.raises(ValidationError, match="held_out"):
        choose_held_out({"a": {"toe": one}}, ["a"], ["a"])


def test_the_place_cost_with_the_design_free_is_the_least_squares_minimum():
    """Reference: the regularised least-squares problem solved directly (numpy lstsq
    on ``[J; w I] d = [-r; 0]``)."""
    from suspenv.methods.curves.model_loop import _free_cost
    from suspenv.rigs.knc_fit import PRIOR_WEIGHT

    rng = np.random.default_rng(5)
    J = rng.normal(size=(60, 4))
    R = rng.normal(size=(3, 60))
    got = _free_cost(R, J)
    A = np.vstack([J, PRIOR_WEIGHT * np.eye(4)])
    for k in range(3):
        b = np.r_[-R[k], np.zeros(4)]
        d = np.linalg.lstsq(A, b, rcond=None)[0]
        want = np.sum((A @ d - b) ** 2)
        assert got[k] == pytest.approx(want, rel=1e-10)
    assert np.allclose(_free_cost(R, None), (R**2).sum(axis=1))


def test_steering_constants_are_fitted_values_when_the_aligning_test_is_measured():
    """The steering system's rates become fitted values ``constants.<name>`` with the
    aligning test; rows with other rates are solved apart (reference: each row alone)
    and the rack's compliance moves the aligning test's toe (reference: the rigid
    direction of the change, a softer rack steers more under the same moment)."""
    from suspenv.methods.curves.identify import fitted_constants

    m, truth = measure_test_car(0, ("noise",), tests=("parallel", "aligning"), steps=12)
    v = resolve_vehicle(None)
    names = [p.name for p in fitted_constants(v, m.tests)]
    assert names == ["constants.rack_mount_rate", "constants.column_torsion_rate"]
    assert fitted_constants(v, ["parallel"]) == []
    model = build_model(m, v, truth.mean_design)
    assert list(model.sub.names[-2:]) == names
    x = model.full(truth.mean_design)[0]
    assert model.constants_at(x) == v.constants
    X = np.vstack([x, x])
    X[1, -1] *= 0.25  # a softer column
    assert model.constants_at(X[1]).column_torsion_rate == pytest.approx(
        0.25 * v.constants.column_torsion_rate
    )
    R, ok, _ = model.residuals_x(X)
    R1, _, _ = model.residuals_x(X[1:])
    assert ok.all()
    np.testing.assert_allclose(R[1], R1[0], rtol=0, atol=1e-9)
    # the sides apart: one steering system, so no right twin of a constant
    two = model.variant(two_sided=True, base=x)
    assert list(two.sub.names[-2:]) == names and two.dim == 2 * 49 - 1 + 2
    assert two.constants_at(two.base) == v.constants
    res = model.run(X, ("aligning",), 12, (), {})["aligning"]
    span = np.ptp(res.channels["toe"], axis=1)  # (2, 2): rows x wheels
    assert np.all(span[1] > span[0])


def test_auto_held_out_ranges_over_the_measured_tests_too(test_car):
    """The choice is among the measured tests (and, on the test car, those it can be
    measured in): ``single`` (one wheel) is the sum of ``parallel`` and ``opposite``
    for a linear axle, which the others determine best (reference: superposition);
    the compliance tests are barely seen by travel tests."""
    from suspenv.methods.curves.identify import auto_held_out

    m, truth = test_car
    v = resolve_vehicle(None)
    test, scores = auto_held_out(m, v, truth.mean_design, None)
    assert set(scores) == {"parallel", "opposite", "single"}
    assert test == "single"
    test, scores = auto_held_out(m, v, truth.mean_design, truth)
    assert test == "single" and set(m.tests) < set(scores)
    assert min(scores[t] for t in set(scores) - set(m.tests)) > scores["single"]


def test_the_loops_partition_the_residual_by_test_and_wheel(test_car):
    """Definition: every residual row in exactly one loop, one loop per test and wheel,
    a loop's rows all of one wheel (samples (P, 2) flattened: even rows left)."""
    m, truth = test_car
    model = build_model(m, resolve_vehicle(None), truth.mean_design)
    loops = model.loops()
    assert len(loops) == 2 * len(model.tests)
    rows = np.sort(np.concatenate(loops))
    np.testing.assert_array_equal(rows, np.arange(model.size))
    for rows in loops:  # one wheel: the same parity within each block
        start = [next(s.start for _, _, s in model.blocks if s.start <= r < s.stop) for r in rows]
        assert len(set((rows - np.array(start)) % 2)) == 1


def test_near_tied_places_are_those_the_bic_does_not_tell_apart():
    """Reference: Kass & Raftery's first step, a BIC difference (cost + k ln n) below 2.
    With n = e^2 one added value costs 2 exactly, so the differences are set by hand."""
    from suspenv.methods.curves.model_loop import BIC_TIE, MAX_TIED, bic, near_ties

    n = int(round(np.exp(2.0)))  # 7: ln n = 1.95
    assert bic(10.0, 2, n) == pytest.approx(10.0 + 2 * np.log(7))
    # screened costs of four one-value places: 100 best, 101.9 tied, 102.1 and 150 not
    assert near_ties([101.9, 150.0, 100.0, 102.1], [1, 1, 1, 1], n) == [2, 0]
    # a place with one value more pays ln n: 100.5 + ln 7 is more than 2 above 100
    assert near_ties([100.0, 100.5], [1, 2], n) == [0]
    # a place with one value fewer gains ln n: 101.5 - ln 7 is below 100, so it leads
    assert near_ties([100.0, 101.5], [2, 1], n) == [1, 0]
    # exact ties are kept in screen order, at most MAX_TIED of them
    assert near_ties([5.0] * 5, [1] * 5, n) == list(range(MAX_TIED))
    assert BIC_TIE == 2.0
    # the screen's measured errors widen the tie: 100 +- 30 and 150 +- 25 overlap,
    # 100 +- 30 and 200 +- 5 do not
    assert near_ties([100.0, 150.0, 200.0], [1, 1, 1], n, [30.0, 25.0, 5.0]) == [0, 1]


def test_tie_options_swap_one_family_place_at_a_time():
    """Every family's best place first, then each near-tied place in its family's slot,
    the other families at their best; at most MAX_TIED sets."""
    from suspenv.methods.curves.model_loop import MAX_TIED, tie_options

    ties = [["loop_a", "loop_b"], ["prog_a", "prog_b", "prog_c"]]
    got = tie_options(ties)
    assert got[0] == ["loop_a", "prog_a"]
    assert got[1] == ["loop_b", "prog_a"]
    assert got[2] == ["loop_a", "prog_b"]
    assert len(got) == MAX_TIED == 3
    assert tie_options([["only"]]) == [["only"]]


def test_the_fits_valleys_are_its_polished_answers_the_answer_first():
    """Definition: every polish stage's answer once, the fit's own answer first, the
    global stage's best point not among them (it is not a polished valley)."""
    from suspenv.methods.curves.curve_fit import CurveFit
    from suspenv.rigs.knc_fit import StageResult

    a, b, g = np.full(3, 0.2), np.full(3, 0.7), np.full(3, 0.5)
    stages = [
        StageResult("global (CMA-ES)", g, 9.0, 10, "", 0.0),
        StageResult("polish from the CMA-ES best", b, 2.0, 10, "", 0.0),
        StageResult("polish from the start design", a.copy(), 1.0, 10, "", 0.0),
    ]
    fit = CurveFit(None, a, a, np.zeros(1), np.zeros((1, 3)), stages)  # type: ignore[arg-type]
    got = fit.valleys
    assert got[0] is a
    assert len(got) == 2 and np.array_equal(got[1], b)


def test_the_secant_update_reproduces_the_step_and_keeps_a_linear_jacobian():
    """Definition (Broyden's update): the updated Jacobian maps the step to the residual
    change; for a linear residual the exact Jacobian is left as it is (to rounding)."""
    from suspenv.rigs.knc_fit import secant_update

    rng = np.random.default_rng(3)
    A = rng.normal(size=(7, 3))
    u, u2 = rng.random(3), rng.random(3)
    J2 = secant_update(u, A @ u, A, u2, A @ u2)
    np.testing.assert_allclose(J2, A, atol=1e-12)
    r, r2, J = rng.normal(size=7), rng.normal(size=7), rng.normal(size=(7, 3))
    np.testing.assert_allclose(secant_update(u, r, J, u2, r2) @ (u2 - u), r2 - r, atol=1e-12)


class _Valley:
    """A curved valley, r = (10 (u1 - u0^2), 1 - u0, noise-free), minimum at u = (1, 1)
    with zero cost (closed form); forward differences as CurveModel.jacobian."""

    dim, size = 2, 2

    def __init__(self):
        self.jacobians = 0

    @staticmethod
    def _r(u):
        return np.array([10.0 * (u[1] - u[0] ** 2), 1.0 - u[0]])

    def residuals(self, U):
        return np.array([self._r(u) for u in U]), np.ones(len(U), bool), [""] * len(U)

    def jacobian(self, u, step=1e-7):
        self.jacobians += 1
        r = self._r(u)
        return r, np.column_stack([(self._r(u + step * e) - r) / step for e in np.eye(2)])


def test_the_secant_polish_reaches_the_minimum_with_fewer_differenced_jacobians():
    """Reference: the valley's closed-form minimum u = (1, 1) (cost 0). The secant runs
    reach it as the differenced ones do, with fewer differenced Jacobians, and the
    Jacobian returned is the differenced one at the answer."""
    from suspenv.rigs.knc_fit import polish

    got = {}
    for broyden in (False, True):
        model = _Valley()
        stage, r, J = polish(
            model, np.array([0.2, 0.9]), 200, 50, 1e-12, ftol=1e-12, broyden=broyden
        )
        np.testing.assert_allclose(stage.u, [1.0, 1.0], atol=1e-4)
        np.testing.assert_array_equal(J, model.jacobian(stage.u)[1])
        got[broyden] = model.jacobians - 1
    assert got[True] < got[False], got


def test_places_refitted_side_by_side_give_the_numbers_of_one_after_the_other():
    """The near-tied places' refits (secant steps) share the two processes: the answers
    are those of the refits one after the other, bit for bit, and each reaches the
    minimum the differenced least squares reaches from the same start (reference: that
    second solver; the stopping rule's own tolerance, one squared noise unit)."""
    from suspenv.methods.curves.model_loop import _refits, _start
    from suspenv.rigs.knc_fit import RESTART_GAIN, polish
    from suspenv.runs.executors import ProcessPool

    m, truth = measure_test_car(0, ("noise",))
    x0 = truth.mean_design.copy()
    v = resolve_vehicle(None)
    x0[v.space().index("static_toe")] += 0.05
    x0[v.space().index("tie_rod_inner_z")] += 2.0
    frees = (["static_toe", "tie_rod_inner_z"], ["static_toe", "static_camber"])
    models = [build_model(m, v, x0, free, False) for free in frees]
    alone = _refits(models, x0, 60, None, False)
    with ProcessPool(1) as pool:
        shared = _refits(models, x0, 60, pool, False)
    for a, b, model in zip(alone, shared, models, strict=True):
        np.testing.assert_array_equal(a.u, b.u)
        assert a.cost == b.cost and a.final.stop.startswith("converged")
        ref, _, _ = polish(model, model.unit(x0), 60, prior=model.unit(_start(model, x0)))
        assert abs(a.cost - ref.cost) < RESTART_GAIN, (a.cost, ref.cost)
