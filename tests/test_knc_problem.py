"""KCIdentification, the 40 objectives, the test vehicle, rig failures, vehicle files, CLI."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.metrics.knc import OBJECTIVE_NAMES, OBJECTIVES, loop_width, quadratic_fit
from suspenv.models.mcpherson import build_axle, design_space, reference_design
from suspenv.models.mcpherson.params import PAPER_IDENTIFIED_POINTS, PAPER_RANGES
from suspenv.models.mcpherson.truth import truth_vehicle
from suspenv.problems.kc_identification import KCIdentification
from suspenv.registry import make_problem
from suspenv.rigs.knc import TESTS, loop_path, run_tests, stroke_grid
from suspenv.rigs.knc_truth import measure_tests


@pytest.fixture(scope="module")
def problem():
    return make_problem("KCIdentification")


def test_design_space_has_the_papers_49_parameters_with_the_reference_inside():
    sp = design_space()
    assert sp.dim == 49
    assert sp.outside_bounds(reference_design()) == []
    # the paper's strut axis point z (217.2) lies outside its own range [125, 145]
    lo, hi = sp.lower[sp.index("strut_axis_point_z")], sp.upper[sp.index("strut_axis_point_z")]
    assert lo == 125 and hi >= 217.2
    # every range contains the paper's range (only widened, never narrowed) for hard points
    for hp, rng in PAPER_RANGES.items():
        for axis, (plo, phi), v in zip("xyz", rng, PAPER_IDENTIFIED_POINTS[hp], strict=True):
            i = sp.index(f"{hp}_{axis}")
            assert sp.lower[i] <= plo and sp.upper[i] >= phi
            assert sp.lower[i] < v < sp.upper[i]


def test_forty_objectives_with_units_and_the_papers_test_split():
    assert len(OBJECTIVE_NAMES) == 40 == len(set(OBJECTIVE_NAMES))
    counts = {t: sum(o.test == t for o in OBJECTIVES) for t in ("parallel", "opposite", "single")}
    assert counts == {"parallel": 13, "opposite": 13, "single": 14}  # paper: 13 + 13 + 14
    assert all(o.unit and o.label for o in OBJECTIVES)


def test_quadratic_fit_recovers_a_known_polynomial():
    # reference: exact polynomial y = 2 + 3x - 0.5x^2 on an uneven grid
    x = np.linspace(-10, 10, 21) + 0.1 * np.sin(np.arange(21))
    y = 2 + 3 * x - 0.5 * x**2
    v, s, c = quadratic_fit(x, y, 10)
    x0 = x[10]
    assert v == pytest.approx(2 + 3 * x0 - 0.5 * x0**2)
    assert s == pytest.approx(3 - x0)
    assert c == pytest.approx(-1.0)


def test_loop_visits_the_grid_design_bump_rebound_design():
    g = stroke_grid(0.04, 30)
    p = loop_path(30)
    assert g[15] == 0 and p[0] == 15 and p[-1] == 15 and p.size == 61
    assert g[p].max() == pytest.approx(0.04) and g[p].min() == pytest.approx(-0.04)
    with pytest.raises(ValidationError, match="even"):
        stroke_grid(0.04, 31)


def test_problem_shapes_targets_and_reference_mismatch(problem):
    assert problem.space.dim == 49 and problem.n_objectives == 40
    assert np.isfinite(problem.targets).all()
    b = problem.evaluate(np.vstack([problem.reference_design(), problem.initial_design()]))
    assert b.ok.all()
    assert (b.objectives >= 0).all()
    # the truth is near the reference: its mismatch is much smaller than the initial model's
    scale = np.abs(problem.targets) + 1e-3
    assert (b.objectives[0] / scale).sum() < 0.5 * (b.objectives[1] / scale).sum()


def test_batch_equals_row_by_row(problem):
    # reference: the same designs evaluated one at a time
    X = problem.space.to_physical(np.random.default_rng(3).random((3, 49)))
    batch = problem.evaluate(X)
    rows = np.vstack([problem.evaluate(x[None, :]).objectives for x in X])
    assert np.allclose(batch.objectives, rows, rtol=1e-6, atol=1e-9, equal_nan=True)


def test_without_concealed_effects_the_reference_is_an_exact_solution():
    p = KCIdentification(concealed=())
    b = p.evaluate(p.reference_design()[None, :])
    assert b.ok.all()
    assert np.abs(b.objectives).max() < 1e-6 * (1 + np.abs(p.targets).max())
    assert np.allclose(p.truth_design(), p.reference_design())


def test_test_vehicle_is_reproducible_and_shows_hysteresis():
    a, b, c = truth_vehicle(1), truth_vehicle(1), truth_vehicle(2)
    assert np.array_equal(a.right, b.right) and not np.array_equal(a.right, c.right)
    assert not np.array_equal(a.left, a.right)  # left/right tolerance
    res = measure_tests(truth_vehicle(1, noise=False), TESTS, steps=10)
    width = loop_width(res)  # N, loading vs unloading branch of the tyre force
    assert (width > 5.0).all()
    plain = run_tests(build_axle(reference_design()[None, :]), ("parallel",), steps=10)
    assert loop_width(plain).max() < 0.05


def test_options_are_validated_and_config_round_trips(problem):
    with pytest.raises(ValidationError, match="concealed"):
        KCIdentification(concealed=("magic",))
    with pytest.raises(ValidationError, match="steps"):
        KCIdentification(steps=7)
    again = KCIdentification(**problem.config())
    assert np.array_equal(again.targets, problem.targets)


def test_a_failing_row_is_reported_and_does_not_disturb_the_others():
    # an absurd static load drives the bushings past their limits on row 1 only
    from suspenv.metrics.knc import objectives

    axle = build_axle(np.tile(reference_design(), (2, 1)))
    axle.corner_load[1] = 1e7
    res = run_tests(axle, steps=6)
    par = res["parallel"]
    assert par.ok[0] and not par.ok[1]
    assert "Error" in par.messages[1] and par.messages[0] == ""
    ref = run_tests(build_axle(reference_design()[None, :]), steps=6)
    assert np.allclose(par.channels["toe"][0], ref["parallel"].channels["toe"][0], atol=1e-9)
    F = objectives(res)  # must not raise on the failed row
    assert np.isfinite(F[0]).all()
    assert np.allclose(F[0], objectives(ref)[0], rtol=1e-6, atol=1e-9)


def test_study_hooks(problem):
    x = problem.reference_design()
    r = problem.residuals(x[None, :])
    assert r.shape == (1, 40)
    assert np.allclose(np.abs(r), problem.evaluate(x[None, :]).objectives)
    curves = problem.curves(x)
    meas = problem.measured_curves()
    assert set(curves) == set(meas) == {"parallel travel", "opposite travel", "single travel"}
    s, v = meas["parallel travel"]["toe [deg]"]
    assert s.shape == v.shape == (61,)


def test_vehicle_file_round_trip_and_errors(tmp_path):
    from suspenv.models.mcpherson.vehicle_file import (
        REFERENCE_FILE,
        VehicleFile,
        dump_vehicle,
        load_vehicle,
    )

    ref = load_vehicle(REFERENCE_FILE)
    assert np.allclose(ref.left, reference_design())
    right = ref.left.copy()
    right[design_space().index("tie_rod_outer_y")] += 1.0
    text = dump_vehicle(VehicleFile("asym", ref.left, right))
    path = tmp_path / "asym.toml"
    path.write_text(text)
    back = load_vehicle(path)
    assert np.allclose(back.right, right) and np.allclose(back.left, ref.left)
    bad = tmp_path / "bad.toml"
    bad.write_text("[design]\nstrut_top_q = 1.0\n")
    with pytest.raises(ValidationError, match="strut_top_q"):
        load_vehicle(bad)
    bad.write_text("[design]\nlca_front_kx = -1.0\n")
    with pytest.raises(ValidationError, match=r"`lca_front_kx > 0` must hold"):
        load_vehicle(bad)


def test_cli_writes_csv_and_plot(tmp_path):
    from suspenv.cli import knc

    parser = argparse.ArgumentParser()
    knc.register(parser.add_subparsers())
    args = parser.parse_args(
        [
            "knc",
            "reference",
            "--test",
            "opposite",
            "--plot",
            "--out",
            str(tmp_path),
            "--steps",
            "10",
        ]
    )
    assert args.func(args) == 0
    csv_path = tmp_path / "mcpherson_reference_opposite.csv"
    png = tmp_path / "mcpherson_reference_opposite.png"
    assert csv_path.is_file() and png.stat().st_size > 10_000
    header = csv_path.read_text().splitlines()[0].split(",")
    assert "toe_left [deg]" in header and "tyre_fz_right [N]" in header
    assert len(csv_path.read_text().splitlines()) == 1 + 21


def test_write_report_picks_the_best_design_and_plots(problem, tmp_path):
    class Archive:  # the part of RunArchive that write_report reads
        def __init__(self, X, batch):
            self._a = {"x": X, "objectives": batch.objectives, "ok": batch.ok}

        def arrays(self):
            return self._a

    X = np.vstack([problem.initial_design(), problem.truth_design()])
    paths = problem.write_report(tmp_path, Archive(X, problem.evaluate(X)))
    assert [p.name for p in paths] == ["kc_report.md", "kc_curves.png"]
    text = paths[0].read_text()
    assert "best is evaluation 1" in text  # the truth's mean design beats the initial model
    assert text.count("| par_") == 13


def test_fit_model_with_the_concealed_hysteresis_reproduces_the_targets():
    # reference: the truth and the fit model are the same code with the same effect list,
    # so the reference design must match hysteresis-only targets exactly; the plain
    # model cannot (its loops close)
    hyst = [
        {"kind": "dahl_hysteresis", "location": "lower_arm_and_top_mount", "params": {"f_c": 80.0}}
    ]
    with_h = KCIdentification(concealed=("hysteresis",), model_effects=hyst, steps=10)
    plain = KCIdentification(concealed=("hysteresis",), steps=10)
    x = with_h.reference_design()[None, :]
    assert np.abs(with_h.evaluate(x).objectives).max() < 1e-9 * np.abs(with_h.targets).max()
    i = plain.objective_names.index("par_susp_ride_rate_pos")
    assert plain.evaluate(x).objectives[0, i] > 0.05  # N/mm
    assert KCIdentification(**with_h.config()).config() == with_h.config()
