"""``cfopt reproduce``: every published figure beside cfopt's, from fixture stores whose
values are chosen so that each verdict is known in advance -- among them each verdict the
first reading of the paper got wrong -- and the command end to end on a tiny grid."""

from __future__ import annotations

import csv
import json
from collections.abc import Callable

import pytest

import cfopt.reproduce as reproduce
from cfopt import GridCell
from cfopt.cli import main
from cfopt.experiments import ResultStore, Sweep, Trial, distributed_grid
from cfopt.generate import SEED_NETWORK, paper_grid
from cfopt.paper import DISAGREEMENTS, FIGURES, figures
from cfopt.reproduce import (
    AGREE,
    DIFFER,
    INCONCLUSIVE,
    NO_TRIALS,
    NOT_COMPARABLE,
    PAPER_DISAGREES,
    Verdict,
    compare_figures,
    iteration_table,
    pairwise_table,
    paper_layout_table,
    paper_tests_table,
    runtime_table,
    sample_sizes,
    verdict_tally,
    write_reproduction,
)

SPEED = {"rachna-dt": 0.01, "grape-s": 0.02, "pair-grape-s": 0.03, "sda": 0.5}
Override = Callable[[GridCell, int, str], dict]


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


def _dip(cell: GridCell, i: int, algorithm: str) -> dict:
    """GRAPE-S at 91 % on mission 0 of the centralized 10:5, 100-robot, 10 % cell."""
    where = (cell.robots, cell.percent_tasks, cell.service_types, cell.services_per_robot)
    if algorithm == "grape-s" and i == 0 and cell.network is None and where == (100, 10, 10, 5):
        return {"percent_optimum": 91.0, "utility": 91.0}
    return {}


def _trials(override: Override = _dip, missions: int = 2) -> list[Trial]:
    """``missions`` per cell of both grids, everything optimal but what ``override`` says."""
    out = []
    for cells, algorithms in (
        (paper_grid(), reproduce.CENTRALIZED_ALGORITHMS),
        (distributed_grid(), reproduce.DISTRIBUTED_ALGORITHMS),
    ):
        for cell in cells:
            for i in range(missions):
                for algorithm in ("exact", *algorithms):
                    out.append(_trial(cell, i, algorithm, **override(cell, i, algorithm)))
    return out


@pytest.fixture(scope="module")
def fixture_trials(tmp_path_factory: pytest.TempPathFactory) -> list[Trial]:
    """The trials, through a real result store (written and read back)."""
    path = tmp_path_factory.mktemp("store") / "trials.sqlite"
    with ResultStore(path) as store:
        for t in _trials():
            store.add(t)
    with ResultStore(path, create=False) as store:
        return store.trials("v")


@pytest.fixture(scope="module")
def comparisons(fixture_trials: list[Trial]):
    return compare_figures(fixture_trials)


def _one(comparisons, kind: str = "figure", **where):
    wanted = figures(**where)
    assert len(wanted) == 1, wanted
    (c,) = [c for c in comparisons if c.figure == wanted[0] and c.kind == kind]
    return c


def _friedman(comparisons, measure: str, ten_five: bool):
    comp = ((10, 5),) if ten_five else None
    return _one(comparisons, measure=measure, test="friedman", evaluation="centralized",
                compositions=comp)  # fmt: skip


# --------------------------------------------------------------------- every figure
def test_every_figure_gets_a_verdict_and_states_both_sides(comparisons) -> None:
    results = [c for c in FIGURES if not c.sample_size]
    assert len([c for c in comparisons if c.kind == "figure"]) == len(results)
    assert {c.verdict for c in comparisons} <= set(Verdict)
    assert not [c.figure for c in comparisons if c.verdict is NO_TRIALS]
    for c in comparisons:
        assert c.paper and c.against and c.tolerance and c.reason, c
        if c.kind == "figure":
            assert c.against.startswith("cfopt: "), c


def test_sample_sizes_are_the_header_not_figures(fixture_trials, comparisons) -> None:
    assert not [c for c in comparisons if c.figure.measure == "trials"]
    lines = sample_sizes(fixture_trials)
    assert lines[0].startswith("centralized (§5): 2 missions per cell, grape-s 64 trials")
    assert "(the paper: 25 missions per cell, 800 per algorithm" in lines[0]
    assert "125 pair-grape-s (10:5)" in lines[1]
    one = sample_sizes(_trials(missions=1)[:10])
    assert one[0].startswith("centralized (§5): 1 mission per cell")


