"""MPI launches that fail, hang or orphan, each as a real ``cfopt run ... --backend mpi``
process: it ends with exit 2 (130 or 143 for a signal), exactly one ``error:`` line on
stderr naming the launcher or the rank and how, no traceback, no process of the job alive
5 s after the end, and no hang past the launcher's stated bounds."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

import pytest

from cfopt import GridCell, MissionError
from heuristics.mpi_job import GRACE, JOB_ENV, ORIGIN_ENV, START_LIMIT

try:
    from heuristics.mpi import launcher

    launcher()
except (ImportError, MissionError) as missing:  # pragma: no cover - CI installs the extra
    if os.environ.get("CI"):
        raise RuntimeError(f"CI must install the mpi extra: {missing}") from missing
    pytest.skip(f"no MPI here ({missing})", allow_module_level=True)

pytestmark = pytest.mark.skipif(
    not Path("/proc/self/environ").exists(), reason="finds the job's processes in /proc"
)

#: Marks every process a test's cfopt starts (the environment is inherited).
TAG = "CFOPT_FAULT_TEST"
#: 20 robots on a ring ticking once a second: d_G 10, so at least 20 quiet ticks (> 20 s).
SLOW = "ring period=1s"
#: Seconds of cfopt's own start-up (imports, the mission, the network) on a loaded machine.
CFOPT_START = 30.0
#: Seconds a process of the job may outlive cfopt's end.
LINGER = 5.0


def hang_bound(time_limit: float) -> float:
    """The longest a job may take: its ranks' start-up, the time limit and the grace, as
    the launcher states them, plus 10 s (and cfopt's own start-up)."""
    return CFOPT_START + min(time_limit + GRACE, START_LIMIT) + time_limit + GRACE + 10


def marked(tag: str) -> list[int]:
    """The live processes carrying ``TAG=tag`` in their environment."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                environ = (entry / "environ").read_bytes().split(b"\0")
            except OSError:
                continue
            if f"{TAG}={tag}".encode() in environ:
                found.append(int(entry.name))
    return found


def command_line(pid: int) -> list[str]:
    raw = Path(f"/proc/{pid}/cmdline").read_bytes()
    return [part.decode(errors="replace") for part in raw.split(b"\0") if part]


class Job:
    """``cfopt run grape-s MISSION --backend mpi --seed 0 --time-limit T ...`` in a
    session of its own."""

    def __init__(
        self,
        mission: Path,
        *extra: str,
        time_limit: float = 5.0,
        env: dict[str, str] | None = None,
    ) -> None:
        self.tag = uuid.uuid4().hex
        self.time_limit = time_limit
        self.process = subprocess.Popen(
            [sys.executable, "-m", "cfopt", "run", "grape-s", str(mission), "--backend",
             "mpi", "--seed", "0", "--time-limit", f"{time_limit:g}", *extra],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            env={**os.environ, **(env or {}), TAG: self.tag}, start_new_session=True,
        )  # fmt: skip

    def folders(self) -> list[Path]:
        """The job folders of this cfopt process."""
        return list(Path(tempfile.gettempdir()).glob(f"cfopt-mpi-{self.process.pid}-*"))

    def ranks_started(self, ranks: int = 2) -> dict[int, int]:
        """Wait until every rank recorded its start; ``{rank: pid}``."""
        deadline = time.monotonic() + hang_bound(self.time_limit)
        while time.monotonic() < deadline:
            assert self.process.poll() is None, self.process.communicate()
            records = [p for f in self.folders() for p in f.glob("rank-*.start")]
            if len(records) == ranks:
                return {
                    int(p.stem.removeprefix("rank-")): int(p.read_text().split()[1])
                    for p in records
                }
            time.sleep(0.2)
        raise AssertionError("the ranks did not start")

    def launcher_pid(self) -> int:
        (pid,) = [p for p in marked(self.tag) if Path(command_line(p)[0]).name == "mpiexec"]
        return pid

    def end(self, codes: tuple[int, ...] = (2,)) -> str:
        """Wait for cfopt (within the launcher's bounds) and check the end; its one line."""
        _, err = self.process.communicate(timeout=hang_bound(self.time_limit))
        assert self.process.returncode in codes, err
        assert "Traceback" not in err, err
        lines = err.splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: "), lines
        deadline = time.monotonic() + LINGER
        while marked(self.tag) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert marked(self.tag) == [], [command_line(p) for p in marked(self.tag)]
        return lines[0]


@pytest.fixture
def mission(tmp_path: Path) -> Path:
    path = tmp_path / "m.json"
    GridCell(20, 20, 4, 2).mission(1).to_json(path)
    return path


def launching_with(command: str) -> dict[str, str]:
    """The environment entries making ``command`` the launcher (``mpiexec`` beside Python
    found on ``PATH``)."""
    path = f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"
    return {"CFOPT_MPIEXEC": command, "PATH": path}


def script(folder: Path, name: str, body: str) -> str:
    """A fake launcher: a shell script getting ``-n K python -m cfopt.mpi ...``."""
    path = folder / name
    path.write_text("#!/bin/sh\n" + body + "\n", encoding="utf-8")
    path.chmod(0o755)
    return str(path)


# ------------------------------------------------------------------- the launcher
@pytest.mark.parametrize(
    ("launch", "line"),
    [
        pytest.param(
            "/bin/false",
            "error: backend: the MPI launcher /bin/false exited with code 1 before starting "
            "any rank: it printed nothing",
            id="false",
        ),
        pytest.param(
            "/bin/true",
            "error: backend: the MPI launcher /bin/true exited with code 0 before starting "
            "any rank: it printed nothing",
            id="true-writes-no-result",
        ),
        pytest.param(
            "mpiexec --bogus-option",
            "error: backend: the MPI launcher mpiexec --bogus-option exited with code 255 "
            "before starting any rank: [mpiexec@",
            id="bogus-option",
        ),
        pytest.param(
            "mpiexec '",
            """error: backend: CFOPT_MPIEXEC="mpiexec '" is not a command line """
            "(No closing quotation)",
            id="unclosed-quote",
        ),
        pytest.param(
            "GARBAGE",
            "error: backend: the MPI job's result run.pickle is unreadable (",
            id="garbage-result",
        ),
        pytest.param(
            "BACKGROUND",
            "error: backend: the MPI launcher {} exited with code 1 before starting any "
            "rank: it printed nothing",
            id="backgrounds-a-child-and-exits-1",
        ),
    ],
)
def test_launchers_that_fail(mission: Path, tmp_path: Path, launch: str, line: str) -> None:
    fakes = {
        "GARBAGE": 'while [ "$1" != --result-file ]; do shift; done; echo garbage > "$2"',
        "BACKGROUND": "sleep 1000 &\nexit 1",  # the sleep holds the launcher's stdout
    }
    if launch in fakes:
        launch = script(tmp_path, f"{launch.lower()}.sh", fakes[launch])
        line = line.format(launch)
    assert Job(mission, env=launching_with(launch)).end().startswith(line)


def test_a_launcher_that_never_starts_a_rank_is_killed(mission: Path, tmp_path: Path) -> None:
    """``exec sleep 1000`` with a 1 s limit: killed (the sleep too) once the ranks had
    ``min(limit + GRACE, START_LIMIT)`` seconds to start."""
    sleeper = script(tmp_path, "sleeper.sh", "exec sleep 1000")
    job = Job(mission, time_limit=1, env=launching_with(sleeper))
    assert job.end() == (
        f"error: backend: 0 of 2 MPI ranks started within {1 + GRACE:g} s of the launch "
        f"(the time limit 1 s + {GRACE:g} s, at most {START_LIMIT:g} s); the job was killed"
    )


# ----------------------------------------------------------------------- the ranks
def test_a_ranks_own_error_line_is_passed_on(mission: Path, tmp_path: Path) -> None:
    """A launcher that loses the mission before starting the ranks: rank 0's line."""
    lose = 'for a; do case $a in *mission.json) rm "$a";; esac; done\nexec mpiexec "$@"'
    line = Job(mission, env=launching_with(script(tmp_path, "lose.sh", lose))).end()
    assert re.fullmatch(r"error: /\S*/cfopt-mpi-\d+-\w+/mission\.json: .+", line), line


@pytest.mark.parametrize(
    ("spec", "edges"),
    [
        pytest.param("geometric radius=0.05", None, id="disconnected"),
        pytest.param("file=edges.txt", "r0 r1\nr1 r99\n", id="unknown-robot-in-file"),
    ],
)
def test_bad_networks_are_the_simulators_line(mission: Path, spec: str, edges: str | None) -> None:
    """Checked before anything is launched: the same line as the simulator's."""
    if edges is not None:
        (mission.parent / "edges.txt").write_text(edges, encoding="utf-8")
        spec = f"file={mission.parent / 'edges.txt'}"
    sim = subprocess.run(
        [sys.executable, "-m", "cfopt", "run", "grape-s", str(mission), "--network", spec,
         "--seed", "0"],
        capture_output=True, text=True,
    )  # fmt: skip
    assert sim.returncode == 2 and len(sim.stderr.splitlines()) == 1, sim.stderr
    assert Job(mission, "--network", spec).end() == sim.stderr.strip()


def test_a_killed_rank_is_named(mission: Path) -> None:
    job = Job(mission, "--network", SLOW, time_limit=60)
    pid = job.ranks_started()[1]
    os.kill(pid, signal.SIGKILL)
    line = job.end()
    # MPICH 4.3 kills the other ranks with SIGKILL as it cleans up, and one of them may be
    # seen first; MPICH 5 leaves them to end themselves
    named = re.match(r"error: backend: rank (\d) \(pid (\d+)\) of the MPI job was killed by ", line)
    assert named, line
    assert int(named.group(1)) in (0, 1) and "SIGKILL" in line


def test_a_killed_launcher_is_named(mission: Path) -> None:
    job = Job(mission, "--network", SLOW, time_limit=60)
    job.ranks_started()
    pid = job.launcher_pid()
    os.kill(pid, signal.SIGKILL)
    assert job.end().endswith(f"mpiexec (pid {pid}) was killed by SIGKILL")


def test_a_stopped_rank_is_killed_after_the_time_limit_and_the_grace(mission: Path) -> None:
    job = Job(mission, "--network", SLOW, time_limit=8)
    pids = job.ranks_started()
    os.kill(pids[1], signal.SIGSTOP)
    assert job.end() == (
        f"error: backend: the MPI job did not end within {8 + GRACE:g} s of its ranks' start "
        f"(the time limit 8 s + {GRACE:g} s): rank 0 (pid {pids[0]}) is still running, "
        f"rank 1 (pid {pids[1]}) is stopped; the job was killed"
    )


# --------------------------------------------------------------------- the parent
def test_sigkill_of_cfopt_leaves_nothing_running(mission: Path) -> None:
    """The launcher, its proxy and the ranks die with cfopt; the job folder cfopt could not
    remove goes with the next MPI run."""
    job = Job(mission, "--network", SLOW, time_limit=60)
    job.ranks_started()
    (folder,) = job.folders()
    job.process.kill()
    job.process.communicate()
    deadline = time.monotonic() + LINGER
    while marked(job.tag) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert marked(job.tag) == [], [command_line(p) for p in marked(job.tag)]
    assert folder.is_dir()
    Job(mission, env=launching_with("/bin/true")).end()
    assert not folder.exists()


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupts_stop_the_whole_job(mission: Path, sig: signal.Signals, code: int) -> None:
    job = Job(mission, "--network", SLOW, time_limit=60)
    job.ranks_started()
    job.process.send_signal(sig)
    assert job.end(codes=(code,)) == f"error: interrupted ({sig.name})"
    assert job.folders() == []


def test_a_rank_dies_with_the_process_that_launched_it(tmp_path: Path) -> None:
    """The ranks' watchdog on the launching process (its parent is someone else: MPICH's
    proxy), here a ``sleep`` standing for it."""
    origin = subprocess.Popen(["sleep", "600"])
    code = "from heuristics.mpi_job import rank_started; import time; rank_started(0); "
    code += "time.sleep(600)"
    env = {**os.environ, JOB_ENV: str(tmp_path), ORIGIN_ENV: f"{socket.gethostname()}:{origin.pid}"}
    rank = subprocess.Popen([sys.executable, "-c", code], env=env)
    try:
        deadline = time.monotonic() + 600  # a hang guard
        while not (tmp_path / "rank-0.start").is_file() and time.monotonic() < deadline:
            time.sleep(0.1)
        assert (tmp_path / "rank-0.start").read_text().split() == [
            socket.gethostname(),
            str(rank.pid),
        ]
        origin.kill()  # left unreaped: a zombie counts as ended
        assert rank.wait(timeout=60) == 1
    finally:
        rank.kill()
        origin.kill()
        origin.wait()
