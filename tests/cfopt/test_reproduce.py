"""``cfopt reproduce``: every published figure beside cfopt's, from a fixture store whose
values are chosen so that each verdict is known in advance; the command end to end on a
tiny grid."""

from __future__ import annotations

import csv
import json

import pytest

import cfopt.reproduce as reproduce
from cfopt import GridCell
from cfopt.cli import main
from cfopt.experiments import ResultStore, Sweep, Trial, distributed_grid
from cfopt.generate import SEED_NETWORK, paper_grid
from cfopt.paper import figures
from cfopt.reproduce import (
    AGREE,
    DIFFERS,
    NO_TRIALS,
    NOT_COMPARABLE,
    compare_figures,
    iteration_table,
    pairwise_table,
    paper_layout_table,
    paper_tests_table,
    runtime_table,
    write_reproduction,
)

SPEED = {"rachna-dt": 0.01, "grape-s": 0.02, "pair-grape-s": 0.03, "sda": 0.5}


def _trial(cell: GridCell, i: int, algorithm: str, **values) -> Trial:
    n = cell.robots
    ten_five = (cell.service_types, cell.services_per_robot) == (10, 5)
    base = dict(
        cell=cell.label, robots=n, percent_tasks=float(cell.percent_tasks),
        service_types=cell.service_types, services_per_robot=cell.services_per_robot,
        load=1.0, mission_index=i, base_seed=0, mission_seed=cell.mission_seed(i), tasks=10,
        total_utility=100.0, algorithm=algorithm, code_version="v", utility=100.0,
        optimum=100.0, optimum_bound=100.0, optimum_status="optimal", percent_optimum=100.0,
        percent_total=100.0, iterations=n + 3 if ten_five else n, rounds=n + 1,
        messages=n * (n + 1), bytes=n * (n + 1) * (16 + 4 * n), work=10 * n,
        seconds=SPEED.get(algorithm, 1.0) * (1 + i / 10) * n / 100, nash_stable=True,
        nash_stable_capped=True, pairwise_stable=True, pairwise_stable_capped=True,
        pareto_stable=True, pairwise_step_ran=None, algorithm_seed=0, finished=0.0,
    )  # fmt: skip
    if algorithm == "pair-grape-s":
        base["pairwise_step_ran"] = ten_five and i == 0
    if cell.network is not None:
        base.update(network=cell.network, sim_seconds=0.5 * n / 100, converged=True,
                    beliefs_agree=True, cut=False, transmissions=n, receptions=n,
                    losses=0)  # fmt: skip
    base.update(values)
    return Trial(**base)


def _fixture_trials() -> list[Trial]:
    """Two missions per cell of both grids.  Everything optimal except GRAPE-S on mission 0
    of the centralized 10:5, 100-robot, 10 % cell (91 %)."""
    trials = []
    for cell in paper_grid():
        for i in range(2):
            for algorithm in ("exact", *reproduce.CENTRALIZED_ALGORITHMS):
                dip = (
                    algorithm == "grape-s" and i == 0
                    and (cell.robots, cell.percent_tasks, cell.service_types) == (100, 10, 10)
                    and cell.services_per_robot == 5
                )  # fmt: skip
                extra = {"percent_optimum": 91.0, "utility": 91.0} if dip else {}
                trials.append(_trial(cell, i, algorithm, **extra))
    for cell in distributed_grid():
        for i in range(2):
            for algorithm in ("exact", *reproduce.DISTRIBUTED_ALGORITHMS):
                trials.append(_trial(cell, i, algorithm))
    return trials


@pytest.fixture(scope="module")
def fixture_trials(tmp_path_factory: pytest.TempPathFactory) -> list[Trial]:
    """The trials, through a real result store (written and read back)."""
    path = tmp_path_factory.mktemp("store") / "trials.sqlite"
    with ResultStore(path) as store:
        for t in _fixture_trials():
            store.add(t)
    with ResultStore(path, create=False) as store:
        return store.trials("v")


