"""The archive's group commits: what a kill, an error or Ctrl-C leaves, and that resume
stays exact; the worker-side problem cache of pooled evaluation; default chunking."""

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from suspenv import make_problem
from suspenv.core import EvaluationBatch
from suspenv.registry import make_strategy
from suspenv.runs import evaluation
from suspenv.runs.archive import ArchiveWriter, RunArchive
from suspenv.runs.evaluation import default_chunk
from suspenv.runs.loop import optimize


def _chunk(b, n=4, d=3, first=0):
    U = np.full((n, d), 0.25 + 0.01 * b)
    res = EvaluationBatch(U[:, :1].copy(), np.zeros((n, 0)), np.ones(n, bool), [""] * n)
    return b, list(range(first, first + n)), U, 2 * U - 1, res


def test_cheap_chunks_are_committed_together_and_an_expensive_one_at_once(tmp_path):
    with RunArchive(tmp_path) as archive:
        w = ArchiveWriter(archive, commit_after_s=3600.0)
        for b in range(5):
            w.append(*_chunk(b), 0.001)
        assert len(archive) == 0 and w.pending == 20  # cheap: waiting for the group commit
        w.append(*_chunk(5), 3600.0)  # as expensive as the commit interval: committed now
        assert len(archive) == 24 and w.pending == 0
        w.append(*_chunk(6), 0.001)
        w.flush()
        arr = archive.arrays()
    assert len(arr["ok"]) == 28
    assert arr["batch"].tolist() == [b for b in range(7) for _ in range(4)]
    np.testing.assert_array_equal(arr["unit"][::4, 0], 0.25 + 0.01 * np.arange(7))


def test_a_chunk_with_a_gap_in_its_rows_reads_back_row_by_row(tmp_path):
    # a resume evaluates a batch's gaps: rows 0, 2, 3 of batch 0 in one chunk (two SQLite
    # rows); reference: the values handed over, the wall time shared equally
    b, _, U, X, res = _chunk(0, n=3)
    U[:, 0] = [0.1, 0.2, 0.3]
    with RunArchive(tmp_path) as archive:
        w = ArchiveWriter(archive, commit_after_s=3600.0)
        w.append(b, [0, 2, 3], U, X, res, 0.3)
        U[:] = -1.0  # the caller reuses its array: the archive keeps what was handed over
        w.flush()
        got = archive.batch(0)
        arr = archive.arrays()
    assert sorted(got) == [0, 2, 3]
    np.testing.assert_array_equal([got[r][0][0] for r in (0, 2, 3)], [0.1, 0.2, 0.3])
    assert arr["row"].tolist() == [0, 2, 3]
    np.testing.assert_allclose(arr["wall_time"], [0.1, 0.1, 0.1], rtol=1e-15)


def test_a_group_commit_is_all_or_nothing(tmp_path):
    # reference: the rows committed before; a transaction that fails half-way (a duplicate
    # (batch, row) in its third chunk) leaves none of its chunks behind
    with RunArchive(tmp_path) as archive:
        archive.append(*_chunk(0), 0.01)
        with pytest.raises(Exception, match="UNIQUE"):
            archive.append_chunks([(*_chunk(1), 0.01), (*_chunk(2), 0.01), (*_chunk(0), 0.01)])
        arr = archive.arrays()
    assert arr["batch"].tolist() == [0, 0, 0, 0]


def test_an_error_in_a_callback_commits_everything_evaluated_and_resume_is_exact(tmp_path):
    p = make_problem("Sphere", dim=4)

    def boom(b, U, batch):
        if b == 6:
            raise RuntimeError("user callback failed")

    with pytest.raises(RuntimeError, match="user callback failed"):
        optimize(
            p,
            make_strategy("cmaes", p, seed=4, popsize=6),
            120,
            run_dir=tmp_path / "run",
            callbacks=[boom],
        )
    with RunArchive(tmp_path / "run") as a:
        assert len(a) == 7 * 6  # batches 0..6 were evaluated: all committed, none lost
    r = optimize(p, make_strategy("cmaes", p, seed=4, popsize=6), 120, run_dir=tmp_path / "run")
    ref = optimize(p, make_strategy("cmaes", p, seed=4, popsize=6), 120, run_dir=tmp_path / "ref")
    assert r.n_resumed == 42 and r.n_evaluations == ref.n_evaluations == 120
    with RunArchive(tmp_path / "run") as a, RunArchive(tmp_path / "ref") as b:
        np.testing.assert_array_equal(a.arrays()["objectives"], b.arrays()["objectives"])
        np.testing.assert_array_equal(a.arrays()["unit"], b.arrays()["unit"])


def test_ctrl_c_commits_everything_evaluated(tmp_path):
    p = make_problem("Sphere", dim=3)
    seen = []

    def interrupt(b, U, batch):
        seen.append(b)
        if b == 9:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        optimize(
            p,
            make_strategy("random", p, seed=1, batch_size=5),
            500,
            run_dir=tmp_path,
            callbacks=[interrupt],
        )
    with RunArchive(tmp_path) as a:
        assert len(a) == 50 and a.meta()["n_evaluations"] == 45  # 10 batches evaluated


