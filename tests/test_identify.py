"""``suspenv identify``: whole-curve fit, identifiability, the job, its files and CLI.

Fast tests use the built-in test car with a few free parameters; the full targets on
all 49 parameters are ``@pytest.mark.slow`` (about two minutes each).
"""

from __future__ import annotations

import json
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from suspenv.cli.main import main
from suspenv.core.errors import ValidationError
from suspenv.core.space import DesignSpace, Parameter
from suspenv.measurements.knc import branch_index
from suspenv.methods.curves.curve_fit import CurveModel, MeasuredCurves, measured_curves
from suspenv.methods.curves.identifiability import (
    K_SIGMA,
    TOLERANCE_PCT,
    assess,
    rank_tests,
    unit_covariance,
)
from suspenv.methods.curves.identify import (
    build_model,
    check_identify_config,
    measure_test_car,
    resolve_vehicle,
    run_identify,
    write_outputs,
)
from suspenv.models.mcpherson.params import design_space
from suspenv.rigs.knc import KCResult, loop_path
from suspenv.rigs.knc_fit import fit_space

FEW = ["static_toe", "static_camber", "tie_rod_inner_z", "top_mount_kz"]


@pytest.fixture(scope="module")
def noisy_car():
    return measure_test_car(0, ["noise"])


def _space(n: int) -> DesignSpace:
    return DesignSpace(Parameter(f"p{i}", 0.0, 1.0, "mm") for i in range(n))


# ------------------------------------------------------------------ curve_fit
def test_fit_space_puts_stiffnesses_on_a_log_scale():
    sp = fit_space(design_space())
    logs = {p.name for p in sp.parameters if p.log}
    assert "top_mount_kz" in logs and "arb_torsion" in logs and "lca_rear_rz" in logs
    assert "strut_top_z" not in logs and "static_toe" not in logs
    # the middle of the unit interval is the geometric mean of the bounds
    i = sp.index("top_mount_kz")
    mid = sp.to_physical(np.full((1, sp.dim), 0.5))[0, i]
    assert mid == pytest.approx(np.sqrt(sp.lower[i] * sp.upper[i]))


def _linear_loop(steps: int = 8, amp: float = 0.04) -> KCResult:
    """A fake rig result whose toe is 2 g on the descending branch and 2 g + 1 on the
    ascending one (g the grid value), left and right equal. The turning points (+-amp)
    are samples of the ascending branch (as in a rig loop), so the two grid intervals
    next to them are not linear on the descending branch."""
    grid = np.linspace(-amp, amp, steps + 1)
    path = loop_path(steps)
    b = branch_index(steps)
    toe = 2 * grid[path] + np.where(b == 1, 0.0, 1.0)
    return KCResult(
        "parallel", grid, path, {"toe": np.stack([toe, toe], -1)[None]}, np.ones(1, bool), [""]
    )


def test_reading_a_loop_takes_each_branch_and_interpolates_linearly():
    res = _linear_loop()
    steps = res.grid.size - 1
    # measured samples on the grid: exactly the loop itself
    on = SimpleNamespace(
        test="parallel",
        drive=res.grid[res.path],
        branch=branch_index(steps).astype(int),
        channels={"toe": res.channels["toe"][0]},
    )
    td = measured_curves(on, steps)
    np.testing.assert_array_equal(td.read(res, "toe")[0], res.channels["toe"][0])
    # samples between grid points: linear in the drive on their own branch (closed form)
    d = np.array([0.0, 0.013, 0.027, -0.021, -0.029, 0.0031])
    br = np.array([0, 0, 1, 1, 1, 2])
    td2 = MeasuredCurves("parallel", d, br, {"toe": np.zeros((6, 2))}, 0.04, steps)
    want = 2 * d + np.where(br == 1, 0.0, 1.0)
    np.testing.assert_allclose(td2.read(res, "toe")[0, :, 0], want, rtol=0, atol=1e-12)


