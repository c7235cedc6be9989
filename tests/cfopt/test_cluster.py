"""Sweeps on a real dask cluster: ``--scheduler``, a worker killed mid-trial, clean errors."""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import json
import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("distributed")

from cfopt import GridCell, MissionError
from cfopt import cluster as cfcluster
from cfopt.cli import main
from cfopt.cluster import DaskExecutor, SchedulerSpec, dask_executor, parse_scheduler
from cfopt.errors import plural
from cfopt.experiments import (
    EXACT,
    ExecutorFailed,
    ResultStore,
    Sweep,
    WorkerDied,
    run_sweep,
)

TINY = Sweep(cells=(GridCell(20, 10, 5, 2),), missions=2, algorithms=("grape-s", "sda"))
#: Trials of about a second (sda's agents in the simulator): long enough to kill one.
SLOW = Sweep(cells=(GridCell(60, 10, 5, 2, network="complete"),), missions=3, algorithms=("sda",))
#: The fields of a trial that depend on when and where it ran, not on what it computed.
_CIRCUMSTANTIAL = {"seconds", "finished"}


@pytest.fixture(scope="module")
def executor() -> Iterator[DaskExecutor]:
    """One local cluster of 2 worker processes (1 thread each) for the whole file."""
    with dask_executor("local:2") as pool:
        yield pool


def _rows(store: Path) -> list[dict[str, Any]]:
    with ResultStore(store) as db:
        trials = db.trials()
    return [
        {k: v for k, v in vars(t).items() if k not in _CIRCUMSTANTIAL}
        for t in sorted(trials, key=lambda t: t.key)
    ]


def _stored(store: Path) -> int:
    uri = f"file:{store}?mode=ro"
    with (
        contextlib.suppress(sqlite3.Error),
        contextlib.closing(sqlite3.connect(uri, uri=True)) as db,
    ):
        return int(db.execute("SELECT COUNT(*) FROM trials").fetchone()[0])
    return 0


def _keys(store: Path) -> list[tuple[str, int, str]]:
    with contextlib.closing(sqlite3.connect(store)) as db:
        return db.execute("SELECT cell, mission_seed, algorithm FROM trials").fetchall()


def _expected(sweep: Sweep) -> set[tuple[str, int, str]]:
    return {
        (c.label, c.mission_seed(i), a)
        for c in sweep.cells
        for i in range(sweep.missions)
        for a in sweep.algorithms_for(c)
    }


def _wait_for(condition: Callable[[], bool], seconds: float = 60) -> None:
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.02)


# ------------------------------------------------------------------------- parsing
def test_parse_scheduler() -> None:
    assert parse_scheduler(" local:8 ") == SchedulerSpec(None, 8)
    assert parse_scheduler("tcp://127.0.0.1:8786") == SchedulerSpec("tcp://127.0.0.1:8786", None)
    assert parse_scheduler("local:3").label == "local:3"


@pytest.mark.parametrize(
    "text", ["local", "local:", "local:0", "local:-1", "local:2.5", "local:9999", "", "a b"]
)
def test_malformed_scheduler_values_name_the_option(text: str) -> None:
    with pytest.raises(MissionError) as info:
        parse_scheduler(text)
    assert info.value.cli_message.startswith("--scheduler: must be ")


# ------------------------------------------------------------------ sweeps on it
def test_a_cluster_sweep_stores_what_an_inline_sweep_stores(
    executor: DaskExecutor, tmp_path: Path
) -> None:
    on_cluster, inline = tmp_path / "cluster.sqlite", tmp_path / "inline.sqlite"
    outcome = run_sweep(TINY, on_cluster, executor=executor, progress=False)
    assert outcome.ok and outcome.completed == TINY.size == 6
    run_sweep(TINY, inline, workers=1, progress=False)
    assert _rows(on_cluster) == _rows(inline)
    again = run_sweep(TINY, on_cluster, executor=executor, progress=False)
    assert (again.completed, again.skipped) == (0, 6)
    assert executor.parallelism == 2


def _worker_pids(executor: DaskExecutor) -> dict[str, int]:
    return executor._client.run(os.getpid)


def _executing(executor: DaskExecutor, address: str) -> int:
    def count(dask_worker: Any) -> int:
        return len(dask_worker.state.executing)

    return executor._client.run(count, workers=[address])[address]


