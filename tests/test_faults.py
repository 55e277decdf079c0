"""Faults of the machinery are not results of the design.

Each fault is compared against the same run without the fault (reference: an
uninterrupted in-process run with the same seed): the archive must hold the same designs
with the same results, row for row. Table of the faults covered: docs/runs.md.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from suspenv import make_problem
from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem
from suspenv.core.errors import InfrastructureError, ValidationError
from suspenv.registry import make_strategy
from suspenv.runs.archive import RunArchive
from suspenv.runs.config import load_config
from suspenv.runs.evaluation import FaultPolicy
from suspenv.runs.executors import ProcessPool
from suspenv.runs.loop import optimize
from suspenv.runs.run_dir import locked
from suspenv.runs.runner import run_experiment

#: archive columns that are results (wall times and timestamps differ between runs)
RESULT_COLUMNS = ("unit", "x", "objectives", "constraints", "ok", "message", "batch", "row")


def archive_results(run_dir: Path) -> dict[str, np.ndarray]:
    with RunArchive(run_dir) as a:
        arrays = a.arrays()
    return {k: arrays[k] for k in RESULT_COLUMNS}


def assert_same_archive(a: Path, b: Path) -> None:
    ra, rb = archive_results(a), archive_results(b)
    for key in RESULT_COLUMNS:
        np.testing.assert_array_equal(ra[key], rb[key], err_msg=key)


def reference_run(tmp_path: Path, budget: int, popsize: int = 8, seed: int = 5) -> Path:
    p = make_problem("Sphere", dim=4)
    optimize(
        p, make_strategy("cmaes", p, seed=seed, popsize=popsize), budget, run_dir=tmp_path / "ref"
    )
    return tmp_path / "ref"


# ------------------------------------------------------------- non-finite results
class NaNSometimes(Problem):
    """Reports success with a NaN objective where x0 > 0.7 (a simulator's silent failure)."""

    name = "NaNSometimes"

    def __init__(self) -> None:
        self.space = DesignSpace([Parameter("x0", 0.0, 1.0), Parameter("x1", 0.0, 1.0)])
        self.objective_names = ("f",)

    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        f = ((X - 0.2) ** 2).sum(1)
        f = np.where(X[:, 0] > 0.7, np.nan, f)
        n = len(X)
        return EvaluationBatch(f[:, None], np.zeros((n, 0)), np.ones(n, bool), [""] * n)


def test_a_nan_reported_as_success_is_a_failed_row_and_best_is_kept(tmp_path):
    p = NaNSometimes()
    batch = p.evaluate(np.array([[0.1, 0.1], [0.9, 0.1]]))
    assert batch.ok.tolist() == [True, False]
    assert batch.messages[1] == "non-finite result: f=nan"
    r = optimize(p, make_strategy("random", p, seed=1, batch_size=10), 200, run_dir=tmp_path)
    with RunArchive(tmp_path) as a:
        arr = a.arrays()
    assert (~arr["ok"]).sum() > 20 and not np.isnan(arr["objectives"][arr["ok"]]).any()
    # the best is the smallest archived good value (independent recomputation)
    assert r.best_objectives == [float(arr["objectives"][arr["ok"], 0].min())]


# ------------------------------------------------------------------ timeouts
class Hangs(Problem):
    """Sphere on [-1, 1]^4 whose calls number ``at`` .. ``at + times - 1`` sleep 30 s (a hung
    solver)."""

    name = "Hangs"

    def __init__(self, at: int, times: int = 1) -> None:
        self.space = DesignSpace(Parameter(f"x{i}", -1.0, 1.0) for i in range(4))
        self.objective_names = ("f",)
        self.calls = 0
        self.at, self.times = at, times

    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        self.calls += 1
        if self.at <= self.calls < self.at + self.times:
            time.sleep(30.0)
        n = len(X)
        f = ((X - 0.3) ** 2).sum(axis=1, keepdims=True)
        return EvaluationBatch(f, np.zeros((n, 0)), np.ones(n, bool), [""] * n)


def test_an_in_process_hang_is_retried_and_never_archived(tmp_path):
    ref = reference_run(tmp_path, 80)
    p = Hangs(at=4)
    policy = FaultPolicy(timeout_s=0.05, retries=2, backoff_s=0.0)
    r = optimize(
        p,
        make_strategy("cmaes", p, seed=5, popsize=8),
        80,
        run_dir=tmp_path / "run",
        faults=policy,
    )
    assert r.n_evaluations == 80 and p.calls == 11  # 10 batches + the hung call
    assert_same_archive(ref, tmp_path / "run")


def test_a_hang_that_stays_stops_the_run_and_resume_completes_it(tmp_path):
    ref = reference_run(tmp_path, 80)
    p = Hangs(at=4, times=100)
    policy = FaultPolicy(timeout_s=0.05, retries=1, backoff_s=0.0)
    with pytest.raises(InfrastructureError, match=r"batch 3 after 24 evaluations.*timeout"):
        optimize(
            p,
            make_strategy("cmaes", p, seed=5, popsize=8),
            80,
            run_dir=tmp_path / "run",
            faults=policy,
        )
    assert len(archive_results(tmp_path / "run")["ok"]) == 24  # nothing of batch 3
    with RunArchive(tmp_path / "run") as a:
        assert "fault of the machinery in batch 3" in a.meta()["stop_reason"]
    good = make_problem("Sphere", dim=4)
    r = optimize(
        good, make_strategy("cmaes", good, seed=5, popsize=8), 80, run_dir=tmp_path / "run"
    )
    assert r.n_resumed == 24 and r.n_evaluations == 80
    assert_same_archive(ref, tmp_path / "run")


def test_a_memory_error_is_not_a_design_failure():
    class Greedy(NaNSometimes):
        def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
            raise MemoryError("cannot allocate 8 GiB")

    with pytest.raises(MemoryError):
        Greedy().evaluate(np.array([[0.1, 0.1], [0.2, 0.2]]))


# ----------------------------------------------------------- lost pool workers
def test_a_killed_pool_worker_is_retried_and_the_archive_equals_the_reference(tmp_path):
    budget = 240
    ref = reference_run(tmp_path, budget)
    p = make_problem("Sphere", dim=4, delay_s=0.02)
    pool = ProcessPool(2)
    killed: list[int] = []

    def kill_one_worker() -> None:
        deadline = time.time() + 60
        while time.time() < deadline and not killed:
            time.sleep(0.02)
            path = tmp_path / "run" / "archive.sqlite"
            if not path.exists():
                continue
            with RunArchive(tmp_path / "run") as a:
                if len(a) < 40:
                    continue
            pids = pool.worker_pids()
            if pids:
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])

    killer = threading.Thread(target=kill_one_worker)
    killer.start()
    try:
        r = optimize(
            p,
            make_strategy("cmaes", p, seed=5, popsize=8),
            budget,
            run_dir=tmp_path / "run",
            executor=pool,
            workers=2,
            chunk_size=2,
            faults=FaultPolicy(timeout_s=10.0, retries=3, backoff_s=0.1),
        )
    finally:
        killer.join()
        pool.shutdown()
    assert killed, "no worker was killed: the test did not exercise the fault"
    assert r.n_evaluations == budget
    arr = archive_results(tmp_path / "run")
    assert arr["ok"].all(), "a lost worker was archived as a failed design"
    assert_same_archive(ref, tmp_path / "run")