def test_tally_plurals() -> None:
    assert verdict_tally({"agree": 1, "differ": 86}) == "1 agrees, 86 differ"
    text = verdict_tally({"inconclusive": 1, "not comparable": 2, "no trials": 1})
    assert text == "2 are not comparable, 1 has no trials, 1 is inconclusive"


# ------------------------------------------------- the verdicts that used to be wrong
def test_friedman_agrees_only_with_the_papers_direction() -> None:
    """Utility (both scopes): the paper has GRAPE-S significantly lowest.  A store where
    SDA ranks lowest differs although both tests are significant; one where GRAPE-S does
    agrees."""

    def sda_lowest(cell, i, algorithm):
        return {"percent_optimum": 95.0, "utility": 95.0} if algorithm == "sda" else {}

    def grape_lowest(cell, i, algorithm):
        return {"percent_optimum": 95.0, "utility": 95.0} if algorithm == "grape-s" else {}

    for scope in (True, False):
        found = compare_figures(_trials(sda_lowest))
        c = _friedman(found, "percent_utility", scope)
        assert c.verdict is DIFFER and "direction reversed: lowest sda" in c.reason
        assert "lowest: grape-s" in c.paper and "lowest: sda" in c.against
        # a post-hoc pair: its own p, after the Friedman test it follows
        pair = _one(found, measure="percent_utility", test="conover", pair=("grape-s", "sda"),
                    compositions=((10, 5),) if scope else None)  # fmt: skip
        assert pair.against.startswith("cfopt: Conover grape-s/sda (after Friedman ")
        assert pair.verdict is DIFFER and "lowest: sda" in pair.against
        c = _friedman(compare_figures(_trials(grape_lowest)), "percent_utility", scope)
        assert c.verdict is AGREE and "same direction" in c.reason


def test_friedman_on_communication_wants_sda_least(comparisons) -> None:
    # the fixture's RACHNA_dt and SDA send the same; make RACHNA_dt the least
    def rachna_least(cell, i, algorithm):
        return {"bytes": 1000} if algorithm == "rachna-dt" else {}

    c = _friedman(compare_figures(_trials(rachna_least)), "communication_mb", True)
    assert c.verdict is DIFFER and "lowest rachna-dt, the paper sda" in c.reason

    def sda_least(cell, i, algorithm):
        return {"bytes": 1000} if algorithm == "sda" else {}

    assert _friedman(compare_figures(_trials(sda_least)), "communication_mb", True).verdict is AGREE


def test_a_curve_agrees_in_level_and_in_shape_separately(comparisons) -> None:
    """The fixture's GRAPE-S sends n (n + 1) beliefs of 16 + 4 n bytes: 4.2, 505 and
    4,020 MB at 100, 500 and 1000 robots, against the paper's 30, 750 and 3,000 MB.  The
    levels at 500 and 1000 agree (within a factor 2), the shape (slope 2.98 against the
    paper's 2.00) does not: two verdicts, two lines."""
    level = {n: _one(comparisons, curve=figures(robots=(n,), statistic="every trial")[0].curve,
                     robots=(n,)) for n in (100, 500, 1000)}  # fmt: skip
    assert [level[n].verdict for n in (100, 500, 1000)] == [DIFFER, AGREE, AGREE]
    assert "cfopt/paper = 0.673" in level[500].reason and "level at this size" in level[500].against
    (shape,) = [c for c in comparisons if c.kind == "shape"]
    assert shape.verdict is DIFFER and shape.figure.value == 2.0
    assert "slope 2.98" in shape.against and "95 % interval" in shape.against
    # the paper's own "consistent with O(n^3)" agrees with cfopt's n^3 ...
    exponent = _one(comparisons, statistic="growth exponent")
    assert exponent.verdict is AGREE
    # ... and disagrees with the paper's own figures
    (own,) = [c for c in comparisons if c.kind == "disagreement" and c.figure == exponent.figure]
    assert own.verdict is PAPER_DISAGREES and "grow as n^2" in own.reason


def test_a_worst_case_is_compared_with_the_maximum() -> None:
    """'GRAPE-S 10:5 worst case > 10,000 MB': one 10:5 mission sends 15 GB; the median
    stays at the fixture's level, the maximum clears the bound."""

    def one_heavy(cell, i, algorithm):
        heavy = algorithm == "grape-s" and cell.network is None and cell.robots == 1000
        heavy = heavy and (cell.service_types, cell.services_per_robot) == (10, 5) and i == 0
        return {"bytes": 15_000 * 10**6} if heavy and cell.percent_tasks == 50 else {}

    c = _one(compare_figures(_trials(one_heavy)), statistic="max", value=10000.0)
    assert c.verdict is AGREE and c.value == 15000.0
    assert c.against.startswith("cfopt: max 15,000 MB over 16 trials")


