"""A user's algorithm everywhere cfopt's own go: ``cfopt run``, ``sweep`` (in this process,
with 2 worker processes, on a dask ``local:2`` cluster), ``report`` and ``audit``.

Two ways in, both as a user would: an installed package -- ``mypkg/__init__.py`` and a
``mypkg-1.0.dist-info`` with a real ``cfopt.algorithms`` entry point, in a temporary
folder on ``PYTHONPATH`` of real ``python -m cfopt`` processes -- and a plain ``mod.py`` in
the folder the command runs from, named ``mod:fn``.  Also: a user's algorithm that raises
is its trials' failure (the sweep goes on, exit 2, each failure with the commands that
replay it), broken registrations are one error line, and the spec's version is part of a
stored trial's key.
"""

from __future__ import annotations

import importlib.util
import json
import os
import sqlite3
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import heuristics
from cfopt import GridCell

ROOT = Path(__file__).resolve().parents[2]
MYPKG = '''
    """A user's package with one algorithm, registered by an entry point."""
    import os

    import cfopt
    import heuristics


    def first_slot(mission, *, seed=None, passes=1):
        """Each robot, in order, takes the first short slot it can serve."""
        need = mission.requirements.copy()
        task = [-1] * mission.n_robots
        service = [-1] * mission.n_robots
        for _ in range(passes):
            for i in range(mission.n_robots):
                if task[i] >= 0:
                    continue
                for j, s in zip(*need.nonzero()):
                    if mission.capabilities[i, s]:
                        task[i], service[i] = int(j), int(s)
                        need[j, s] -= 1
                        break
        return cfopt.Assignment(task=task, service=service)


    SPEC = heuristics.AlgorithmSpec(
        name="first-slot",
        run=first_slot,
        version=os.environ.get("MYPKG_VERSION", "1"),
        options=(heuristics.Option("passes", int, 1, "passes over the robots"),),
        summary="each robot takes the first short slot it can serve",
    )
'''
MOD = """
    import cfopt


    def fn(mission, *, seed=None):
        return cfopt.Assignment.empty(mission)


    def flaky(mission, *, seed=None):
        if mission.n_robots == 12:
            raise ValueError("twelve robots are too many")
        return cfopt.Assignment.empty(mission)


    NUMBER = 3
"""
GRID = ["--percent-tasks", "20", "--compositions", "3:2", "--missions", "2"]


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text), encoding="utf-8")


def install(folder: Path, package: str, code: str, entries: dict[str, str]) -> Path:
    """``package`` and its ``*.dist-info`` in ``folder``, as pip would install them."""
    _write(folder / package / "__init__.py", code)
    info = folder / f"{package}-1.0.dist-info"
    _write(info / "METADATA", f"Metadata-Version: 2.1\nName: {package}\nVersion: 1.0\n")
    lines = "".join(f"{name} = {target}\n" for name, target in entries.items())
    _write(info / "entry_points.txt", f"[cfopt.algorithms]\n{lines}")
    return folder


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Where mypkg is installed (first-slot, by its entry point)."""
    return install(tmp_path_factory.mktemp("site"), "mypkg", MYPKG, {"first-slot": "mypkg:SPEC"})


def cfopt(
    *args: str, cwd: Path, site: Path | None = None, **env: str
) -> subprocess.CompletedProcess:
    """``python -m cfopt ARGS`` in ``cwd``, with ``site`` (the user's packages) on the path."""
    paths = ([os.fspath(site)] if site else []) + [os.fspath(ROOT)]
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join(paths), **env}
    environment.pop("PYTEST_ADDOPTS", None)
    return subprocess.run(
        [sys.executable, "-m", "cfopt", *args],
        cwd=cwd,
        env=environment,
        capture_output=True,
        text=True,
        timeout=600,
    )


def ok(result: subprocess.CompletedProcess) -> subprocess.CompletedProcess:
    assert result.returncode == 0, result.stderr
    return result


def one_error(result: subprocess.CompletedProcess, fragment: str) -> str:
    assert result.returncode == 2, (result.stdout, result.stderr)
    assert result.stderr.startswith("error: ") and result.stderr.count("\n") == 1, result.stderr
    assert "Traceback" not in result.stderr and fragment in result.stderr, result.stderr
    return result.stderr


