"""Sweeps and the result store: rows, resumption, kill safety, grids, failures."""

from __future__ import annotations

import concurrent.futures as cf
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path
from types import MappingProxyType

import pytest

import heuristics.registry
from cfopt import GridCell, MissionError, solve_exact
from cfopt.experiments import (
    EXACT,
    ResultStore,
    Sweep,
    audit_grid,
    grid_from_file,
    named_grid,
    product_grid,
    quick_grid,
    run_sweep,
)
from heuristics.registry import get_algorithm

TINY = (GridCell(20, 10, 5, 2), GridCell(24, 50, 5, 1, load=1.25))


@pytest.fixture(scope="module")
def tiny_store(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Sweep]:
    store = tmp_path_factory.mktemp("sweep") / "trials.sqlite"
    sweep = Sweep(cells=TINY, missions=2, algorithms=("grape-s", "sda"))
    outcome = run_sweep(sweep, store, workers=1, progress=False)
    assert outcome.ok and outcome.completed == 12 and outcome.skipped == 0
    return store, sweep


def test_tiny_sweep_rows(tiny_store: tuple[Path, Sweep]) -> None:
    store, _ = tiny_store
    with ResultStore(store) as db:
        trials = db.trials()
    assert len(trials) == 12
    assert len({t.key for t in trials}) == 12
    assert {(t.cell, t.mission_index, t.algorithm) for t in trials} == {
        (c.label, i, a) for c in TINY for i in range(2) for a in (EXACT, "grape-s", "sda")
    }
    exact = {(t.cell, t.mission_seed): t for t in trials if t.algorithm == EXACT}
    for t in trials:
        cell = next(c for c in TINY if c.label == t.cell)
        mission = cell.mission(t.mission_index)
        assert t.mission_seed == cell.mission_seed(t.mission_index)
        assert (t.robots, t.percent_tasks, t.load, t.tasks) == (
            cell.robots,
            cell.percent_tasks,
            cell.load,
            mission.n_tasks,
        )
        assert t.total_utility == mission.total_utility
        # scored against the exact solve of the same mission, recomputed independently
        reference = exact[(t.cell, t.mission_seed)]
        assert (t.optimum, t.optimum_status) == (reference.utility, "optimal")
        assert t.optimum == solve_exact(mission).utility
        assert t.percent_optimum == pytest.approx(100 * t.utility / t.optimum)
        assert t.percent_total == pytest.approx(100 * t.utility / mission.total_utility)
        if t.algorithm == EXACT:
            assert t.iterations is None and t.messages is None and t.percent_optimum == 100
        else:
            run = get_algorithm(t.algorithm)(mission, seed=t.mission_seed)
            assert t.utility == run.assignment.utility(mission)
            assert (t.iterations, t.messages, t.bytes, t.work) == (
                run.iterations,
                run.messages,
                run.bytes,
                run.work,
            )
            assert t.algorithm_seed == t.mission_seed
        assert isinstance(t.nash_stable, bool) and isinstance(t.pairwise_stable, bool)
        assert isinstance(t.pareto_stable, bool)
        assert t.pairwise_stable == t.nash_stable  # strict pairwise = Nash (proofs.stability)


def test_rerun_skips_everything(tiny_store: tuple[Path, Sweep]) -> None:
    store, sweep = tiny_store
    again = run_sweep(sweep, store, workers=1, progress=False)
    assert (again.completed, again.skipped, again.ok) == (0, 12, True)
    with ResultStore(store) as db:
        assert db.count() == 12
        trial = db.trials()[0]
        assert db.add(trial) is False  # INSERT OR IGNORE keeps the first
        assert db.count() == 12
        assert len(db.sweeps()) >= 2


def test_more_missions_only_runs_the_new_ones(tmp_path: Path) -> None:
    store = tmp_path / "s.sqlite"
    small = Sweep(cells=TINY[:1], missions=1, algorithms=("grape-s",))
    assert run_sweep(small, store, workers=1, progress=False).completed == 2
    bigger = Sweep(cells=TINY[:1], missions=3, algorithms=("grape-s", "pair-grape-s"))
    outcome = run_sweep(bigger, store, workers=1, progress=False)
    assert (outcome.completed, outcome.skipped, outcome.total) == (7, 2, 9)


