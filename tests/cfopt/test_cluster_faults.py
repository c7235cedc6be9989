"""Hostile ``--scheduler`` values and servers, each met by a real ``cfopt sweep`` process.

Every row ends with exit 0, or 2 and exactly one ``error:`` line on stderr (130/143 on a
signal): no traceback, not even one logged by dask before the error line, no wait past
the connect timeout (plus :data:`SLACK` seconds) once the connection reached the server,
and no process left behind in the command's process group.
"""

from __future__ import annotations

import contextlib
import os
import random
import signal
import socket
import sqlite3
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("distributed")

import cfopt
from cfopt import MissionError
from cfopt.cluster import CONNECT_TIMEOUT, SchedulerSpec, parse_scheduler

ROOT = Path(cfopt.__file__).resolve().parents[1]
#: Two trials of well under a second.
TINY = ["sweep", "--robots", "10", "--percent-tasks", "10", "--compositions", "2:1",
        "--missions", "1", "--algorithms", "grape-s", "--quiet"]  # fmt: skip
#: Sixteen trials of about a second each (sda's agents in the simulator).
SLOW = ["sweep", "--robots", "60", "--percent-tasks", "10", "--compositions", "5:2",
        "--network", "complete", "--missions", "8", "--algorithms", "sda", "--quiet"]  # fmt: skip
#: Seconds a command may take past its connect timeout to say so and end.
SLACK = 10.0
#: Seconds after which a command is taken for hung and killed (imports included).
HUNG = 300.0
UNSUPPORTED = "is not supported: cfopt connects over tcp only, give tcp://HOST:PORT or HOST:PORT"


# ------------------------------------------------------------------------ processes
@dataclass
class Ended:
    """A finished command: its exit code, output, and when it ended (monotonic)."""

    code: int
    out: str
    err: str
    at: float