@pytest.mark.parametrize("seconds", [0.3, 0.8, 1.5])
def test_a_kill_during_group_commits_leaves_whole_batches_and_resume_is_exact(tmp_path, seconds):
    # cheap evaluations (many batches per group commit), killed at a few points in time
    # (the first before the first group commit);
    # reference: an uninterrupted run with the same seed, compared row by row
    run_dir = tmp_path / "run"
    script = textwrap.dedent(f"""
        import sys
        from suspenv import make_problem
        from suspenv.registry import make_strategy
        from suspenv.runs.loop import optimize
        p = make_problem("ZDT1", dim=5)
        print("start", flush=True)
        optimize(p, make_strategy("pymoo_nsga2", p, seed=3, population_size=10),
                 budget=1_000_000, run_dir={str(run_dir)!r})
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "start"
    deadline = time.time() + 60
    while time.time() < deadline and not (run_dir / "archive.sqlite").exists():
        time.sleep(0.01)
    time.sleep(seconds)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    with RunArchive(run_dir) as a:
        arr = a.arrays()
    n_killed = len(arr["ok"])
    assert n_killed < 1_000_000  # 0 when killed before the first group commit
    batches, counts = np.unique(arr["batch"], return_counts=True)
    assert (counts == 10).all()  # whole batches only (in-process: one chunk per batch)
    assert batches.tolist() == list(range(len(batches)))  # and no gap

    p = make_problem("ZDT1", dim=5)
    budget = n_killed + 50

    def strategy():  # never stops by itself; what it asks depends on every result told
        return make_strategy("pymoo_nsga2", p, seed=3, population_size=10)

    r = optimize(p, strategy(), budget, run_dir=run_dir)
    assert r.n_resumed == n_killed and r.n_evaluations == budget
    ref_dir = tmp_path / "ref"
    optimize(p, strategy(), budget, run_dir=ref_dir)
    with RunArchive(run_dir) as a, RunArchive(ref_dir) as b:
        got, ref = a.arrays(), b.arrays()
    for key in ("unit", "x", "objectives", "batch", "row"):
        np.testing.assert_array_equal(got[key], ref[key])


def test_a_kill_loses_at_most_the_commit_interval(tmp_path):
    # the run reports each batch's end on stdout; after the kill the archive holds every
    # batch that ended COMMIT_AFTER_S (plus a margin for a loaded machine) before the kill
    run_dir = tmp_path / "run"
    script = textwrap.dedent(f"""
        import sys, time
        from suspenv import make_problem
        from suspenv.registry import make_strategy
        from suspenv.runs.loop import optimize
        p = make_problem("Sphere", dim=3, delay_s=0.01)
        def said(b, U, batch):
            print(b, time.time(), flush=True)
        optimize(p, make_strategy("random", p, seed=1, batch_size=4), budget=10_000,
                 run_dir={str(run_dir)!r}, callbacks=[said])
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    ends: list[tuple[int, float]] = []

    def read() -> None:
        for line in proc.stdout:
            b, t = line.split()
            ends.append((int(b), float(t)))

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    deadline = time.time() + 60
    while time.time() < deadline and len(ends) < 400:
        time.sleep(0.01)
    killed_at = time.time()
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    reader.join(5)
    with RunArchive(run_dir) as a:
        n = len(a)
    margin = ArchiveWriter.COMMIT_AFTER_S + 1.5
    must_have = [b for b, t in ends if t < killed_at - margin]
    assert must_have, "the run did not get far enough to test anything"
    assert n >= 4 * (max(must_have) + 1)


def test_pooled_evaluation_unpickles_the_problem_once_per_worker():
    p = make_problem("Sphere", dim=3)
    key, payload = evaluation._shipped(p)
    X = np.full((2, 3), 0.1)
    evaluation._WORKER_PROBLEMS.clear()
    a = evaluation._evaluate_shipped(key, payload, X)
    cached = evaluation._WORKER_PROBLEMS[key]
    b = evaluation._evaluate_shipped(key, payload, X)
    assert evaluation._WORKER_PROBLEMS[key] is cached and cached is not p
    np.testing.assert_array_equal(a.objectives, b.objectives)
    np.testing.assert_array_equal(a.objectives, p.evaluate(X).objectives)
    # a problem whose state changed is another entry
    key2, _ = evaluation._shipped(make_problem("Sphere", dim=3, delay_s=0.001))
    assert key2 != key


def test_an_unpicklable_problem_still_runs_on_a_thread_pool(tmp_path):
    p = make_problem("Sphere", dim=3)
    p.unpicklable = threading.Lock()  # a thread pool never pickles
    ref = optimize(p, make_strategy("cmaes", p, seed=2, popsize=6), 60)
    with ThreadPoolExecutor(2) as pool:
        r = optimize(
            p,
            make_strategy("cmaes", p, seed=2, popsize=6),
            60,
            executor=pool,
            workers=2,
            run_dir=tmp_path,
        )
    assert r.best_objectives == ref.best_objectives


def test_default_chunking_is_one_chunk_per_worker_per_batch():
    assert default_chunk(42, 1) == 42
    assert default_chunk(42, 2) == 21
    assert default_chunk(43, 2) == 22
    assert default_chunk(3, 8) == 1
