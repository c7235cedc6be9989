"""Sweeps on a dask cluster: the executor behind ``cfopt sweep --scheduler``.

``--scheduler`` takes the address of a running dask scheduler (``tcp://HOST:PORT`` or
``HOST:PORT``; dask's other transports, tls, ucx, inproc and ws, are not supported) or
``local:N``, a :class:`distributed.LocalCluster` of ``N`` worker processes with one thread
each, started for the sweep and torn down at its end.  :func:`dask_executor` gives a
:class:`concurrent.futures.Executor` on it for :func:`cfopt.experiments.run_sweep`.

A running scheduler must answer within :data:`CONNECT_TIMEOUT` seconds, the whole of it:
the TCP connection, dask's handshake and the scheduler's first answer.  A server that
accepts the connection and stays silent, or that answers with something other than dask's
protocol (or is a dask worker), is refused by then with one error naming ``--scheduler``.

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
import ipaddress
import logging
import re
import signal
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from types import ModuleType
from typing import Any, TypeVar

from cfopt._limits import CONNECT_TIMEOUT  # defined there: the --help text needs no dask
from cfopt.errors import ExecutorFailed, MissionError, WorkerDied, plural

__all__ = [
    "CONNECT_TIMEOUT",
    "INSTALL_HINT",
    "SCHEMES",
    "WORKER_TIMEOUT",
    "DaskExecutor",
    "SchedulerLost",
    "SchedulerSpec",
    "dask_executor",
    "parse_scheduler",
]

#: Seconds a running scheduler with no worker is given for one to join.
WORKER_TIMEOUT = 30.0
#: Seconds a teardown waits for the client and a local cluster to close.
CLOSE_TIMEOUT = 10.0
#: How to get dask, for the error raised when it is missing.
INSTALL_HINT = 'pip install "cfopt[cluster]"'
#: The address schemes cfopt connects over (dask's tls, ucx, inproc and ws are not).
SCHEMES = ("tcp",)
_OPTION = "--scheduler"
_LOCAL = re.compile(r"local:(\d{1,4})\Z")
_FORMS = "tcp://HOST:PORT or HOST:PORT, e.g. tcp://127.0.0.1:8786"
_HOST_LABEL = re.compile(r"[A-Za-z0-9_-]{1,63}\Z")
_PORT = re.compile(r"[0-9]{1,5}\Z")
_T = TypeVar("_T")
#: Characters of an exception's text shown in an error line.
_REASON = 160


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

    An address is ``tcp://HOST:PORT`` or ``HOST:PORT`` (:data:`SCHEMES`): a host name, an
    IPv4 address or an IPv6 one in brackets (``tcp://[::1]:8786``), and a port from 1 to
    65535.  The scheme is lowercased; whether a scheduler answers there is checked by
    connecting (:func:`dask_executor`).

    Raises
    ------
    cfopt.MissionError
        Naming ``--scheduler`` and the problem: ``local:`` without a whole number in range,
        an empty value or one with spaces, a scheme other than tcp, no host, a host that is
        not one, no port or one out of range.

    >>> parse_scheduler("local:x")
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: scheduler: must be local:N with N a whole number from 1 to ...
    >>> parse_scheduler("TCP://[::1]:8786").address
    'tcp://[::1]:8786'
    """
    value = str(text).strip()
    if value.lower() == "local" or value.lower().startswith("local:"):
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
    return SchedulerSpec(_checked_address(value), None)


def _checked_address(value: str) -> str:
    """``value`` if it is ``tcp://HOST:PORT`` or ``HOST:PORT`` (the scheme lowercased)."""
    scheme, sep, location = value.partition("://")
    if not sep:
        location = value
    elif scheme.lower() not in SCHEMES:
        raise _bad_address(
            value,
            f"the scheme {scheme!r} is not supported: cfopt connects over "
            f"{', '.join(SCHEMES)} only, give {_FORMS}",
        )
    host, port = _host_and_port(value, location)
    if not host:
        raise _bad_address(value, f"no host: give {_FORMS}")
    if port is None:
        raise _bad_address(value, f"no port: give {_FORMS}")
    if _PORT.match(port) is None or not 1 <= int(port) <= 65535:
        raise _bad_address(value, f"the port must be a whole number from 1 to 65535, got {port!r}")
    return f"{scheme.lower()}://{location}" if sep else location