def test_residual_of_the_noise_free_truth_is_zero_and_the_jacobian_is_batch_independent():
    m, truth = measure_test_car(0, [])
    model = build_model(m, resolve_vehicle(None), truth.mean_design, FEW)
    u = model.unit(truth.mean_design)
    R, ok, _ = model.residuals(u[None])
    assert ok[0] and np.abs(R[0]).max() < 1e-3  # noise units: the data are the rig's own
    r, J = model.jacobian(u)
    # one column from two separate one-design evaluations (no batch)
    i, h = FEW.index("tie_rod_inner_z"), 1e-4
    up = u.copy()
    up[i] += h
    R1, _, _ = model.residuals(up[None])
    np.testing.assert_allclose(J[:, i], (R1[0] - r) / h, rtol=1e-6, atol=1e-3)
    assert np.linalg.norm(J[:, i]) > 100  # bump steer sees the tie-rod height


def test_a_model_needs_noise_levels_and_known_parameters(noisy_car):
    m, truth = noisy_car
    veh = resolve_vehicle(None)
    with pytest.raises(ValidationError, match="unknown parameter 'static_tow'"):
        build_model(m, veh, truth.mean_design, ["static_tow"])
    tests = [measured_curves(t) for t in m.tests.values()]
    with pytest.raises(ValidationError, match="noise level > 0"):
        CurveModel(tests, {}, veh.space(), truth.mean_design)


# ------------------------------------------------------------ identifiability
def test_covariance_is_the_inverse_normal_matrix_for_a_regular_jacobian():
    rng = np.random.default_rng(0)
    J = rng.normal(size=(50, 3))
    np.testing.assert_allclose(unit_covariance(J), np.linalg.inv(J.T @ J), rtol=1e-10)