@pytest.fixture
def work(tmp_path: Path) -> Path:
    """A folder with a mission and the user's ``mod.py``."""
    GridCell(12, 20, 3, 2).mission(0).to_json(tmp_path / "m.json")
    _write(tmp_path / "mod.py", MOD)
    return tmp_path


def _trials(store: Path) -> list[tuple]:
    with sqlite3.connect(store) as db:
        return db.execute(
            "SELECT algorithm, algorithm_version, utility, iterations, messages, seconds "
            "FROM trials ORDER BY cell, mission_seed, algorithm, algorithm_version"
        ).fetchall()


# ------------------------------------------------------------------ cfopt run
def test_run_finds_an_installed_algorithm(site: Path, work: Path) -> None:
    data = json.loads(
        ok(cfopt("run", "first-slot", "m.json", "--json", cwd=work, site=site)).stdout
    )
    assert data["algorithm"] == "first-slot" and data["utility"] > 0
    assert data["iterations"] is None and data["messages"] is None and data["seconds"] >= 0
    assert isinstance(data["nash_stable"], bool) and len(data["assignment"]) > 0
    text = ok(cfopt("run", "first-slot", "m.json", "--passes", "2", cwd=work, site=site)).stdout
    assert "iterations, rounds, messages and bytes not reported" in text.splitlines()[0]
    helped = ok(cfopt("run", "first-slot", "--help", cwd=work, site=site)).stdout
    assert "--passes INT" in helped and "passes over the robots (default: 1)" in helped
    listed = ok(cfopt("run", "--help", cwd=work, site=site)).stdout
    assert "first-slot" in listed and "each robot takes the first short slot" in listed


def test_run_takes_module_attr_from_the_current_directory(work: Path) -> None:
    data = json.loads(
        ok(cfopt("run", "mod:fn", "m.json", "--json", "--seed", "3", cwd=work)).stdout
    )
    assert data["algorithm"] == "mod:fn" and data["seed"] == 3 and data["utility"] == 0
    one_error(cfopt("run", "mod:fn", "m.json", "--passes", "2", cwd=work), "--passes 2")
    one_error(
        cfopt("run", "mod:fn", "m.json", "--network", "complete", cwd=work),
        "'mod:fn' has no distributed agents",
    )


def test_a_raising_algorithm_is_one_error_line(work: Path) -> None:
    err = one_error(cfopt("run", "mod:flaky", "m.json", cwd=work), "mod:flaky")
    assert err == "error: mod:flaky: raised ValueError: twelve robots are too many (on m.json)\n"


@pytest.mark.parametrize(
    ("algorithm", "fragment"),
    [
        pytest.param("nosuchmodule:fn", "nosuchmodule:fn: cannot import nosuchmodule", id="import"),
        pytest.param("mod:NUMBER", "mod:NUMBER: must be a heuristics.AlgorithmSpec", id="object"),
        pytest.param("mod:nope", "mod:nope: mod has no attribute 'nope'", id="attribute"),
    ],
)
def test_bad_references_are_one_error_line(work: Path, algorithm: str, fragment: str) -> None:
    one_error(cfopt("run", algorithm, "m.json", cwd=work), fragment)
    sweep = ["sweep", "--robots", "12", *GRID, "--algorithms", f"grape-s,{algorithm}"]
    one_error(cfopt(*sweep, "--store", "s.sqlite", cwd=work), fragment)
    assert not (work / "s.sqlite").exists()


@pytest.mark.parametrize(
    ("entries", "fragment"),
    [
        pytest.param(
            {"grape-s": "clashpkg:idle"},
            "entry point grape-s = clashpkg:idle (group cfopt.algorithms): algorithm name "
            "'grape-s' is already registered (by cfopt); choose another name",
            id="clash",
        ),
        pytest.param(
            {"gone": "nosuchpkg:idle"}, "cannot be loaded: ModuleNotFoundError", id="import"
        ),
        pytest.param(
            {"three": "clashpkg:THREE"}, "must be a heuristics.AlgorithmSpec", id="object"
        ),
    ],
)
def test_a_broken_installed_package_is_one_error_line(
    tmp_path: Path, work: Path, entries: dict[str, str], fragment: str
) -> None:
    code = "import cfopt\nTHREE = 3\ndef idle(mission, *, seed=None):\n    return None\n"
    broken = install(tmp_path / "broken-site", "clashpkg", code, entries)
    for argv in (["run", "grape-s", "m.json"], ["run", "--help"]):
        one_error(cfopt(*argv, cwd=work, site=broken), fragment)


