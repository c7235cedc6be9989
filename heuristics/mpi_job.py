"""An MPI job from its launch to its end: bounded waits, nothing left running, and one
line that says what failed.

:func:`heuristics.mpi.mpi_run` runs ``LAUNCHER -n K python -m cfopt.mpi ...`` with
:func:`run_job`; every rank calls :func:`rank_started` first and :func:`rank_ended` last
(``python -m cfopt.mpi`` does), which is how the launching process learns which ranks
started, which finished and which did not.

The job folder
--------------
:func:`job_folder` makes ``cfopt-mpi-PID-XXXXXXXX`` in the temporary directory (``PID``:
the launching process): the mission, the result, the launcher's output (``launcher.log``:
its stdout and stderr, and the ranks') and a record per rank (``rank-R.start``: its host
and pid; ``rank-R.end``: its exit code).  It goes when the run ends.  A process killed by
SIGKILL cannot remove anything: the next MPI run of the same user removes the folders of
launching processes that no longer exist, and SIGKILLs any process still marked with one.

Waiting
-------
The ranks must all have started within ``min(time_limit + GRACE, START_LIMIT)`` seconds of
the launch; from then on the job has ``time_limit + GRACE`` seconds (the ranks cut the run
at ``time_limit``, real seconds from their start; a lock-step run whose logical seconds
fall behind real time is stopped there too).  A job that overruns is killed: one line
naming the bound and the state of every rank that had not finished (stopped, still
running, gone).

Nothing left running
--------------------
* The launcher runs in a session of its own (Ctrl-C at the terminal reaches the launching
  process alone, which passes SIGINT on to the launcher, waits :data:`STOP_GRACE` seconds,
  then kills the job) and the kernel kills it when the launching process dies, even by
  SIGKILL (:func:`cfopt._workers.parent_death_hook`);
* every process of the job carries ``CFOPT_MPI_JOB=FOLDER`` in its environment: however
  the job ends, its launcher's process group and every local process so marked are
  SIGKILLed (the ranks MPICH starts are in sessions of their own, out of reach of a
  process-group kill);
* each rank dies with its parent (MPICH's ``hydra_pmi_proxy``) and within a second of the
  launching process (its host and pid in ``CFOPT_MPI_ORIGIN``), by the same mechanism as
  a sweep's workers (:func:`cfopt._workers.die_with_parent`, ``watch_parent``).

Failures
--------
A job that fails for a reason outside cfopt raises :class:`MPIJobError` (the command line
prints it as one ``error:`` line and exits 2): the launcher cannot start or is killed, no
rank starts, a rank is killed or stopped, the job overruns, the result is unreadable.  A
rank's own ``error:`` line is passed on as it is.  A rank that crashed with a traceback
(a bug) raises :class:`RuntimeError` with the end of the job's output.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import re
import shlex
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from cfopt import MissionError
from cfopt._workers import die_with_parent, parent_death_hook, process_exists, watch_parent

__all__ = [
    "GRACE",
    "JOB_ENV",
    "ORIGIN_ENV",
    "START_LIMIT",
    "STOP_GRACE",
    "MPIJobError",
    "RankRecord",
    "job_environment",
    "job_folder",
    "kill_marked",
    "rank_ended",
    "rank_records",
    "rank_started",
    "run_job",
]

#: Seconds a job may run beyond its time limit (the ranks' start-up and gathering).
GRACE = 10.0
#: Seconds the ranks may take to start, at most (less with a short time limit).
START_LIMIT = 120.0
#: Seconds the launcher has to stop its ranks after SIGINT before the job is killed.
STOP_GRACE = 5.0
#: Environment variable marking every process of a job (its value: the job folder).
JOB_ENV = "CFOPT_MPI_JOB"
#: Environment variable telling the ranks the launching process (``HOST:PID``).
ORIGIN_ENV = "CFOPT_MPI_ORIGIN"
#: The exit code of a rank (and of MPICH's launcher) stopped by SIGINT.
INTERRUPTED = 130
_PREFIX = "cfopt-mpi-"
_STALE = re.compile(re.escape(_PREFIX) + r"(\d+)-\w+")
_LOG = "launcher.log"
_POLL = 0.1  # seconds between two looks at the job
_SHOWN = 300  # characters of the launcher's output quoted in an error line
_TRACEBACK = "Traceback (most recent call last):"

T = TypeVar("T")


class MPIJobError(MissionError, RuntimeError):
    """An MPI job that failed for a reason outside cfopt (module docstring, Failures).

    A :class:`cfopt.MissionError`, so that the command line prints it as one ``error:``
    line and exits 2, and a :class:`RuntimeError`, as :func:`heuristics.mpi.mpi_run`
    documents for a failed job.
    """


@dataclass(frozen=True)
class RankRecord:
    """What a rank recorded in the job folder: where it ran, and its exit code once it
    finished (``None`` before, or when it never did)."""

    rank: int
    host: str
    pid: int
    code: int | None


# ------------------------------------------------------------------------ the folder
@contextlib.contextmanager
def job_folder() -> Iterator[Path]:
    """A fresh job folder (module docstring), removed at the end; the stale folders of
    launching processes that died are removed first."""
    base = Path(tempfile.gettempdir())
    remove_stale_folders(base)
    prefix = f"{_PREFIX}{os.getpid()}-"
    with tempfile.TemporaryDirectory(prefix=prefix, dir=base, ignore_cleanup_errors=True) as f:
        yield Path(f)


def remove_stale_folders(base: Path) -> None:
    """Remove this user's job folders in ``base`` whose launching process is gone, after
    SIGKILLing any process still marked with one."""
    with contextlib.suppress(OSError):
        for entry in os.scandir(base):
            match = _STALE.fullmatch(entry.name)
            if match is None or process_exists(int(match[1])):
                continue
            with contextlib.suppress(OSError):
                if entry.is_dir(follow_symlinks=False) and entry.stat().st_uid == os.getuid():
                    kill_marked(entry.path)
                    shutil.rmtree(entry.path)


def job_environment(folder: Path) -> dict[str, str]:
    """The launcher's environment: this one, cfopt importable from wherever this process
    imported it (an uninstalled checkout), and the job's marks (module docstring)."""
    env = dict(os.environ)
    here = str(Path(__file__).resolve().parent.parent)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (here, env.get("PYTHONPATH")) if p)
    env[JOB_ENV] = str(folder)
    env[ORIGIN_ENV] = f"{socket.gethostname()}:{os.getpid()}"
    return env


