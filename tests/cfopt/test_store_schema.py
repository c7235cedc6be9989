"""The result store's schemas 4 and 5: the per-trial communication table (4), the
algorithm's version in the primary key (5), their round trip, and the in-place upgrades
from schemas 4, 3 and 2."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import sqlite3
from pathlib import Path

import pytest

from cfopt import GridCell, MissionError
from cfopt.experiments import run_trial
from cfopt.store import (
    _SCHEMA_3_COLUMNS,
    _SCHEMA_4_COLUMNS,
    _SCHEMA_5_COLUMNS,
    _TRIAL_FIELDS,
    ResultStore,
    Trial,
    _column_type,
)
from heuristics import get_algorithm
from heuristics.communication import MODELS

CELL = GridCell(12, 50, 5, 2)


@pytest.fixture(scope="module")
def trials() -> dict[str, Trial]:
    exact = run_trial(CELL, 0, "exact")
    optimum = (exact.optimum_status, exact.optimum, exact.optimum_bound)
    out = {"exact": exact}
    for name in ("grape-s", "pair-grape-s-chain", "sda", "rachna-dt"):
        out[name] = run_trial(CELL, 0, name, optimum=optimum)
    return out


def _schema(path: Path, version: str, trials: list[Trial]) -> None:
    """A store as an older cfopt wrote it: its columns, its version, these trials."""
    lacking = set(_SCHEMA_5_COLUMNS)
    lacking |= set(_SCHEMA_4_COLUMNS) if version in ("2", "3") else set()
    lacking |= set(_SCHEMA_3_COLUMNS) if version == "2" else set()
    columns = [f for f in _TRIAL_FIELDS if f not in lacking]
    with contextlib.closing(sqlite3.connect(path)) as db:
        db.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT)")
        db.execute("INSERT INTO meta VALUES ('schema_version', ?)", (version,))
        body = ", ".join(f"{c} {_column_type(c)}" for c in columns)
        db.execute(
            f"CREATE TABLE trials ({body}, "
            "PRIMARY KEY (cell, mission_seed, algorithm, code_version))"
        )
        for t in trials:
            values = [getattr(t, c) for c in columns]
            values = [int(v) if isinstance(v, bool) else v for v in values]
            values = [json.dumps(v) if isinstance(v, tuple) else v for v in values]
            db.execute(
                f"INSERT INTO trials ({', '.join(columns)}) "
                f"VALUES ({', '.join('?' * len(columns))})",
                values,
            )
        db.commit()


def _version(path: Path) -> str:
    with contextlib.closing(sqlite3.connect(path)) as db:
        return db.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()[0]


def test_trials_carry_the_runs_communication_table(trials) -> None:
    run = get_algorithm("grape-s")(CELL.mission(0), seed=CELL.mission_seed(0))
    t = trials["grape-s"]
    assert t.communication == run.communication
    assert [(md, en) for md, en, _, _ in t.communication] == [
        (c.medium, c.encoding) for c in MODELS
    ]
    assert (t.messages, t.bytes) == run.communication_cost("broadcast", "full")
    assert trials["pair-grape-s-chain"].communication is not None
    assert trials["sda"].communication is not None
    assert trials["rachna-dt"].communication is not None
    assert trials["exact"].communication is None  # the exact solve sends nothing


def test_round_trip(tmp_path: Path, trials) -> None:
    path = tmp_path / "s.sqlite"
    with ResultStore(path) as store:
        for t in trials.values():
            assert store.add(t)
    assert _version(path) == "5"
    with ResultStore(path, create=False) as store:
        back = {t.algorithm: t for t in store.trials()}
    assert back == trials
    assert back["grape-s"].communication == trials["grape-s"].communication
    assert isinstance(back["sda"].communication, tuple)


@pytest.mark.parametrize("version", ["4", "3", "2"])
def test_older_stores_are_upgraded_in_place(tmp_path: Path, trials, version) -> None:
    path = tmp_path / "old.sqlite"
    # a store from before schema 5 holds trials of each engine's first version
    old = [dataclasses.replace(trials["grape-s"], algorithm_version="1")]
    if version in ("3", "2"):  # no communication column
        old = [dataclasses.replace(old[0], communication=None)]
    if version == "2":  # a schema-2 store has no distributed columns: they read as None
        old = [dataclasses.replace(old[0], **dict.fromkeys(_SCHEMA_3_COLUMNS))]
    _schema(path, version, old)
    # reading does not change the file, and the missing columns read as empty
    with ResultStore(path, create=False) as store:
        assert store.trials() == old
    assert _version(path) == version
    # opening to write upgrades it (2 -> 3 -> 4 -> 5 at once), keeping the stored trials
    with ResultStore(path) as store:
        assert store.trials() == old
        assert store.add(trials["sda"])
        assert not store.add(old[0])  # same key: the stored one stays
    assert _version(path) == "5"
    with contextlib.closing(sqlite3.connect(path)) as db:
        columns = {r[1] for r in db.execute("PRAGMA table_info(trials)")}
    assert set(_TRIAL_FIELDS) <= columns
    with ResultStore(path, create=False) as store:
        back = {(t.algorithm, t.algorithm_version): t for t in store.trials()}
    sda = trials["sda"]
    assert back == {("grape-s", "1"): old[0], ("sda", sda.algorithm_version): sda}


@pytest.mark.parametrize(
    "text",
    ['"not a table"', "[[1, 2, 3, 4]]", '[["broadcast", "full", -1, 5]]', "{", "[[true]]"],
)
def test_an_edited_table_is_a_clean_error(tmp_path: Path, trials, text) -> None:
    path = tmp_path / "s.sqlite"
    with ResultStore(path) as store:
        store.add(trials["grape-s"])
    with contextlib.closing(sqlite3.connect(path)) as db:
        db.execute("UPDATE trials SET communication = ?", (text,))
        db.commit()
    with (
        ResultStore(path, create=False) as store,
        pytest.raises(MissionError, match="column communication holds"),
    ):
        store.trials()


def test_older_trials_read_as_version_1_and_exact_as_none(tmp_path: Path, trials) -> None:
    """Before schema 5 every algorithm was at version "1"; the exact solve has none."""
    path = tmp_path / "old.sqlite"
    _schema(path, "4", [trials["exact"], trials["sda"]])
    with ResultStore(path, create=False) as store:
        versions = {t.algorithm: t.algorithm_version for t in store.trials()}
    assert versions == {"exact": "", "sda": "1"}
    with ResultStore(path) as store:  # upgraded: the version is part of the key now
        assert {t.algorithm: t.algorithm_version for t in store.trials()} == versions
        assert store.add(dataclasses.replace(trials["sda"], algorithm_version="2"))
        assert not store.add(trials["sda"])
        assert ("n=12 p=50% 5:2 load=1", trials["sda"].mission_seed, "sda", "2") in store.done(
            trials["sda"].code_version
        )
    with contextlib.closing(sqlite3.connect(path)) as db:
        key = sorted((r[5], r[1]) for r in db.execute("PRAGMA table_info(trials)") if r[5])
    assert [name for _, name in key] == [
        "cell", "mission_seed", "algorithm", "algorithm_version", "code_version",
    ]  # fmt: skip