# ------------------------------------------------------------- sweeps, report
def _sweep(*extra: str) -> list[str]:
    return ["sweep", "--robots", "12,16", *GRID, "--quiet", "--json", *extra]


def test_sweep_and_report_an_installed_algorithm(site: Path, tmp_path: Path) -> None:
    argv = _sweep("--algorithms", "grape-s,first-slot", "--workers", "1", "--store", "s.sqlite")
    first = json.loads(ok(cfopt(*argv, cwd=tmp_path, site=site)).stdout)
    assert (first["trials"], first["completed"], first["failed"]) == (12, 12, 0)
    rows = [r for r in _trials(tmp_path / "s.sqlite") if r[0] == "first-slot"]
    assert len(rows) == 4 and all(r[1] == "1" and r[3] is None and r[4] is None for r in rows)
    assert json.loads(ok(cfopt(*argv, cwd=tmp_path, site=site)).stdout)["skipped"] == 12
    report = ok(cfopt("report", "s.sqlite", "-o", "r", "--json", cwd=tmp_path, site=site))
    gap = json.loads(report.stdout)
    assert "first-slot" in json.dumps(gap)
    markdown = (tmp_path / "r" / "report.md").read_text(encoding="utf-8")
    assert "first-slot" in markdown and "grape-s" in markdown


def test_a_new_spec_version_is_computed_again(site: Path, tmp_path: Path) -> None:
    argv = _sweep("--algorithms", "grape-s,first-slot", "--workers", "1", "--store", "v.sqlite")
    ok(cfopt(*argv, cwd=tmp_path, site=site))
    again = json.loads(ok(cfopt(*argv, cwd=tmp_path, site=site, MYPKG_VERSION="2")).stdout)
    assert (again["completed"], again["skipped"]) == (4, 8)  # only first-slot's trials
    versions = sorted({(r[0], r[1]) for r in _trials(tmp_path / "v.sqlite")})
    shipped = ("grape-s", heuristics.ALGORITHMS["grape-s"].version)  # untouched by the user's
    assert versions == [("exact", ""), ("first-slot", "1"), ("first-slot", "2"), shipped]
    ok(cfopt("report", "v.sqlite", "-o", "r", cwd=tmp_path, site=site))
    csv = (tmp_path / "r" / "summary.csv").read_text(encoding="utf-8")
    assert csv.count("first-slot") == 1  # the report reads version 2 only, not both


def test_a_two_worker_sweep_finds_both_kinds(site: Path, work: Path) -> None:
    argv = _sweep("--algorithms", "first-slot,mod:fn", "--workers", "2", "--store", "w.sqlite")
    outcome = json.loads(ok(cfopt(*argv, cwd=work, site=site)).stdout)
    assert (outcome["completed"], outcome["failed"]) == (12, 0)
    algorithms = {r[0] for r in _trials(work / "w.sqlite")}
    assert algorithms == {"exact", "first-slot", "mod:fn"}


@pytest.mark.skipif(importlib.util.find_spec("distributed") is None, reason="needs dask")
def test_a_dask_sweep_finds_both_kinds(site: Path, work: Path) -> None:
    argv = _sweep("--algorithms", "first-slot,mod:fn", "--scheduler", "local:2")
    outcome = json.loads(ok(cfopt(*argv, "--store", "d.sqlite", cwd=work, site=site)).stdout)
    assert (outcome["completed"], outcome["failed"]) == (12, 0)
    assert {r[0] for r in _trials(work / "d.sqlite")} == {"exact", "first-slot", "mod:fn"}


def test_the_same_trials_wherever_they_run(site: Path, work: Path) -> None:
    """In this process and in 2 workers: the same stored values (timing apart)."""
    stores = []
    for workers in ("1", "2"):
        store = work / f"same-{workers}.sqlite"
        argv = _sweep("--algorithms", "first-slot,mod:fn,sda", "--workers", workers)
        ok(cfopt(*argv, "--store", store.name, cwd=work, site=site))
        stores.append([row[:5] for row in _trials(store)])
    assert stores[0] == stores[1]