def test_a_worker_killed_mid_trial_loses_and_duplicates_nothing(
    executor: DaskExecutor, tmp_path: Path
) -> None:
    store = tmp_path / "killed.sqlite"
    pids = _worker_pids(executor)
    victim_address, victim = sorted(pids.items())[0]
    outcome: list[Any] = []
    sweep = threading.Thread(
        target=lambda: outcome.append(run_sweep(SLOW, store, executor=executor, progress=False))
    )
    sweep.start()
    try:
        _wait_for(lambda: _stored(store) >= 1 and _executing(executor, victim_address) > 0)
        os.kill(victim, signal.SIGKILL)  # mid-trial: its task goes to another worker
    finally:
        sweep.join(timeout=120)
    assert not sweep.is_alive()
    (done,) = outcome
    assert done.ok and done.failures == () and done.completed == SLOW.size
    keys = _keys(store)
    assert len(keys) == len(set(keys)) == SLOW.size  # every trial exactly once
    assert set(keys) == _expected(SLOW)
    # the nanny replaced the dead worker
    executor._client.wait_for_workers(2, timeout=90)
    assert victim not in _worker_pids(executor).values()


@contextlib.contextmanager
def _allowed_failures(executor: DaskExecutor, count: int) -> Iterator[None]:
    def swap(dask_scheduler: Any, value: int) -> int:
        old, dask_scheduler.allowed_failures = dask_scheduler.allowed_failures, value
        return old

    old = executor._client.run_on_scheduler(swap, value=count)
    try:
        yield
    finally:
        executor._client.run_on_scheduler(swap, value=old)
        executor._client.wait_for_workers(2, timeout=90)


def _die(code: int) -> None:
    os._exit(code)


def test_a_call_that_keeps_killing_its_worker_is_worker_died(executor: DaskExecutor) -> None:
    with _allowed_failures(executor, 0):  # dask gives up at the first death
        future = executor.submit(_die, 3)
        assert isinstance(future.exception(timeout=60), WorkerDied)
    assert "died 1 time " in str(future.exception())
    assert executor.submit(sum, [1, 2]).result(timeout=60) == 3  # the cluster goes on


class _DyingExecutor(cf.Executor):
    """Every exact solve's worker died; the heuristics run in this process."""

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> cf.Future:
        future: cf.Future = cf.Future()
        if args[2] == EXACT:
            future.set_exception(WorkerDied("the worker running it died 4 times"))
        else:
            future.set_result(fn(*args, **kwargs))
        return future


def test_trials_whose_workers_died_are_failures_without_traceback(tmp_path: Path) -> None:
    store = tmp_path / "s.sqlite"
    outcome = run_sweep(TINY, store, executor=_DyingExecutor(), progress=False)
    assert not outcome.ok and outcome.completed == 0 and len(outcome.failures) == 6
    exact = [f for f in outcome.failures if f[2] == EXACT]
    assert [f[3] for f in exact] == ["WorkerDied: the worker running it died 4 times"] * 2
    assert _stored(store) == 0


# ------------------------------------------------------------------ the command line
SWEEP = ["sweep", "--robots", "20", "--percent-tasks", "10", "--compositions", "5:2",
         "--missions", "2", "--algorithms", "grape-s,sda", "--quiet", "--store"]  # fmt: skip


def _one_error_line(capsys: pytest.CaptureFixture[str], code: int, fragment: str) -> str:
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: --"), err
    assert fragment in lines[0], lines[0]
    return lines[0]