def _host_and_port(value: str, location: str) -> tuple[str, str | None]:
    """Split ``HOST:PORT`` (``[IPv6]:PORT``), checking the host; the port is ``None`` when
    there is none."""
    if location.startswith("["):
        host, bracket, rest = location[1:].partition("]")
        if not bracket or rest[:1] not in ("", ":"):
            raise _bad_address(value, "an IPv6 host goes in brackets, e.g. tcp://[::1]:8786")
        try:
            ipaddress.IPv6Address(host)
        except ValueError:
            raise _bad_address(value, f"{host!r} is not an IPv6 address") from None
        return host, rest[1:] if rest else None
    host, colon, port = location.rpartition(":")
    if not colon:
        host, port = location, None
    elif ":" in host:
        raise _bad_address(value, "an IPv6 host goes in brackets, e.g. tcp://[::1]:8786")
    labels = host.removesuffix(".").split(".")
    if host and (len(host) > 253 or not all(_HOST_LABEL.match(label) for label in labels)):
        raise _bad_address(value, f"{host!r} is not a host name or an IP address")
    return host, port


def _bad_address(value: str, problem: str) -> MissionError:
    return _error(f"not a scheduler address: {value!r} ({problem})")


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
    scheduler: str | SchedulerSpec,
    *,
    connect_timeout: float | None = None,
    logs: bool = True,
) -> Iterator[DaskExecutor]:
    """An executor on a dask cluster, for the ``with`` block; torn down at its end.

    Parameters
    ----------
    scheduler : str or SchedulerSpec
        ``local:N`` or a scheduler's address (:func:`parse_scheduler`).
    connect_timeout : float, optional
        Seconds for the scheduler to answer (the TCP connection, dask's handshake and
        the scheduler's first answer, all of it), and to reconnect after a lost
        connection (default: :data:`CONNECT_TIMEOUT`).
    logs : bool, default True
        ``False`` drops every log record of the process while the executor lives, from
        its start to the end of its teardown (dask's, tornado's and asyncio's loggers
        print tracebacks to stderr when a scheduler goes away; the command line says
        what went wrong in one line instead).

    Yields
    ------
    DaskExecutor

    Raises
    ------
    cfopt.MissionError
        Naming ``--scheduler``: dask is not installed, the value is malformed, the
        scheduler does not answer as one within ``connect_timeout``, or a local cluster
        cannot start.

    Notes
    -----
    The workers of a running scheduler must run the same cfopt sources as this process
    (the same :func:`cfopt.experiments.code_version`), or the connection is refused.
    At the end, normal or not (an exception, Ctrl-C), the tasks not finished are
    cancelled and the client is closed; a local cluster's workers are stopped and its
    scheduler closed.  A remote cluster keeps running.  A connection given up at the
    deadline leaves a thread waiting on it in the background; a client it makes late is
    closed.
    """
    label = scheduler.label if isinstance(scheduler, SchedulerSpec) else scheduler
    spec = parse_scheduler(label)
    distributed = import_distributed()
    timeout = CONNECT_TIMEOUT if connect_timeout is None else connect_timeout
    with contextlib.nullcontext() if logs else _no_logging():
        client, cluster = _open(distributed, spec, timeout)
        executor = DaskExecutor(client, spec.label)
        try:
            yield executor
        finally:
            executor.shutdown(wait=False, cancel_futures=True)
            _close(client)
            _close(cluster)


@contextlib.contextmanager
def _no_logging() -> Iterator[None]:
    """No log record is emitted in the block, whichever its logger."""
    previous = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    try:
        yield
    finally:
        logging.disable(previous)


def _open(distributed: ModuleType, spec: SchedulerSpec, timeout: float) -> tuple[Any, Any]:
    """The client, and the local cluster it is on (``None`` for a running scheduler)."""
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
    return client, cluster


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
    """A client of ``cluster`` (local) or of the scheduler at ``spec.address``, within
    ``timeout`` seconds; a running scheduler is first asked what it is."""
    deadline = time.monotonic() + timeout
    if cluster is None:
        _require_scheduler(distributed, spec, deadline, timeout)
    target = cluster if cluster is not None else spec.address
    start = functools.partial(distributed.Client, target, timeout=timeout, set_as_default=False)
    try:
        return _by(deadline, start, late=_close)
    except (OSError, TimeoutError) as exc:
        raise _unreachable(spec.label, timeout, exc) from None
    except Exception as exc:  # it answered identity, then turned the client away
        raise _error(f"{spec.label}: the scheduler refused this client ({_why(exc)})") from None