def test_any_executor_gives_the_same_trials(tiny_store: tuple[Path, Sweep], tmp_path) -> None:
    store, sweep = tiny_store
    other = tmp_path / "threads.sqlite"
    with cf.ThreadPoolExecutor(max_workers=3) as pool:
        outcome = run_sweep(sweep, other, executor=pool, progress=False)
    assert outcome.completed == 12
    with ResultStore(store) as a, ResultStore(other) as b:
        left = {t.key: (t.utility, t.optimum, t.iterations, t.messages) for t in a.trials()}
        right = {t.key: (t.utility, t.optimum, t.iterations, t.messages) for t in b.trials()}
    assert left == right


def test_a_failing_trial_is_reported_and_not_stored(monkeypatch, tmp_path: Path) -> None:
    def boom(mission, **options):
        raise RuntimeError("deliberate failure")

    table = dict(heuristics.registry.ALGORITHMS, boom=boom)
    monkeypatch.setattr(heuristics.registry, "ALGORITHMS", MappingProxyType(table))
    store = tmp_path / "s.sqlite"
    sweep = Sweep(cells=TINY[:1], missions=2, algorithms=("grape-s", "boom"))
    outcome = run_sweep(sweep, store, workers=1, progress=False)
    assert outcome.completed == 4 and not outcome.ok
    assert [f[2] for f in outcome.failures] == ["boom", "boom"]
    assert "deliberate failure" in outcome.failures[0][3]
    with ResultStore(store) as db:
        assert {t.algorithm for t in db.trials()} == {EXACT, "grape-s"}


def test_store_refuses_foreign_files_and_leaves_them_alone(tmp_path: Path) -> None:
    text = tmp_path / "mission.json"
    text.write_text('{"format": "cfopt.mission/1"}\n', encoding="utf-8")
    with pytest.raises(MissionError, match="not a cfopt result store"):
        ResultStore(text)
    assert text.read_text(encoding="utf-8") == '{"format": "cfopt.mission/1"}\n'
    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as db:
        db.execute("CREATE TABLE birds (name TEXT)")
    db.close()
    with pytest.raises(MissionError, match="something else"):
        ResultStore(other)
    with pytest.raises(MissionError, match="is a directory"):
        ResultStore(tmp_path)


# -------------------------------------------------------------------- kill safety
def _count(store: Path) -> int:
    try:
        with sqlite3.connect(f"file:{store}?mode=ro", uri=True, timeout=5) as db:
            return int(db.execute("SELECT COUNT(*) FROM trials").fetchone()[0])
    except sqlite3.Error:
        return 0


