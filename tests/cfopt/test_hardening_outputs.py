"""Hostile output paths, time limits and path options.

Every row runs the real process (``python -m cfopt``) and ends with exit 0, or with exit
2, one ``error:`` line and no traceback; and nothing is written where the user did not
ask (the folder it runs in is compared before and after).  The rule for outputs: ``-``
and ``/dev/null`` are always accepted, a directory or a device never receives a file,
any other existing path is replaced only with ``--force``.
"""

from __future__ import annotations

import io
import os
import shutil
import stat
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from cfopt import GridCell, Mission, MissionError, solve_exact
from cfopt._jsonio import output_target
from cfopt.exact import MAX_TIME_LIMIT
from cfopt.experiments import Sweep
from heuristics.simulate import MAX_TIME_LIMIT as MAX_RUN_TIME_LIMIT
from heuristics.simulate import simulate
from tests.cfopt.test_hardening import BASE, assert_one_error_line, cfopt, tiny_store

# ---------------------------------------------------------------------------- helpers
GENERATE = [
    "generate", "--robots", "10", "--percent-tasks", "20", "--service-types", "2",
    "--services-per-robot", "1", "--seed", "1",
]  # fmt: skip
SWEEP = ["sweep", "--robots", "10", "--missions", "1", "--algorithms", "grape-s", "--quiet"]
LONG_NAME = "a" * 256  # one byte more than a name may have
LONG_PATH = "/".join(["b" * 200] * 25)  # 5024 characters, more than a path may have
VALID_NAME = "v" * 250 + ".json"  # 255 bytes: the longest valid name


def snapshot(folder: Path) -> dict[str, object]:
    """Every entry under ``folder``: a file's bytes, a link's target, or its kind."""
    entries: dict[str, object] = {}
    for path in sorted(folder.rglob("*")):
        name = os.fspath(path.relative_to(folder))
        if path.is_symlink():
            entries[name] = f"-> {os.readlink(path)}"
        elif path.is_dir():
            entries[name] = "directory"
        elif path.is_file():
            entries[name] = path.read_bytes()
        else:
            entries[name] = stat.S_IFMT(path.lstat().st_mode)
    return entries


@pytest.fixture(scope="module")
def store_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tiny_store(tmp_path_factory.mktemp("store"))


@pytest.fixture
def work(tmp_path: Path, store_file: Path) -> Path:
    """A folder with a mission, a store, a directory, and links to a file and to /dev/null."""
    folder = tmp_path / "work"
    folder.mkdir()
    Mission.from_dict(BASE).to_json(folder / "m.json")
    shutil.copy(store_file, folder / "s.sqlite")
    (folder / "d").mkdir()
    (folder / "d.json").mkdir()
    (folder / "mlink").symlink_to("m.json")
    (folder / "nul").symlink_to(os.devnull)
    return folder


def null_device() -> os.stat_result:
    return os.stat(os.devnull)


# ------------------------------------------------- refusals: exit 2, one line, no change
def _rows(prefix: list[str], fragment: str, *variants: tuple[str, list[str]]) -> list:
    return [pytest.param([*prefix, *argv], fragment, id=name) for name, argv in variants]


