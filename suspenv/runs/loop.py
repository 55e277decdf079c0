"""The one ask -> evaluate -> archive -> tell loop.

Example::

    from suspenv import make_problem
    from suspenv.registry import make_strategy
    from suspenv.runs.loop import optimize

    problem = make_problem("Sphere", dim=10)
    strategy = make_strategy("cmaes", problem, seed=1)
    result = optimize(problem, strategy, budget=2000, run_dir="runs/sphere")

Rules:
- ``budget`` counts evaluations. Batches are never truncated: the loop stops before a
  batch that would not fit in what is left of the budget (stop reason says so); a budget
  smaller than the first batch is a ValidationError (the run would evaluate nothing).
- Evaluation goes through any :class:`concurrent.futures.Executor` (in-process when
  None): each batch is split into chunks (default: one per worker), and every chunk is
  handed to the archive's :class:`~suspenv.runs.archive.ArchiveWriter` as it completes
  (its group commits say what a kill loses; resume evaluates that again).
- Resuming: pass the run directory of a run that died. The strategy, rebuilt with the
  same seed and options, is replayed against the archive: archived designs are told
  again, not re-evaluated; only the missing rows of a partly evaluated batch are run.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from suspenv.core.errors import InfrastructureError, ValidationError
from suspenv.core.options import integer
from suspenv.core.problem import Problem
from suspenv.core.result import EvaluationBatch
from suspenv.runs import quality as run_quality
from suspenv.runs.archive import ArchiveWriter, Chunk, RunArchive
from suspenv.runs.evaluation import (
    FaultPolicy,
    alarm_handler,
    default_chunk,
    evaluate_chunks,
)
from suspenv.runs.run_dir import locked
from suspenv.runs.versions import package_versions

#: lock file beside an archive while a run writes it (the run directory's own lock,
#: ``.lock``, is held by :func:`suspenv.runs.runner.run_experiment` around a whole pipeline)
ARCHIVE_LOCK = ".archive.lock"

BatchCallback = Callable[[int, np.ndarray, EvaluationBatch], None]


class Recorder(Protocol):
    """Receives every evaluated chunk as soon as it completes (before the strategy is told).

    :class:`~suspenv.runs.archive.RunArchive` is the standard recorder.
    """

    def append(self, *chunk: *Chunk) -> None:
        """One :data:`~suspenv.runs.archive.Chunk`: (batch index, rows in the batch, U,
        X, results, seconds its evaluation took)."""


@dataclass
class RunResult:
    """What a finished (or stopped) run reports."""

    n_evaluations: int
    n_batches: int
    stop_reason: str
    wall_time: float
    n_resumed: int = 0
    #: the best feasible evaluation by the problem's quality (:mod:`suspenv.runs.quality`);
    #: None when there is none, and always for several objectives without a quality
    best_index: int | None = None
    best_x: dict[str, float] | None = None
    best_objectives: list[float] | None = None

    def as_dict(self) -> dict[str, Any]:
        return {
            "n_evaluations": self.n_evaluations,
            "n_batches": self.n_batches,
            "stop_reason": self.stop_reason,
            "wall_time_s": self.wall_time,
            "n_resumed": self.n_resumed,
            "best_index": self.best_index,
            "best_x": self.best_x,
            "best_objectives": self.best_objectives,
        }


def optimize(
    problem: Problem,
    strategy: Any,
    budget: int,
    *,
    run_dir: str | Path | None = None,
    seed: int | None = None,
    executor: Executor | None = None,
    workers: int = 1,
    chunk_size: int | None = None,
    progress: bool = False,
    callbacks: Sequence[BatchCallback] = (),
    recorders: Sequence[Recorder] = (),
    meta: dict[str, Any] | None = None,
    faults: FaultPolicy | None = None,
) -> RunResult:
    """Run ``strategy`` on ``problem`` for at most ``budget`` evaluations.

    Args:
        problem: the problem (evaluates physical batches).
        strategy: anything with ``ask() -> U``, ``tell(U, batch)``, ``stop() -> str|None``.
        budget: maximum number of evaluations (>= 1).
        run_dir: where the archive lives; an existing archive is resumed. None: no archive.
        seed: recorded with the run (the strategy was built with it).
        executor: a ``concurrent.futures.Executor`` for the evaluations (None: in-process).
        workers: evaluations the executor runs at once, as its owner configured it (the
            loop does not ask the executor); sets the default chunk size.
        chunk_size: designs per executor task (default: one chunk per worker, since
            vectorised problems pay a fixed cost per call).
        progress: show a progress bar on stderr.
        callbacks: called as ``cb(batch_index, U, batch)`` after each tell.
        recorders: extra :class:`Recorder` objects (the run directory's archive is one).
        meta: extra items stored in the archive's meta table.
        faults: timeout and retries for faults of the machinery (default: the problem's
            ``timeout_s``, 3 retries); see :mod:`suspenv.runs.evaluation`. When retries are
            spent, :class:`~suspenv.core.errors.InfrastructureError` ends the run; the
            archive keeps every evaluation done, and calling again resumes.
    """
    budget = integer("optimize", "budget", budget, lo=1)
    workers = integer("optimize", "workers", workers, lo=1)
    policy = faults if faults is not None else FaultPolicy(timeout_s=problem.timeout_s)
    with contextlib.ExitStack() as stack:
        if run_dir is not None:
            folder = Path(run_dir)
            if not folder.is_dir() and folder.suffix:  # a file path: RunArchive's rule
                folder = folder.parent
            stack.enter_context(locked(folder, ARCHIVE_LOCK, "archive folder"))
        if executor is None:
            stack.enter_context(alarm_handler())  # the timeout's handler, once per run
        archive, writer = _open_archive(run_dir, problem, strategy, seed, budget, policy, meta)
        bar = _progress_bar(problem, budget) if progress else None
        receivers = [*recorders] if writer is None else [writer, *recorders]
        evaluator = _Evaluator(problem, executor, workers, chunk_size, policy, receivers, bar)
        return _optimize(problem, strategy, budget, archive, writer, evaluator, callbacks)


def _beyond_budget(n: int, used: int, budget: int) -> str:
    """The stop reason when a batch of ``n`` would not fit in what is left of the budget
    ('' when it fits); a ValidationError when not even the first batch fits (the run
    would evaluate nothing)."""
    if used + n <= budget:
        return ""
    if used == 0:
        raise ValidationError(
            f"`budget >= the first batch` must hold, but budget={budget} is smaller than "
            f"the strategy's first batch of {n} designs: nothing would be evaluated; give "
            f"a budget of at least {n}, or a smaller batch"
        )
    return (
        f"budget: the next batch of {n} would exceed the budget ({used} of {budget} "
        "used); batches are never truncated"
    )


def _close(archive: RunArchive, writer: ArchiveWriter | None, **meta: Any) -> None:
    """Commit every evaluation handed over (a clean stop, an error or Ctrl-C lose
    nothing), record ``meta`` and close the archive, even when a write fails (a full
    disk: the failure is raised after the archive is closed)."""
    try:
        if writer is not None:
            writer.flush()
        archive.set_meta(**meta)
    finally:
        archive.close()


@dataclass
class _Tally:
    """What a run has done so far: evaluations, batches and the best feasible design by
    the problem's quality (none for several objectives without one:
    :mod:`suspenv.runs.quality`)."""

    used: int = 0
    resumed: int = 0
    batches: int = 0
    stop_reason: str = ""
    best: float = math.inf
    best_index: int | None = None
    best_objectives: list[float] | None = None
    best_x: np.ndarray | None = None

    def result(self, problem: Problem, wall: float) -> RunResult:
        """The run's report after ``wall`` seconds (the best design by parameter name)."""
        return RunResult(
            n_evaluations=self.used,
            n_batches=self.batches,
            stop_reason=self.stop_reason,
            wall_time=wall,
            n_resumed=self.resumed,
            best_index=self.best_index,
            best_objectives=self.best_objectives,
            best_x=None if self.best_x is None else problem.space.as_dict(self.best_x),
        )

    def record(self, problem: Problem, batch: EvaluationBatch, X: np.ndarray) -> None:
        """Take the best of a batch just told (rows ``X``)."""
        F = batch.objectives
        q = run_quality.quality(problem, F)
        i = None if q is None else run_quality.best_row(q, batch.feasible)
        if q is not None and i is not None and q[i] < self.best:
            self.best, self.best_index = float(q[i]), self.used + i
            self.best_objectives, self.best_x = F[i].tolist(), X[i].copy()