# ------------------------------------------------------------------------- the ranks
def rank_started(rank: int) -> None:
    """What a rank does first.  When :func:`run_job` launched it: die with the parent and
    with the launching process, and record this rank's host and pid.  Otherwise (ranks
    started by hand) nothing."""
    folder = os.environ.get(JOB_ENV)
    if not folder:
        return
    host, _, origin = os.environ.get(ORIGIN_ENV, "").rpartition(":")
    parent = os.getppid()
    die_with_parent(parent)
    here = host == socket.gethostname() and origin.isdigit()
    watch_parent(parent, int(origin) if here else None)
    _record(Path(folder) / f"rank-{rank}.start", f"{socket.gethostname()} {os.getpid()}")


def rank_ended(rank: int, code: int) -> None:
    """What a rank does last (its exit code ``code``), when :func:`run_job` launched it."""
    folder = os.environ.get(JOB_ENV)
    if folder:
        _record(Path(folder) / f"rank-{rank}.end", str(code))


def _record(path: Path, text: str) -> None:
    """Write ``path`` whole or not at all (a folder another node cannot see is no error)."""
    with contextlib.suppress(OSError):
        partial = path.with_name(f"{path.name}.{os.getpid()}.partial")
        partial.write_text(text, encoding="utf-8")
        partial.replace(path)


def rank_records(folder: Path) -> dict[int, RankRecord]:
    """The ranks that recorded their start in ``folder``, by rank."""
    records = {}
    for start in folder.glob("rank-*.start"):
        with contextlib.suppress(OSError, ValueError):
            rank = int(start.stem.removeprefix("rank-"))
            host, pid = start.read_text(encoding="utf-8").split()
            end = start.with_suffix(".end")
            code = int(end.read_text(encoding="utf-8")) if end.is_file() else None
            records[rank] = RankRecord(rank, host, int(pid), code)
    return records


# ---------------------------------------------------------------------------- the job
def run_job(
    launcher: Sequence[str],
    ranks: int,
    program: Sequence[str],
    *,
    folder: Path,
    result: Path,
    time_limit: float,
    kind: type[T],
) -> T:
    """Run ``LAUNCHER -n RANKS PROGRAM`` in ``folder`` until it ends; the ``kind`` object
    its ranks pickled into ``result``.  Waits and kills as the module docstring says.

    Raises
    ------
    MPIJobError
        The job failed (one line: which rank or the launcher, and how).
    KeyboardInterrupt
        Ctrl-C or SIGTERM here (the job is stopped first), or a rank stopped by SIGINT.
    RuntimeError
        A rank crashed with a traceback (the end of the job's output is in the message).
    """
    command = [*launcher, "-n", str(ranks), *program]
    job = _start(command, folder)
    try:
        overrun = _wait(job, folder, ranks, time_limit)
        failure = (
            _diagnose(job, shlex.join(launcher), folder, result)
            if overrun is None
            else _overrun(overrun, folder, ranks, time_limit)
        )
    except BaseException:
        _stop(job)
        raise
    finally:
        _end(job, folder)
    if failure is not None:
        raise failure
    return _load(result, kind)