def _wait_until_gone(group: int, timeout: float = 60) -> None:
    """Wait until no process of process group ``group`` is left (killed processes that are
    in the middle of a system call end it first)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            os.killpg(group, 0)
        except ProcessLookupError:
            return
        time.sleep(0.02)
    raise AssertionError(f"process group {group} still has processes after {timeout} s")


def test_killed_sweep_resumes_with_one_row_per_trial(tmp_path: Path) -> None:
    store = tmp_path / "killed.sqlite"
    command = [
        sys.executable, "-m", "cfopt", "sweep", "--robots", "30", "--percent-tasks", "10,50",
        "--compositions", "5:1,10:5", "--load", "1,1.25", "--missions", "4",
        "--algorithms", "grape-s,pair-grape-s,sda",
        "--workers", "2", "--store", str(store), "--quiet", "--json",
    ]  # fmt: skip
    total = 2 * 2 * 2 * 4 * 4  # cells x missions x (exact + 3 heuristics)
    proc = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True
    )
    deadline = time.monotonic() + 600  # a hang guard: wait for the state
    while _count(store) < 15 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)  # the parent and its workers, mid-way
    proc.communicate()
    _wait_until_gone(proc.pid)  # a worker inside a commit's fsync dies only once it is done
    stored = _count(store)
    assert 15 <= stored < total, "the sweep must be killed mid-way"

    resumed = subprocess.run(command, capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    summary = json.loads(resumed.stdout)
    # a commit the kill interrupted may still land once sqlite recovers it: never fewer
    assert summary["skipped"] >= stored and summary["completed"] == total - summary["skipped"]
    with sqlite3.connect(store) as db:
        rows = db.execute("SELECT cell, mission_seed, algorithm, code_version FROM trials")
        keys = [tuple(r) for r in rows]
    assert len(keys) == len(set(keys)) == total
    cells = product_grid([30], [10, 50], [(5, 1), (10, 5)], [1.0, 1.25])
    algorithms = (EXACT, "grape-s", "pair-grape-s", "sda")
    assert {k[:3] for k in keys} == {
        (c.label, c.mission_seed(i), a) for c in cells for i in range(4) for a in algorithms
    }


# -------------------------------------------------------------------------- grids
def test_named_grids() -> None:
    assert len(named_grid("paper")) == 32 and len(named_grid("paper-distributed")) == 20
    assert {c.load for c in named_grid("paper", [1.0, 1.25])} == {1.0, 1.25}
    cells = audit_grid()
    achievable = [c for c in cells if c.load == 1]
    assert {c.robots for c in achievable} == {100, 500}
    assert {c.composition for c in achievable} == {"5:1", "5:5", "10:1", "10:5"}
    assert {c.percent_tasks for c in achievable if c.robots == 500} == {1, 10, 50}
    assert {c.load for c in cells} == {1.0, 1.25, 1.5, 2.0}
    assert {c.robots for c in quick_grid()} == {100}
    with pytest.raises(MissionError, match="fixed loads"):
        named_grid("audit", [1.25])
    with pytest.raises(MissionError, match="unknown grid"):
        named_grid("papers")


def test_grid_files(tmp_path: Path) -> None:
    toml = tmp_path / "grid.toml"
    toml.write_text(
        'robots = [20, 30]\npercent_tasks = [10]\ncompositions = ["5:2"]\nmissions = 3\n'
        "[[cells]]\nrobots = 40\npercent_tasks = 50\nservice_types = 5\n"
        "services_per_robot = 1\nload = 1.25\n",
        encoding="utf-8",
    )
    cells, missions = grid_from_file(toml)
    assert missions == 3
    assert [c.label for c in cells] == [
        "n=20 p=10% 5:2 load=1",
        "n=30 p=10% 5:2 load=1",
        "n=40 p=50% 5:1 load=1.25",
    ]
    js = tmp_path / "grid.json"
    js.write_text(json.dumps({"robots": [20], "compositions": ["10:5"]}), encoding="utf-8")
    cells, missions = grid_from_file(js)
    assert missions is None and [c.percent_tasks for c in cells] == [1, 10, 50]


@pytest.mark.parametrize(
    ("name", "text", "match"),
    [
        pytest.param("g.toml", "robot = [20]", r"g\.toml: robot: unknown key", id="typo"),
        pytest.param("g.toml", "robots = 20", "robots: must be a non-empty list", id="scalar"),
        pytest.param("g.toml", "robots = [0]", "robots: must be a whole number", id="zero"),
        pytest.param(
            "g.toml", 'robots = [20]\ncompositions = ["10-5"]', r"compositions\[0\]", id="comp"
        ),
        pytest.param("g.toml", "missions = 2", "no cells", id="empty"),
        pytest.param(
            "g.toml", "[[cells]]\nrobots = 20\npercent_tasks = 10", 'missing key "service_types"',
            id="cell-missing",
        ),
        pytest.param(
            "g.toml", "[[cells]]\nrobots=20\npercent_tasks=10\nservice_types=2\n"
            "services_per_robot=3", r"cells\[0\]\.services_per_robot", id="cell-bad",
        ),
        pytest.param("g.toml", "robots = [", r"g\.toml: not valid TOML", id="syntax"),
        pytest.param("g.json", "{", r"g\.json: not valid JSON", id="json-syntax"),
        pytest.param("g.yaml", "robots: [20]", "must end in .toml or .json", id="suffix"),
        pytest.param(
            "g.toml", "robots = [20]\nmissions = 0", "missions: must be a whole", id="missions"
        ),
    ],
)  # fmt: skip
def test_bad_grid_files(tmp_path: Path, name: str, text: str, match: str) -> None:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    with pytest.raises(MissionError, match=match):
        grid_from_file(path)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        pytest.param({"missions": 0}, "missions: must be a whole number >= 1", id="missions"),
        pytest.param({"algorithms": ("grape",)}, "unknown algorithm 'grape'", id="algorithm"),
        pytest.param({"cells": ()}, "cells: must be a non-empty", id="no-cells"),
        pytest.param({"time_limit": 0}, "time_limit", id="time-limit"),
    ],
)
def test_bad_sweeps(kwargs: dict, match: str) -> None:
    args = {"cells": TINY, **kwargs}
    with pytest.raises(MissionError, match=match):
        Sweep(**args)


def test_sweep_always_includes_exact() -> None:
    sweep = Sweep(cells=TINY, missions=2, algorithms=("sda", "exact", "sda"))
    assert sweep.algorithms == (EXACT, "sda") and sweep.size == 8