def _start(args: list[str], scheduler: str, store: Path) -> subprocess.Popen[str]:
    """``python -m cfopt ARGS --store STORE --scheduler SCHEDULER``, in a session of its own."""
    paths = [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]
    return subprocess.Popen(
        [sys.executable, "-m", "cfopt", *args, "--store", str(store), "--scheduler", scheduler],
        cwd=store.parent,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(paths)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


def _finish(process: subprocess.Popen[str]) -> Ended:
    """Wait for the command (killing its group if hung) and check nothing of it is left."""
    try:
        out, err = process.communicate(timeout=HUNG)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        pytest.fail(f"hung for {HUNG:g} s")
    ended = Ended(process.returncode, out, err, time.monotonic())
    _wait_for(lambda: not _group(process.pid), seconds=30, what="processes left behind")
    return ended


def _sweep(scheduler: str, tmp_path: Path, args: list[str] = TINY) -> Ended:
    return _finish(_start(args, scheduler, tmp_path / "s.sqlite"))


def _group(pgid: int) -> list[int]:
    """The live processes of process group ``pgid`` (Linux: read from /proc)."""
    if not sys.platform.startswith("linux"):
        return []
    found = []
    for entry in Path("/proc").iterdir():
        with contextlib.suppress(OSError, IndexError, ValueError):
            state, _, group = (entry / "stat").read_text().rsplit(")", 1)[1].split()[:3]
            if int(group) == pgid and state != "Z":
                found.append(int(entry.name))
    return found


def _wait_for(condition: Callable[[], bool], *, seconds: float, what: str) -> None:
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting: {what}"
        time.sleep(0.05)


def _one_error(ended: Ended, fragment: str) -> str:
    assert ended.code == 2, ended.err
    assert "Traceback" not in ended.err, ended.err
    lines = ended.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: --scheduler"), ended.err
    assert fragment in lines[0], lines[0]
    assert ended.out == ""
    return lines[0]


def _stored(store: Path) -> int:
    with (
        contextlib.suppress(sqlite3.Error),
        contextlib.closing(sqlite3.connect(f"file:{store}?mode=ro", uri=True)) as db,
    ):
        return int(db.execute("SELECT COUNT(*) FROM trials").fetchone()[0])
    return 0


# ---------------------------------------------------------------- address checks
@pytest.mark.parametrize(
    ("value", "address"),
    [
        ("tcp://10.0.0.5:8786", "tcp://10.0.0.5:8786"),
        ("TCP://10.0.0.5:8786", "tcp://10.0.0.5:8786"),
        ("10.0.0.5:1", "10.0.0.5:1"),
        ("localhost:8786", "localhost:8786"),  # an address, not a malformed local:N
        ("tcp://sched-1.example.org.:65535", "tcp://sched-1.example.org.:65535"),
        ("tcp://[::1]:8786", "tcp://[::1]:8786"),
        ("[fe80::1%eth0]:8786", "[fe80::1%eth0]:8786"),
    ],
)
def test_addresses_cfopt_connects_to(value: str, address: str) -> None:
    assert parse_scheduler(value) == SchedulerSpec(address, None)


@pytest.mark.parametrize(
    ("value", "problem"),
    [
        ("tcp://127.0.0.1", "no port"),
        ("127.0.0.1", "no port"),
        ("tcp://[::1]", "no port"),
        ("tcp://:8786", "no host"),
        ("tcp://127.0.0.1:0", "the port must be a whole number from 1 to 65535, got '0'"),
        ("127.0.0.1:65536", "the port must be a whole number from 1 to 65535, got '65536'"),
        ("tcp://host:http", "the port must be a whole number from 1 to 65535, got 'http'"),
        ("tcp://host:", "the port must be a whole number from 1 to 65535, got ''"),
        ("tcp://::1:8786", "an IPv6 host goes in brackets"),
        ("tcp://[::1:8786", "an IPv6 host goes in brackets"),
        ("tcp://[::1]x:8786", "an IPv6 host goes in brackets"),
        ("tcp://[nope]:8786", "'nope' is not an IPv6 address"),
        ("tcp://a..b:8786", "'a..b' is not a host name or an IP address"),
        ("tcp://user@host:8786", "'user@host' is not a host name or an IP address"),
        ("tcp://host/path:8786", "'host/path' is not a host name or an IP address"),
        (f"tcp://{'a' * 64}:8786", "is not a host name or an IP address"),
        ("tls://127.0.0.1:8786", f"the scheme 'tls' {UNSUPPORTED}"),
        ("://127.0.0.1:8786", f"the scheme '' {UNSUPPORTED}"),
    ],
)
def test_malformed_addresses_name_the_problem(value: str, problem: str) -> None:
    with pytest.raises(MissionError) as info:
        parse_scheduler(value)
    message = info.value.cli_message
    assert message.startswith(f"--scheduler: not a scheduler address: {value!r} ("), message
    assert problem in message and message.endswith(")"), message


@pytest.mark.parametrize(
    ("value", "problem"),
    [
        ("tcp://127.0.0.1", "no port: give tcp://HOST:PORT or HOST:PORT"),
        ("tcp://127.0.0.1:99999", "the port must be a whole number from 1 to 65535"),
        ("ucx://127.0.0.1:8786", f"the scheme 'ucx' {UNSUPPORTED}"),
        ("tls://127.0.0.1:8786", f"the scheme 'tls' {UNSUPPORTED}"),
        ("inproc://192.0.2.2/4242/1", f"the scheme 'inproc' {UNSUPPORTED}"),
        ("ws://127.0.0.1:8786", f"the scheme 'ws' {UNSUPPORTED}"),
    ],
)
def test_cli_refuses_malformed_addresses_in_one_line(
    value: str, problem: str, tmp_path: Path
) -> None:
    ended = _sweep(value, tmp_path)
    _one_error(ended, f"--scheduler: not a scheduler address: {value!r} ({problem}")
    assert not (tmp_path / "s.sqlite").exists()


def test_cli_reproduce_refuses_a_malformed_address_in_one_line(tmp_path: Path) -> None:
    args = ["reproduce", "--missions", "1", "--centralized-only", "--quiet", "-o", "rep"]
    ended = _finish(_start(args, "tls://127.0.0.1:8786", tmp_path / "s.sqlite"))
    _one_error(ended, f"(the scheme 'tls' {UNSUPPORTED}")
    assert not (tmp_path / "s.sqlite").exists()


def test_code_help_and_readme_state_the_same_connect_timeout(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from cfopt.cli import main

    stated = f"within {CONNECT_TIMEOUT:g} s"
    for command in ("sweep", "reproduce"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        shown = " ".join(capsys.readouterr().out.split())
        assert f"tcp://HOST:PORT or HOST:PORT, that must answer {stated}" in shown
    readme_file = Path(__file__).resolve().parents[2] / "README.md"  # the checkout's
    readme = " ".join(readme_file.read_text(encoding="utf-8").split())
    assert f"a scheduler that has not answered {stated} (the connection, dask's" in readme


# ------------------------------------------------------------ servers that are not dask
@dataclass
class Server:
    """A TCP server on 127.0.0.1 run by a thread of the test: ``answer`` meets each
    connection as it is accepted; the connections stay open until the server stops."""

    answer: Callable[[socket.socket], None]
    accepted: list[float] = field(default_factory=list)
    address: str = ""

    @contextlib.contextmanager
    def running(self) -> Iterator[Server]:
        connections: list[socket.socket] = []
        stop = threading.Event()
        with socket.create_server(("127.0.0.1", 0)) as listener:
            listener.settimeout(0.1)
            self.address = f"tcp://127.0.0.1:{listener.getsockname()[1]}"

            def serve() -> None:
                while not stop.is_set():
                    try:
                        connection, _ = listener.accept()
                    except TimeoutError:
                        continue
                    self.accepted.append(time.monotonic())
                    connections.append(connection)
                    with contextlib.suppress(OSError):
                        self.answer(connection)

            thread = threading.Thread(target=serve, daemon=True)
            thread.start()
            try:
                yield self
            finally:
                stop.set()
                thread.join()
                for connection in connections:
                    connection.close()


def _random_bytes(connection: socket.socket) -> None:
    connection.sendall(random.Random(21).randbytes(4096))


def _http(connection: socket.socket) -> None:
    connection.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
    connection.close()


def _junk_frame(connection: socket.socket) -> None:
    """A well-framed message (dask's length prefixes) whose payload is no msgpack."""
    connection.sendall(struct.pack("<QQQ", 24, 1, 8) + b"\xc1" * 8)


def _close(connection: socket.socket) -> None:
    connection.close()


def _silent(connection: socket.socket) -> None:
    """Accept and say nothing (the connection stays open)."""


NOT_DASK = "not a dask scheduler (its answer is not dask's protocol: "


@pytest.mark.parametrize(
    ("answer", "fragment"),
    [
        (_random_bytes, NOT_DASK),
        (_http, NOT_DASK),
        (_junk_frame, NOT_DASK),
        (_close, "cannot reach the scheduler at "),
        (_silent, f"within {CONNECT_TIMEOUT:g} s (no answer)"),
    ],
    ids=["random-bytes", "http", "junk-frame", "closes-at-once", "silent"],
)
def test_servers_that_do_not_speak_dask_are_one_line_within_the_timeout(
    answer: Callable[[socket.socket], None], fragment: str, tmp_path: Path
) -> None:
    with Server(answer).running() as server:
        ended = _sweep(server.address, tmp_path)
    line = _one_error(ended, fragment)
    assert line.startswith(f"error: --scheduler: {server.address}: not a dask scheduler") or (
        line.startswith(f"error: --scheduler: cannot reach the scheduler at {server.address} ")
    )
    assert server.accepted, "the command never connected"
    assert ended.at - server.accepted[0] < CONNECT_TIMEOUT + SLACK
    assert not (tmp_path / "s.sqlite").exists()


@pytest.mark.parametrize(
    ("signum", "code", "name"), [(signal.SIGTERM, 143, "SIGTERM"), (signal.SIGINT, 130, "SIGINT")]
)
def test_a_signal_while_waiting_for_a_silent_server_ends_the_command(
    signum: int, code: int, name: str, tmp_path: Path
) -> None:
    with Server(_silent).running() as server:
        process = _start(TINY, server.address, tmp_path / "s.sqlite")
        try:
            _wait_for(lambda: bool(server.accepted), seconds=HUNG, what="a connection")
        finally:
            sent = time.monotonic()
            os.killpg(process.pid, signum)
            ended = _finish(process)
    assert (ended.code, ended.err, ended.out) == (code, f"error: interrupted ({name})\n", "")
    assert ended.at - sent < SLACK


# ------------------------------------------------------------------- real schedulers
@contextlib.contextmanager
def _tcp_cluster() -> Iterator[Any]:
    """A dask cluster in this process (one worker thread) that listens on tcp."""
    from distributed import LocalCluster

    cluster = LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=False,
        protocol="tcp",
        dashboard_address=None,
        scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},  # not 8787, maybe taken
    )
    try:
        yield cluster
    finally:
        cluster.close()


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    with _tcp_cluster() as running:
        yield running


def test_a_sweep_on_a_running_scheduler_says_nothing_on_stderr(
    cluster: Any, tmp_path: Path
) -> None:
    ended = _sweep(cluster.scheduler_address, tmp_path)
    assert (ended.code, ended.err) == (0, ""), ended.err
    assert "2 trials run, 0 already stored, 0 failed, of 2" in ended.out
    assert _stored(tmp_path / "s.sqlite") == 2


def test_a_worker_address_is_not_a_scheduler(cluster: Any, tmp_path: Path) -> None:
    (worker,) = cluster.scheduler.workers
    ended = _sweep(worker, tmp_path)
    _one_error(ended, f"--scheduler: {worker}: not a dask scheduler (it says it is a dask Worker)")


def test_a_scheduler_lost_mid_sweep_is_one_line_without_dask_s_traceback(
    tmp_path: Path,
) -> None:
    store = tmp_path / "s.sqlite"
    with _tcp_cluster() as lost:
        address = lost.scheduler_address
        process = _start(SLOW, address, store)
        try:
            _wait_for(
                lambda: _stored(store) >= 1 or process.poll() is not None,
                seconds=HUNG,
                what="a stored trial",
            )
        finally:
            lost.close()
            ended = _finish(process)
    kept = _stored(store)
    assert 1 <= kept < 16
    line = _one_error(ended, "lost the connection to the scheduler; ")
    assert line.startswith(f"error: --scheduler {address}: lost the connection")
    assert f"computed by this run {'is' if kept == 1 else 'are'} kept in" in line


def test_a_local_cluster_sweep_leaves_no_process_behind(tmp_path: Path) -> None:
    ended = _sweep("local:1", tmp_path)  # _finish checks the process group is empty
    assert (ended.code, ended.err) == (0, ""), ended.err
    assert _stored(tmp_path / "s.sqlite") == 2


#: Starts the ``cfopt`` command with a shorter wait for a first worker.
SHORT_WORKER_WAIT = (
    "import cfopt.cluster as c; c.WORKER_TIMEOUT = 2.0\nfrom cfopt.cli import entry\nentry()"
)


def test_a_scheduler_without_workers_is_one_line_not_a_hang(tmp_path: Path) -> None:
    from distributed import LocalCluster

    empty = LocalCluster(
        n_workers=0, processes=False, protocol="tcp", dashboard_address=None,
        scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
    )  # fmt: skip
    try:
        process = subprocess.Popen(
            [sys.executable, "-c", SHORT_WORKER_WAIT, *TINY, "--store",
             str(tmp_path / "s.sqlite"), "--scheduler", empty.scheduler_address],
            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            start_new_session=True,
        )  # fmt: skip
        ended = _finish(process)
    finally:
        empty.close()
    _one_error(ended, "no worker joined the scheduler within 2 s (start one with: dask worker")
