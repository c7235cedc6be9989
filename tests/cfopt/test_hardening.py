"""A hostile user's inputs: every one ends with exit 2 and one ``error:`` line, nothing the
user had is lost, interrupted and killed jobs leave no workers and no half-written files,
and two sweeps never run the same trial twice.

Cases about the command line run it as a real process (``python -m cfopt``).
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import resource
import signal
import sqlite3
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from cfopt import GridCell, Mission, MissionError
from cfopt.experiments import Sweep, run_sweep
from heuristics import ALGORITHMS

# ---------------------------------------------------------------------------- helpers
BASE = Mission.from_arrays(
    [[1, 0], [1, 1], [0, 1], [1, 1]], [[2, 0], [0, 1], [1, 1]], [5.0, 3.0, 4.0]
).to_dict()
ASSIGNMENT = {"assignment": [{"robot": "r0", "task": "t0", "service": "s0"}]}
LONG_NUMBER = "7" * 5000


def cfopt(
    *args: str,
    cwd: Path | None = None,
    stdin: str | None = None,
    timeout: float = 120,
    preexec: Callable[[], None] | None = None,
) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "cfopt", *args],
        capture_output=True,
        text=True,
        input=stdin,
        cwd=cwd,
        timeout=timeout,
        preexec_fn=preexec,
    )


def assert_one_error_line(result: subprocess.CompletedProcess, fragment: str) -> None:
    assert result.returncode == 2, (result.returncode, result.stderr)
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("error: ") and "Traceback" not in result.stderr
    assert fragment in lines[0], lines[0]


def mission_with(change: Callable[[dict], None]) -> str:
    data = json.loads(json.dumps(BASE))
    change(data)
    return json.dumps(data)


def with_metadata_number(data: dict) -> None:
    data["metadata"] = {"x": "@@"}


def set_key(path: tuple, value: object) -> Callable[[dict], None]:
    def change(data: dict) -> None:
        target = data
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value

    return change


def fifo(folder: Path, name: str) -> None:
    os.mkfifo(folder / name)


def tiny_store(folder: Path) -> Path:
    store = folder / "s.sqlite"
    sweep = Sweep(cells=(GridCell(10, 20, 3, 2),), missions=1, algorithms=("grape-s",))
    run_sweep(sweep, store, workers=1, progress=False)
    return store


def edit_store(sql: str) -> Callable[[Path], None]:
    def prepare(folder: Path) -> None:
        store = tiny_store(folder)
        with contextlib.closing(sqlite3.connect(store)) as db:
            db.execute(sql)
            db.commit()

    return prepare


def files(**contents: str) -> Callable[[Path], None]:
    def prepare(folder: Path) -> None:
        for name, text in contents.items():
            (folder / name.replace("_", ".")).write_text(text, encoding="utf-8")

    return prepare


def both(*steps: Callable[[Path], None]) -> Callable[[Path], None]:
    def prepare(folder: Path) -> None:
        for step in steps:
            step(folder)

    return prepare


GENERATE = ["generate", "--percent-tasks", "10", "--services-per-robot", "2"]
OVERFLOW = mission_with(
    lambda d: d["tasks"].__setitem__(slice(None), [t | {"utility": 1e308} for t in d["tasks"]])
)
SURROGATE_ROBOT = json.dumps(BASE).replace('"r0"', '"\\ud800"')
SURROGATE_SERVICE = json.dumps(BASE).replace('"s1"', '"\\udfff"')

# --------------------------------------------------------- bad input: exit 2, one line
BAD_INPUTS = [
    pytest.param(
        files(m_json=mission_with(with_metadata_number).replace('"@@"', LONG_NUMBER)),
        ["validate", "m.json"],
        "a number of 5000 digits is out of the range",
        id="integer-of-5000-digits-in-mission",
    ),
    pytest.param(
        files(
            m_json=json.dumps(BASE),
            a_json=json.dumps({"assignment": [], "x": "@@"}).replace('"@@"', LONG_NUMBER),
        ),
        ["check", "m.json", "a.json"],
        "a.json: line 1, column",
        id="integer-of-5000-digits-in-assignment",
    ),
    pytest.param(
        files(m_json=mission_with(set_key(("tasks", 0, "requires", "s0"), 10**309))),
        ["validate", "m.json"],
        "tasks[0].requires.s0: must be at most 2147483647",
        id="requirement-10e309",
    ),
    pytest.param(
        files(m_json=mission_with(set_key(("tasks", 0, "requires", "s0"), -(10**309)))),
        ["solve", "m.json"],
        "tasks[0].requires.s0: must be a whole number >= 1",
        id="requirement-minus-10e309",
    ),
    pytest.param(
        files(m_json=SURROGATE_ROBOT),
        ["validate", "m.json"],
        "robots[0].id: must be valid Unicode text",
        id="lone-surrogate-robot-id",
    ),
    pytest.param(
        files(m_json=SURROGATE_SERVICE),
        ["run", "grape-s", "m.json"],
        "services[1]: must be valid Unicode text",
        id="lone-surrogate-service",
    ),
    pytest.param(
        files(
            m_json=json.dumps(BASE),
            a_json=json.dumps(ASSIGNMENT).replace('"r0"', '"\\ud800"'),
        ),
        ["check", "m.json", "a.json"],
        'unknown robot "\\ud800"',
        id="lone-surrogate-in-assignment",
    ),
    *(
        pytest.param(
            files(m_json=OVERFLOW, a_json=json.dumps(ASSIGNMENT)),
            argv,
            "tasks: the utilities add up to more than the largest floating-point number",
            id=f"utilities-1e308-{argv[0]}",
        )
        for argv in (
            ["validate", "--json", "m.json"],
            ["solve", "m.json"],
            ["run", "sda", "m.json"],
            ["check", "m.json", "a.json"],
        )
    ),
    pytest.param(
        files(m_json=mission_with(set_key(("metadata",), {"x": "@@"})).replace('"@@"', "1e999")),
        ["validate", "m.json"],
        "metadata.x: must be a finite number",
        id="metadata-infinity",
    ),
    pytest.param(
        files(m_json="[" * 3000 + "]" * 3000),
        ["validate", "m.json"],
        "nested too deeply",
        id="nested-3000-deep",
    ),
    pytest.param(
        lambda folder: fifo(folder, "m.json"),
        ["validate", "m.json"],
        "m.json: is a FIFO (named pipe), not a regular file",
        id="fifo-mission",
    ),
    pytest.param(
        both(files(m_json=json.dumps(BASE)), lambda folder: fifo(folder, "a.json")),
        ["check", "m.json", "a.json"],
        "a.json: is a FIFO (named pipe), not a regular file",
        id="fifo-assignment",
    ),
    pytest.param(
        None,
        ["validate", "/dev/zero"],
        "is a character device, not a regular file",
        id="device-mission",
    ),
    pytest.param(
        None,
        [*GENERATE, "--robots", "10000000000000000000000", "--service-types", "10"],
        "--robots: 1e+22 robots, 1e+21 tasks and 10 service types would need about",
        id="generate-1e22-robots",
    ),
    pytest.param(
        None,
        [*GENERATE, "--robots", "100", "--service-types", "10", "--load", "1e300"],
        "--load: asks for 1e+302 robots' worth of requirements in all; at most 2147483647",
        id="generate-load-1e300",
    ),
    pytest.param(
        None,
        [*GENERATE, "--robots", "100", "--service-types", "1000000000"],
        "1000000000 service types would need about",
        id="generate-1e9-service-types",
    ),
    pytest.param(
        None,
        [*GENERATE, "--robots", "10", "--service-types", "1", "--services-per-robot", "3"],
        "--services-per-robot: must be a whole number between 1 and 1, got 3",
        id="generate-flag-names",
    ),
    pytest.param(
        None,
        [*GENERATE, "--robots", "10", "--service-types", "2", "-o", "nowhere/m.json"],
        "nowhere/m.json: the folder 'nowhere' does not exist",
        id="generate-missing-folder",
    ),
    pytest.param(
        files(g_json=json.dumps({"robots": [1e22]})),
        ["sweep", "--grid", "g.json", "--store", "s.sqlite"],
        "g.json: product: robots: 1e+22 robots",
        id="grid-file-1e22-robots",
    ),
    pytest.param(
        None,
        ["sweep", "--grid", "nosuch"],
        "--grid: unknown grid 'nosuch': give one of paper, paper-distributed, audit, quick",
        id="unknown-grid-name",
    ),
    pytest.param(
        None,
        ["sweep", "--robots", "10", "--compositions", "3:5"],
        "composition 3:5: the services per robot (5) must be between 1 and the service types",
        id="composition-k-over-s",
    ),
    pytest.param(
        None,
        ["sweep", "--robots", "10", "--missions", "100000000000000000000", "--store", "s.sqlite"],
        "--missions: ",
        id="sweep-1e20-missions",
    ),
    pytest.param(
        edit_store("UPDATE trials SET percent_optimum = 'abc' WHERE algorithm = 'grape-s'"),
        ["report", "s.sqlite", "-o", "r"],
        'column percent_optimum holds "abc", expected a number',
        id="report-text-in-a-numeric-column",
    ),
    pytest.param(
        edit_store("ALTER TABLE trials DROP COLUMN seconds"),
        ["report", "s.sqlite", "-o", "r"],
        "its trials table lacks the column(s) seconds",
        id="report-missing-column",
    ),
    pytest.param(
        tiny_store,
        ["report", "s.sqlite", "-o", "no/such/report"],
        "no/such/report: the folder 'no/such' does not exist",
        id="report-missing-parent-folder",
    ),
    pytest.param(
        files(m_json=json.dumps(BASE), a_json="{}"),
        ["run", "grape-s", "m.json", "-o", "a.json"],
        "a.json: already exists (pass --force to replace it)",
        id="run-output-exists",
    ),
]


@pytest.mark.parametrize(("prepare", "argv", "fragment"), BAD_INPUTS)
def test_bad_input_exits_2_with_one_error_line(
    tmp_path: Path, prepare: Callable[[Path], None] | None, argv: list[str], fragment: str
) -> None:
    if prepare is not None:
        prepare(tmp_path)
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    assert_one_error_line(cfopt(*argv, cwd=tmp_path, timeout=60), fragment)
    assert {p: p.read_bytes() for p in before} == before  # nothing the user had changed


EXTREMES = Mission.from_arrays(
    [[1, 0], [1, 1], [0, 1]], [[1, 0], [2147483647, 1], [0, 1]], [1e25, 5.0, 1e-300]
)


@pytest.mark.parametrize("algorithm", ["grape-s", "pair-grape-s", "sda", "rachna-dt"])
def test_extreme_but_valid_missions_are_answered(tmp_path: Path, algorithm: str) -> None:
    """A utility of 1e25, one of 1e-300 and a requirement of 2**31 - 1 (a task no mission
    can staff): every algorithm answers at once, without a traceback or a huge allocation."""
    path = tmp_path / "m.json"
    EXTREMES.to_json(path)
    started = time.monotonic()
    result = cfopt("run", algorithm, str(path), "--json", timeout=60)
    assert result.returncode == 0, result.stderr
    utility = json.loads(result.stdout)["utility"]
    # the auctions buy t0 (worth 1e25); GRAPE-S's reward ignores utility and chases t1,
    # whose requirement makes every load tiny: it earns nothing, which is its answer
    assert utility >= 1e25 if algorithm in ("sda", "rachna-dt") else utility == 0
    assert time.monotonic() - started < 30


@pytest.mark.parametrize("where", ["services", "name", "metadata"])
def test_deeply_nested_values_from_python_are_clean_errors(where: str) -> None:
    deep: list = []
    for _ in range(995):
        deep = [deep]
    data = json.loads(json.dumps(BASE))
    if where == "services":
        data["services"][0] = deep
    elif where == "name":
        data["name"] = deep
    else:
        data["metadata"] = {"deep": deep}
    with pytest.raises(MissionError, match=r"nested|must be"):
        Mission.from_dict(data)


# ------------------------------------------------------------- full disks keep the data
def _tmpfs(folder: Path, size: str) -> bool:
    if os.geteuid() != 0 or sys.platform != "linux":
        return False
    result = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)],
        capture_output=True,
    )
    return result.returncode == 0


def _file_size_limit(limit: int) -> Callable[[], None]:
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # write() then fails with EFBIG
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


@pytest.fixture(params=["tmpfs", "file-size-limit"])
def full_disk(
    request: pytest.FixtureRequest, tmp_path: Path
) -> Iterator[tuple[Path, Callable[[], None] | None]]:
    """A folder where a write of more than about 40 KB fails: a small tmpfs (a real full
    disk; needs root) or, everywhere, a file size limit on the child process."""
    folder = tmp_path / "disk"
    folder.mkdir()
    if request.param == "tmpfs":
        if not _tmpfs(folder, "48k"):
            pytest.skip("cannot mount a tmpfs here (not root)")
        try:
            yield folder, None
        finally:
            subprocess.run(["umount", str(folder)], check=False)
    else:
        yield folder, _file_size_limit(40_000)


BIG = [*GENERATE, "--robots", "1000", "--service-types", "10", "--seed", "1"]


def test_a_full_disk_leaves_no_truncated_file(full_disk) -> None:
    folder, limit = full_disk
    result = cfopt(*BIG, "-o", str(folder / "m.json"), preexec=limit)
    assert_one_error_line(result, "m.json: cannot write (")
    assert list(folder.iterdir()) == []  # neither the file nor a temporary one


def test_a_full_disk_with_force_keeps_the_original(full_disk) -> None:
    folder, limit = full_disk
    small = [*GENERATE, "--robots", "20", "--service-types", "3", "--seed", "1"]
    assert cfopt(*small, "-o", str(folder / "m.json")).returncode == 0
    original = (folder / "m.json").read_bytes()
    result = cfopt(*BIG, "-o", str(folder / "m.json"), "--force", preexec=limit)
    assert_one_error_line(result, "the existing file is unchanged")
    assert (folder / "m.json").read_bytes() == original
    assert [p.name for p in folder.iterdir()] == ["m.json"]
    Mission.from_json(folder / "m.json")  # still valid


def test_a_full_disk_leaves_no_partial_report(full_disk, tmp_path: Path) -> None:
    folder, limit = full_disk
    store = tiny_store(tmp_path)
    result = cfopt("report", str(store), "-o", str(folder / "report"), preexec=limit)
    assert_one_error_line(result, "cannot write the report")
    assert list(folder.iterdir()) == []  # no CSVs, no directory


def test_stdout_on_a_full_device_is_a_clean_error() -> None:
    with open("/dev/full", "w") as full:
        result = subprocess.run(
            [sys.executable, "-m", "cfopt", *BIG], stdout=full, stderr=subprocess.PIPE, text=True
        )
    assert_one_error_line(result, "cannot write the output (No space left on device)")


# ------------------------------------------------------------------- signals and workers
SWEEP = [
    "sweep", "--robots", "120", "--percent-tasks", "50", "--compositions", "10:5",
    "--missions", "8", "--workers", "2", "--store",
]  # fmt: skip


TRIALS = 8 * (1 + len(ALGORITHMS))  # missions x (exact + every heuristic)


def _stored(store: Path) -> int:
    if not store.exists():
        return 0
    try:
        with contextlib.closing(sqlite3.connect(f"file:{store}?mode=ro", uri=True)) as db:
            return int(db.execute("SELECT COUNT(*) FROM trials").fetchone()[0])
    except sqlite3.Error:
        return 0


def _start(*args: str, cwd: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "cfopt", *args],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


def _wait_for(condition: Callable[[], bool], seconds: float = 60) -> None:
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


def _workers(pid: int) -> set[int]:
    """The children of ``pid`` that are forks of it (pool workers share its command line;
    a program it runs, e.g. one numpy starts while it is imported, does not)."""

    def command(p: int) -> bytes:
        with contextlib.suppress(OSError):
            return Path(f"/proc/{p}/cmdline").read_bytes()
        return b""

    return {child for child in _children(pid) if command(child) == command(pid)}


def _children(pid: int) -> set[int]:
    found = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            with contextlib.suppress(OSError, IndexError):
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
                if int(fields[1]) == pid:
                    found.add(int(entry.name))
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


#: The ``read`` system call's number, as ``/proc/PID/syscall`` shows it, per machine.
_READ_SYSCALL = {"x86_64": "0", "aarch64": "63", "arm64": "63"}


def _reading_stdin(pid: int) -> bool:
    """Whether process ``pid`` is blocked in ``read(0, ...)`` (Linux: /proc/PID/syscall)."""
    try:
        fields = Path(f"/proc/{pid}/syscall").read_text().split()
    except OSError:
        return False
    return fields[:2] == [_READ_SYSCALL[os.uname().machine], "0x0"]


@pytest.mark.skipif(
    sys.platform != "linux" or os.uname().machine not in _READ_SYSCALL,
    reason="reads /proc/PID/syscall",
)
def test_ctrl_c_while_reading_stdin_is_one_line() -> None:
    process = subprocess.Popen(
        [sys.executable, "-m", "cfopt", "validate", "-"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    # a state, not a time: Python and cfopt started (on a loaded machine that can take
    # seconds) and the command waits for its input
    _wait_for(lambda: _reading_stdin(process.pid) or process.poll() is not None, 300)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=30)
    assert process.returncode == 130
    assert err == "error: interrupted (SIGINT)\n"


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_an_interrupted_sweep_keeps_what_it_stored(tmp_path: Path, sig: int, code: int) -> None:
    store = tmp_path / "s.sqlite"
    process = _start(*SWEEP, str(store), cwd=tmp_path)
    _wait_for(lambda: _stored(store) >= 2)
    process.send_signal(sig)
    _, err = process.communicate(timeout=60)
    assert process.returncode == code, err
    last = err.strip().splitlines()[-1]
    match = re.fullmatch(
        r"error: interrupted \((SIGINT|SIGTERM)\): (\d+) trials? computed by this run "
        r"(?:is|are) kept in .*s\.sqlite; run the same command again to resume",
        last,
    )
    assert match, err
    kept = int(match.group(2))
    assert kept == _stored(store) >= 2
    assert "Traceback" not in err
    resumed = cfopt(*SWEEP, str(store), "--quiet", cwd=tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    assert f", {kept} already stored," in resumed.stdout
    assert _stored(store) == TRIALS


@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc")
@pytest.mark.parametrize("workers_seen", [1, 2])
def test_ctrl_c_as_the_workers_start_is_one_line(tmp_path: Path, workers_seen: int) -> None:
    """A terminal's Ctrl-C reaches the whole process group, workers being forked included:
    the parent alone answers it, whatever state the workers are in."""
    store = tmp_path / "s.sqlite"
    process = _start(*SWEEP, str(store), cwd=tmp_path)
    _wait_for(lambda: len(_workers(process.pid)) >= workers_seen, seconds=60)
    os.killpg(process.pid, signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and errors[0].startswith("error: interrupted (SIGINT)"), err
    assert err.strip().splitlines()[-1] == errors[0]


@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc")
def test_killing_a_sweep_leaves_no_worker_behind(tmp_path: Path) -> None:
    store = tmp_path / "s.sqlite"
    process = _start(*SWEEP, str(store), cwd=tmp_path)
    _wait_for(lambda: len(_children(process.pid)) >= 2 and _stored(store) >= 1)
    workers = _children(process.pid)
    process.kill()  # SIGKILL: the parent cannot clean up anything
    process.wait(timeout=10)
    killed = time.monotonic()
    _wait_for(lambda: not any(_alive(pid) for pid in workers), seconds=5)
    assert time.monotonic() - killed < 5
    # nobody holds the parent's stdout any more: a reader (`| tee log`) sees the end
    assert process.stdout.read() == ""
    process.stdout.close()
    process.stderr.close()


# Distributed runs (about a second each at 200 robots) keep the first sweep busy while the
# second one starts: the centralized engines finish the whole sweep in under a second.
LONG_SWEEP = [
    "sweep", "--robots", "200", "--percent-tasks", "50", "--compositions", "10:5",
    "--missions", "12", "--algorithms", "grape-s", "--network", "complete latency=uniform:1ms:10ms",
    "--workers", "1", "--quiet", "--store",
]  # fmt: skip


def test_a_second_sweep_on_the_same_store_is_refused(tmp_path: Path) -> None:
    store = tmp_path / "s.sqlite"
    first = _start(*LONG_SWEEP, str(store), cwd=tmp_path)
    _wait_for(lambda: (tmp_path / "s.sqlite.lock").exists() and _stored(store) >= 1)
    second = cfopt(*LONG_SWEEP, str(store), cwd=tmp_path)
    assert_one_error_line(second, f"in use by cfopt sweep (process {first.pid})")
    out, err = first.communicate(timeout=300)
    assert first.returncode == 0, err
    assert "24 trials run, 0 already stored, 0 failed, of 24" in out  # each computed once
    again = cfopt(*LONG_SWEEP, str(store), cwd=tmp_path)
    assert "0 trials run, 24 already stored" in again.stdout
    assert _stored(store) == 24
    assert not (tmp_path / "s.sqlite.lock").exists()


# --------------------------------------------------------------- the newcomer's round trip
@pytest.mark.parametrize("algorithm", ["grape-s", "sda"])
def test_run_writes_an_assignment_that_check_agrees_with(tmp_path: Path, algorithm: str) -> None:
    mission = tmp_path / "m.json"
    generated = cfopt(*GENERATE, "--robots", "30", "--service-types", "5", "-o", str(mission))
    assert generated.returncode == 0
    run = cfopt("run", algorithm, str(mission), "-o", str(tmp_path / "a.json"), "--json")
    assert run.returncode == 0, run.stderr
    verdicts = json.loads(run.stdout)
    for source in ("a.json", "run.json"):
        (tmp_path / "run.json").write_text(run.stdout, encoding="utf-8")
        check = cfopt("check", str(mission), str(tmp_path / source), "--json")
        assert check.returncode == 0, check.stderr
        report = json.loads(check.stdout)
        assert report["utility"] == verdicts["utility"]
        assert report["nash_stable"] == verdicts["nash_stable"]
        assert report["pairwise_stable"] == verdicts["pairwise_stable"]
        assert report["pareto_stable"] == verdicts["pairwise_stable_pareto"]
    text = cfopt("run", algorithm, str(mission)).stdout.splitlines()
    assert re.fullmatch(
        r"stability under the seed's reward: Nash (yes|no), pairwise \(strict\) (yes|no), "
        r"pairwise \(pareto\) (yes|no)",
        text[1],
    )


def test_check_reads_the_json_of_solve(tmp_path: Path) -> None:
    mission = tmp_path / "m.json"
    mission.write_text(json.dumps(BASE), encoding="utf-8")
    solved = cfopt("solve", str(mission), "--json")
    (tmp_path / "solve.json").write_text(solved.stdout, encoding="utf-8")
    check = cfopt("check", str(mission), str(tmp_path / "solve.json"), "--json")
    assert check.returncode == 0, check.stderr
    assert json.loads(check.stdout)["utility"] == json.loads(solved.stdout)["utility"] == 9.0


def test_plural_forms() -> None:
    one = Mission.from_arrays([[1]], [[1]], [1.0]).to_json()
    assert cfopt("validate", "-", stdin=one).stdout == "ok: 1 robot, 1 task, 1 service\n"
    assert cfopt("validate", "-", stdin=json.dumps(BASE)).stdout == (
        "ok: 4 robots, 3 tasks, 2 services\n"
    )