@dataclass
class _Evaluator:
    """Evaluates the rows of a batch not in the archive, handing every chunk to the
    recorders (the archive's writer first) and the progress bar as it completes."""

    problem: Problem
    executor: Executor | None
    workers: int
    chunk_size: int | None
    policy: FaultPolicy
    recorders: Sequence[Recorder]
    bar: Any

    def batch(
        self,
        b: int,
        U: np.ndarray,
        X: np.ndarray,
        results: list[EvaluationBatch | None],
        replayed: int,
    ) -> EvaluationBatch:
        """Batch ``b`` (unit rows ``U``, physical rows ``X``) with the ``replayed`` rows
        of ``results`` (archived, the others None) evaluated no more."""
        n = len(U)
        todo = (
            np.arange(n)
            if not replayed
            else np.array([r for r in range(n) if results[r] is None], dtype=int)
        )
        parts: list[tuple[list[int], EvaluationBatch]] = []
        if todo.size:
            chunk = self.chunk_size or default_chunk(todo.size, self.workers)
            chunks = evaluate_chunks(
                self.problem,
                X[todo] if replayed else X,
                todo,
                self.executor,
                chunk,
                self.workers,
                self.policy,
            )
            for rows, res, secs in chunks:
                self._hand_over(b, rows, U, X, res, secs)
                parts.append((rows, res))
        if self.bar is not None and replayed:
            self.bar.update(replayed)
        if not replayed and len(parts) == 1:
            return parts[0][1]  # one chunk, in order: nothing to assemble
        for rows, res in parts:
            for j, r in enumerate(rows):
                results[r] = res.take([j])
        return EvaluationBatch.concatenate(results)  # type: ignore[arg-type]

    def _hand_over(
        self,
        b: int,
        rows: list[int],
        U: np.ndarray,
        X: np.ndarray,
        res: EvaluationBatch,
        secs: float,
    ) -> None:
        """One evaluated chunk to the recorders and the progress bar."""
        if len(rows) == len(U):  # the whole batch in order: no fancy-index copies
            u_rows, x_rows = U, X
        else:
            u_rows, x_rows = U[rows], X[rows]
        for rec in self.recorders:
            rec.append(b, rows, u_rows, x_rows, res, secs)
        if self.bar is not None:
            self.bar.update(len(rows))