@pytest.fixture(scope="module")
def comparisons(fixture_trials: list[Trial]):
    return compare_figures(fixture_trials)


def _verdict(comparisons, **where):
    wanted = figures(**where)
    assert len(wanted) == 1, wanted
    (c,) = [c for c in comparisons if c.figure == wanted[0]]
    return c


def test_every_figure_gets_a_verdict(comparisons) -> None:
    assert len(comparisons) == len(reproduce.FIGURES)
    assert {c.verdict for c in comparisons} <= {AGREE, DIFFERS, NOT_COMPARABLE, NO_TRIALS}
    # both grids are in the store: every figure has trials
    assert not [c.figure for c in comparisons if c.verdict == NO_TRIALS]


def test_utility_extremes_and_medians(comparisons) -> None:
    table2 = dict(table="Table 2", service_types=10, percent_tasks=10.0)
    low = _verdict(comparisons, robots=100, statistic="min", **table2)
    assert (low.value, low.verdict) == (91.0, AGREE)  # 89.68 vs 91: within 5 points
    median = _verdict(comparisons, robots=100, statistic="median", **table2)
    assert (median.value, median.verdict) == (95.5, DIFFERS)  # median of 91 and 100
    assert "-4.50 points" in median.reason
    clean = _verdict(comparisons, robots=500, statistic="min", **table2)
    assert clean.verdict == DIFFERS and "no cfopt trial below the optimum among 2" in clean.reason


def test_counts_iterations_and_proportions(comparisons) -> None:
    trials = _verdict(comparisons, evaluation="centralized", measure="trials", algorithm="all")
    assert (trials.value, trials.verdict) == (64, DIFFERS)
    assert "2 missions in each of 32 cells" in trials.reason
    iterations = _verdict(comparisons, measure="iterations")
    assert (iterations.value, iterations.verdict) == (1.0, AGREE)
    # the pairwise step ran on mission 0 of each 10:5 cell: 8 of 16 against 111 of 200
    ran = _verdict(comparisons, evaluation="centralized", measure="pairwise_step_ran")
    assert (ran.value, ran.trials, ran.verdict) == (8, 16, AGREE)
    assert "paper: 111 of 200" in ran.reason


def test_runtime_is_not_compared_across_machines(comparisons) -> None:
    c = _verdict(comparisons, evaluation="centralized", measure="runtime_s", algorithm="grape-s",
                 statistic="max")  # fmt: skip
    assert c.verdict == NOT_COMPARABLE and "counted work" in c.reason
    sim = _verdict(comparisons, evaluation="distributed", measure="runtime_s",
                   algorithm="grape-s", statistic="upper bound")  # fmt: skip
    assert sim.value == 2.5 and sim.verdict == AGREE  # simulated seconds below the 180 s bound


def test_communication_volume_within_a_factor(comparisons) -> None:
    # GRAPE-S at 100 robots in the fixture: 100 * 101 * 416 bytes = 4.2 MB, the seed 30 MB
    c = _verdict(comparisons, measure="communication_mb", robots=100, service_types=5,
                 services_per_robot=1)  # fmt: skip
    assert c.value == pytest.approx(4.2016) and c.verdict == DIFFERS
    assert "cfopt/paper = 0.14" in c.reason


def test_statistical_tests_with_the_papers_sets(fixture_trials, comparisons) -> None:
    friedman = _verdict(comparisons, measure="friedman_chi2_runtime", service_types=10)
    assert friedman.verdict == AGREE and friedman.trials == 16
    assert "lowest first: rachna-dt 1.00, grape-s 2.00, pair-grape-s 3.00, sda 4.00" in (
        friedman.reason
    )
    overall = _verdict(comparisons, measure="friedman_chi2_runtime", service_types=None)
    assert overall.trials == 64 and "pair-grape-s" not in overall.reason  # the paper's three
    utility = _verdict(comparisons, measure="friedman_chi2_utility", service_types=None)
    assert utility.verdict == DIFFERS and "not the paper's conclusion" in utility.reason
    header, rows = paper_tests_table(fixture_trials, comparisons)
    assert len(rows) == 10 and header[-1] == "conclusion"
    sizes = next(r for r in rows if r[2] == "grape-s by robots" and "runtime" in r[1])
    assert sizes[-2].startswith("increases with the level")


