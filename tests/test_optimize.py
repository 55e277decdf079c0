"""The optimise loop: budget rule, failures as values, executors, resume after a kill,
reproducibility by seed."""

import os
import signal
import subprocess
import sys
import textwrap
import time
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pytest

from suspenv import make_problem
from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem
from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.registry import make_strategy
from suspenv.runs.archive import RunArchive
from suspenv.runs.loop import optimize


class Fragile(Problem):
    """x > 0.8 raises inside the physics (a 'lock-up'); used to test failures as values."""

    name = "Fragile"

    def __init__(self):
        self.space = DesignSpace([Parameter("x", 0.0, 1.0), Parameter("y", 0.0, 1.0)])
        self.objective_names = ("f",)

    def _evaluate(self, X):
        if np.any(X[:, 0] > 0.8):
            raise EvaluationError(f"linkage locks up at x={X[X[:, 0] > 0.8, 0].max():.3f}")
        n = len(X)
        return EvaluationBatch(
            X.sum(1, keepdims=True), np.zeros((n, 0)), np.ones(n, bool), [""] * n
        )


def test_budget_never_exceeded_and_batches_never_truncated():
    p = make_problem("Sphere", dim=3)
    r = optimize(p, make_strategy("cmaes", p, seed=0, popsize=7), budget=50)
    assert r.n_evaluations == 49 and r.n_batches == 7  # 7 whole batches of 7 fit in 50
    assert "never truncated" in r.stop_reason


def test_exception_in_model_becomes_failed_row_and_run_continues(tmp_path):
    p = Fragile()
    r = optimize(p, make_strategy("random", p, seed=1, batch_size=10), budget=100, run_dir=tmp_path)
    assert r.n_evaluations == 100
    with RunArchive(tmp_path) as a:
        arr = a.arrays()
    bad = arr["x"][:, 0] > 0.8
    assert bad.any() and not arr["ok"][bad].any() and arr["ok"][~bad].all()
    assert all("EvaluationError: linkage locks up" in m for m in arr["message"][bad])
    assert np.isnan(arr["objectives"][bad]).all()


def test_same_seed_same_numbers_and_csv(tmp_path):
    p = make_problem("ZDT1", dim=4)
    outs = []
    for k in range(2):
        optimize(
            p,
            make_strategy("nsga2", p, seed=5, population_size=10),
            budget=60,
            run_dir=tmp_path / str(k),
        )
        with RunArchive(tmp_path / str(k)) as a:
            outs.append(a.arrays()["objectives"])
            csv = a.to_csv(tmp_path / f"{k}.csv")
    np.testing.assert_array_equal(outs[0], outs[1])
    header = csv.read_text().splitlines()[0].split(",")
    designs = [f"design:x{j} [-]" for j in range(4)]  # ZDT1's variables have no unit
    assert header == [
        "batch",
        "row",
        *designs,
        "objective:f1",
        "objective:f2",
        "ok",
        "message",
        "wall_time [s]",
    ]
    assert len(csv.read_text().splitlines()) == 61
    # the CSV reads back as numbers equal to the archive's (reference: the SQLite archive)
    table = np.genfromtxt(csv, delimiter=",", skip_header=1, dtype=float)
    np.testing.assert_array_equal(table[:, 6:8], outs[1])
    with RunArchive(tmp_path / "1") as a:
        x = a.arrays()["x"]
    np.testing.assert_array_equal(table[:, 2:6], x)


@pytest.mark.parametrize("kind", ["thread", "process"])
def test_executor_gives_the_same_numbers_as_in_process(tmp_path, kind):
    p = make_problem("Sphere", dim=4)
    ref = optimize(
        p, make_strategy("cmaes", p, seed=2, popsize=8), budget=80, run_dir=tmp_path / "ref"
    )
    pool = ThreadPoolExecutor(2) if kind == "thread" else ProcessPoolExecutor(2)
    with pool:
        r = optimize(
            p,
            make_strategy("cmaes", p, seed=2, popsize=8),
            budget=80,
            run_dir=tmp_path / kind,
            executor=pool,
            chunk_size=3,
        )
    assert r.best_objectives == ref.best_objectives
    with RunArchive(tmp_path / "ref") as a, RunArchive(tmp_path / kind) as b:
        np.testing.assert_array_equal(a.arrays()["objectives"], b.arrays()["objectives"])


