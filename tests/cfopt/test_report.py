"""Reports: tables, statistics (checked against scipy), plots, files, refusal to overwrite."""

from __future__ import annotations

import csv
import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import scikit_posthocs
from scipy import stats

from cfopt import GridCell, MissionError
from cfopt.cli import main
from cfopt.experiments import EXACT, ResultStore, Sweep, Trial, run_sweep
from cfopt.report import (
    cell_table,
    format_range,
    load_trials,
    statistics,
    summary_rows,
    write_report,
)

CELLS = (GridCell(20, 10, 5, 2), GridCell(20, 50, 10, 2), GridCell(24, 50, 5, 1, load=1.25))


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("fixture") / "trials.sqlite"
    sweep = Sweep(cells=CELLS, missions=3, algorithms=("grape-s", "pair-grape-s", "sda"))
    assert run_sweep(sweep, path, workers=1, progress=False).ok
    return path


@pytest.fixture(scope="module")
def written(store: Path, tmp_path_factory: pytest.TempPathFactory):
    trials, version = load_trials(store)
    out = tmp_path_factory.mktemp("written") / "report"
    return trials, version, write_report(trials, out, version=version, source=str(store))


def _trial(**values) -> Trial:
    base = dict(
        cell="c", robots=100, percent_tasks=10.0, service_types=5, services_per_robot=1,
        load=1.0, mission_index=0, base_seed=0, mission_seed=0, tasks=10, total_utility=100.0,
        algorithm="grape-s", code_version="v", utility=100.0, optimum=100.0,
        optimum_bound=100.0, optimum_status="optimal", percent_optimum=100.0,
        percent_total=100.0, iterations=1, rounds=2, messages=10, bytes=1000, work=5,
        seconds=0.1, nash_stable=True, nash_stable_capped=True, pairwise_stable=True,
        pairwise_stable_capped=True, pareto_stable=True, pairwise_step_ran=None,
        algorithm_seed=0, finished=0.0,
    )  # fmt: skip
    base.update(values)
    if "cell" not in values:
        base["cell"] = f"n={base['robots']} p={base['percent_tasks']:g}"
    return Trial(**base)


# ------------------------------------------------------------------------- tables
def test_format_range() -> None:
    assert format_range([100.0, 89.68, 100.0, 96.59]) == "98.3 (89.7, 100)"
    assert format_range([]) == "-"


def test_cell_table_matches_the_trials(store: Path) -> None:
    trials, _ = load_trials(store)
    header, rows = cell_table(trials, "percent_total")
    assert header == ["load", "S:k", "% tasks", "robots", "grape-s", "pair-grape-s", "sda"]
    assert len(rows) == len(CELLS)
    for row in rows:
        load, comp, p, n = row[:4]
        for algorithm, text in zip(header[4:], row[4:], strict=True):
            values = [
                t.percent_total
                for t in trials
                if t.algorithm == algorithm
                and (f"{t.load:g}", t.composition, f"{t.percent_tasks:g}", str(t.robots))
                == (load, comp, p, n)
            ]
            assert len(values) == 3
            assert text == format_range(values)
    runtime_header, _ = cell_table(trials, "seconds")
    assert EXACT in runtime_header  # the solver's runtime is reported beside the heuristics


def test_summary_rows_count(store: Path) -> None:
    trials, _ = load_trials(store)
    rows = summary_rows(trials)
    assert {(r["load"], r["algorithm"]) for r in rows} == {
        (load, a) for load in (1.0, 1.25) for a in (EXACT, "grape-s", "pair-grape-s", "sda")
    }
    for r in rows:
        mine = [t for t in trials if (t.load, t.algorithm) == (r["load"], r["algorithm"])]
        assert r["trials"] == len(mine)
        assert r["nash_stable"] == sum(t.nash_stable for t in mine)
        assert r["percent_optimum"]["median"] == pytest.approx(
            np.median([t.percent_optimum for t in mine])
        )


def test_unproven_optimum_is_marked() -> None:
    trials = [
        _trial(algorithm="grape-s", optimum_status="time_limit", percent_optimum=101.0),
        _trial(algorithm="sda"),
    ]
    _, rows = cell_table(trials, "percent_optimum")
    assert rows[0][4].endswith("†") and not rows[0][5].endswith("†")


# --------------------------------------------------------------------- statistics
def test_kruskal_and_mannwhitney_match_scipy() -> None:
    rng = np.random.default_rng(3)
    data = {n: rng.normal(90 + n / 100, 3, size=7).round(2) for n in (100, 500, 1000)}
    trials = [
        _trial(robots=n, percent_tasks=p, mission_seed=i, percent_optimum=float(v))
        for n, values in data.items()
        for i, v in enumerate(values)
        for p in (10.0,)
    ]
    trials += [  # 1 % tasks only for n > 100, as in the seed: excluded from the size test
        _trial(robots=n, percent_tasks=1.0, mission_seed=i, percent_optimum=50.0 + i)
        for n in (500, 1000)
        for i in range(7)
    ]
    results = [r for r in statistics(trials) if r.metric == "percent_optimum"]
    size = next(r for r in results if r.factor == "robots")
    h, p = stats.kruskal(*(data[n] for n in (100, 500, 1000)))
    assert size.test == "Kruskal-Wallis" and size.groups == ("100", "500", "1000")
    assert (size.statistic, size.p_value) == (pytest.approx(h), pytest.approx(p))
    assert size.subset == "load 1, percent tasks 10" and size.n == 21
    _, p_post = stats.mannwhitneyu(data[100], data[1000], alternative="two-sided")
    assert dict(((a, b), q) for a, b, q in size.posthoc)[("100", "1000")] == pytest.approx(p_post)
    tasks = next(r for r in results if r.factor == "percent_tasks")
    assert tasks.test == "Mann-Whitney-Wilcoxon" and tasks.subset == "load 1, robots 500, 1000"
    low = [t.percent_optimum for t in trials if t.robots > 100 and t.percent_tasks == 1]
    high = [t.percent_optimum for t in trials if t.robots > 100 and t.percent_tasks == 10]
    u, p = stats.mannwhitneyu(low, high, alternative="two-sided")
    assert (tasks.statistic, tasks.p_value) == (pytest.approx(u), pytest.approx(p))