def _open_archive(
    run_dir: str | Path | None,
    problem: Problem,
    strategy: Any,
    seed: int | None,
    budget: int,
    policy: FaultPolicy,
    meta: dict[str, Any] | None,
) -> tuple[RunArchive | None, ArchiveWriter | None]:
    """The run directory's archive (count checked, the run's description recorded in
    its meta) and its writer; (None, None) without a run directory."""
    if run_dir is None:
        return None, None
    archive = RunArchive(run_dir)
    archive.check_count(archive.meta().get("n_evaluations"), "its meta")
    archive.set_meta(
        problem=getattr(problem, "name", type(problem).__name__),
        parameter_names=list(problem.space.names),
        parameter_units=list(problem.space.units),
        objective_names=list(problem.objective_names),
        objective_units=list(getattr(problem, "objective_units", ()) or ()),
        constraint_names=list(problem.constraint_names),
        strategy=getattr(strategy, "name", type(strategy).__name__),
        seed=seed,
        budget=budget,
        versions=package_versions(),
        faults=policy.as_dict(),
        **(meta or {}),
    )
    return archive, ArchiveWriter(archive)


def _progress_bar(problem: Problem, budget: int) -> Any:
    """A tqdm progress bar over the budget's evaluations."""
    from tqdm.auto import tqdm

    return tqdm(
        total=budget,
        unit="eval",
        desc=getattr(problem, "name", "run"),
        dynamic_ncols=True,
        leave=True,
    )