# ------------------------------------------------- run directories and configs
SPHERE = """
name = "faults"
seed = 5
budget = {budget}

[problem]
name = "Sphere"
options = {{ dim = 4, delay_s = {delay} }}

[strategy]
name = "cmaes"
options = {{ popsize = 8 }}

[run]
output = "{output}"
plots = false
progress = false
"""


def write_config(tmp_path: Path, budget: int = 80, delay: float = 0.0) -> Path:
    path = tmp_path / "faults.toml"
    path.write_text(SPHERE.format(budget=budget, delay=delay, output=tmp_path / "runs"))
    return path


def test_a_second_run_into_a_busy_run_directory_is_refused(tmp_path):
    cfg = load_config(write_config(tmp_path))
    with (
        locked(tmp_path / "runs" / "faults-seed5"),
        pytest.raises(ValidationError, match=r"is in use by another run \(pid \d+"),
    ):
        run_experiment(cfg)


def test_a_bad_option_leaves_no_run_directory_and_the_fix_runs(tmp_path):
    path = write_config(tmp_path)
    bad = load_config(path, ["strategy.options.popsize=1"])
    with pytest.raises(ValidationError, match="popsize"):
        run_experiment(bad)
    assert not (tmp_path / "runs").exists()
    run_dir, summary = run_experiment(load_config(path))
    assert summary["n_evaluations"] == 80


