"""Worker processes that never outlive the sweep that started them.

:func:`make_executor` gives the executor a sweep runs its trials on: the calling process
for one worker, else a :class:`concurrent.futures.ProcessPoolExecutor` whose workers

- die with their parent: on Linux the kernel kills them the moment the parent dies (even
  by SIGKILL, ``prctl(PR_SET_PDEATHSIG)``), and everywhere a watchdog thread ends a worker
  within a second of finding itself orphaned;
- ignore SIGINT: Ctrl-C reaches the whole foreground process group, and only the parent
  should answer it (it then stops the workers with :func:`stop_executor`, and the trials
  stored so far are kept).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

from cfopt.errors import parameter_error

__all__ = ["default_workers", "make_executor", "stop_executor"]

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
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise parameter_error("workers", f"must be a whole number >= 1, got {workers!r}")
    if n == 1:
        return InlineExecutor()
    return cf.ProcessPoolExecutor(max_workers=n, initializer=_worker_setup, initargs=(os.getpid(),))


def _worker_setup(parent: int) -> None:
    """Runs first in every worker process."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # the parent died before the line above took effect
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()


def _watch_parent(parent: int) -> None:
    while True:
        time.sleep(WATCHDOG_PERIOD)
        if os.getppid() != parent:
            os._exit(1)


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