def _start(command: list[str], folder: Path) -> subprocess.Popen[bytes]:
    try:
        with open(folder / _LOG, "wb") as log:
            return subprocess.Popen(
                command,
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=log,
                env=job_environment(folder),
                start_new_session=True,
                preexec_fn=parent_death_hook(),
            )
    except OSError as exc:
        raise MPIJobError(
            f"backend: cannot start the MPI launcher {command[0]!r} ({exc.strerror or exc})"
        ) from None


@dataclass(frozen=True)
class _Overrun:
    seconds: float  # the bound that ran out
    started: bool  # whether every rank had started


def _wait(
    job: subprocess.Popen[bytes], folder: Path, ranks: int, time_limit: float
) -> _Overrun | None:
    """``None`` once the launcher has ended; else the bound that ran out first."""
    bound = min(time_limit + GRACE, START_LIMIT)
    deadline = time.monotonic() + bound
    started = False
    while not _ended(job):
        now = time.monotonic()
        if not started and len(rank_records(folder)) >= ranks:
            started, bound = True, time_limit + GRACE
            deadline = now + bound
        if now >= deadline:
            return _Overrun(bound, started)
        time.sleep(_POLL)
    return None


def _ended(job: subprocess.Popen[bytes]) -> bool:
    """Whether the launcher has ended, leaving it unreaped where the system allows, so
    that its process group cannot be taken by another process before it is killed."""
    if not hasattr(os, "waitid"):
        return job.poll() is not None
    try:
        return os.waitid(os.P_PID, job.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None
    except ChildProcessError:  # reaped already
        return True


def _stop(job: subprocess.Popen[bytes]) -> None:
    """Ctrl-C or SIGTERM here: SIGINT to the launcher (it passes it on to every rank),
    which has :data:`STOP_GRACE` seconds to end."""
    with contextlib.suppress(ProcessLookupError):
        os.kill(job.pid, signal.SIGINT)
    deadline = time.monotonic() + STOP_GRACE
    while not _ended(job) and time.monotonic() < deadline:
        time.sleep(_POLL)


def _end(job: subprocess.Popen[bytes], folder: Path) -> None:
    """SIGKILL what is left of the job (the launcher's process group, every process
    marked with ``folder``), then reap the launcher."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(job.pid, signal.SIGKILL)
    kill_marked(str(folder))
    with contextlib.suppress(subprocess.TimeoutExpired):
        job.wait(timeout=STOP_GRACE)


def kill_marked(folder: str) -> None:
    """SIGKILL every local process whose environment marks it as of the job ``folder``
    (Linux: read from ``/proc``; elsewhere nothing), until none is left."""
    for _ in range(20):
        marked = _marked(folder)
        if not marked:
            return
        for pid in marked:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.kill(pid, signal.SIGKILL)
        time.sleep(0.05)


def _marked(folder: str) -> list[int]:
    """The pids of the live processes marked with the job ``folder``."""
    mark = f"{JOB_ENV}={folder}".encode()
    found = []
    with contextlib.suppress(OSError):
        for entry in os.scandir("/proc"):
            if entry.name.isdigit() and int(entry.name) != os.getpid():
                with contextlib.suppress(OSError):
                    if mark in Path(entry.path, "environ").read_bytes().split(b"\0"):
                        found.append(int(entry.name))
    return found


# ------------------------------------------------------------------------- diagnosis
def _overrun(overrun: _Overrun, folder: Path, ranks: int, time_limit: float) -> MPIJobError:
    """The line for a job that overran its bound (read before its processes are killed)."""
    records = rank_records(folder)
    bound = f"the time limit {time_limit:g} s + {GRACE:g} s"
    if not overrun.started:
        stopped = [f"pid {pid} is stopped" for pid in _marked(str(folder)) if _stopped(pid)]
        return MPIJobError(
            f"backend: {len(records)} of {ranks} MPI ranks started within "
            f"{overrun.seconds:g} s of the launch ({bound}, at most {START_LIMIT:g} s)"
            + "".join(f"; {line}" for line in stopped)
            + "; the job was killed"
        )
    marked = _marked(str(folder))
    unfinished = [_state(r, marked) for r in sorted(records.values(), key=_rank) if r.code is None]
    return MPIJobError(
        f"backend: the MPI job did not end within {overrun.seconds:g} s of its ranks' start "
        f"({bound}): {', '.join(unfinished)}; the job was killed"
    )


def _rank(record: RankRecord) -> int:
    return record.rank


def _state(record: RankRecord, marked: list[int]) -> str:
    """``rank R (pid P) is stopped``, ``... is still running`` or ``... is gone``
    (``marked``: the job's live local processes)."""
    who = f"rank {record.rank} (pid {record.pid})"
    if record.host != socket.gethostname():
        return f"{who} on {record.host} had not finished"
    if record.pid not in marked:
        return f"{who} is gone"
    return f"{who} is stopped" if _stopped(record.pid) else f"{who} is still running"


def _stopped(pid: int) -> bool:
    """Whether process ``pid`` is stopped (by SIGSTOP, SIGTSTP, a debugger; Linux)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text(encoding="utf-8")
    except OSError:
        return False
    return stat.rpartition(")")[2].split()[:1] in (["T"], ["t"])


def _diagnose(
    job: subprocess.Popen[bytes], launcher: str, folder: Path, result: Path
) -> BaseException | None:
    """What went wrong with a job whose launcher ended (``None``: nothing)."""
    code = job.returncode if job.returncode is not None else _exit_code(job)
    if code == 0 and result.is_file():
        return None
    if code == INTERRUPTED:
        return KeyboardInterrupt()
    log = _read_log(folder)
    said = next((line for line in log.splitlines() if line.startswith("error: ")), None)
    if said is not None:  # the ranks' own line (rank 0's, the others keep quiet)
        return MPIJobError(said.removeprefix("error: "))
    if _TRACEBACK in log:
        tail = "\n".join(log.strip().splitlines()[-20:])
        crashed = f"a rank of the MPI job ({launcher}) crashed; exit code {code}"
        return RuntimeError(f"{crashed}:\n{tail}")
    return MPIJobError("backend: " + _what_failed(code, launcher, job.pid, folder, result, log))


def _exit_code(job: subprocess.Popen[bytes]) -> int:
    """The ended launcher's exit code (negative: the signal that killed it), unreaped."""
    if not hasattr(os, "waitid"):
        return job.wait()
    info = os.waitid(os.P_PID, job.pid, os.WEXITED | os.WNOWAIT)
    if info.si_code == os.CLD_EXITED:
        return info.si_status
    return -info.si_status


def _what_failed(code: int, launcher: str, pid: int, folder: Path, result: Path, log: str) -> str:
    """The launcher, or the ranks that died and how, or the exit codes of all."""
    if code < 0:
        return f"the MPI launcher {launcher} (pid {pid}) was killed by {_signal_name(-code)}"
    records = rank_records(folder)
    if not records:
        return (
            f"the MPI launcher {launcher} exited with code {code} before starting any rank: "
            + _first_line(log)
        )
    lost = sorted((r for r in records.values() if r.code is None), key=_rank)
    named = [r for r in lost if re.search(rf"\bPID\s+{r.pid}\b", log, re.IGNORECASE)]
    if lost:
        culprits = ", ".join(f"rank {r.rank} (pid {r.pid})" for r in named or lost)
        found = re.search(r"\bsignal:?\s+(\d+)", log, re.IGNORECASE)
        how = f"was killed by {_signal_name(int(found[1]))}" if found else "died before finishing"
        return f"{culprits} of the MPI job {how}; {launcher} exited with code {code}"
    codes = ", ".join(f"rank {r.rank}: {r.code}" for r in sorted(records.values(), key=_rank))
    missing = "" if result.is_file() else " and wrote no result"
    return f"the MPI job ({launcher}) exited with code {code}{missing} (exit codes {codes})"


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def _read_log(folder: Path) -> str:
    try:
        return (folder / _LOG).read_text(encoding="utf-8", errors="replace")
    except OSError:
        return ""


def _first_line(log: str) -> str:
    line = next((line.strip() for line in log.splitlines() if line.strip()), None)
    if line is None:
        return "it printed nothing"
    return line if len(line) <= _SHOWN else line[: _SHOWN - 3] + "..."


def _load(result: Path, kind: type[T]) -> T:
    """The ranks' result; a file that is not a pickled ``kind`` is an :class:`MPIJobError`."""
    try:
        value: Any = pickle.loads(result.read_bytes())
    except Exception as exc:  # unpickling garbage can raise nearly any exception
        raise MPIJobError(
            f"backend: the MPI job's result {result.name} is unreadable "
            f"({type(exc).__name__}: {exc})"
        ) from None
    if not isinstance(value, kind):
        raise MPIJobError(
            f"backend: the MPI job's result {result.name} holds a {type(value).__name__}, "
            f"not a {kind.__name__}"
        )
    return value