def test_a_run_directory_without_results_is_replaced(tmp_path):
    path = write_config(tmp_path)
    run_dir = tmp_path / "runs" / "faults-seed5"
    run_dir.mkdir(parents=True)
    (run_dir / "config.resolved.toml").write_text('name = "faults"\nseed = 5\nbudget = 1\n')
    _, summary = run_experiment(load_config(path))
    assert summary["n_evaluations"] == 80


def test_resolved_config_holds_the_fault_policy(tmp_path):
    run_dir, _ = run_experiment(load_config(write_config(tmp_path)))
    text = (run_dir / "config.resolved.toml").read_text()
    assert "timeout_s = 60.0" in text and "retries = 3" in text


@pytest.mark.parametrize(
    ("override", "needle"),
    [
        ("run.timeout_s=0", "`run.timeout_s > 0` must hold, but got run.timeout_s=0"),
        ("run.timeout_s=inf", "`run.timeout_s` must be a finite number with `run.timeout_s > 0`"),
        ("run.retries=-1", "`0 <= run.retries <= 100` must hold, but got run.retries=-1"),
        ("run.retries=2.5", "`run.retries` must be an integer with `0 <= run.retries <= 100`"),
        ("run.retry_backoff_s=nan", "`run.retry_backoff_s` must be a finite number"),
        ("run.chunk_size=0", "run.chunk_size"),
        ("run.plots=2", "run.plots"),
        ("run.dask_scheduler=8786", "run.dask_scheduler"),
        ("run.timeuot_s=3", "did you mean 'timeout_s'"),
        ("problem.optons={}", "did you mean 'options'"),
        ("strategy.option={}", "did you mean 'options'"),
    ],
)
def test_run_table_rules_are_checked_when_the_config_is_loaded(tmp_path, override, needle):
    with pytest.raises(ValidationError) as err:
        load_config(write_config(tmp_path), [override])
    assert needle in str(err.value)


# ------------------------------------------- the main process dies: no orphans
def _children(pid: int) -> list[int]:
    """Process ids whose parent is ``pid`` (Linux /proc)."""
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        if int(fields[1]) == pid:
            out.append(int(entry.name))
    return out


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_killing_the_main_process_kills_its_workers_and_resume_equals_reference(tmp_path):
    budget = 240
    ref = reference_run(tmp_path, budget)
    path = write_config(tmp_path, budget=budget, delay=0.02)
    script = textwrap.dedent(f"""
        import sys
        from suspenv.cli.main import main
        sys.exit(main(["run", {str(path)!r}, "--workers", "2", "--set", "run.chunk_size=2"]))
    """)
    proc = subprocess.Popen([sys.executable, "-c", script])
    run_dir = tmp_path / "runs" / "faults-seed5"
    workers: list[int] = []
    deadline = time.time() + 90
    while time.time() < deadline:
        time.sleep(0.05)
        if (run_dir / "archive.sqlite").exists():
            with RunArchive(run_dir) as a:
                if len(a) >= 40:
                    workers = _children(proc.pid)
                    break
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert workers, "the run had no pool workers when it was killed"
    time.sleep(3.0)  # the parent-watch polls every 0.5 s; SIGKILL on parent death is at once
    assert not [w for w in workers if _alive(w)], "pool workers outlived their parent"
    _, summary = run_experiment(load_config(path))
    assert summary["n_resumed"] >= 40 and summary["n_evaluations"] == budget
    assert_same_archive(ref, run_dir)