def test_kruskal_known_value() -> None:
    # by hand: ranks 1-3, 4-6, 7-9; H = 12/(9*10) * (6^2 + 15^2 + 24^2)/3 - 3*10 = 7.2,
    # p = chi2(2).sf(7.2) = exp(-3.6)
    trials = [
        _trial(robots=n, percent_optimum=float(v), mission_seed=v)
        for n, values in ((100, (1, 2, 3)), (500, (4, 5, 6)), (1000, (7, 8, 9)))
        for v in values
    ]
    r = next(
        r for r in statistics(trials) if r.factor == "robots" and r.metric == "percent_optimum"
    )
    assert r.test == "Kruskal-Wallis"
    assert r.statistic == pytest.approx(7.2)
    assert r.p_value == pytest.approx(np.exp(-3.6))


def test_friedman_and_conover_match_scipy_and_scikit_posthocs() -> None:
    rng = np.random.default_rng(7)
    matrix = rng.normal([95.0, 97.0, 99.0], 1.5, size=(9, 3)).round(2)
    names = ("grape-s", "rachna-dt", "sda")  # the report orders heuristics by name
    trials = [
        _trial(algorithm=a, mission_seed=i, percent_optimum=float(matrix[i, j]))
        for i in range(9)
        for j, a in enumerate(names)
    ]
    friedman = [
        r for r in statistics(trials) if r.test == "Friedman" and r.metric == "percent_optimum"
    ]
    assert len(friedman) == 1
    r = friedman[0]
    chi2, p = stats.friedmanchisquare(*matrix.T)
    assert (r.statistic, r.p_value, r.n) == (pytest.approx(chi2), pytest.approx(p), 9)
    conover = scikit_posthocs.posthoc_conover_friedman(matrix).to_numpy()
    got = {(a, b): q for a, b, q in r.posthoc}
    assert got[("grape-s", "sda")] == pytest.approx(conover[0, 2])
    assert got[("grape-s", "rachna-dt")] == pytest.approx(conover[0, 1])


def test_no_variation_is_said_not_tested() -> None:
    trials = [
        _trial(robots=n, algorithm=a, mission_seed=i)
        for n in (100, 500)
        for a in ("grape-s", "sda", "rachna-dt")
        for i in range(3)
    ]
    results = [r for r in statistics(trials) if r.metric == "percent_optimum"]
    assert results and all(r.statistic is None and "no variation" in r.note for r in results)


# -------------------------------------------------------------------------- files
def test_report_files(written) -> None:
    trials, version, report = written
    out = report.directory
    names = {p.name for p in report.files}
    assert {"report.md", "report.html", "trials.csv", "summary.csv", "statistics.csv"} <= names
    pngs = sorted(out.glob("*.png"))
    assert len(pngs) == 9  # the headline, then 4 metrics (percent, seconds, work, MB) x 2 loads
    assert (out / "fig_headline_percent_optimum.png") in pngs
    assert (out / "fig_work_load1.png") in pngs  # machine-independent runtime beside wall time
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)
    markdown = (out / "report.md").read_text(encoding="utf-8")
    assert "| load | S:k | % tasks | robots | grape-s | pair-grape-s | sda |" in markdown
    assert version in markdown
    assert "Mann-Whitney-Wilcoxon" in markdown and "Friedman" in markdown
    for png in pngs:
        assert f"]({png.name})" in markdown
    page = (out / "report.html").read_text(encoding="utf-8")
    assert page.count("data:image/png;base64,") == 9
    assert 'src="http' not in page and "<table>" in page
    with (out / "trials.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == len(trials)
    assert {r["algorithm"] for r in rows} == {EXACT, "grape-s", "pair-grape-s", "sda"}
    assert report.gap_report["trials"] == len(trials)
    json.dumps(report.gap_report)  # JSON-ready


def test_report_refuses_to_overwrite(written, tmp_path: Path) -> None:
    trials, _, report = written
    out = tmp_path / "report"
    shutil.copytree(report.directory, out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    mine = out / "notes.txt"
    mine.write_text("my notes", encoding="utf-8")
    with pytest.raises(MissionError, match="already holds a report"):
        write_report(trials, out)
    assert {p.name: p.read_bytes() for p in out.iterdir() if p != mine} == before
    write_report(trials, out, force=True)
    assert mine.read_text(encoding="utf-8") == "my notes"  # not ours: never touched


def test_cli_report(store: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r"
    assert main(["report", str(store), "-o", str(out), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["trials"] == 3 * 3 * 4 and data["report_directory"] == str(out)
    assert data["summary"][0]["algorithm"] == EXACT
    assert main(["report", str(store), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "--force" in err and err.count("\n") == 1
    assert main(["report", str(tmp_path / "missing.sqlite"), "-o", str(tmp_path / "x")]) == 2
    assert "no such result store" in capsys.readouterr().err


def test_report_of_an_empty_store(tmp_path: Path) -> None:
    ResultStore(tmp_path / "empty.sqlite").close()
    with pytest.raises(MissionError, match="holds no trials"):
        load_trials(tmp_path / "empty.sqlite")


def test_trial_is_frozen() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        _trial().utility = 3.0  # type: ignore[misc]