REFUSED = [
    # output paths
    *_rows(
        [],
        "d: is a directory, not a file cfopt may write",
        ("generate-o-directory", [*GENERATE, "-o", "d"]),
        ("generate-o-directory-force", [*GENERATE, "-o", "d", "--force"]),
        ("solve-o-directory-force", ["solve", "m.json", "-o", "d", "--force"]),
        ("run-o-directory", ["run", "grape-s", "m.json", "-o", "d"]),
    ),
    *_rows(
        [],
        "/dev/zero: is a character device, not a file cfopt may write",
        ("generate-o-dev-zero-force", [*GENERATE, "-o", "/dev/zero", "--force"]),
        ("solve-o-dev-zero", ["solve", "m.json", "-o", "/dev/zero"]),
    ),
    pytest.param(
        [*GENERATE, "-o", "m.json"],
        "m.json: already exists (pass --force to replace it)",
        id="generate-o-existing-file",
    ),
    pytest.param(
        [*GENERATE, "-o", "mlink"],
        "mlink: already exists (pass --force to replace it)",
        id="generate-o-link-to-a-file",
    ),
    pytest.param(
        [*GENERATE, "-o", ""], "must name a file, got an empty path", id="generate-o-empty"
    ),
    *_rows(
        [],
        "'-' (stdin or stdout) cannot be one",
        ("report-o-dash", ["report", "s.sqlite", "-o", "-"]),
        ("audit-o-dash", ["audit", "--claims-only", "-o", "-"]),
        ("reproduce-o-dash", ["reproduce", "--missions", "1", "-o", "-"]),
        ("sweep-store-dash", [*SWEEP, "--store", "-"]),
        ("reproduce-store-dash", ["reproduce", "--missions", "1", "--store", "-"]),
        ("report-store-dash", ["report", "-", "-o", "r"]),
    ),
    *_rows(
        [],
        "exists and is not a directory",
        ("report-o-file", ["report", "s.sqlite", "-o", "m.json"]),
        ("audit-o-file", ["audit", "--claims-only", "-o", "m.json"]),
        ("reproduce-o-file", ["reproduce", "--missions", "1", "-o", "m.json"]),
    ),
    # stores
    pytest.param(
        [*SWEEP, "--store", "d"], "d: is a directory, not a result store", id="sweep-store-dir"
    ),
    pytest.param(
        ["reproduce", "--missions", "1", "-o", "r", "--store", "d"],
        "d: is a directory, not a result store",
        id="reproduce-store-dir-creates-no-report-dir",
    ),
    pytest.param(
        [*SWEEP, "--store", "s" * 250],
        "the name is too long for a result store (at most 247 bytes here",
        id="sweep-store-name-without-room-for-its-journal",
    ),
    # time limits
    *(
        pytest.param(["solve", "m.json", "--time-limit", value], fragment, id=f"solve-{name}")
        for name, value, fragment in (
            ("1e10", "1e10", "must be at most 1e+09 seconds (about 31 years), got '1e10'"),
            ("9.3e9", "9.3e9", "must be at most 1e+09 seconds"),
            ("inf", "inf", "must be a finite number > 0, got 'inf'"),
            ("nan", "nan", "must be a finite number > 0, got 'nan'"),
            ("negative", "-1", "must be a finite number > 0, got '-1'"),
            ("zero", "0", "must be a finite number > 0, got '0'"),
            ("bool", "true", "must be a number, got 'true'"),
            ("text", "abc", "must be a number, got 'abc'"),
        )
    ),
    pytest.param(
        [*SWEEP, "--store", "new.sqlite", "--time-limit", "1e10"],
        "argument --time-limit: must be at most 1e+09 seconds",
        id="sweep-time-limit-1e10",
    ),
    pytest.param(
        ["run", "grape-s", "m.json", "--network", "complete", "--time-limit", "1e10"],
        "argument --time-limit: must be at most 1e+09 seconds",
        id="run-network-time-limit-1e10",
    ),
    pytest.param(
        ["run", "grape-s", "m.json", "--network", "complete", "--time-limit", "9000"],
        f"--time-limit: at most {MAX_RUN_TIME_LIMIT} simulated seconds, got 9000.0",
        id="run-network-time-limit-over-the-simulators",
    ),
    pytest.param(
        ["run", "grape-s", "m.json", "--backend", "mpi", "--time-limit", "1e10"],
        "argument --time-limit: must be at most 1e+09 seconds",
        id="run-mpi-time-limit-1e10",
    ),
    # names too long: outputs
    *_rows(
        [],
        "name too long for the file system",
        ("generate-o-256-characters", [*GENERATE, "-o", LONG_NAME]),
        ("generate-o-5000-characters", [*GENERATE, "-o", LONG_PATH]),
        ("run-o-256-characters", ["run", "grape-s", "m.json", "-o", LONG_NAME]),
        ("solve-o-5000-characters", ["solve", "m.json", "-o", LONG_PATH]),
        ("report-o-256-characters", ["report", "s.sqlite", "-o", LONG_NAME]),
        ("report-o-5000-characters", ["report", "s.sqlite", "-o", LONG_PATH]),
        ("audit-o-256-characters", ["audit", "--claims-only", "-o", LONG_NAME]),
        ("reproduce-o-5000-characters", ["reproduce", "--missions", "1", "-o", LONG_PATH]),
        ("sweep-store-5000-characters", [*SWEEP, "--store", LONG_PATH]),
        # and inputs
        ("validate-256-characters", ["validate", LONG_NAME]),
        ("validate-5000-characters", ["validate", LONG_PATH]),
        ("check-256-characters", ["check", "m.json", LONG_NAME]),
        ("report-store-256-characters", ["report", LONG_NAME]),
        ("sweep-grid-5000-characters", ["sweep", "--grid", LONG_PATH, "--store", "x.sqlite"]),
        ("sweep-grid-256-characters", ["sweep", "--grid", LONG_NAME + ".json"]),
        ("run-network-file-256", ["run", "grape-s", "m.json", "--network", LONG_NAME + ".json"]),
    ),
    # input files given as directories
    pytest.param(["validate", "d"], "d: is a directory, not a JSON file", id="validate-dir"),
    pytest.param(["check", "m.json", "d"], "d: is a directory, not a JSON file", id="check-dir"),
    pytest.param(["report", "d"], "d: is a directory, not a result store", id="report-dir"),
    pytest.param(
        ["sweep", "--grid", "d.json", "--store", "x.sqlite"],
        "d.json: is a directory, not a JSON file",
        id="sweep-grid-dir",
    ),
    pytest.param(
        ["run", "grape-s", "m.json", "--network", "file=d"],
        "token 'file=d': is a directory, not an edge list",
        id="run-network-edge-list-dir",
    ),
]