def test_simulated_seconds_are_not_compared_with_wall_time(comparisons) -> None:
    distributed = [c for c in comparisons if c.figure.evaluation == "distributed"
                   and c.figure.measure == "runtime_s" and c.kind == "figure"]  # fmt: skip
    assert distributed and {c.verdict for c in distributed} == {NOT_COMPARABLE}
    c = _one(comparisons, evaluation="distributed", statistic="count", threshold=(0.0, 180.0))
    assert c.value == 40 and c.paper.startswith("count 496 ")  # the paper's 496, not all 500
    assert c.against == "cfopt: 40 of 40 trials took under 180 simulated seconds"
    assert "'<3 min' is said of 496 of them, not of all 500" in c.reason
    longest = _one(comparisons, evaluation="distributed", statistic="count", value=1.0)
    assert longest.against.endswith("took at least 240 simulated seconds")
    centralized = _one(comparisons, algorithm="grape-s", statistic="max", value=735.0,
                       compositions=None)  # fmt: skip
    assert centralized.verdict is NOT_COMPARABLE and "counted work" in centralized.reason


def test_a_bound_agrees_only_within_its_tolerance() -> None:
    """'SDA < 500 MB' with cfopt's auction ~100x below: on the bound's side, not within a
    factor 2 of it -- the comparison shows both numbers and the ratio."""

    def quiet_sda(cell, i, algorithm):
        return {"bytes": 4_500_000 + 100_000 * i} if algorithm == "sda" else {}

    c = _one(compare_figures(_trials(quiet_sda)), evaluation="centralized", algorithm="sda",
             statistic="max", value=500.0)  # fmt: skip
    assert c.verdict is DIFFER and c.value == 4.6
    assert "cfopt/paper = 0.0092" in c.reason and "within a factor 2" in c.tolerance
    assert "max < 500 MB" in c.paper


def test_tables_carry_the_papers_numbers(comparisons) -> None:
    assert not paper_layout_table(comparisons, "Table 3")[1]  # the paper's grid, no figures
    header, rows = paper_layout_table(comparisons, "Table 2")
    assert header[:3] == ["composition", "% tasks", "robots"] and len(rows) == 6
    assert rows[0][:6] == ["10:5", "10", "100", "100.00 / 95.50", "89.68 / 91.00",
                           "100.00 / 100.00"]  # fmt: skip
    assert len(paper_layout_table(comparisons, "Table 4")[1]) == 4  # GRAPE-S, distributed
    assert len(paper_layout_table(comparisons, "Table 5")[1]) == 20  # SDA, distributed


# ------------------------------------------------------------- small samples, counts
def test_utility_extremes_and_medians(comparisons) -> None:
    table2 = dict(table="Table 2", compositions=((10, 5),), percent_tasks=(10.0,))
    low = _one(comparisons, robots=(100,), statistic="min", **table2)
    assert (low.value, low.verdict) == (91.0, AGREE)  # 89.68 vs 91: within 5 points
    median = _one(comparisons, robots=(100,), statistic="median", **table2)
    assert (median.value, median.verdict) == (95.5, INCONCLUSIVE)  # median of 91 and 100
    assert median.verdict_text == "inconclusive: n = 2" and "-4.50 points" in median.reason
    assert median.tolerance == "within 1 percentage point"
    assert low.tolerance == "within 5 percentage points"
    clean = _one(comparisons, robots=(500,), statistic="min", **table2)
    assert clean.verdict is AGREE  # 100 against 98.47: within 5 points
    overall = _one(comparisons, statistic="min", value=89.68, table="text")
    assert overall.verdict is AGREE  # cfopt's 91 over all cells
    # the 96.07 % figure: the next lowest of that cell
    assert _one(comparisons, statistic="second lowest", evaluation="centralized").value == 100.0


def test_a_test_without_power_is_inconclusive() -> None:
    """Mann-Whitney-Wilcoxon between two groups of 2 cannot reach p < 0.05 (2/C(4,2) =
    0.33): inconclusive: n = 4, however the values fall."""
    only = figures(evaluation="centralized", algorithm="pair-grape-s", test="mann-whitney",
                   factor="robots", pair=("100", "500"), measure="runtime_s")  # fmt: skip
    trials = [t for t in _trials(missions=1) if t.robots != 1000]
    (c,) = compare_figures(trials, only)
    assert c.verdict is INCONCLUSIVE and c.verdict_text == "inconclusive: n = 4"
    assert "no power" in c.reason


