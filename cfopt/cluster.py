"""Sweeps on a dask cluster: the executor behind ``cfopt sweep --scheduler``.

``--scheduler`` takes the address of a running dask scheduler (``tcp://host:8786``) or
``local:N``, a :class:`distributed.LocalCluster` of ``N`` worker processes with one thread
each, started for the sweep and torn down at its end.  :func:`dask_executor` gives a
:class:`concurrent.futures.Executor` on it for :func:`cfopt.experiments.run_sweep`.

The store stays with the caller: workers compute trials and return them, and only the
calling process writes.  When a worker dies, dask gives its trials to other workers, up to
its ``distributed.scheduler.allowed-failures`` (3 by default); a trial whose workers died
every time ends as :class:`cfopt.experiments.WorkerDied` (a failed trial, not stored, tried
again by the next run).  A lost scheduler ends the sweep with :class:`SchedulerLost`, and
what was stored is kept.

dask is an optional dependency (``pip install "cfopt[cluster]"``); this module imports it
only when a cluster is asked for.

Examples
--------
>>> parse_scheduler("local:2")
SchedulerSpec(address=None, local_workers=2)
>>> parse_scheduler("tcp://10.0.0.5:8786").label
'tcp://10.0.0.5:8786'
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import functools
import logging
import re
import signal
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from types import ModuleType
from typing import Any

from cfopt.errors import MissionError, plural
from cfopt.experiments import ExecutorFailed, WorkerDied

__all__ = [
    "CONNECT_TIMEOUT",
    "INSTALL_HINT",
    "DaskExecutor",
    "SchedulerLost",
    "SchedulerSpec",
    "dask_executor",
    "parse_scheduler",
]

#: Seconds to reach a scheduler (and to reconnect to one that went away) before giving up.
CONNECT_TIMEOUT = 5.0
#: Seconds a teardown waits for the client and a local cluster to close.
CLOSE_TIMEOUT = 10.0
#: How to get dask, for the error raised when it is missing.
INSTALL_HINT = 'pip install "cfopt[cluster]"'
_OPTION = "--scheduler"
_LOCAL = re.compile(r"local:(\d{1,4})\Z")


class SchedulerLost(ExecutorFailed):
    """The connection to the scheduler was lost and could not be made again."""


@dataclass(frozen=True)
class SchedulerSpec:
    """A parsed ``--scheduler`` value (frozen).

    Attributes
    ----------
    address : str or None
        A running scheduler's address; ``None`` for a local cluster.
    local_workers : int or None
        Worker processes of the local cluster (``local:N``); ``None`` for an address.
    """

    address: str | None
    local_workers: int | None

    @property
    def label(self) -> str:
        """The value as given: ``local:N`` or the address."""
        return self.address if self.address is not None else f"local:{self.local_workers}"


def parse_scheduler(text: str) -> SchedulerSpec:
    """Parse ``--scheduler``: ``local:N`` (1 <= N <= 1024) or a scheduler address.

    An address is anything else that is not empty, has no spaces and does not start with
    ``local``; it is checked by connecting (:func:`dask_executor`).

    Raises
    ------
    cfopt.MissionError
        Naming ``--scheduler``: ``local:`` without a whole number in range, or an empty
        address or one with spaces.

    >>> parse_scheduler("local:x")
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: scheduler: must be local:N with N a whole number from 1 to ...
    """
    value = str(text).strip()
    if value.lower().startswith("local"):
        match = _LOCAL.match(value)
        if match is None or not 1 <= int(match.group(1)) <= 1024:
            raise _error(
                "must be local:N with N a whole number from 1 to 1024 (worker processes), "
                f"got {text!r}"
            )
        return SchedulerSpec(None, int(match.group(1)))
    if not value or any(c.isspace() for c in value):
        raise _error(
            f"must be a scheduler address such as tcp://host:8786, or local:N, got {text!r}"
        )
    return SchedulerSpec(value, None)


def _error(problem: str) -> MissionError:
    return MissionError(f"scheduler: {problem}", cli=f"{_OPTION}: {problem}")


def import_distributed() -> ModuleType:
    """``distributed``, or a :class:`cfopt.MissionError` saying how to install it."""
    try:
        import distributed
    except ImportError as exc:
        raise _error(
            f"needs dask's distributed scheduler, which is not installed ({exc}); "
            f"install it with: {INSTALL_HINT}"
        ) from None
    return distributed


# ------------------------------------------------------------------------ executor
class DaskExecutor(cf.Executor):
    """A :class:`concurrent.futures.Executor` on a :class:`distributed.Client`.

    Each call is a dask task of its own (``pure=False``: never shared with another
    submission).  Its :class:`~concurrent.futures.Future` ends as the task does, except
    that a task whose workers all died fails with :class:`cfopt.experiments.WorkerDied`,
    and a task lost with the scheduler connection fails with :class:`SchedulerLost`.

    Parameters
    ----------
    client : distributed.Client
    label : str
        The scheduler as the user named it, for messages.
    """

    def __init__(self, client: Any, label: str) -> None:
        self._client, self._label = client, label
        self._killed_worker = _killed_worker_type()
        self._tasks: dict[cf.Future, Any] = {}
        self._lock = threading.Lock()
        self._stopping = False

    @property
    def parallelism(self) -> int:
        """Threads of the cluster's workers now (at least 1)."""
        threads = self._client.nthreads()
        return max(1, sum(threads.values()))

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> cf.Future:
        """Run ``fn(*args, **kwargs)`` on the cluster."""
        if self._stopping:
            raise RuntimeError("cannot submit to a DaskExecutor after shutdown")
        if self._client.status in ("closing", "closed"):
            raise self._lost()
        call = functools.partial(fn, *args, **kwargs)  # no keyword taken by Client.submit
        task = self._client.submit(call, pure=False)
        future: cf.Future = cf.Future()
        with self._lock:
            self._tasks[future] = task
        task.add_done_callback(lambda done: self._settle(done, future))
        return future

    def _settle(self, task: Any, future: cf.Future) -> None:
        """Runs in dask's callback thread when ``task`` is done: copies its outcome."""
        status = task.status
        if status == "finished":
            try:
                outcome: Any = task.result()
            except BaseException as exc:  # a result that cannot be read back
                status, outcome = "error", exc
        elif status == "cancelled":
            outcome = None if self._stopping else self._lost()
        else:
            outcome = self._failure(task)
        with self._lock:
            self._tasks.pop(future, None)
            if future.done():  # cancelled by shutdown meanwhile
                return
            if status == "finished":
                future.set_result(outcome)
            elif outcome is None:
                _cancel(future)
            else:
                future.set_exception(outcome)

    def _failure(self, task: Any) -> BaseException:
        exc = task.exception()
        if isinstance(exc, self._killed_worker):
            attempts = getattr(exc, "allowed_failures", None)
            times = plural(attempts + 1, "time") if isinstance(attempts, int) else "every time"
            return WorkerDied(
                f"the worker running it died {times} (killed, out of memory, or a crash "
                "in compiled code); dask gives up on a task after "
                "distributed.scheduler.allowed-failures deaths"
            )
        return exc.with_traceback(task.traceback())

    def _lost(self) -> SchedulerLost:
        return SchedulerLost(
            f"scheduler: lost the connection to {self._label}",
            cli=f"{_OPTION} {self._label}: lost the connection to the scheduler",
        )

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Stop taking calls; with ``cancel_futures`` or without ``wait``, cancel the tasks
        not finished (running ones included: their workers drop them)."""
        with self._lock:
            self._stopping = True
            pending = list(self._tasks.items())
        if wait and not cancel_futures:
            cf.wait([future for future, _ in pending])
            return
        with self._lock:
            for future, _ in pending:
                if not future.done():
                    _cancel(future)
        tasks = [task for _, task in pending]
        if tasks and self._client.status == "running":
            with contextlib.suppress(Exception):
                self._client.cancel(tasks, force=True)


def _cancel(future: cf.Future) -> None:
    """Cancel a pending future and wake whoever waits on it (``cf.wait``)."""
    future.cancel()
    future.set_running_or_notify_cancel()


def _killed_worker_type() -> type[BaseException]:
    from distributed.scheduler import KilledWorker

    return KilledWorker


# ----------------------------------------------------------------------- lifecycle
@contextlib.contextmanager
def dask_executor(
    scheduler: str | SchedulerSpec, *, connect_timeout: float | None = None
) -> Iterator[DaskExecutor]:
    """An executor on a dask cluster, for the ``with`` block; torn down at its end.

    Parameters
    ----------
    scheduler : str or SchedulerSpec
        ``local:N`` or a scheduler's address (:func:`parse_scheduler`).
    connect_timeout : float, optional
        Seconds to reach the scheduler, and to reconnect after a lost connection
        (default: :data:`CONNECT_TIMEOUT`).

    Yields
    ------
    DaskExecutor

    Raises
    ------
    cfopt.MissionError
        Naming ``--scheduler``: dask is not installed, the value is malformed, the
        scheduler cannot be reached within ``connect_timeout``, or a local cluster cannot
        start.

    Notes
    -----
    The workers of a running scheduler must run the same cfopt sources as this process
    (the same :func:`cfopt.experiments.code_version`), or the connection is refused.
    At the end, normal or not (an exception, Ctrl-C), the tasks not finished are
    cancelled and the client is closed; a local cluster's workers are stopped and its
    scheduler closed.  A remote cluster keeps running.
    """
    spec = scheduler if isinstance(scheduler, SchedulerSpec) else parse_scheduler(scheduler)
    distributed = import_distributed()
    timeout = CONNECT_TIMEOUT if connect_timeout is None else connect_timeout
    cluster = _start_local(distributed, spec.local_workers) if spec.address is None else None
    try:
        client = _connect(distributed, spec, cluster, timeout)
    except BaseException:
        _close(cluster)
        raise
    if cluster is None:
        try:
            _check_workers(client, spec.label)
        except BaseException:
            _close(client)
            raise
    executor = DaskExecutor(client, spec.label)
    try:
        yield executor
    finally:
        executor.shutdown(wait=False, cancel_futures=True)
        _close(client)
        _close(cluster)


def _start_local(distributed: ModuleType, workers: int | None) -> Any:
    """A LocalCluster of ``workers`` processes, one thread each, no dashboard."""
    try:
        return distributed.LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            # its HTTP server (health checks) on a free port, never the dashboard's 8787
            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
            silence_logs=logging.ERROR,
            preload=[__name__],  # dask_setup, in every worker process, restarted ones too
        )
    except (OSError, RuntimeError, TimeoutError) as exc:
        raise _error(f"local:{workers}: the local cluster did not start ({exc})") from None


def dask_setup(worker: Any) -> None:
    """Run by dask in each worker process of a local cluster as it starts (a preload).

    The worker ignores SIGINT: Ctrl-C reaches the whole foreground process group, and
    only the sweep's process answers it (it then closes the cluster, keeping what it
    stored); a worker still ends with its parent.
    """
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _connect(distributed: ModuleType, spec: SchedulerSpec, cluster: Any, timeout: float) -> Any:
    """A client of ``cluster`` (local) or of the scheduler at ``spec.address``."""
    if cluster is None:
        _check_address(spec.label)
    target = cluster if cluster is not None else spec.address
    try:
        return distributed.Client(target, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise _error(
            f"cannot reach the scheduler at {spec.label} within {timeout:g} s ({exc})"
        ) from None


def _check_address(address: str) -> None:
    """Refuse an address whose scheme dask does not know, before any client exists (a
    client that failed to start would complain again when garbage-collected)."""
    from distributed.comm.addressing import parse_address
    from distributed.comm.registry import get_backend

    try:
        scheme, location = parse_address(address)
        get_backend(scheme)
    except (ValueError, TypeError) as exc:
        raise _error(f"not a scheduler address: {address!r} ({exc})") from None
    if not location:
        raise _error(f"not a scheduler address: {address!r} (no host)")


def _check_workers(client: Any, label: str) -> None:
    """Refuse a remote cluster whose workers run other cfopt code than this process.

    Trials are stored under this process's :func:`cfopt.experiments.code_version`, so
    workers computing them with other sources would mislabel them.  Workers that join
    later are not checked.
    """
    from cfopt import experiments

    try:
        versions = client.run(_worker_code_version)
    except Exception as exc:  # cfopt missing on a worker: its pickled call cannot load
        raise _error(
            f"{label}: the workers cannot run cfopt ({type(exc).__name__}: {exc})"
        ) from None
    mine = experiments.code_version()
    other = sorted({v for v in versions.values() if v != mine})
    if other:
        raise _error(
            f"{label}: workers run cfopt code {', '.join(other)}, this process {mine}; "
            "install the same cfopt on the workers"
        )


def _worker_code_version() -> str:
    """Runs on a worker: its :func:`cfopt.experiments.code_version`."""
    from cfopt.experiments import code_version

    return code_version()


def _close(thing: Any) -> None:
    """Close a client or a cluster, quietly and within :data:`CLOSE_TIMEOUT`."""
    if thing is None:
        return
    with contextlib.suppress(Exception):
        thing.close(timeout=CLOSE_TIMEOUT)
