"""Evaluating a batch through an executor, telling faults of the machinery from results.

The rule: :meth:`suspenv.core.problem.Problem.evaluate` turns every fault of a design (a
lock-up, a diverging solver, a non-finite objective) into a failed row, which is a result
and is archived. So any exception that still escapes an evaluation is a fault of the
machinery (a lost worker or scheduler, a timeout, memory) or of the problem's own code,
and it is never archived as the design's result. The chunk is retried
(:class:`FaultPolicy`: bounded, with back-off, on a fresh pool); when the retries are spent
the run stops with :class:`~suspenv.core.errors.InfrastructureError`, keeping every chunk
that did complete, so rerunning the same command evaluates exactly what is missing.

Timeouts: ``timeout_s`` bounds each design. A round of chunks on ``w`` workers may take
``timeout_s`` times the designs one worker gets (plus :data:`POOL_STARTUP_S` for a pool's
start and imports). In-process the limit is a ``SIGALRM`` timer, which works in the main
thread on POSIX and interrupts Python code (a simulator stuck inside one C call is
interrupted when the call returns); use ``workers >= 2`` for a hard limit, since a pool's
hung worker is killed.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import pickle
import signal
import sys
import threading
import time
from collections.abc import Iterator, Mapping
from concurrent.futures import FIRST_COMPLETED, CancelledError, Executor, Future, wait
from concurrent.futures import TimeoutError as FuturesTimeout
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from suspenv.core.errors import InfrastructureError
from suspenv.core.options import integer, number
from suspenv.core.problem import Problem
from suspenv.core.result import EvaluationBatch
from suspenv.runs.executors import HEARTBEAT_S, Connected, Restartable

#: seconds a process pool or cluster may add to a round of chunks (worker start, imports)
POOL_STARTUP_S = 30.0


class EvaluationTimeout(BaseException):  # noqa: N818 - a signal, like KeyboardInterrupt
    """Raised in the main thread when an in-process evaluation exceeds its time limit.

    A BaseException, so that ``Problem.evaluate`` (which turns every ``Exception`` into a
    failed row) cannot mistake the timeout for a fault of the design.
    """


@dataclass(frozen=True)
class FaultPolicy:
    """How faults of the machinery are retried.

    Attributes:
        timeout_s: seconds one design may take (> 0); see the module docstring.
        retries: times a faulty chunk is evaluated again (>= 0) before the run stops.
        backoff_s: seconds to wait before the first retry (>= 0); doubles for each next one.
    """

    timeout_s: float = 60.0
    retries: int = 3
    backoff_s: float = 1.0

    def __post_init__(self) -> None:
        # named as the keys of the [run] table; retries is kept as the int it stands for
        number("config", "run.timeout_s", self.timeout_s, lo=0.0, lo_open=True)
        retries = integer("config", "run.retries", self.retries, lo=0, hi=100)
        object.__setattr__(self, "retries", retries)
        number("config", "run.retry_backoff_s", self.backoff_s, lo=0.0, hi=3600.0)

    @classmethod
    def for_run(cls, run: Mapping[str, Any], problem: Problem) -> FaultPolicy:
        """The policy of a ``[run]`` table; ``timeout_s`` defaults to the problem's own
        :attr:`~suspenv.core.problem.Problem.timeout_s`."""
        timeout = run.get("timeout_s")
        return cls(
            timeout_s=problem.timeout_s if timeout is None else timeout,
            retries=run.get("retries", cls.retries),
            backoff_s=run.get("retry_backoff_s", cls.backoff_s),
        )

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    def pause(self, attempt: int) -> float:
        """Seconds to wait before retry number ``attempt`` (1, 2, ...)."""
        return self.backoff_s * 2.0 ** (attempt - 1)


#: (positions in the batch, their results, seconds since the batch started)
Yielded = tuple[list[int], EvaluationBatch, float]


def default_chunk(n: int, workers: int) -> int:
    """Designs per executor task when ``run.chunk_size`` is not set: one chunk per worker
    per batch, ``ceil(n / workers)``. A vectorised problem pays a fixed cost per call
    (Python set-up, solver start, the task's transport); more, smaller chunks would pay it
    again for every chunk without keeping more workers busy."""
    return max(1, math.ceil(n / max(int(workers), 1)))


#: problems a worker process has unpickled, by the digest of their pickle (see
#: :class:`_Shipped`); a few at most, the oldest dropped first
_WORKER_PROBLEMS: dict[str, Problem] = {}
_WORKER_PROBLEMS_MAX = 4


def _shipped(problem: Problem) -> tuple[str, bytes] | None:
    """``(key, payload)``: the problem pickled once for every chunk of a batch.

    ``executor.submit(problem.evaluate, X)`` would pickle the whole problem for every
    chunk, and the worker would unpickle a fresh copy each time, whose caches start cold.
    Instead the bytes are pickled once per batch; a worker unpickles them on its first
    chunk and keeps the problem for the next chunks, keyed by the bytes' digest (a problem
    whose state changed is a new entry). None when the problem cannot be pickled (a thread
    pool needs no pickle: the problem's own method is submitted then)."""
    try:
        payload = pickle.dumps(problem, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception:  # noqa: BLE001 - unpicklable: the executor decides (threads run it)
        return None
    return hashlib.blake2b(payload, digest_size=16).hexdigest(), payload


def _evaluate_shipped(key: str, payload: bytes, X: np.ndarray) -> Any:
    """Worker side of :func:`_shipped`: ``evaluate(X)`` of the problem cached in this
    process (unpickled on first use)."""
    problem = _WORKER_PROBLEMS.get(key)
    if problem is None:
        problem = pickle.loads(payload)
        while len(_WORKER_PROBLEMS) >= _WORKER_PROBLEMS_MAX:
            _WORKER_PROBLEMS.pop(next(iter(_WORKER_PROBLEMS)))
        _WORKER_PROBLEMS[key] = problem
    return problem.evaluate(X)


def evaluate_chunks(
    problem: Problem,
    X: np.ndarray,
    rows: np.ndarray,
    executor: Executor | None,
    chunk: int,
    workers: int,
    policy: FaultPolicy,
) -> Iterator[Yielded]:
    """Yield ``(rows, EvaluationBatch, seconds)`` per chunk as chunks complete.

    ``rows`` are the positions of ``X``'s designs in their batch. Faulty chunks are retried
    per ``policy``; raises :class:`InfrastructureError` when retries are spent (chunks
    yielded before stay yielded: the caller archives them as they come).
    """
    if executor is None:
        yield from _in_process(problem, X, rows, policy)
        return
    pending = [slice(i, i + chunk) for i in range(0, len(rows), chunk)]
    t0 = time.perf_counter()
    shipped = _shipped(problem)
    attempt = 0
    while True:
        rounds = math.ceil(len(pending) / max(workers, 1))
        limit = policy.timeout_s * chunk * rounds + POOL_STARTUP_S
        futures, faults, failed = _submit(executor, problem, shipped, X, pending)
        yield from _collect(futures, limit, executor, rows, t0, policy, faults, failed)
        if not failed:
            return
        if isinstance(executor, Connected) and (lost := executor.lost()):
            raise InfrastructureError(lost)
        attempt += 1
        n_rows = sum(len(rows[s]) for s in failed)
        _retry_or_raise(
            policy, attempt, n_rows, faults, f"{n_rows} design(s) hit a fault of the machinery"
        )
        if isinstance(executor, Restartable):
            executor.restart()
        time.sleep(policy.pause(attempt))
        pending = failed


def _submit(
    executor: Executor,
    problem: Problem,
    shipped: tuple[str, bytes] | None,
    X: np.ndarray,
    pending: list[slice],
) -> tuple[dict[Future[Any], slice], list[str], list[slice]]:
    """Submit the ``pending`` chunks of ``X``: (future -> chunk, faults, chunks that
    could not be submitted)."""
    futures: dict[Future[Any], slice] = {}
    faults: list[str] = []
    failed: list[slice] = []
    for s in pending:
        try:
            fut = (
                executor.submit(problem.evaluate, X[s])
                if shipped is None
                else executor.submit(_evaluate_shipped, *shipped, X[s])
            )
            futures[fut] = s
        except Exception as exc:  # noqa: BLE001 - a closed or lost executor
            faults.append(_describe(exc))
            failed.append(s)
    return futures, faults, failed


def _collect(
    futures: dict[Future[Any], slice],
    limit: float,
    executor: Executor,
    rows: np.ndarray,
    t0: float,
    policy: FaultPolicy,
    faults: list[str],
    failed: list[slice],
) -> Iterator[Yielded]:
    """Yield each chunk of ``futures`` that succeeds within ``limit`` seconds as it
    completes; the faults and the chunks to retry are appended to ``faults`` and
    ``failed``."""
    handled: set[Future[Any]] = set()
    try:
        for fut in _completed(futures, limit, executor):
            handled.add(fut)
            s = futures[fut]
            res, fault = _outcome(fut)
            if res is None:
                faults.append(fault)
                failed.append(s)
                continue
            yield rows[s].tolist(), res, time.perf_counter() - t0
    except FuturesTimeout:
        late = [f for f in futures if f not in handled]
        for fut in late:
            s = futures[fut]
            res, fault = _outcome(fut) if fut.done() else (None, "")
            if res is not None:  # finished just as time ran out
                yield rows[s].tolist(), res, time.perf_counter() - t0
                continue
            fut.cancel()
            failed.append(s)
        faults.append(
            f"timeout: not done within {limit:.0f} s ({policy.timeout_s:g} s per design, "
            f"run.timeout_s)"
        )


def _retry_or_raise(
    policy: FaultPolicy, attempt: int, n_rows: int, faults: list[str], what: str
) -> None:
    """After a faulty ``attempt`` at ``n_rows`` designs: :class:`InfrastructureError`
    naming every distinct fault when ``policy``'s retries are spent, else a warning
    (``what`` happened, the first fault, when the retry comes)."""
    if attempt > policy.retries:
        raise InfrastructureError(
            f"{n_rows} design(s) could not be evaluated after {attempt} attempt(s) "
            f"({'; '.join(dict.fromkeys(faults))}); none of them was archived"
        ) from None
    fault = f"{what} ({faults[0]})" if what else faults[0]
    retry = f"retry {attempt} of {policy.retries} in {policy.pause(attempt):g} s"
    print(f"suspenv: {fault}; {retry}", file=sys.stderr, flush=True)


def _completed(
    futures: dict[Future[Any], slice], limit: float, executor: Executor
) -> Iterator[Future[Any]]:
    """``as_completed(futures, timeout=limit)`` that also checks, every
    :data:`~suspenv.runs.executors.HEARTBEAT_S` seconds, that a :class:`Connected`
    executor still has its cluster: a lost one stops the run at once
    (:class:`InfrastructureError`), whatever the evaluation timeout."""
    deadline = time.monotonic() + limit
    waiting = set(futures)
    while waiting:
        lost = executor.lost() if isinstance(executor, Connected) else None
        if lost:
            for fut in waiting:
                fut.cancel()
            raise InfrastructureError(lost)
        left = deadline - time.monotonic()
        if left <= 0:
            raise FuturesTimeout()
        done, waiting = wait(waiting, timeout=min(left, HEARTBEAT_S), return_when=FIRST_COMPLETED)
        yield from done


def _in_process(
    problem: Problem, X: np.ndarray, rows: np.ndarray, policy: FaultPolicy
) -> Iterator[Yielded]:
    attempt = 0
    while True:
        t0 = time.perf_counter()
        limit = policy.timeout_s * len(rows)
        try:
            with time_limit(limit):
                res = problem.evaluate(X)
        except (EvaluationTimeout, MemoryError) as exc:
            fault = (
                f"timeout: not done within {limit:g} s ({policy.timeout_s:g} s per design, "
                "run.timeout_s)"
                if isinstance(exc, EvaluationTimeout)
                else _describe(exc)
            )
            attempt += 1
            _retry_or_raise(policy, attempt, len(rows), [fault], "")
            time.sleep(policy.pause(attempt))
            continue
        yield rows.tolist(), res, time.perf_counter() - t0
        return


@contextlib.contextmanager
def time_limit(seconds: float) -> Iterator[None]:
    """Raise :class:`EvaluationTimeout` in the block after ``seconds`` (main thread, POSIX;
    elsewhere the block runs unbounded).

    Inside :func:`alarm_handler` (the run loop enters it once per run) only the timer is
    armed and disarmed; otherwise the handler is installed and restored around the block."""
    if not _timers_usable() or not math.isfinite(seconds):
        yield
        return
    global _limit_s
    outer = _limit_s
    _limit_s = seconds
    installed = signal.getsignal(signal.SIGALRM) is _expire
    previous = None if installed else signal.signal(signal.SIGALRM, _expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        _limit_s = outer
        if not installed:
            signal.signal(signal.SIGALRM, previous)


def _timers_usable() -> bool:
    """``SIGALRM`` timers work here: on POSIX (``setitimer``), in the main thread."""
    return hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()


#: the limit of the innermost :func:`time_limit` (for the timeout's message)
_limit_s = math.inf


def _expire(signum: int, frame: Any) -> None:
    raise EvaluationTimeout(f"evaluation exceeded {_limit_s:g} s")


@contextlib.contextmanager
def alarm_handler() -> Iterator[None]:
    """Install the timeout's ``SIGALRM`` handler for the whole block (a run), so that each
    :func:`time_limit` inside only arms a timer; the previous handler is restored after."""
    if not _timers_usable() or signal.getsignal(signal.SIGALRM) is _expire:
        yield
        return
    previous = signal.signal(signal.SIGALRM, _expire)
    try:
        yield
    finally:
        signal.signal(signal.SIGALRM, previous)


def _outcome(fut: Future[Any]) -> tuple[EvaluationBatch | None, str]:
    """The chunk's batch, or None and a description of the machinery's fault."""
    try:
        res = fut.result(timeout=0)
    except (Exception, CancelledError) as exc:  # noqa: BLE001 - every escape is a fault
        return None, _describe(exc)
    if not isinstance(res, EvaluationBatch):
        return None, f"executor returned {type(res).__name__}, not an EvaluationBatch"
    return res, ""


def _describe(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__