def test_counts_iterations_and_proportions(comparisons) -> None:
    iterations = _one(comparisons, measure="iterations")
    assert (iterations.value, iterations.verdict) == (1.0, AGREE)
    # the pairwise step ran on mission 0 of each 10:5 cell: 8 of 16 against 111 of 200
    ran = _one(comparisons, evaluation="centralized", measure="pairwise_step_ran")
    assert (ran.value, ran.trials, ran.verdict) == (8, 16, AGREE)
    assert "111 of 200" in ran.paper and "8 of 16" in ran.against
    solved = _one(comparisons, evaluation="centralized", measure="solved_trials", algorithm="all")
    assert solved.verdict is AGREE and "grape-s 64 of 64" in solved.against
    cut = _one(comparisons, measure="cut_trials")
    assert cut.verdict is NOT_COMPARABLE and "one-hour" in cut.reason


def test_statistical_tests_with_the_papers_sets(fixture_trials, comparisons) -> None:
    # GRAPE-S's centralized runtime grows with the collective size in the fixture, too
    size = _one(comparisons, evaluation="centralized", algorithm="grape-s", test="kruskal",
                measure="runtime_s", factor="robots")  # fmt: skip
    assert size.verdict is AGREE and "increases" in size.against
    # which algorithm is fastest depends on the implementations
    runtime = _friedman(comparisons, "runtime_s", True)
    assert runtime.verdict is NOT_COMPARABLE and "implemented" in runtime.reason
    assert "lowest: rachna-dt" in runtime.against and "lowest: pair-grape-s" in runtime.paper
    header, rows = paper_tests_table(comparisons)
    assert header[-2:] == ["verdict", "why"] and len(rows) == len([f for f in FIGURES if f.test])


def test_a_trend_against_the_papers_is_a_difference() -> None:
    """GRAPE-S's centralized runtime falls with the percent tasks here; the paper's rises
    (H = 271.95): both significant, the direction reversed."""

    def falling(cell, i, algorithm):
        if algorithm != "grape-s" or cell.network is not None:
            return {}
        return {"seconds": (1 + i / 100) / cell.percent_tasks}

    only = figures(evaluation="centralized", algorithm="grape-s", test="kruskal",
                   measure="runtime_s", factor="percent_tasks")  # fmt: skip
    (c,) = compare_figures(_trials(falling), only)
    assert c.verdict is DIFFER and "decreases" in c.against
    assert (
        c.reason
        == "both significant, but with percent tasks cfopt: decreases; the paper: increases"
    )


def test_the_paper_disagrees_with_itself(comparisons) -> None:
    own = [c for c in comparisons if c.kind == "disagreement"]
    assert len(own) == len(DISAGREEMENTS) == 3
    assert {c.verdict for c in own} == {PAPER_DISAGREES}
    eight = next(c for c in own if "8 min 17 s" in c.paper)
    assert "<= 8 min 12 s" in eight.against and "497 s" in eight.reason


def test_other_tables(fixture_trials) -> None:
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
    assert "## The paper's Table 4: GRAPE-S percent utility, distributed" in text
    assert "## The paper's Table 5: SDA percent utility, distributed" in text
    assert "## The paper disagrees with itself" in text
    assert "Sample: centralized (§5): 2 missions per cell" in text
    assert "differ, " in text and "figures differs" not in text
    with (out / "reproduction.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == len(comparisons) and {"paper", "against", "tolerance"} <= set(rows[0])
    assert "inconclusive: n = 2" in {r["verdict"] for r in rows}
    before = (out / "reproduction.md").read_bytes()
    with pytest.raises(reproduce.MissionError, match=r"reproduction\.md"):
        write_reproduction(fixture_trials, comparisons, out, missions=2)
    assert (out / "reproduction.md").read_bytes() == before
    write_reproduction(fixture_trials, comparisons, out, missions=1, force=True)
    assert "1 mission per cell" in (out / "reproduction.md").read_text(encoding="utf-8")


# ----------------------------------------------------------------------- end to end
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
    assert "1 mission per cell" in printed and "comparisons with the paper:" in printed
    assert "reproduction.md" in printed
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
    assert sum(data["verdicts"].values()) == len(data["comparisons"])
    assert data["sample"][0].startswith("centralized (§5): 1 mission per cell")
