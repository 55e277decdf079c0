"""PlanarLinkage problem: known optimum, failures as values, both solvers, render, report, CLI."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.models.planar import load_geometry, solve_single, sweep_outputs
from suspenv.registry import make_problem


def _design_of(problem, geometry_name):
    """Physical design vector (mm) that puts the problem's variables at a geometry's points."""
    pts = load_geometry(geometry_name).points_mm()
    values = {}
    for name in problem.space.names:
        point, _, axis = name.partition(".")
        values[name] = pts[point][0 if axis == "y" else 1]
    return problem.space.from_dict(values)


@pytest.mark.parametrize("geometry", ["double_wishbone", "mcpherson"])
def test_target_design_is_a_known_optimum(geometry):
    # the default target differs from the baseline only in the free coordinates, so the
    # target's own coordinates reproduce its curves exactly: curve_error = 0 there
    p = make_problem("PlanarLinkage", geometry=geometry)
    x_target = _design_of(p, f"{geometry}_target")
    assert np.all(p.space.to_unit(x_target[None]) >= 0)
    assert np.all(p.space.to_unit(x_target[None]) <= 1)
    batch = p.evaluate(np.vstack([p.reference_design(), x_target]))
    assert batch.ok.all()
    assert batch.objectives[1, 0] == pytest.approx(0.0, abs=1e-9)
    assert batch.objectives[0, 0] > 0.5  # the baseline is visibly off target
    # curve_error is the scaled RMS of the camber and track errors it reports
    e = batch.extras
    expected = np.sqrt((e["camber_rms_deg"][0] / 0.1) ** 2 + (e["track_rms_mm"][0] / 1.0) ** 2)
    assert batch.objectives[0, 0] == pytest.approx(expected, rel=1e-12)


def test_camber_gain_mode_objective_and_constraints():
    p = make_problem(
        "PlanarLinkage",
        target_camber_gain=-30.0,
        max_half_track_change=5.0,
        roll_centre_range=[0.0, 40.0],
    )
    assert p.constraint_names == (
        "half_track_change_excess",
        "roll_centre_below_range",
        "roll_centre_above_range",
    )
    g = load_geometry("double_wishbone")
    out = sweep_outputs(g, solve_single(g, p.travel))  # independent of the problem's path
    batch = p.evaluate(p.reference_design()[None])
    gain = float(out.camber_gain_deg_per_m)
    assert batch.objectives[0, 0] == pytest.approx(abs(gain + 30.0), rel=1e-9)
    rc = out.roll_centre_mm[p.n_travel // 2]
    np.testing.assert_allclose(
        batch.constraints[0],
        [np.abs(out.half_track_mm).max() - 5.0, 0.0 - rc, rc - 40.0],
        rtol=1e-9,
    )
    assert not batch.feasible[0]  # RC ~49 mm lies above the 40 mm limit


def test_locked_rows_fail_alone():
    p = make_problem("PlanarLinkage")
    good = p.reference_design()
    bad = good.copy()
    # a zero-length upper arm pins the upper ball joint: the wheel cannot move at all
    bad[p.space.index("upper_inner.y")] = bad[p.space.index("upper_outer.y")]
    bad[p.space.index("upper_inner.z")] = bad[p.space.index("upper_outer.z")]
    batch = p.evaluate(np.vstack([good, bad, good]))
    assert batch.ok.tolist() == [True, False, True]
    assert "Error" in batch.messages[1] and batch.messages[0] == ""
    assert np.isnan(batch.objectives[1]).all()
    assert batch.objectives[0, 0] == batch.objectives[2, 0]


def test_pymunk_solver_gives_the_same_objectives():
    X = np.array([[0.2, 0.7, 0.4, 0.6, 0.3, 0.5], [0.5, 0.5, 0.5, 0.5, 0.5, 0.5]])
    kw = {"n_travel": 13}
    a = make_problem("PlanarLinkage", **kw).evaluate_unit(X)
    b = make_problem("PlanarLinkage", solver="pymunk", **kw).evaluate_unit(X)
    assert a.ok.all() and b.ok.all()
    # curve errors of order 1-10: solvers agree to better than 1e-4 of a scale unit
    np.testing.assert_allclose(b.objectives, a.objectives, atol=1e-4)


def test_bad_options_name_the_rule():
    with pytest.raises(ValidationError, match="`solver` must be one of"):
        make_problem("PlanarLinkage", solver="adams")
    with pytest.raises(ValidationError, match="odd integer"):
        make_problem("PlanarLinkage", n_travel=60)
    with pytest.raises(ValidationError, match="'<point>.y' or '<point>.z'"):
        make_problem("PlanarLinkage", variables=["strut_top.y"])
    with pytest.raises(ValidationError, match="target geometry must be a double_wishbone"):
        make_problem("PlanarLinkage", target="mcpherson")
    with pytest.raises(ValidationError, match="`span > 0`"):
        make_problem("PlanarLinkage", span=0)


def test_config_rebuilds_the_problem():
    p = make_problem("PlanarLinkage", geometry="mcpherson", target_camber_gain=-20.0, span=25)
    q = make_problem("PlanarLinkage", **p.config())
    U = np.random.default_rng(3).random((4, p.space.dim))
    np.testing.assert_array_equal(p.evaluate_unit(U).objectives, q.evaluate_unit(U).objectives)


def test_render_rgb_draws_the_linkage():
    p = make_problem("PlanarLinkage")
    img = p.render_rgb(p.reference_design())
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
    assert (img < 128).any() and (img > 200).any()  # lines on a light background
    other = p.render_rgb(p.space.to_physical(np.full((1, p.space.dim), 0.9))[0])
    assert not np.array_equal(img, other)  # a different design looks different


class _Archive:
    def __init__(self, problem, U):
        X = problem.space.to_physical(U)
        b = problem.evaluate(X)
        self._arrays = {
            "unit": U,
            "x": X,
            "objectives": b.objectives,
            "constraints": b.constraints,
            "ok": b.ok,
            "message": np.array(b.messages),
            "batch": np.zeros(len(U), int),
        }

    def arrays(self):
        return self._arrays


def test_write_report_writes_best_geometry_figure_and_markdown(tmp_path):
    p = make_problem("PlanarLinkage")
    U = np.random.default_rng(0).random((8, p.space.dim))
    archive = _Archive(p, U)
    paths = p.write_report(tmp_path, archive)
    assert {q.name for q in paths} == {"planar_best.toml", "planar_best.png", "planar_report.md"}
    best = int(np.nanargmin(archive.arrays()["objectives"][:, 0]))
    # the written geometry re-evaluates to the archived best objective
    g = load_geometry(tmp_path / "planar_best.toml")
    x = _design_from_geometry(p, g)
    assert p.evaluate(x[None]).objectives[0, 0] == pytest.approx(
        archive.arrays()["objectives"][best, 0], rel=1e-9
    )
    assert "planar_best.png" in (tmp_path / "planar_report.md").read_text()


def _design_from_geometry(problem, g):
    pts = g.points_mm()
    return problem.space.from_dict(
        {n: pts[n.split(".")[0]][0 if n.endswith(".y") else 1] for n in problem.space.names}
    )


def _cli(argv):
    import argparse

    from suspenv.cli import planar

    parser = argparse.ArgumentParser(prog="suspenv")
    planar.register(parser.add_subparsers())
    args = parser.parse_args(argv)
    return args.func(args)


def test_cli_planar_prints_and_plots(tmp_path, capsys):
    assert _cli(["planar", "double_wishbone", "--plot", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert "camber gain at design" in text and "roll centre" in text
    assert (tmp_path / "double_wishbone.png").stat().st_size > 10_000
    assert (tmp_path / "double_wishbone_curves.png").is_file()
    with pytest.raises(ValidationError, match="neither a file nor a bundled example"):
        _cli(["planar", "no_such_geometry"])


def test_env_render_returns_the_linkage_picture():
    import gymnasium as gym

    import suspenv.envs  # noqa: F401 - registers suspenv/<Name>-v0

    env = gym.make("suspenv/PlanarLinkage-v0", render_mode="rgb_array")
    env.reset(seed=0)
    env.step(env.action_space.sample())
    img = env.render()
    env.close()
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3


@pytest.mark.slow
def test_speed_benchmark_runs(tmp_path):
    import json

    from benchmarks import planar_speed

    assert planar_speed.main(["--quick", "--output-dir", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "planar_speed.json").read_text())["summary"]
    assert summary["travel_points"] == 61 and summary["pymunk_ms_per_candidate"] > 0


def test_teaching_experiment_runs_and_beats_the_baseline(tmp_path):
    from pathlib import Path

    from suspenv.runs.config import load_config
    from suspenv.runs.runner import run_experiment

    config_path = Path(__file__).resolve().parents[1] / "experiments" / "planar_camber.toml"
    config = load_config(
        config_path, ["budget=120", f'run.output="{tmp_path}"', "run.progress=false"]
    )
    run_dir, summary = run_experiment(config)
    for name in ("planar_best.toml", "planar_best.png", "planar_report.md"):
        assert (Path(run_dir) / name).is_file(), name
    problem = make_problem("PlanarLinkage", **config["problem"]["options"])
    baseline = problem.evaluate(problem.reference_design()[None]).objectives[0, 0]
    best = load_geometry(Path(run_dir) / "planar_best.toml")
    x = _design_from_geometry(problem, best)
    batch = problem.evaluate(x[None])
    assert batch.feasible[0]
    assert batch.objectives[0, 0] < 0.2 * baseline  # 11 deg/m off at the start


def test_cmaes_identifies_the_target_hard_points():
    # identification: the target's hard points are the unique zero of curve_error here
    # (4 coordinates of a McPherson strut); CMA-ES must recover them from the baseline
    from suspenv.strategies.cmaes import CMAES

    p = make_problem("PlanarLinkage", geometry="mcpherson")
    truth = _design_of(p, "mcpherson_target")
    strategy = CMAES(dim=p.space.dim, seed=1, popsize=12, sigma0=0.25)
    best, best_x = np.inf, None
    for _ in range(250):
        if strategy.stop() is not None:
            break
        U = strategy.ask()
        batch = p.evaluate_unit(U)
        strategy.tell(U, batch)
        i = int(np.nanargmin(batch.objectives[:, 0]))
        if batch.objectives[i, 0] < best:
            best, best_x = batch.objectives[i, 0], p.space.to_physical(U[i : i + 1])[0]
    assert best < 1e-6
    np.testing.assert_allclose(best_x, truth, atol=0.01)  # mm