def test_cli_sweep_on_a_running_scheduler(
    executor: DaskExecutor, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    store = tmp_path / "s.sqlite"
    address = executor._client.scheduler.address
    assert main([*SWEEP, str(store), "--scheduler", address]) == 0
    assert "6 trials run, 0 already stored, 0 failed, of 6" in capsys.readouterr().out
    assert sorted(_keys(store)) == sorted(_expected(TINY))
    assert executor._client.status == "running"  # a remote cluster is left running


def test_workers_running_other_cfopt_code_are_refused(
    executor: DaskExecutor,
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    import cfopt.experiments

    monkeypatch.setattr(cfopt.experiments, "code_version", lambda *_: "0.1.0+elsewhere")
    address = executor._client.scheduler.address
    code = main([*SWEEP, str(tmp_path / "s.sqlite"), "--scheduler", address])
    _one_error_line(capsys, code, "this process 0.1.0+elsewhere; install the same cfopt")
    assert not (tmp_path / "s.sqlite").exists()


def test_cli_without_dask_says_how_to_install_it(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed fails
    code = main([*SWEEP, str(tmp_path / "s.sqlite"), "--scheduler", "local:2"])
    _one_error_line(capsys, code, 'pip install "cfopt[cluster]"')
    assert not (tmp_path / "s.sqlite").exists()


@pytest.mark.parametrize(
    ("value", "fragment"),
    [
        ("local:two", "--scheduler: must be local:N"),
        ("bogus://x", "--scheduler: not a scheduler address: 'bogus://x'"),
        ("tcp://127.0.0.1:9", "--scheduler: cannot reach the scheduler at tcp://127.0.0.1:9"),
    ],
)
def test_cli_bad_schedulers_are_one_error_line(
    value: str,
    fragment: str,
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.setattr(cfcluster, "CONNECT_TIMEOUT", 1.0)
    started = time.monotonic()
    code = main([*SWEEP, str(tmp_path / "s.sqlite"), "--scheduler", value])
    _one_error_line(capsys, code, fragment)
    assert time.monotonic() - started < 15


def test_cli_workers_and_scheduler_conflict(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main([*SWEEP, str(tmp_path / "s.sqlite"), "--scheduler", "local:2", "--workers", "2"])
    _one_error_line(capsys, code, "--workers: not with --scheduler")


def _descendants(pid: int) -> set[int]:
    found: set[int] = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            with contextlib.suppress(OSError, IndexError, ValueError):
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
                if int(fields[1]) == pid:
                    found |= {int(entry.name), *_descendants(int(entry.name))}
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc")
def test_ctrl_c_stops_a_local_cluster_sweep_cleanly(
    executor: DaskExecutor, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Ctrl-C reaches the whole process group: the workers ignore it, the sweep answers
    it with one line, the cluster goes away, and the same command resumes."""
    store = tmp_path / "s.sqlite"
    args = ["sweep", "--robots", "60", "--percent-tasks", "10", "--compositions", "5:2",
            "--network", "complete", "--missions", "4", "--algorithms", "sda", "--quiet",
            "--store", str(store)]  # fmt: skip
    process = subprocess.Popen(
        [sys.executable, "-m", "cfopt", *args, "--scheduler", "local:2"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        _wait_for(lambda: _stored(store) >= 1, seconds=90)
        workers = _descendants(process.pid)
        assert len(workers) >= 2
        os.killpg(process.pid, signal.SIGINT)  # what a terminal's Ctrl-C does
        _, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 130, err
    kept = _stored(store)
    verb = "is" if kept == 1 else "are"
    assert err == (
        f"error: interrupted (SIGINT): {plural(kept, 'trial')} computed by this run {verb} "
        f"kept in {store}; run the same command again to resume\n"
    )
    _wait_for(lambda: not any(_alive(pid) for pid in workers), seconds=10)
    address = executor._client.scheduler.address
    assert main([*args, "--scheduler", address]) == 0  # resumed on the shared cluster
    assert f", {kept} already stored, 0 failed, of 8" in capsys.readouterr().out
    keys = _keys(store)
    assert len(keys) == len(set(keys)) == 8


# ----------------------------------------------------------------- a lost scheduler
def test_a_lost_scheduler_stops_the_sweep_keeping_what_it_stored(tmp_path: Path) -> None:
    from distributed import LocalCluster

    store = tmp_path / "s.sqlite"
    cluster = LocalCluster(  # in this process, on tcp (cfopt refuses dask's inproc://)
        n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", dashboard_address=None
    )
    address = cluster.scheduler_address
    try:
        with dask_executor(address, connect_timeout=1.0) as pool:
            closer = threading.Thread(
                target=lambda: (_wait_for(lambda: _stored(store) >= 1), cluster.close())
            )
            closer.start()
            with pytest.raises(ExecutorFailed) as info:
                run_sweep(SLOW, store, executor=pool, progress=False)
            closer.join(timeout=30)
    finally:
        cluster.close()
    kept = _stored(store)
    assert 1 <= kept < SLOW.size
    verb = "is" if kept == 1 else "are"
    message = info.value.cli_message
    assert message.startswith(f"--scheduler {address}: lost the connection")
    assert f"{plural(kept, 'trial')} computed by this run {verb} kept in {store}" in message


def test_cli_reproduce_on_a_running_scheduler(
    executor: DaskExecutor,
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``cfopt reproduce --scheduler``: the trials run on the cluster, the store and the
    report stay here, and every trial of the (shrunken) grid is stored."""
    from cfopt import reproduce
    from tests.cfopt.test_reproduce import _tiny_sweeps

    monkeypatch.setattr(reproduce, "reproduction_sweeps", _tiny_sweeps)
    out = tmp_path / "rep"
    address = executor._client.scheduler.address
    argv = ["reproduce", "--missions", "1", "--centralized-only", "--quiet", "-o", str(out)]
    assert main([*argv, "--scheduler", address, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["trials_computed"] == 2 * 5 and data["trials_reused"] == 0
    assert (out / "reproduction.md").is_file()
    assert sorted(_keys(out / "trials.sqlite")) == sorted(_expected(_tiny_sweeps(1)[0]))
    code = main([*argv, "--force", "--scheduler", "local:2", "--workers", "2"])
    _one_error_line(capsys, code, "--workers: not with --scheduler")
