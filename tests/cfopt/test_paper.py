"""The seed paper's figures as data: transcribed once, checked here for shape."""

from __future__ import annotations

import re
from collections import Counter

import pytest

from cfopt.experiments import distributed_grid
from cfopt.generate import paper_grid
from cfopt.paper import FIGURES, figures

MEASURES = {
    "percent_utility", "runtime_s", "communication_mb", "trials", "iterations",
    "pairwise_step_ran", "optimal_trials", "friedman_chi2_runtime",
    "friedman_chi2_communication", "friedman_chi2_utility", "kruskal_h_runtime_robots",
    "kruskal_h_runtime_percent_tasks", "kruskal_h_communication_robots",
    "kruskal_h_utility_percent_tasks",
}  # fmt: skip
STATISTICS = {"median", "min", "max", "upper bound", "lower bound", "count", "value"}


def test_every_figure_is_well_formed() -> None:
    for f in FIGURES:
        assert f.evaluation in ("centralized", "distributed"), f
        assert f.section.startswith("§") and f.quote, f
        assert f.measure in MEASURES and f.statistic in STATISTICS, f
        assert f.value >= 0, f
        assert (f.service_types is None) == (f.services_per_robot is None), f


def test_every_figure_covers_cells_of_its_grid() -> None:
    grids = {"centralized": paper_grid(), "distributed": distributed_grid()}
    for f in FIGURES:
        covered = [
            c
            for c in grids[f.evaluation]
            if f.robots in (None, c.robots)
            and f.percent_tasks in (None, c.percent_tasks)
            and f.service_types in (None, c.service_types)
            and f.services_per_robot in (None, c.services_per_robot)
        ]
        assert covered, f


@pytest.mark.parametrize(
    ("table", "evaluation", "rows"), [("Table 2", "centralized", 6), ("Table 3", "distributed", 4),
                                      ("Table 4", "distributed", 20)]
)  # fmt: skip
def test_utility_tables_have_the_papers_layout(table: str, evaluation: str, rows: int) -> None:
    entries = figures(table=table)
    assert {f.evaluation for f in entries} == {evaluation}
    by_row = Counter((f.service_types, f.services_per_robot, f.percent_tasks, f.robots)
                     for f in entries)  # fmt: skip
    assert len(by_row) == rows and set(by_row.values()) == {3}
    for key in by_row:
        stats = {
            f.statistic: f.value
            for f in entries
            if (f.service_types, f.services_per_robot, f.percent_tasks, f.robots) == key
        }
        assert set(stats) == {"median", "min", "max"}
        assert 0 <= stats["min"] <= stats["median"] <= stats["max"] <= 100, key


def test_table_values_as_printed_in_the_paper() -> None:
    # spot checks, one per table, against the paper's printed rows
    def row(table, s, k, p, n):
        got = {f.statistic: f.value for f in figures(table=table, service_types=s,
               services_per_robot=k, percent_tasks=p, robots=n)}  # fmt: skip
        return got["median"], got["min"], got["max"]

    assert row("Table 2", 10, 5, 10.0, 100) == (100.0, 89.68, 100.0)
    assert row("Table 3", 10, 5, 10.0, 500) == (100.0, 96.7, 100.0)
    assert row("Table 4", 5, 1, 50.0, 500) == (3.9, 1.6, 8.2)
    assert row("Table 4", 10, 5, 50.0, 500) == (4.5, 2.4, 27.4)


def test_test_statistics_are_quoted_with_their_value() -> None:
    for f in FIGURES:
        if f.measure.startswith(("friedman", "kruskal")):
            printed = {float(x.replace(",", "")) for x in re.findall(r"\d[\d,]*\.\d+", f.quote)}
            assert f.value in printed, f


def test_communication_figures_cover_three_sizes() -> None:
    values = {
        f.robots: f.value
        for f in figures(measure="communication_mb", algorithm="grape-s", statistic="value")
    }
    assert values == {100: 30, 500: 750, 1000: 3000}


def test_figures_rejects_unknown_fields() -> None:
    with pytest.raises(TypeError, match="no field 'colour'"):
        figures(colour="red")