def _require_scheduler(
    distributed: ModuleType, spec: SchedulerSpec, deadline: float, timeout: float
) -> None:
    """Refuse a server at ``spec.address`` that has not answered dask's ``identity`` call
    as a scheduler by ``deadline``: one that stays silent, one whose bytes are not dask's
    protocol, a dask worker.  (A client of such a server waits forever for the handshake
    or fails with a traceback, and cannot be closed.)"""
    import asyncio  # here: the command line's start does not pay for it

    address = str(spec.address)
    try:
        identity = _by(deadline, lambda: asyncio.run(_identity(distributed, address, deadline)))
    except (OSError, TimeoutError) as exc:
        raise _unreachable(spec.label, timeout, exc) from None
    except Exception as exc:  # bytes that are not dask's protocol fail its decoders anyhow
        raise _error(
            f"{spec.label}: not a dask scheduler (its answer is not dask's protocol: {_why(exc)})"
        ) from None
    kind = identity.get("type") if isinstance(identity, dict) else None
    if kind != "Scheduler":
        what = f"says it is a dask {kind}" if isinstance(kind, str) else "gave no identity"
        raise _error(f"{spec.label}: not a dask scheduler (it {what})")


async def _identity(distributed: ModuleType, address: str, deadline: float) -> Any:
    """The answer of the server at ``address`` to dask's ``identity`` call, by
    ``deadline`` (:func:`time.monotonic`)."""
    import asyncio

    seconds = max(0.0, deadline - time.monotonic())
    # dask's own connect gives up a little earlier, so that its reason (connection
    # refused, unknown host) is the one told rather than the deadline's
    async with (
        asyncio.timeout(seconds),
        distributed.rpc(address, timeout=0.9 * seconds) as server,
    ):
        return await server.identity()


def _by(deadline: float, call: Callable[[], _T], *, late: Callable[[_T], Any] | None = None) -> _T:
    """``call()`` in a thread of its own, given up at ``deadline`` (:func:`time.monotonic`).

    Raises
    ------
    TimeoutError
        At the deadline, if the call has not returned; what it returns later goes to
        ``late`` (as when the wait is interrupted, by Ctrl-C).
    """
    box: cf.Future[_T] = cf.Future()

    def run() -> None:
        try:
            box.set_result(call())
        except BaseException as exc:
            box.set_exception(exc)

    def hand_over(done: cf.Future[_T]) -> None:
        if late is not None and done.exception() is None:
            late(done.result())

    threading.Thread(target=run, name="cfopt-dask-connect", daemon=True).start()
    try:
        return box.result(timeout=max(0.0, deadline - time.monotonic()))
    except BaseException:
        box.add_done_callback(hand_over)
        raise


def _unreachable(label: str, timeout: float, exc: BaseException) -> MissionError:
    return _error(f"cannot reach the scheduler at {label} within {timeout:g} s ({_why(exc)})")


def _why(exc: BaseException) -> str:
    """What went wrong, on one line: the text of the first cause of ``exc``."""
    while isinstance(exc.__cause__, Exception):
        exc = exc.__cause__
    if isinstance(exc, TimeoutError):
        return "no answer"
    text = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
    text = " ".join(text.split()) or type(exc).__name__
    return text if len(text) <= _REASON else text[: _REASON - 3] + "..."


def _check_workers(client: Any, label: str) -> None:
    """Refuse a remote cluster whose workers run other cfopt code than this process.

    Trials are stored under this process's :func:`cfopt.experiments.code_version`, so
    workers computing them with other sources would mislabel them.  Workers that join
    later are not checked.
    """
    from cfopt import experiments

    try:
        client.wait_for_workers(1, timeout=WORKER_TIMEOUT)
    except Exception:  # distributed raises TimeoutError or its own subclass of it
        raise _error(
            f"{label}: no worker joined the scheduler within {WORKER_TIMEOUT:g} s (start "
            f"one with: dask worker {label})"
        ) from None
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
