"""Worker processes that never outlive the sweep that started them.

:func:`make_executor` gives the executor a sweep runs its trials on: the calling process
for one worker, else a :class:`concurrent.futures.ProcessPoolExecutor` whose workers

- die with their parent: on Linux the kernel kills them the moment the parent dies (even
  by SIGKILL, ``prctl(PR_SET_PDEATHSIG)``), and everywhere a watchdog thread ends a worker
  within a second of finding itself orphaned;
- ignore SIGINT: Ctrl-C reaches the whole foreground process group, and only the parent
  should answer it (it then stops the workers with :func:`stop_executor`, and the trials
  stored so far are kept).

The two mechanisms are public for other processes that must not outlive theirs: the MPI
launcher :func:`heuristics.mpi.mpi_run` starts (:func:`parent_death_hook`) and its ranks
(:func:`die_with_parent`, :func:`watch_parent` with the pid of the ``cfopt`` process that
launched them).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import ctypes
import functools
import os
import select
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

from cfopt.checks import require_int

__all__ = [
    "default_workers",
    "die_with_parent",
    "make_executor",
    "parent_death_hook",
    "process_exists",
    "stop_executor",
    "watch_parent",
]

#: Seconds between two looks of a worker's watchdog at its parent.
WATCHDOG_PERIOD = 0.5
_PR_SET_PDEATHSIG = 1


class InlineExecutor(cf.Executor):
    """Runs each call at submission, in the calling process (``workers=1``)."""

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> cf.Future:
        future: cf.Future = cf.Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except Exception as exc:
            future.set_exception(exc)
        return future


def default_workers() -> int:
    """The CPUs this process may use."""
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)


def make_executor(workers: int | None) -> cf.Executor:
    """``workers`` processes that die with this one (default: the usable CPUs); in-process
    for 1."""
    n = default_workers() if workers is None else workers
    require_int("workers", n, minimum=1, flag=True)
    if n == 1:
        return InlineExecutor()
    return _WorkerPool(max_workers=n, initializer=_worker_setup, initargs=(os.getpid(),))


class _WorkerPool(cf.ProcessPoolExecutor):
    """A process pool whose workers never see a Ctrl-C meant for their parent.

    The pool forks its workers inside :meth:`submit`.  A SIGINT that reached a worker
    after the fork but before its initializer ignored SIGINT would end it with a
    ``KeyboardInterrupt`` of its own (a traceback, and a broken pool instead of the
    parent's clean "interrupted" line), so SIGINT is blocked in the submitting thread
    while it may fork: the child starts with it blocked, ignores it, then unblocks it
    (:func:`_worker_setup`); the parent's own SIGINT is delivered when ``submit`` returns.
    """

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> cf.Future:
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            return super().submit(fn, *args, **kwargs)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)


def _worker_setup(parent: int) -> None:
    """Runs first in every worker process (started with SIGINT blocked, see
    :class:`_WorkerPool`)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    die_with_parent(parent)
    watch_parent(parent)


def die_with_parent(parent: int) -> None:
    """Have the kernel SIGKILL this process the moment its parent dies, even by SIGKILL
    (Linux, ``prctl(PR_SET_PDEATHSIG)``; nothing elsewhere), and end it at once when
    ``parent`` is no longer its parent (it died before).  Starts no thread: safe in a
    forked child before ``exec`` (see :func:`parent_death_hook`)."""
    prctl = _prctl()
    if prctl is not None:
        prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:
        os._exit(1)


def parent_death_hook() -> Callable[[], None]:
    """A ``preexec_fn`` for :class:`subprocess.Popen`: the child (the program it runs)
    dies with the calling process (:func:`die_with_parent`)."""
    _prctl()  # load libc here, not in the forked child
    return functools.partial(die_with_parent, os.getpid())


def watch_parent(parent: int, origin: int | None = None) -> None:
    """Start a daemon thread that ends this process (exit code 1) within
    :data:`WATCHDOG_PERIOD` seconds of finding that ``parent`` is no longer its parent,
    or that ``origin`` (a process further up, e.g. the one that started the launcher of
    this process) has ended; at once when ``origin`` has already ended."""
    alive = _liveness(origin) if origin is not None else None
    threading.Thread(target=_watch, args=(parent, alive), daemon=True).start()


def _watch(parent: int, alive: Callable[[], bool] | None) -> None:
    while True:
        if os.getppid() != parent or (alive is not None and not alive()):
            os._exit(1)
        time.sleep(WATCHDOG_PERIOD)


def _liveness(pid: int) -> Callable[[], bool]:
    """Whether ``pid`` still runs: a pidfd when the system has them (a zombie counts as
    ended, a reused pid is not mistaken for it), else ``kill(pid, 0)``."""
    try:
        fd = os.pidfd_open(pid)
    except ProcessLookupError:
        return lambda: False
    except (AttributeError, OSError):
        return functools.partial(process_exists, pid)
    return lambda: not select.select([fd], [], [], 0)[0]


def process_exists(pid: int) -> bool:
    """Whether a process ``pid`` exists (a zombie still does)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@functools.cache
def _prctl() -> Callable[..., int] | None:
    """libc's ``prctl`` (Linux), else ``None``."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


def stop_executor(executor: cf.Executor) -> None:
    """Cancel what has not started and end the worker processes at once.

    ``shutdown(cancel_futures=True)`` alone would wait for the running calls (a trial can
    take minutes); the workers are killed instead.  Python before 3.14 has no public way
    to do that, so the pool's process table is used when there is one.
    """
    kill = getattr(executor, "kill_workers", None)
    processes = list(getattr(executor, "_processes", None) or {})
    executor.shutdown(wait=False, cancel_futures=True)
    if kill is not None:
        with contextlib.suppress(Exception):
            kill()
        return
    for pid in processes:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.kill(pid, signal.SIGKILL)