def test_dask_local_cluster_executor(tmp_path):
    distributed = pytest.importorskip("distributed")
    p = make_problem("Sphere", dim=3)
    ref = optimize(p, make_strategy("cmaes", p, seed=3, popsize=6), budget=36)
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        r = optimize(
            p,
            make_strategy("cmaes", p, seed=3, popsize=6),
            budget=36,
            executor=client.get_executor(),
            run_dir=tmp_path,
        )
    assert r.best_objectives == ref.best_objectives and r.n_evaluations == 36


def test_resume_after_kill_loses_nothing_and_duplicates_nothing(tmp_path):
    run_dir = tmp_path / "run"
    script = textwrap.dedent(f"""
        from suspenv import make_problem
        from suspenv.registry import make_strategy
        from suspenv.runs.loop import optimize
        p = make_problem("Sphere", dim=4, delay_s=0.02)
        optimize(p, make_strategy("cmaes", p, seed=9, popsize=8), budget=400,
                 run_dir={str(run_dir)!r}, chunk_size=3)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script])
    deadline = time.time() + 60
    n_before = 0
    while time.time() < deadline:
        time.sleep(0.05)
        if (run_dir / "archive.sqlite").exists():
            with RunArchive(run_dir) as a:
                n_before = len(a)
            if n_before >= 60:
                break
    os.kill(proc.pid, signal.SIGKILL)  # no clean-up: the hardest way to die
    proc.wait()
    with RunArchive(run_dir) as a:
        n_killed = len(a)
    assert 60 <= n_killed < 400

    p = make_problem("Sphere", dim=4)
    r = optimize(p, make_strategy("cmaes", p, seed=9, popsize=8), budget=400, run_dir=run_dir)
    assert r.n_resumed == n_killed and r.n_evaluations == 400
    with RunArchive(run_dir) as a:
        arr = a.arrays()
    assert len(arr["ok"]) == 400
    assert len(set(zip(arr["batch"], arr["row"], strict=True))) == 400  # no duplicates
    ref = optimize(
        p, make_strategy("cmaes", p, seed=9, popsize=8), budget=400, run_dir=tmp_path / "ref"
    )
    with RunArchive(tmp_path / "ref") as a:
        np.testing.assert_array_equal(a.arrays()["objectives"], arr["objectives"])
    assert ref.best_objectives == r.best_objectives


def test_resume_with_other_seed_is_refused(tmp_path):
    p = make_problem("Sphere", dim=2)
    optimize(p, make_strategy("random", p, seed=1, batch_size=5), budget=10, run_dir=tmp_path)
    with pytest.raises(ValidationError, match="differs from what the strategy asks"):
        optimize(p, make_strategy("random", p, seed=2, batch_size=5), budget=20, run_dir=tmp_path)


def test_nan_design_and_bad_budget_rejected():
    p = make_problem("Sphere", dim=2)
    with pytest.raises(ValidationError, match=r"must be finite, but row 0 parameter 'x1' is nan"):
        p.evaluate(np.array([[0.1, np.nan]]))
    with pytest.raises(ValidationError, match=r"`budget >= 1`.*budget=0"):
        optimize(p, make_strategy("random", p), budget=0)


def test_evaluations_csv_round_trips_through_pandas(tmp_path):
    # reference: the SQLite archive's float64 values, compared bit for bit; a failed row
    # (NaN objectives) and a message with a comma must not shift the columns
    pd = pytest.importorskip("pandas")
    p = Fragile()
    optimize(p, make_strategy("random", p, seed=3, batch_size=20), 100, run_dir=tmp_path)
    with RunArchive(tmp_path) as a:
        arrays = a.arrays()
        path = a.to_csv(tmp_path / "evaluations.csv")
    df = pd.read_csv(path)
    f, x, y = "objective:f", "design:x [-]", "design:y [-]"
    assert df[f].dtype == np.float64 and df[x].dtype == np.float64
    np.testing.assert_array_equal(df[f].to_numpy(), arrays["objectives"][:, 0])
    np.testing.assert_array_equal(df[[x, y]].to_numpy(), arrays["x"])
    assert (~arrays["ok"]).any() and df[f].min() == np.nanmin(arrays["objectives"])
    assert df["ok"].tolist() == arrays["ok"].astype(int).tolist()
