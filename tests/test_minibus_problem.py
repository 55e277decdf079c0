"""MinibusRideHandling: objectives, constraints, failures, report, experiment configs."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.models.minibus.vehicle import STUDY_PICK, design_space
from suspenv.problems.minibus import MinibusRideHandling, ride_focused_pick
from suspenv.registry import make_problem
from suspenv.reports.minibus import write_minibus_report

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def problem() -> MinibusRideHandling:
    return make_problem("MinibusRideHandling")


@pytest.fixture(scope="module")
def evaluated(problem):
    space = design_space()
    rng = np.random.default_rng(7)
    X = np.vstack([STUDY_PICK, space.lower, space.upper, space.to_physical(rng.random((5, 8)))])
    return X, problem.evaluate(X)


def test_space_and_names_are_the_studys(problem):
    # reference: minibus_ride_handling.md, "8 design variables"
    assert problem.space.names == ("K1", "K2", "K3", "T1", "T2", "T3", "C1", "C2")
    np.testing.assert_allclose(problem.space.lower, [60, 130, 1e3, 7e4, 2e5, 2e5, 0.6, 0.6])
    np.testing.assert_allclose(problem.space.upper, [85, 180, 5e3, 1.5e5, 9e5, 9e5, 1.8, 1.8])
    np.testing.assert_allclose(problem.reference_design(), STUDY_PICK)
    assert problem.n_objectives == 5 and problem.n_constraints == 8


def test_objectives_are_no_load_plus_weighted_full_load(problem, evaluated):
    X, b = evaluated
    assert b.ok.all(), b.messages
    e = b.extras
    w = 1.5
    np.testing.assert_allclose(
        b.objectives[:, 0], e["aw_front_no_load"] + w * e["aw_front_full_load"]
    )
    np.testing.assert_allclose(
        b.objectives[:, 1], e["aw_rear_no_load"] + w * e["aw_rear_full_load"]
    )
    # default handling objectives: the step steer's yaw response time, the slalom's
    # steering-wheel angle and roll amplitudes
    assert problem.objective_names[2:] == (
        "f3_yaw_response_time",
        "f4_steering_wheel",
        "f5_roll",
    )
    np.testing.assert_allclose(
        b.objectives[:, 2], e["yaw_response_time_no_load"] + w * e["yaw_response_time_full_load"]
    )
    np.testing.assert_allclose(
        b.objectives[:, 3], e["steering_wheel_no_load"] + w * e["steering_wheel_full_load"]
    )
    np.testing.assert_allclose(b.objectives[:, 4], e["roll_no_load"] + w * e["roll_full_load"])
    np.testing.assert_allclose(b.constraints[:, 2], e["aw_rear_no_load"] - problem.rms_limit)
    np.testing.assert_allclose(b.constraints[:, 5], e["roll_full_load"] - 6.0)
    np.testing.assert_allclose(b.constraints[:, 7], -e["understeer_min_full_load"])
    # ISO 7401 response times of a light bus: 0.15-0.6 s; the loaded one is slower
    for lc in ("no_load", "full_load"):
        t90 = e[f"yaw_response_time_{lc}"]
        assert np.all((t90 > 0.15) & (t90 < 0.6))
    assert np.all(e["yaw_response_time_full_load"] > e["yaw_response_time_no_load"])
    # plausibility of the parts: grip 0.5-1 g, slalom yaw = the path's u * curvature
    # amplitude, 13.1 deg/s (the secant tyres' larger sideslip rate adds up to 10 %);
    # steering-wheel angle (L/R + K a_y) * ratio, about 57 deg
    assert np.all((e["ay_max_no_load"] > 4.9) & (e["ay_max_no_load"] < 9.8))
    assert np.all(np.abs(e["yaw_rate_no_load"] / 13.1 - 1) < 0.10)
    assert np.all((e["steering_wheel_no_load"] > 45) & (e["steering_wheel_no_load"] < 70))
    # the full load rolls more than the empty vehicle in the slalom (higher CoM, mass)
    assert np.all(e["roll_full_load"] > e["roll_no_load"])
    # every design of the box understeers in the linear range, both loads (ISO 4138)
    assert np.all(e["understeer_no_load"] > 0) and np.all(e["understeer_full_load"] > 0)


def test_study_handling_objectives_are_an_option():
    # the study's definitions: yaw-rate and roll amplitudes of the time-domain slalom
    p = MinibusRideHandling(handling="study")
    assert p.objective_names[3:] == ("f4_yaw_rate", "f5_roll")
    assert p.objective_units[3] == "deg/s"
    b = p.evaluate(STUDY_PICK[None, :])
    e = b.extras
    assert b.ok.all(), b.messages
    np.testing.assert_allclose(
        b.objectives[:, 3], e["yaw_rate_no_load"] + 1.5 * e["yaw_rate_full_load"]
    )
    assert np.all(np.abs(e["yaw_rate_no_load"] / 13.1 - 1) < 0.15)
    # the default's roll (path followed exactly, linear range) lies within 20 % of the
    # time-domain run's: its driver cuts the path a little (lower lateral acceleration
    # than the path's) and the slalom's 0.39 g sits at the edge of the linear range
    d = make_problem("MinibusRideHandling").evaluate(STUDY_PICK[None, :]).extras
    for lc in ("no_load", "full_load"):
        np.testing.assert_allclose(d[f"roll_{lc}"], e[f"roll_{lc}"], rtol=0.20)
    with pytest.raises(ValidationError, match="handling"):
        MinibusRideHandling(handling="fast")


def test_batch_and_single_evaluations_agree(problem, evaluated):
    # vectorised batch == one design at a time (same road, same rigs)
    X, b = evaluated
    single = problem.evaluate(X[1:2])
    np.testing.assert_allclose(single.objectives[0], b.objectives[1], rtol=1e-7)


def test_load_weight_and_limits_are_options():
    p = MinibusRideHandling(load_weight=1.0, rms_limit=0.6, roll_limit_deg=3.0)
    assert p.config()["rms_limit"] == 0.6
    rebuilt = MinibusRideHandling(**p.config())
    assert rebuilt.config() == p.config()
    with pytest.raises(ValidationError, match="rms_limit > 0"):
        MinibusRideHandling(rms_limit=0.0)
    with pytest.raises(ValidationError, match="n_cones >= 4"):
        MinibusRideHandling(n_cones=3)


def test_a_design_that_spins_is_a_failed_row_with_a_reason():
    # a very fast slalom: the vehicle cannot follow the cones
    p = MinibusRideHandling(
        slalom_speed_kmh=110.0, slalom_amplitude=2.5, ride_duration_s=2.0, handling="study"
    )
    b = p.evaluate(STUDY_PICK[None, :])
    assert not b.ok[0]
    assert "slalom" in b.messages[0]
    assert np.isnan(b.objectives[0]).all()


def test_ride_focused_pick_rule():
    base = np.array([1.0, 1.0, -10.0, 30.0, 5.0])
    F = np.array(
        [
            [0.5, 0.5, -9.0, 30.0, 5.0],  # best ride but worse grip than baseline
            [0.9, 0.8, -10.5, 29.0, 4.0],  # keeps handling, ride score 1.7
            [0.8, 0.8, -10.0, 30.0, 5.0],  # keeps handling, ride score 1.6 -> the pick
        ]
    )
    front = np.ones(3, bool)
    assert ride_focused_pick(F, front, base) == 2
    # no design keeps the baseline handling: smallest ride score overall
    assert ride_focused_pick(F[:1], front[:1], base) == 0
    with pytest.raises(ValidationError, match="empty"):
        ride_focused_pick(F, np.zeros(3, bool), base)


def _linked_images(md: Path) -> list[str]:
    return re.findall(r"!\[[^]]*\]\(([^)]+)\)", md.read_text())


def test_report_files(problem, evaluated, tmp_path):
    X, b = evaluated
    arrays = {
        "x": X,
        "unit": problem.space.to_unit(X),
        "objectives": b.objectives,
        "constraints": b.constraints,
        "ok": b.ok,
    }
    paths = write_minibus_report(problem, tmp_path, arrays)
    names = {p.name for p in paths}
    assert names == {
        "minibus_report.md",
        "minibus_parallel.png",
        "suspension_report.md",
        "suspension_elements.png",
    }
    assert all(p.exists() for p in paths)
    text = (tmp_path / "minibus_report.md").read_text()
    assert "Ride-focused pick" in text and "study pick" in text
    # no run figures here: the report links only what it drew
    assert _linked_images(tmp_path / "minibus_report.md") == ["minibus_parallel.png"]
    # without figures: the Markdown files only, no image linked
    bare = tmp_path / "bare"
    paths = write_minibus_report(problem, bare, arrays, plots=False)
    assert sorted(p.name for p in paths) == ["minibus_report.md", "suspension_report.md"]
    assert sorted(p.name for p in bare.iterdir()) == sorted(p.name for p in paths)
    assert _linked_images(bare / "minibus_report.md") == []
    assert "K1" in (bare / "suspension_report.md").read_text()


RUN_CONFIG = """
seed = 1
budget = 48
[problem]
name = "MinibusRideHandling"
[strategy]
name = "nsga2"
options = {{ population_size = 24 }}
[run]
output = "{out}"
workers = 1
progress = false
plots = {plots}
"""

RUN_CODE = """
import sys
from suspenv.runs.config import load_config
from suspenv.runs.runner import run_experiment
run_dir, _ = run_experiment(load_config(sys.argv[1]))
print(run_dir)
print("matplotlib" in sys.modules)
"""


@pytest.mark.parametrize("plots", [False, True])
def test_run_report_honours_plots(tmp_path, plots):
    """A run with ``plots = false`` draws no figure and never imports matplotlib (a fresh
    interpreter's ``sys.modules``); with figures, the files docs/minibus_handling.md
    lists exist and every image the report links is there."""
    config = tmp_path / "run.toml"
    config.write_text(RUN_CONFIG.format(out=tmp_path / "runs", plots=str(plots).lower()))
    done = subprocess.run(
        [sys.executable, "-c", RUN_CODE, str(config)],
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
    )
    run_dir, imported = done.stdout.split()[-2:]
    run = Path(run_dir)
    images = sorted(p.name for p in run.glob("*.png"))
    linked = _linked_images(run / "minibus_report.md")
    assert (run / "suspension_report.md").exists()
    if not plots:
        assert imported == "False" and images == [] and linked == []
        return
    documented = ["pareto_pairs.png", "minibus_parallel.png", "suspension_elements.png"]
    assert set(documented) <= set(images)
    assert linked == ["pareto_pairs.png", "minibus_parallel.png"]
    # each figure drawn once: the pair plot is the run's, not a second minibus copy
    assert not any(name.startswith("minibus_pareto") for name in images)


@pytest.mark.parametrize("name", ["minibus_nsga2.toml", "minibus_quick.toml"])
def test_experiment_configs(name):
    cfg = tomllib.loads((ROOT / "experiments" / name).read_text())
    assert cfg["problem"]["name"] == "MinibusRideHandling"
    assert cfg["strategy"]["name"] in ("nsga2", "pymoo_nsga2")
    pop = cfg["strategy"]["options"]["population_size"]
    if name == "minibus_nsga2.toml":
        # reference: the study's optimiser settings, population 500 x 60 generations
        assert pop == 500 and cfg["budget"] == 30000 and cfg["budget"] // pop == 60
    else:
        assert cfg["budget"] <= 200
