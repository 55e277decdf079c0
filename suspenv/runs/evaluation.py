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
import math
import signal
import sys
import threading
import time
from collections.abc import Iterator, Mapping
from concurrent.futures import CancelledError, Executor, Future, as_completed
from concurrent.futures import TimeoutError as FuturesTimeout
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from suspenv.core.errors import InfrastructureError, ValidationError
from suspenv.core.problem import Problem
from suspenv.core.result import EvaluationBatch
from suspenv.runs.executors import Restartable

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
        t, r, b = self.timeout_s, self.retries, self.backoff_s
        if not (isinstance(t, int | float) and not isinstance(t, bool) and 0 < t < math.inf):
            raise ValidationError(f"`0 < run.timeout_s < inf` must hold, but got timeout_s={t!r}")
        if not (isinstance(r, int) and not isinstance(r, bool) and 0 <= r <= 100):
            raise ValidationError(
                f"`run.retries` must be an integer in [0, 100], but got retries={r!r}"
            )
        if not (isinstance(b, int | float) and not isinstance(b, bool) and 0 <= b <= 3600):
            raise ValidationError(
                f"`0 <= run.retry_backoff_s <= 3600` must hold, but got retry_backoff_s={b!r}"
            )

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
    attempt = 0
    while True:
        rounds = math.ceil(len(pending) / max(workers, 1))
        limit = policy.timeout_s * chunk * rounds + POOL_STARTUP_S
        futures: dict[Future[Any], slice] = {}
        faults: list[str] = []
        failed: list[slice] = []
        for s in pending:
            try:
                futures[executor.submit(problem.evaluate, X[s])] = s
            except Exception as exc:  # noqa: BLE001 - a closed or lost executor
                faults.append(_describe(exc))
                failed.append(s)
        handled: set[Future[Any]] = set()
        try:
            for fut in as_completed(futures, timeout=limit):
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
        if not failed:
            return
        attempt += 1
        n_rows = sum(len(rows[s]) for s in failed)
        if attempt > policy.retries:
            raise InfrastructureError(
                f"{n_rows} design(s) could not be evaluated after {attempt} attempt(s) "
                f"({'; '.join(dict.fromkeys(faults))}); none of them was archived"
            )
        _warn(f"{n_rows} design(s) hit a fault of the machinery ({faults[0]}); retry "
              f"{attempt} of {policy.retries} in {policy.pause(attempt):g} s")
        if isinstance(executor, Restartable):
            executor.restart()
        time.sleep(policy.pause(attempt))
        pending = failed


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
            if attempt > policy.retries:
                raise InfrastructureError(
                    f"{len(rows)} design(s) could not be evaluated after {attempt} attempt(s) "
                    f"({fault}); none of them was archived"
                ) from None
            _warn(f"{fault}; retry {attempt} of {policy.retries} in {policy.pause(attempt):g} s")
            time.sleep(policy.pause(attempt))
            continue
        yield rows.tolist(), res, time.perf_counter() - t0
        return


@contextlib.contextmanager
def time_limit(seconds: float) -> Iterator[None]:
    """Raise :class:`EvaluationTimeout` in the block after ``seconds`` (main thread, POSIX;
    elsewhere the block runs unbounded)."""
    usable = hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()
    if not usable or not math.isfinite(seconds):
        yield
        return

    def expire(signum: int, frame: Any) -> None:
        raise EvaluationTimeout(f"evaluation exceeded {seconds:g} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
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


def _warn(text: str) -> None:
    print(f"suspenv: {text}", file=sys.stderr, flush=True)