@pytest.mark.parametrize(("argv", "fragment"), REFUSED)
def test_refused_with_one_line_and_nothing_written(
    work: Path, argv: list[str], fragment: str
) -> None:
    before, null = snapshot(work), null_device()
    assert_one_error_line(cfopt(*argv, cwd=work, timeout=120), fragment)
    assert snapshot(work) == before
    assert os.path.samestat(null_device(), null)  # /dev/null was not replaced


def test_the_mpi_rank_takes_the_same_time_limits(work: Path) -> None:
    """``python -m cfopt.mpi`` (what mpiexec starts): ``--time-limit 0`` was taken as the
    default; now it is refused as ``cfopt run`` refuses it, in one line."""
    result = subprocess.run(
        [sys.executable, "-m", "cfopt.mpi", "grape-s", "m.json", "--time-limit", "0"],
        cwd=work,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert_one_error_line(result, "argument --time-limit: must be a finite number > 0, got '0'")


# ------------------------------------------------------------------- accepted: exit 0
DISCARDED = [
    pytest.param([*GENERATE, "-o", "/dev/null"], id="generate"),
    pytest.param([*GENERATE, "-o", "/dev/null", "--force"], id="generate-force"),
    pytest.param([*GENERATE, "-o", "nul"], id="generate-link-to-dev-null"),
    pytest.param(["solve", "m.json", "-o", "/dev/null", "--json"], id="solve"),
    pytest.param(["run", "grape-s", "m.json", "-o", "/dev/null", "--json"], id="run"),
    # a report directory or a store: computed and printed, kept nowhere
    pytest.param(["report", "s.sqlite", "-o", "/dev/null"], id="report-o"),
    pytest.param(["report", "s.sqlite", "-o", "nul", "--json"], id="report-o-link"),
    pytest.param([*SWEEP, "--store", "/dev/null"], id="sweep-store"),
]


@pytest.mark.parametrize("argv", DISCARDED)
def test_dev_null_is_always_accepted(work: Path, argv: list[str]) -> None:
    before, null = snapshot(work), null_device()
    result = cfopt(*argv, cwd=work)
    assert result.returncode == 0, result.stderr
    assert snapshot(work) == before
    assert os.path.samestat(null_device(), null)
    assert stat.S_ISCHR(null_device().st_mode)


@pytest.mark.parametrize(
    "argv",
    [
        pytest.param([*GENERATE, "-o", VALID_NAME], id="generate"),
        pytest.param(["solve", "m.json", "-o", VALID_NAME], id="solve"),
        pytest.param(["run", "sda", "m.json", "-o", VALID_NAME], id="run"),
    ],
)
def test_a_name_of_255_bytes_is_written(work: Path, argv: list[str]) -> None:
    """The temporary file has a short name of its own, so the longest valid name works."""
    before = snapshot(work)
    result = cfopt(*argv, cwd=work)
    assert result.returncode == 0, result.stderr
    after = snapshot(work)
    assert set(after) - set(before) == {VALID_NAME}  # and no temporary file left
    assert after[VALID_NAME].startswith(b"{")  # type: ignore[union-attr]


def test_a_report_directory_of_255_bytes_is_written(work: Path) -> None:
    name = "r" * 255
    result = cfopt("report", "s.sqlite", "-o", name, cwd=work)
    assert result.returncode == 0, result.stderr
    assert (work / name / "report.md").is_file()
    assert not [p for p in (work / name).iterdir() if p.name.startswith(".")]


def test_force_through_a_link_replaces_the_file_and_keeps_the_link(work: Path) -> None:
    result = cfopt(*GENERATE, "-o", "mlink", "--force", cwd=work)
    assert result.returncode == 0, result.stderr
    assert os.readlink(work / "mlink") == "m.json"
    assert Mission.from_json(work / "m.json").n_robots == 10  # the generated mission


# ------------------------------------------------------------------------------ FIFOs
def test_a_fifo_is_replaced_only_with_force(work: Path) -> None:
    fifo = work / "pipe"
    os.mkfifo(fifo)
    assert_one_error_line(
        cfopt(*GENERATE, "-o", "pipe", cwd=work), "pipe: already exists (pass --force"
    )
    received: list[bytes] = []
    reader = threading.Thread(target=lambda: received.append(fifo.read_bytes()), daemon=True)
    reader.start()
    result = cfopt(*GENERATE, "-o", "pipe", "--force", cwd=work)
    reader.join(60)
    assert result.returncode == 0, result.stderr
    assert stat.S_ISFIFO(fifo.lstat().st_mode)  # written through, not renamed over
    assert Mission.from_json(io.StringIO(received[0].decode())).n_robots == 10


# ----------------------------------------------------------------------- block devices
@pytest.fixture
def block_device(work: Path, tmp_path: Path) -> Iterator[tuple[Path, Callable[[], bytes] | None]]:
    """A symbolic link to a block device, and a way to read what the device holds.

    A loop device over a file of this test's own when one can be set up (root and
    ``losetup``), else a link to an existing block device node such as ``/dev/loop0``
    (unread: its content is not ours), else the test is skipped.
    """
    backing = tmp_path / "disk.img"
    backing.write_bytes(bytes(64 * 1024))
    link = work / "disk"
    device = _attach_loop(backing)
    if device is not None:
        link.symlink_to(device)
        try:
            yield link, backing.read_bytes
        finally:
            subprocess.run(["losetup", "--detach", device], check=False, capture_output=True)
        return
    node = _existing_block_device()
    if node is None:
        pytest.skip("no loop device can be created and no block device node exists here")
    link.symlink_to(node)
    yield link, None


def _attach_loop(backing: Path) -> str | None:
    if os.geteuid() != 0 or shutil.which("losetup") is None:
        return None
    result = subprocess.run(
        ["losetup", "--find", "--show", str(backing)], capture_output=True, text=True
    )
    return result.stdout.strip() if result.returncode == 0 and result.stdout.strip() else None


def _existing_block_device() -> str | None:
    for candidate in ("/dev/loop0", *sorted(str(p) for p in Path("/dev").glob("loop*"))):
        try:
            if stat.S_ISBLK(os.stat(candidate).st_mode):
                return candidate
        except OSError:
            continue
    return None


@pytest.mark.parametrize("force", [[], ["--force"]], ids=["plain", "force"])
@pytest.mark.parametrize(
    "command",
    [GENERATE, ["solve", "m.json"], ["run", "grape-s", "m.json"]],
    ids=["generate", "solve", "run"],
)
def test_a_link_to_a_block_device_is_never_written(
    work: Path, block_device: tuple[Path, Callable[[], bytes] | None], command, force
) -> None:
    link, content = block_device
    before, entries = content() if content is not None else None, snapshot(work)
    result = cfopt(*command, "-o", link.name, *force, cwd=work)
    assert_one_error_line(result, "disk: is a block device, not a file cfopt may write")
    assert snapshot(work) == entries  # the link is still a link, and nothing beside it
    if content is not None:
        assert content() == before  # not one byte reached the disk


# --------------------------------------------------------------------- read-only folders
@pytest.fixture
def read_only(tmp_path: Path) -> Iterator[tuple[Path, list[str]]]:
    """A folder nothing can be written into, and the command prefix that sees it so.

    Not root: ``chmod 555``.  Root ignores that: a read-only tmpfs mounted on it, else
    one mounted inside ``unshare`` (a user and mount namespace around the command), else
    the test is skipped.
    """
    folder = tmp_path / "ro"
    folder.mkdir()
    if os.geteuid() != 0:
        folder.chmod(0o555)
        try:
            yield folder, []
        finally:
            folder.chmod(0o755)
        return
    if _mount_read_only(folder):
        try:
            yield folder, []
        finally:
            subprocess.run(["umount", str(folder)], check=False)
        return
    prefix = ["unshare", "--user", "--map-root-user", "--mount", "sh", "-c"]
    prefix += ['mount -t tmpfs -o ro tmpfs "$0" && exec "$@"', str(folder)]
    probe = subprocess.run([*prefix, "true"], capture_output=True)
    if shutil.which("unshare") is None or probe.returncode != 0:
        pytest.skip("root here, and neither mount nor unshare can make a read-only folder")
    yield folder, prefix


def _mount_read_only(folder: Path) -> bool:
    if sys.platform != "linux" or shutil.which("mount") is None:
        return False
    result = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(folder)], capture_output=True
    )
    return result.returncode == 0


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        pytest.param(["report", "s.sqlite", "-o", "{ro}/r"], "r", id="report"),
        pytest.param(["audit", "--claims-only", "-o", "{ro}/a"], "a", id="audit"),
        pytest.param(["reproduce", "--missions", "1", "-o", "{ro}/r"], "r", id="reproduce"),
        pytest.param([*GENERATE, "-o", "{ro}/m.json"], "m.json", id="generate"),
        pytest.param(["solve", "m.json", "-o", "{ro}/a.json"], "a.json", id="solve"),
        pytest.param([*SWEEP, "--store", "{ro}/s.sqlite"], "s.sqlite.lock", id="sweep"),
    ],
)
def test_a_read_only_folder_is_one_error_line(
    work: Path, read_only: tuple[Path, list[str]], argv: list[str], named: str
) -> None:
    folder, prefix = read_only
    argv = [a.replace("{ro}", str(folder)) for a in argv]
    before = snapshot(work)
    result = subprocess.run(
        [*prefix, sys.executable, "-m", "cfopt", *argv],
        cwd=work,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert_one_error_line(result, f"error: {folder / named}: ")
    reason = "Read-only file system" if os.geteuid() == 0 else "ermission denied"
    assert reason in result.stderr
    assert snapshot(work) == before


# -------------------------------------------------------------------- the Python API
@pytest.mark.parametrize(
    "value",
    [1e10, 9.3e9, 10**400, float("inf"), float("nan"), -1.0, 0, True, "60"],
    ids=["1e10", "9.3e9", "10**400", "inf", "nan", "negative", "zero", "bool", "text"],
)
def test_bad_time_limits_are_mission_errors_in_python(value: object) -> None:
    """Never an OverflowError (what ``solve_exact(m, time_limit=1e10)`` raised)."""
    mission = Mission.from_dict(BASE)
    with pytest.raises(MissionError, match=r"^time_limit: must be"):
        solve_exact(mission, time_limit=value)  # type: ignore[arg-type]
    with pytest.raises(MissionError, match=r"^time_limit: must be"):
        Sweep(cells=(GridCell(10, 20, 3, 2),), missions=1, time_limit=value)  # type: ignore[arg-type]
    with pytest.raises(MissionError, match=r"^time_limit: (must be|at most 8796)"):
        simulate(mission, "grape-s", "complete", seed=0, time_limit=value)  # type: ignore[arg-type]


def test_the_ceilings_themselves_are_accepted() -> None:
    mission = Mission.from_dict(BASE)
    assert MAX_TIME_LIMIT < threading.TIMEOUT_MAX  # what overflowed before
    assert solve_exact(mission, time_limit=MAX_TIME_LIMIT).status.value == "optimal"
    run = simulate(mission, "grape-s", "complete", seed=0, time_limit=MAX_RUN_TIME_LIMIT)
    assert not run.network.cut


def test_the_help_states_the_rules() -> None:
    def text(command: str) -> str:
        return " ".join(cfopt(command, "--help").stdout.split())

    assert "at most 1e9 s" in text("solve") and "at most 1e9" in text("sweep")
    assert f"at most {MAX_RUN_TIME_LIMIT}" in text("run")
    for command in ("generate", "solve", "run"):
        assert "a directory or a device other than /dev/null is refused" in text(command)
        assert "/dev/null discards it" in text(command)


def test_output_target_is_the_one_rule(tmp_path: Path) -> None:
    (tmp_path / "f.json").write_text("{}")
    (tmp_path / "link").symlink_to("f.json")
    (tmp_path / "null").symlink_to(os.devnull)
    assert output_target(os.devnull, overwrite=False) is None
    assert output_target(tmp_path / "null", overwrite=True) is None
    assert output_target(tmp_path / "new.json", overwrite=False) == tmp_path / "new.json"
    assert output_target(tmp_path / "link", overwrite=True) == (tmp_path / "f.json").resolve()
    assert output_target(tmp_path, overwrite=True, directory=True) == tmp_path
    for path, kwargs, fragment in (
        (tmp_path / "f.json", {"overwrite": False}, "pass overwrite=True"),
        (tmp_path, {"overwrite": True}, "is a directory"),
        ("/dev/zero", {"overwrite": True}, "is a character device"),
        (tmp_path / "f.json", {"overwrite": True, "directory": True}, "not a directory"),
        (tmp_path / ("x" * 256), {"overwrite": True}, "name too long"),
    ):
        with pytest.raises(MissionError, match=fragment):
            output_target(path, **kwargs)