def test_tables_in_the_papers_layout(fixture_trials, comparisons) -> None:
    header, rows = paper_layout_table(comparisons, "Table 2")
    assert header[:3] == ["composition", "% tasks", "robots"] and len(rows) == 6
    assert rows[0] == ["10:5", "10", "100", "100.00 / 95.50", "89.68 / 91.00",
                       "100.00 / 100.00", "median differ"]  # fmt: skip
    assert len(paper_layout_table(comparisons, "Table 4")[1]) == 20
    _, iterations = iteration_table(fixture_trials)
    row = next(r for r in iterations if r[:4] == ["centralized", "grape-s", "10:5", "100"])
    assert row[4:] == ["4", "0", "1.03", "1.03"]
    _, pairwise = pairwise_table(fixture_trials)
    assert ["centralized", "10:5", "8", "16", "50.0 %", "111 of 200 (55.5 %)"] in pairwise
    _, runtime = runtime_table(fixture_trials)
    grape = next(r for r in runtime if r[:3] == ["distributed", "grape-s", "500"])
    assert grape[3] == "24" and grape[-2:] == ["24/24", "24/24"]  # 12 cells, 2 missions


def test_write_reproduction_refuses_to_overwrite(fixture_trials, comparisons, tmp_path) -> None:
    out = tmp_path / "rep"
    files = write_reproduction(fixture_trials, comparisons, out, missions=2)
    assert [p.name for p in files] == list(reproduce.REPRODUCTION_FILES)
    text = (out / "reproduction.md").read_text(encoding="utf-8")
    assert "## The paper's Table 2" in text and "Communication models" not in text
    with (out / "reproduction.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == len(comparisons) and rows[0]["verdict"] in (AGREE, DIFFERS)
    before = (out / "reproduction.md").read_bytes()
    with pytest.raises(reproduce.MissionError, match=r"reproduction\.md"):
        write_reproduction(fixture_trials, comparisons, out, missions=2)
    assert (out / "reproduction.md").read_bytes() == before
    write_reproduction(fixture_trials, comparisons, out, missions=3, force=True)
    assert "3 missions per cell" in (out / "reproduction.md").read_text(encoding="utf-8")


TINY = (GridCell(100, 10, 10, 5), GridCell(100, 50, 5, 1))


def _tiny_sweeps(missions: int = 1, base_seed: int = 0, distributed: bool = True):
    sweeps = [Sweep(TINY, missions, reproduce.CENTRALIZED_ALGORITHMS, base_seed)]
    if distributed:
        cell = GridCell(100, 50, 5, 1, network=SEED_NETWORK)
        sweeps.append(Sweep((cell,), missions, reproduce.DISTRIBUTED_ALGORITHMS, base_seed))
    return sweeps


def test_the_command_end_to_end(monkeypatch, tmp_path, capsys) -> None:
    monkeypatch.setattr(reproduce, "reproduction_sweeps", _tiny_sweeps)
    out = tmp_path / "rep"
    argv = ["reproduce", "--missions", "1", "--workers", "1", "--quiet", "-o", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "published figures:" in printed and "reproduction.md" in printed
    assert (out / "report.md").exists() and (out / "trials.sqlite").exists()
    # run again: refused before any work, nothing replaced
    before = (out / "reproduction.md").read_bytes()
    assert main(argv) == 2
    assert "reproduction.md" in capsys.readouterr().err
    assert (out / "reproduction.md").read_bytes() == before
    # with --force: every trial comes from the store
    assert main([*argv, "--force", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["trials_computed"] == 0 and data["trials_reused"] == 2 * 5 + 1 * 4
    assert sum(data["verdicts"].values()) == len(reproduce.FIGURES)