def test_a_raising_algorithm_fails_its_trials_and_the_sweep_goes_on(work: Path) -> None:
    argv = _sweep("--algorithms", "grape-s,mod:flaky", "--workers", "1", "--store", "f.sqlite")
    result = cfopt(*argv, cwd=work)
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
    outcome = json.loads(result.stdout)
    assert (outcome["trials"], outcome["completed"], outcome["failed"]) == (12, 10, 2)
    lines = result.stderr.strip().splitlines()
    failed = [line for line in lines if line.startswith("trial mod:flaky on n=12")]
    assert len(failed) == 2 and "raised ValueError: twelve robots are too many" in failed[0]
    assert lines[-1].startswith("error: 2 trials of mod:flaky failed")
    stored = _trials(work / "f.sqlite")
    assert len(stored) == 10 and sum(r[0] == "mod:flaky" for r in stored) == 2  # n=16 ran
    replay = lines[lines.index(failed[0]) + 1].strip()
    assert replay.startswith("replay: cfopt generate --robots 12 --percent-tasks 20 ")
    commands = replay.removeprefix("replay: ").replace("cfopt ", f"{sys.executable} -m cfopt ")
    again = subprocess.run(
        ["bash", "-c", commands], cwd=work, capture_output=True, text=True, timeout=120,
        env={**os.environ, "PYTHONPATH": os.fspath(ROOT)},
    )  # fmt: skip
    assert again.returncode == 2 and "mod:flaky: raised ValueError" in again.stderr
    rerun = cfopt(*argv, cwd=work)  # the failed trials are retried, the others kept
    assert json.loads(rerun.stdout)["skipped"] == 10 and rerun.returncode == 2


# --------------------------------------------------------------------- audit
def test_audit_puts_a_users_algorithm_on_the_grid(
    work: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import cfopt.experiments
    import proofs.claims
    from cfopt.cli import main
    from proofs.claimkit import Claim, Scope, Verdict, VerdictKind
    from proofs.claims_generic import claim_prefix

    def claims(*, budget=25, seed=0, ids=None):
        return [Verdict(i, "holds", VerdictKind.HOLDS, budget, None, 0.01) for i in ids]

    class Holds:  # the generic claims' check, made instant (tests/proofs checks them)
        def check(self, claim, n_missions, seed):
            return VerdictKind.HOLDS, n_missions, None, ""

    def generic(algorithm, *, directory=None):
        name = claim_prefix(algorithm)
        return [Claim(f"{name}.valid", "valid", "any", (algorithm,), Holds(), Scope.GENERALISATION)]

    cells = (GridCell(12, 20, 3, 2), GridCell(16, 20, 3, 2, load=1.25))
    monkeypatch.setattr(cfopt.experiments, "quick_grid", lambda: cells)
    monkeypatch.setattr(proofs.claims, "CLAIMS", {"H1": None})
    monkeypatch.setattr(proofs.claims, "audit_claims", claims)
    monkeypatch.setattr(proofs.claims, "algorithm_claims", generic)
    monkeypatch.chdir(work)
    argv = ["audit", "--quick", "--workers", "1", "--json", "-o", "audit", "--quiet"]
    assert main([*argv, "--algorithm", "mod:fn", "--algorithm", "sda"]) == 0
    data = json.loads(capsys.readouterr().out)
    gap = data["gap_report"]
    assert "mod:fn" in json.dumps(gap)
    # beside the registered claims, each algorithm's generic ones, in the same verdicts
    assert [v["id"] for v in data["claims"]] == ["H1", "mod-fn.valid", "sda.valid"]
    with sqlite3.connect(work / "audit" / "trials.sqlite") as db:
        names = {row[0] for row in db.execute("SELECT DISTINCT algorithm FROM trials")}
    assert {"mod:fn", "grape-s", "rachna-dt", "exact"} <= names  # beside the registered ones
    assert "mod:fn" in (work / "audit" / "report.md").read_text(encoding="utf-8")
    assert "mod-fn.valid" in (work / "audit" / "claims.csv").read_text(encoding="utf-8")
    # claims only: just the algorithms' generic claims; an unknown one is an error line
    assert main(["audit", "--claims-only", "--algorithm", "mod:fn", "-o", "a2", "--json"]) == 0
    assert [v["id"] for v in json.loads(capsys.readouterr().out)["claims"]] == ["mod-fn.valid"]
    assert main(["audit", "--claims-only", "--algorithm", "nosuch", "-o", "a3"]) == 2
    assert "error: --algorithm: unknown algorithm 'nosuch'" in capsys.readouterr().err