# ---------------------------------------------------- the Dask scheduler dies
def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _start_dask(port: int, log: Path) -> list[subprocess.Popen]:
    fh = log.open("a")
    scheduler = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "distributed.cli.dask_scheduler",
            "--host",
            "127.0.0.1",
            "--port",
            str(port),
            "--dashboard-address",
            ":0",
            "--no-show",
        ],
        stdout=fh,
        stderr=fh,
    )
    worker = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "distributed.cli.dask_worker",
            f"tcp://127.0.0.1:{port}",
            "--nthreads",
            "1",
            "--nworkers",
            "1",
            "--no-dashboard",
            "--memory-limit",
            "0",
        ],
        stdout=fh,
        stderr=fh,
    )
    return [scheduler, worker]


@pytest.mark.slow
def test_a_killed_dask_scheduler_stops_the_run_and_resume_equals_reference(tmp_path):
    """The scheduler is killed mid-run with an evaluation timeout of 10 minutes: the run
    must notice by the client's connection (SCHEDULER_GRACE_S = 10 s, polled every
    HEARTBEAT_S), not by the timeout, and exit non-zero well within 60 s."""
    pytest.importorskip("distributed")
    budget = 240
    ref = reference_run(tmp_path, budget)
    path = write_config(tmp_path, budget=budget, delay=0.05)
    port = _free_port()
    procs = _start_dask(port, tmp_path / "dask.log")
    try:
        time.sleep(4.0)
        cmd = [
            sys.executable,
            "-m",
            "suspenv.cli.main",
            "run",
            str(path),
            "--dask",
            f"tcp://127.0.0.1:{port}",
            "--set",
            "run.retries=3",
            "--set",
            "run.retry_backoff_s=2",
            "--set",
            "run.timeout_s=600",
        ]
        run = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)
        run_dir = tmp_path / "runs" / "faults-seed5"
        deadline = time.time() + 120
        while time.time() < deadline and run.poll() is None:
            time.sleep(0.05)
            if (run_dir / "archive.sqlite").exists():
                with RunArchive(run_dir) as a:
                    if len(a) >= 40:
                        break
        procs[0].kill()  # the scheduler
        killed = time.monotonic()
        _, err = run.communicate(timeout=300)
        took = time.monotonic() - killed
    finally:
        for p in procs:
            p.kill()
            p.wait()
    assert run.returncode != 0, "the run exited 0 although its scheduler died"
    assert took < 60.0, f"the run took {took:.0f} s to stop after its scheduler died"
    assert "run the same command again to resume" in err
    assert "is unreachable" in err and "Traceback" not in err, err
    arr = archive_results(run_dir)
    assert arr["ok"].all() and len(arr["ok"]) < budget
    _, summary = run_experiment(load_config(path))  # in-process: `run` may differ on resume
    assert summary["n_evaluations"] == budget
    assert_same_archive(ref, run_dir)


class _Client:
    """Stands in for a Dask client: its executor is a thread pool, its status is set."""

    status = "running"

    def get_executor(self) -> ThreadPoolExecutor:
        self.pool = ThreadPoolExecutor(1)
        return self.pool


def test_a_lost_cluster_stops_the_wait_after_its_grace_not_the_timeout():
    from suspenv.runs.evaluation import evaluate_chunks
    from suspenv.runs.executors import DaskExecutor

    client = _Client()
    executor = DaskExecutor(client, "tcp://127.0.0.1:1", grace_s=1.0)
    p = make_problem("Sphere", dim=2, delay_s=10.0)  # longer than the bound below
    chunks = evaluate_chunks(
        p, np.zeros((1, 2)), np.arange(1), executor, 1, 1, FaultPolicy(timeout_s=600.0)
    )
    threading.Timer(0.5, setattr, (client, "status", "connecting")).start()
    t0 = time.monotonic()
    with pytest.raises(InfrastructureError, match="scheduler tcp://127.0.0.1:1 is unreachable"):
        next(chunks)
    assert time.monotonic() - t0 < 8.0  # grace 1 s + HEARTBEAT_S 1 s, with margin
    client.pool.shutdown(wait=False, cancel_futures=True)


def test_two_optimize_calls_into_one_archive_are_refused(tmp_path):
    p = make_problem("Sphere", dim=2)
    with (
        locked(tmp_path, ".archive.lock"),
        pytest.raises(ValidationError, match="archive folder .* is in use by another run"),
    ):
        optimize(p, make_strategy("random", p, seed=1, batch_size=2), 4, run_dir=tmp_path)
    assert not (tmp_path / "archive.sqlite").exists()
