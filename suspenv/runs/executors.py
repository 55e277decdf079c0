"""The executors that evaluate designs: in-process, a local process pool, or a Dask cluster.

:func:`make_executor` builds the one a run's ``[run]`` table asks for. A process pool is a
:class:`ProcessPool`: it can be replaced after a fault (:meth:`ProcessPool.restart` kills
its workers, hung or not, and starts fresh ones), and its workers die with the process
that owns them, so a killed run leaves no orphans evaluating into the void.

A Dask executor (``run.dask_scheduler``) is a :class:`DaskExecutor` around Dask's own
``client.get_executor()``: Dask reschedules work from a lost worker itself. A lost
scheduler is noticed by the client's connection status, which
:mod:`suspenv.runs.evaluation` reads every :data:`HEARTBEAT_S` seconds while it waits
(:meth:`DaskExecutor.lost`), independently of the evaluation timeout: a scheduler that
stays unreachable for :data:`SCHEDULER_GRACE_S` seconds stops the run with a message (the
archive keeps everything evaluated; rerunning resumes).

Security: a Dask scheduler runs whatever pickled code its clients send, and its default
transport is unauthenticated TCP. Use it on a trusted network only, or with TLS
(``tls://`` addresses and a ``distributed.security.Security`` configured through Dask's
config file or ``DASK_DISTRIBUTED__COMM__TLS__*`` variables; see docs/runs.md).
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from typing import Any, Protocol, runtime_checkable

#: seconds between a worker's checks that the process that started it is still alive
PARENT_POLL_S = 0.5
#: seconds between checks of a cluster's connection while chunks are evaluated
HEARTBEAT_S = 1.0
#: seconds a Dask scheduler may stay unreachable (the client reconnecting) before the
#: run stops
SCHEDULER_GRACE_S = 10.0


@runtime_checkable
class Restartable(Protocol):
    """An executor that can be replaced after a fault (lost, hung or killed workers)."""

    def restart(self) -> None: ...


def _die_with_parent(parent: int) -> None:
    """Pool-worker initializer: end this worker when the process that started it ends.

    Linux delivers SIGKILL to the worker the moment its parent dies (``PR_SET_PDEATHSIG``);
    everywhere a daemon thread also checks every :data:`PARENT_POLL_S` seconds that the
    parent pid is unchanged (a worker whose parent died is re-parented) and exits.
    """
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # 1 = PR_SET_PDEATHSIG
    if os.getppid() != parent:  # the parent died before the line above
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(PARENT_POLL_S)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, name="suspenv-parent-watch", daemon=True).start()


class ProcessPool(Executor):
    """A :class:`~concurrent.futures.ProcessPoolExecutor` that can be restarted.

    Its workers die with the owning process (see :func:`_die_with_parent`).
    :meth:`restart` kills every worker (a hung evaluation included) and starts a new pool;
    futures of the old pool end with an error, which the caller retries.
    """

    def __init__(self, max_workers: int):
        self.max_workers = int(max_workers)
        self._pool = self._new_pool()

    def _new_pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            max_workers=self.max_workers,
            initializer=_die_with_parent,
            initargs=(os.getpid(),),
        )

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        return self._pool.submit(fn, *args, **kwargs)

    def worker_pids(self) -> list[int]:
        """Process ids of the current workers (those started so far)."""
        procs = getattr(self._pool, "_processes", None) or {}
        return [int(p) for p in procs]

    def restart(self) -> None:
        """Kill every worker of the current pool and start a new pool."""
        self.kill()
        self._pool = self._new_pool()

    def kill(self) -> None:
        """Kill every worker of the current pool (running evaluations included)."""
        old = self._pool
        kill = getattr(old, "kill_workers", None)  # Python >= 3.14
        if callable(kill):
            with contextlib.suppress(Exception):
                kill()
        else:
            for proc in list((getattr(old, "_processes", None) or {}).values()):
                with contextlib.suppress(Exception):
                    proc.kill()
        with contextlib.suppress(Exception):
            old.shutdown(wait=False, cancel_futures=True)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)


@runtime_checkable
class Connected(Protocol):
    """An executor that can tell that its cluster is gone (see :class:`DaskExecutor`)."""

    def lost(self) -> str | None: ...


class DaskExecutor(Executor):
    """Dask's ``client.get_executor()`` that can tell when its scheduler is gone."""

    def __init__(self, client: Any, address: str, grace_s: float = SCHEDULER_GRACE_S):
        self.client, self.address, self.grace_s = client, address, grace_s
        self._executor = client.get_executor()
        self._away_since: float | None = None
        # tornado (a callback's exception) and distributed's batched sender ("Batched
        # Comm Closed") log a closed connection to the scheduler with a traceback the
        # moment the scheduler goes, before :meth:`lost` can tell; the run's own lines
        # say what happens
        _quiet(("tornado", "distributed.batched"))

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        return self._executor.submit(fn, *args, **kwargs)

    def lost(self) -> str | None:
        """None while the client is connected to its scheduler (or has been away less
        than ``grace_s`` seconds, reconnecting); else what happened."""
        status = str(getattr(self.client, "status", "running"))
        if status == "running":
            self._away_since = None
            return None
        now = time.monotonic()
        if self._away_since is None:
            self._away_since = now
            # the client's reconnect attempts, and their cancellation when the run stops,
            # are logged as errors with tracebacks; the run's own lines say what happens
            _quiet(("distributed", "tornado"))
        away = now - self._away_since
        if away < self.grace_s and status != "closed":
            return None
        return (
            f"the Dask scheduler {self.address} is unreachable (the client's connection "
            f"is {status!r}, for {away:.0f} s)"
        )

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._executor.shutdown(wait=wait)


def _quiet(loggers: tuple[str, ...]) -> None:
    """Log only critical records from ``loggers`` (dotted names) and their children."""
    for name in [*loggers, *logging.root.manager.loggerDict]:
        if any(name == q or name.startswith(q + ".") for q in loggers):
            logging.getLogger(name).setLevel(logging.CRITICAL)


@contextlib.contextmanager
def make_executor(run: dict[str, Any]) -> Iterator[Executor | None]:
    """None (in-process), a :class:`ProcessPool` (``workers > 1``) or a Dask executor
    (``dask_scheduler``: the scheduler's address, e.g. ``tcp://host:8786`` or ``tls://``)."""
    address = run.get("dask_scheduler")
    if address:
        from distributed import Client

        with Client(address) as client:
            yield DaskExecutor(client, address)
    elif run.get("workers", 1) > 1:
        pool = ProcessPool(run["workers"])
        try:
            yield pool
        except BaseException:
            pool.kill()  # a hung or faulty worker must not outlive the run
            raise
        pool.shutdown(wait=True)
    else:
        yield None


def executor_workers(run: dict[str, Any]) -> int:
    """Evaluations the executor of :func:`make_executor` runs at once: ``workers`` for a
    process pool, 1 in-process, and ``max(workers, 2)`` on a Dask cluster (its size is not
    known here; two chunks per batch at least)."""
    workers = int(run.get("workers", 1) or 1)
    return max(workers, 2) if run.get("dask_scheduler") else workers