def _replayed(
    problem: Problem,
    archive: RunArchive | None,
    b: int,
    U: np.ndarray,
    done: dict[int, Any],
) -> list[EvaluationBatch | None]:
    """The results of batch ``b`` as far as the archive holds them (``done``: row ->
    (archived unit row, result)); None for the rows still to evaluate. A ValidationError
    when an archived design is not the one the strategy asks now."""
    results: list[EvaluationBatch | None] = [None] * len(U)
    for r, (u_arch, res) in done.items():
        if r >= len(U) or not np.allclose(u_arch, U[r], rtol=0, atol=1e-12):
            assert archive is not None  # invariant: `done` is empty without an archive
            raise ValidationError(
                f"resume: archived design (batch {b}, row {r}) differs from what the "
                "strategy asks now; the seed, strategy options or problem changed. "
                f"Use a new run directory (archive: {archive.path})"
            )
        results[r] = problem.with_scales(res)  # archived rows carry no scales
    return results


def _optimize(
    problem: Problem,
    strategy: Any,
    budget: int,
    archive: RunArchive | None,
    writer: ArchiveWriter | None,
    evaluator: _Evaluator,
    callbacks: Sequence[BatchCallback],
) -> RunResult:
    """The run of :func:`optimize` with its archive (None: no run directory) and
    evaluator open: the stop reason of an interruption or fault, the archive closed
    whatever happens."""
    bar = evaluator.bar
    t_start = time.perf_counter()
    run = _Tally()
    try:
        _run_batches(problem, strategy, budget, archive, evaluator, callbacks, run)
    except KeyboardInterrupt:
        run.stop_reason = (
            f"interrupted after {run.used} evaluations (archive kept; resume with same dir)"
        )
        raise
    except InfrastructureError as exc:
        run.stop_reason = f"fault of the machinery in batch {run.batches}: {exc}"
        raise InfrastructureError(
            f"run stopped in batch {run.batches} after {run.used} evaluations: {exc}. The "
            "archive keeps every evaluation done; run the same command again to resume"
        ) from None
    finally:
        if bar is not None:
            bar.close()
        wall = time.perf_counter() - t_start
        if archive is not None:
            _close(
                archive,
                writer,
                stop_reason=run.stop_reason,
                n_evaluations=run.used,
                wall_time_s=wall,
            )
    return run.result(problem, wall)


def _stop_reason(strategy: Any, used: int, budget: int) -> str:
    """Why the run stops before asking again: the strategy's reason, or the budget used
    up ('' to go on)."""
    reason = strategy.stop() or ""
    if not reason and used >= budget:
        reason = f"budget: {used} of {budget} evaluations used"
    return reason


def _run_batches(
    problem: Problem,
    strategy: Any,
    budget: int,
    archive: RunArchive | None,
    evaluator: _Evaluator,
    callbacks: Sequence[BatchCallback],
    run: _Tally,
) -> None:
    """Ask, evaluate (or replay from ``archive``), tell and record batch after batch
    until a stop reason is set in ``run``."""
    replaying = archive is not None
    while True:
        run.stop_reason = _stop_reason(strategy, run.used, budget)
        if run.stop_reason:
            return
        U = np.atleast_2d(strategy.ask())
        n = U.shape[0]
        run.stop_reason = _beyond_budget(n, run.used, budget)
        if run.stop_reason:
            return
        X = problem.space.to_physical(U)
        # replaying an archive: rows of batch b+1 exist only when batch b is complete,
        # so after the first batch without rows no later lookup can find any
        done = archive.batch(run.batches) if archive is not None and replaying else {}
        replaying = replaying and len(done) == n
        results = _replayed(problem, archive, run.batches, U, done)
        run.resumed += len(done)
        batch = evaluator.batch(run.batches, U, X, results, len(done))
        strategy.tell(U, batch)
        run.record(problem, batch, X)
        if evaluator.bar is not None and math.isfinite(run.best):
            evaluator.bar.set_postfix(best=f"{run.best:.4g}", refresh=False)
        for cb in callbacks:
            cb(run.batches, U, batch)
        run.used += n
        run.batches += 1