def test_verdicts_identified_flat_and_correlated():
    """Closed-form Jacobian: p0 seen alone, p1 seen by nothing, p2 and p3 only as a sum."""
    n = 400
    J = np.zeros((n, 4))
    J[: n // 2, 0] = 1e3  # p0 moves the first half of the residuals
    J[n // 2 :, 2] = J[n // 2 :, 3] = 1e3  # p2 and p3 move the second half alike
    r = np.zeros(n)
    ident = assess(J, r, np.full(4, 0.5), _space(4))
    kinds = [v.kind for v in ident.verdicts]
    assert kinds == ["identified", "flat", "correlated", "correlated"]
    # p0: stderr = 1 / sqrt(n / 2 * 1e6) of the unit range
    assert ident.verdicts[0].stderr_pct == pytest.approx(100 / np.sqrt(n / 2 * 1e6))
    assert ident.verdicts[2].correlated_with[0][0] == "p3"
    assert ident.verdicts[2].correlated_with[0][1] == pytest.approx(-1.0, abs=1e-6)
    # the rule: K_SIGMA stderr within TOLERANCE_PCT of the range
    assert K_SIGMA * ident.verdicts[0].stderr_pct <= TOLERANCE_PCT


def test_rank_tests_names_the_test_that_sees_the_flat_parameter():
    n = 100
    J = np.zeros((n, 2))
    J[:, 0] = 1e3
    ident = assess(J, np.zeros(n), np.full(2, 0.5), _space(2))
    sees = np.zeros((n, 2))
    sees[:, 1] = 1e3
    blind = np.zeros((n, 2))
    blind[:, 0] = 1e3
    ranked = rank_tests(ident, J, {"blind": blind, "sees": sees}, np.full(2, 0.5), _space(2))
    assert [g.test for g in ranked] == ["sees", "blind"]
    assert ranked[0].newly_identified == ["p1"] and ranked[1].newly_identified == []


def test_a_soft_series_spring_is_not_called_identified_on_the_physical_scale_alone():
    """Log-scale stiffness near its lower bound: a small physical stderr but a long valley
    on the fit's scale (see the module docstring of identifiability)."""
    sp = DesignSpace([Parameter("k", 50.0, 50000.0, "N/mm", log=True)])
    J = np.full((100, 1), 2.0)  # stderr on the fit scale 0.05 of the unit interval
    ident = assess(J, np.zeros(100), np.array([0.01]), sp)
    v = ident.verdicts[0]
    assert v.stderr_pct < TOLERANCE_PCT / K_SIGMA  # physical scale alone would accept it
    assert not v.identified and v.stderr_unit_pct == pytest.approx(5.0)


# ------------------------------------------------------------------ the job
@pytest.fixture(scope="module")
def few_result(noisy_car):
    """Four parameters free, started 5 % of their ranges off the truth (the others at it)."""
    m, truth = noisy_car
    veh = resolve_vehicle(None)
    sp = veh.space()
    x0 = truth.mean_design.copy()
    for name in FEW:
        i = sp.index(name)
        x0[i] += 0.05 * (sp.upper[i] - sp.lower[i])
    # the rear lower-arm bush's x moves along the arm's axis: the travel tests barely see it
    opts = {"free": [*FEW, "lca_rear_bush_x"], "global_evaluations": 48, "popsize": 8}
    return run_identify(m, veh, opts, truth=truth, seed=3, x0=x0)


def test_the_polish_beside_the_global_stage_gives_the_same_numbers_in_one_process(
    noisy_car, few_result
):
    # few_result ran with the default workers = 2 (the start's polish in a second process)
    m, truth = noisy_car
    veh = resolve_vehicle(None)
    sp = veh.space()
    x0 = truth.mean_design.copy()
    for name in FEW:
        i = sp.index(name)
        x0[i] += 0.05 * (sp.upper[i] - sp.lower[i])
    opts = {
        "free": [*FEW, "lca_rear_bush_x"],
        "global_evaluations": 48,
        "popsize": 8,
        "workers": 1,
        "next_test": False,
        "rerun_next": False,
        "diagnose": False,
    }
    one = run_identify(m, veh, opts, truth=truth, seed=3, x0=x0)
    assert [s.name for s in one.fit.stages] == [s.name for s in few_result.fit.stages]
    assert [s.cost for s in one.fit.stages] == [s.cost for s in few_result.fit.stages]
    assert np.array_equal(one.fit.x, few_result.fit.x)


def test_few_free_parameters_meet_the_noise_floor_and_the_rule(few_result):
    res = few_result
    assert max(res.curve_rms().values()) <= 1.5
    assert max(res.curve_rms(res.initial_residual).values()) > 10  # the start was off
    assert res.fit.stages[0].name.startswith("global") and res.fit.converged
    # both starts are polished to convergence; the answer is the lower final cost
    polished = res.fit.stages[1:3]
    assert [s.name for s in polished] == [
        "polish from the CMA-ES best",
        "polish from the start design",
    ]
    assert res.fit.final.cost == min(s.cost for s in polished)
    for v in res.identifiability.verdicts:
        if v.identified:
            assert v.error_pct is not None and v.error_pct <= TOLERANCE_PCT, v.name
    assert res.identifiability.verdicts[FEW.index("static_toe")].identified


def test_two_sided_fit_gives_each_side_its_own_values(noisy_car, tmp_path):
    from suspenv.models.mcpherson.vehicle_file import load_vehicle

    m, truth = noisy_car
    veh = resolve_vehicle(None)
    opts = {"free": FEW, "sides": "both", "initial": "vehicle", "next_test": False}
    res = run_identify(m, veh, opts, truth=truth)
    assert res.model.dim == 2 * len(FEW) and res.fit.x.shape == (98,)
    assert res.model.sub.names[len(FEW)] == "static_toe@right"
    toe = {v.name: v for v in res.identifiability.verdicts if v.name.startswith("static_toe")}
    for v in toe.values():  # each side's toe on its own, within the rule of the truth
        assert v.identified and v.error_pct is not None and v.error_pct <= TOLERANCE_PCT
    write_outputs(res, tmp_path, figures=False)
    v = load_vehicle(tmp_path / "identified.toml")
    np.testing.assert_allclose(np.r_[v.left, v.right], res.fit.x, rtol=1e-12)
    assert max(res.curve_rms().values()) <= 1.5


def test_outputs_and_identified_vehicle_round_trip(tmp_path, few_result):
    from suspenv.models.mcpherson.vehicle_file import load_vehicle

    files = write_outputs(few_result, tmp_path, figures=True)
    names = {f.name for f in files}
    assert {"identified.toml", "identify.json", "report.md", "curves.png"} <= names
    v = load_vehicle(tmp_path / "identified.toml")
    np.testing.assert_allclose(v.left, few_result.fit.x, rtol=1e-12)
    s = json.loads((tmp_path / "identify.json").read_text())
    assert s["n_parameters"] == len(FEW) + 1 and s["n_curves"] == len(few_result.curve_rms())
    text = (tmp_path / "report.md").read_text()
    head = text.split("## Fit per curve")[0]
    for word in ("**Fit**", "**Identified**", "**Not identified**", "**Remaining residual**"):
        assert word in head


def test_data_warnings_are_on_the_first_screen(tmp_path, few_result):
    """A loader's warning (suspenv/measurements/knc_checks.py, e.g. a spike) is printed
    before the fit's lines, above the first table."""
    m = few_result.measurement
    warned = replace(m, meta={**m.meta, "warnings": ["toe_left at data row 8: a spike"]})
    write_outputs(replace(few_result, measurement=warned), tmp_path, figures=False)
    head = (tmp_path / "report.md").read_text().split("## Fit per curve")[0]
    assert "- **Data warning**: toe_left at data row 8: a spike" in head


def test_next_test_and_rerun_are_reported(few_result):
    res = few_result
    assert res.identifiability.not_identified() == ["lca_rear_bush_x"]
    assert res.identifiability.verdicts[-1].kind == "flat"
    from suspenv.measurements.knc import RIG_TESTS

    tested = {g.test for g in res.candidates}
    assert tested == set(RIG_TESTS) - set(res.measurement.tests)  # the opposed ones too
    assert res.rerun is not None and res.rerun.test == res.candidates[0].test


def test_residual_screen_names_the_hidden_hysteresis():
    """The symmetric linear model fitted to a car with bushing hysteresis: the loop
    signature must be named (the effect is the truth's, concealed from the fit)."""
    m, truth = measure_test_car(0, ["hysteresis", "noise"])
    opts = {
        "free": FEW,
        "global_evaluations": 0,
        "initial": "vehicle",
        "next_test": False,
        "polish_nfev": 20,
    }
    res = run_identify(m, resolve_vehicle(None), opts, truth=truth)
    assert res.diagnosis is not None
    assert "loop" in [n["family"] for n in res.diagnosis["named"]]


# ------------------------------------------------------------ config and CLI
def test_config_check_fills_defaults_and_refuses_bad_values():
    cfg = {"pipeline": "identify", "problem": {"name": "KCIdentification", "options": {}}}
    out = check_identify_config(cfg)
    assert out["identify"]["method"] == "curves" and out["identify"]["polish_nfev"] > 0
    with pytest.raises(ValidationError, match="unknown option 'budgt'"):
        check_identify_config({**cfg, "identify": {"budgt": 3}})
    with pytest.raises(ValidationError, match="`problem.name` must be 'KCIdentification'"):
        check_identify_config({**cfg, "problem": {"name": "Sphere"}})
    with pytest.raises(ValidationError, match="`0 < sigma0 <= 1`"):
        check_identify_config({**cfg, "identify": {"sigma0": 0.0}})


def test_kc_identification_reads_a_measurement_folder(tmp_path):
    from suspenv.measurements.knc_file import write_measurement
    from suspenv.problems.kc_identification import KCIdentification

    car = KCIdentification(concealed=["noise"])
    write_measurement(car.measurement, tmp_path / "car")
    measured = KCIdentification(measurements=str(tmp_path / "car"))
    assert measured.truth is None and measured.truth_design is None
    np.testing.assert_allclose(measured.targets, car.targets, rtol=1e-9, atol=1e-12)
    assert measured.config()["measurements"] == str(tmp_path / "car")
    assert "measurements" not in car.config()  # the test car's config is unchanged
    # the paper's method on the same measured targets, through the identify pipeline
    cfg = {
        "pipeline": "identify",
        "problem": {"name": "KCIdentification", "options": {"measurements": str(tmp_path / "car")}},
        "identify": {"method": "tey2014"},
    }
    checked = check_identify_config(cfg)
    assert checked["study"]["doe_samples"] == 500 and checked["identify"]["method"] == "tey2014"


def test_cli_refuses_a_non_empty_output_folder(tmp_path, capsys):
    (tmp_path / "keep.txt").write_text("x")
    assert main(["identify", "test-car", "--out", str(tmp_path)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


def test_cli_test_car_writes_its_files(tmp_path):
    from suspenv.cli.identify import CONCEALED
    from suspenv.methods.curves import identify

    assert CONCEALED == identify.CONCEALED
    out = tmp_path / "o"
    code = main(
        [
            "identify",
            "test-car",
            "--concealed",
            "noise",
            "--free",
            "static_toe,static_camber",
            "--global-evaluations",
            "16",
            "--no-figures",
            "--quiet",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    assert {p.name for p in out.iterdir()} == {"identified.toml", "identify.json", "report.md"}


# ------------------------------------------------------------------ targets
@pytest.mark.slow
def test_target_noise_only_every_curve_and_every_identified_parameter():
    """Issue 13's target on the reference car, noise only, all 49 parameters."""
    m, truth = measure_test_car(0, ["noise"])
    res = run_identify(m, resolve_vehicle(None), {}, truth=truth)
    assert max(res.curve_rms().values()) <= 1.5
    ident = [v for v in res.identifiability.verdicts if v.identified]
    assert ident
    for v in ident:
        assert v.error_pct is not None and v.error_pct <= TOLERANCE_PCT, v.name
    if res.rerun is not None:
        for v in res.rerun.identifiability.verdicts:
            if v.identified:
                assert v.error_pct is not None and v.error_pct <= TOLERANCE_PCT, v.name


@pytest.mark.slow
def test_target_default_concealed_effects_are_named():
    m, truth = measure_test_car(0, ["hysteresis", "tolerance", "noise"])
    res = run_identify(m, resolve_vehicle(None), {"rerun_next": False}, truth=truth)
    assert res.diagnosis is not None
    named = {n["family"] for n in res.diagnosis["named"]}
    assert "loop" in named and "lr_asymmetry" in named


def test_noise_free_curves_get_the_rig_default_weights_and_declared_noise_is_kept():
    # simulated loops carry no noise: the estimate is round-off, which as a weight would
    # make every parameter look identified; the fit takes the rig's typical noise instead
    from suspenv.measurements.knc_file import from_results
    from suspenv.methods.curves.identify import fit_weights
    from suspenv.models.mcpherson.params import build_axle
    from suspenv.models.mcpherson.truth import CHANNEL_NOISE
    from suspenv.rigs.knc import run_tests

    x = design_space().reference()[None, :]
    res = run_tests(build_axle(x), ("parallel",))
    m = from_results(res, "simulated", noise={"camber": 1e-3})
    assert m.noise["toe"] < 1e-2 * CHANNEL_NOISE["toe"]  # the estimate: curve shape, round-off
    w = fit_weights(m)
    assert w.noise["toe"] == CHANNEL_NOISE["toe"]
    assert w.noise_source["toe"].startswith("rig default")
    assert w.noise["camber"] == 1e-3  # declared: kept
    assert m.noise["toe"] < 1e-2 * CHANNEL_NOISE["toe"]  # the input is not changed


def test_a_fit_to_noise_free_curves_names_nothing_in_its_residual():
    # the residual of an exact fit is round-off; read in units of the weights' noise (not
    # of its own roughness) it holds no pattern (reference: the model is the truth)
    from suspenv.measurements.knc_file import from_results
    from suspenv.models.mcpherson.params import build_axle
    from suspenv.rigs.knc import run_tests

    veh = resolve_vehicle(None)
    x = 0.5 * (veh.left + veh.right)
    m = from_results(run_tests(build_axle(x[None, :]), ("parallel", "opposite")), "exact")
    opts = {"free": FEW, "global_evaluations": 0, "next_test": False, "rerun_next": False}
    res = run_identify(m, veh, opts, x0=x)
    assert max(res.curve_rms().values()) < 0.01
    assert res.diagnosis is not None and res.diagnosis["named"] == []
