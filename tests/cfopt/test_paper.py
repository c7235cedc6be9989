"""The seed paper's figures as data: transcribed once, checked here against the paper's
LaTeX (its §5 and §6, verbatim in ``data/seed_sections_5_6.tex``): every quote is the
paper's, at the section the figure names, and every number of those sections is a figure
or is left out with a stated reason."""

from __future__ import annotations

import math
import re
from collections import Counter
from pathlib import Path

import pytest

from cfopt.experiments import distributed_grid
from cfopt.generate import paper_grid
from cfopt.paper import (
    DISAGREEMENTS,
    FIGURES,
    OMITTED,
    RELATIONS,
    Figure,
    figures,
    plain_text,
)

LATEX = (Path(__file__).parent / "data" / "seed_sections_5_6.tex").read_text(encoding="utf-8")
HEADING = re.compile(r"\\(section|subsection|subsubsection)\*?\{([^}]*)\}")
NUMBER = re.compile(r"\d[\d,]*(?:\.\d+)?")
MEASURES = {
    "percent_utility", "runtime_s", "communication_mb", "trials", "solved_trials",
    "pairwise_step_ran", "optimal_trials", "cut_trials", "completed_trials", "iterations",
}  # fmt: skip
STATISTICS = {
    "median", "min", "max", "second lowest", "second highest", "every trial", "count",
    "share", "largest cell median", "cell median range", "median difference", "median ratio",
    "spread ratio", "share lower", "growth exponent", "chi2", "H", "p",
}  # fmt: skip
TESTS = {"", "friedman", "conover", "kruskal", "mann-whitney", "wilcoxon"}


def _sections() -> list[tuple[str, str]]:
    """(section number, plain text) of every part of the excerpt; it starts at §5."""
    parts, counters, number = [], [4, 0, 0], ""
    position = 0
    for match in HEADING.finditer(LATEX):
        parts.append((number, plain_text(LATEX[position : match.start()])))
        depth = ("section", "subsection", "subsubsection").index(match[1])
        counters[depth] += 1
        counters[depth + 1 :] = [0] * (2 - depth)
        number = "§" + ".".join(str(c) for c in counters[: depth + 1])
        position = match.end()
    parts.append((number, plain_text(LATEX[position:])))
    return [(n, text) for n, text in parts if n]


SECTIONS = _sections()


def _places(quote: str) -> list[tuple[str, int]]:
    """(section, offset) of every occurrence of a quote."""
    return [
        (number, m.start())
        for number, text in SECTIONS
        for m in re.finditer(re.escape(quote), text)
    ]


def _value(token: str) -> float:
    return float(token.rstrip(",").replace(",", ""))


def _numbers(text: str) -> set[float]:
    return {_value(t) for t in NUMBER.findall(text)}


def _accounts_for(f: Figure) -> set[float]:
    """The numbers of its quote a figure stands for: its value as printed, its cells, the
    test's n and p."""
    out = _numbers(f.printed) | _numbers(f.p) | {f.value}
    out |= set(f.robots or ()) | set(f.percent_tasks or ())
    out |= {x for c in f.compositions or () for x in c}
    out |= {x for cell in f.excluding for x in cell}
    out |= {_value(g) for g in (*f.groups, *f.pair) if NUMBER.fullmatch(g)}
    if f.n is not None:
        out.add(f.n)
    return out


def test_the_excerpt_is_sections_5_and_6() -> None:
    numbers = [n for n, _ in SECTIONS]
    assert numbers[0] == "§5" and "§5.1.3" in numbers and numbers[-1] == "§6.2"
    assert LATEX.count(r"\begin{table}") == 5  # the paper's Tables 1 to 5


def test_every_quote_is_the_papers_at_its_section() -> None:
    for f in FIGURES:
        places = _places(f.quote)
        assert len(places) == 1, (f.quote, places)
        assert places[0][0] == f.section, (f.quote, places[0][0], f.section)
        if f.direction_quote:
            assert _places(f.direction_quote), f.direction_quote
    for d in DISAGREEMENTS:
        for part in d.other_quote.split(" ... "):
            assert [n for n, _ in _places(part)] == [d.other_section], part
    for o in OMITTED:
        assert _places(o.quote), o.quote


def test_every_number_of_sections_5_and_6_is_a_figure_or_left_out_with_a_reason() -> None:
    spans: dict[str, list[tuple[int, int, set[float]]]] = {n: [] for n, _ in SECTIONS}
    for f in FIGURES:
        ((number, start),) = _places(f.quote)
        spans[number].append((start, start + len(f.quote), _accounts_for(f)))
    for o in OMITTED:
        assert o.reason and o.numbers, o
        for number, start in _places(o.quote):
            spans[number].append((start, start + len(o.quote), set(o.numbers)))
    missing = []
    for number, text in SECTIONS:
        for m in NUMBER.finditer(text):
            value = _value(m[0])
            if not any(a <= m.start() < b and value in covered for a, b, covered in spans[number]):
                missing.append(
                    f"{number}: {m[0]!r} in ...{text[max(0, m.start() - 60) : m.end() + 30]}..."
                )
    assert not missing, "\n".join(missing)


def test_the_omitted_numbers_are_in_their_quotes() -> None:
    for o in OMITTED:
        assert set(o.numbers) <= _numbers(o.quote), o


def test_every_figure_is_well_formed() -> None:
    for f in FIGURES:
        assert f.evaluation in ("centralized", "distributed"), f
        assert f.section.startswith("§") and f.quote and f.printed, f
        assert f.measure in MEASURES and f.statistic in STATISTICS, f
        assert f.relation in RELATIONS and f.test in TESTS, f
        assert f.value >= 0 and math.isfinite(f.value), f
        if f.test:
            assert f.factor and f.significant is not None and (f.groups or f.pair), f
            assert f.trend in ("", "increases", "decreases"), f
            assert not f.lowest or f.lowest in (*f.groups, *f.pair), f
        if f.test in ("conover",) or (f.test == "mann-whitney" and f.pair):
            assert len(f.pair) == 2, f


def test_every_figure_covers_cells_of_its_grid() -> None:
    grids = {"centralized": paper_grid(), "distributed": distributed_grid()}
    for f in FIGURES:
        covered = [
            c
            for c in grids[f.evaluation]
            if f.covers(c.robots, c.percent_tasks, c.service_types, c.services_per_robot)
        ]
        assert covered, f


@pytest.mark.parametrize(
    ("table", "evaluation", "rows"),
    [("Table 2", "centralized", 6), ("Table 4", "distributed", 4), ("Table 5", "distributed", 20)],
)
def test_utility_tables_have_the_papers_layout(table: str, evaluation: str, rows: int) -> None:
    entries = figures(table=table)
    assert {f.evaluation for f in entries} == {evaluation}
    by_row = Counter((f.compositions, f.percent_tasks, f.robots) for f in entries)
    assert len(by_row) == rows and set(by_row.values()) == {3}
    for key in by_row:
        stats = {
            f.statistic: f.value
            for f in entries
            if (f.compositions, f.percent_tasks, f.robots) == key
        }
        assert set(stats) == {"median", "min", "max"}
        assert 0 <= stats["min"] <= stats["median"] <= stats["max"] <= 100, key


def test_table_values_as_printed_in_the_paper() -> None:
    def row(table, comp, p, n):
        got = {f.statistic: f.value for f in figures(table=table, compositions=(comp,),
               percent_tasks=(p,), robots=(n,))}  # fmt: skip
        return got["median"], got["min"], got["max"]

    assert row("Table 2", (10, 5), 10.0, 100) == (100.0, 89.68, 100.0)
    assert row("Table 4", (10, 5), 10.0, 500) == (100.0, 96.7, 100.0)
    assert row("Table 5", (5, 1), 50.0, 500) == (3.9, 1.6, 8.2)
    assert row("Table 5", (10, 5), 50.0, 500) == (4.5, 2.4, 27.4)
    # the captions' 1 %-task rows: 100 % (the paper's Tables 2 and 4)
    for caption in ("Table 2 caption", "Table 4 caption"):
        ones = figures(table=caption, percent_tasks=(1.0,))
        assert [(f.statistic, f.value) for f in ones] == [("min", 100.0)]


def test_figures_the_issue_listed_as_omitted_are_there() -> None:
    def printed(**where):
        return [f.printed for f in figures(**where)]

    assert "<=7 min 18 s" in printed(algorithm="grape-s", statistic="second highest")
    assert printed(statistic="median difference") == ["<10 s"]
    h = {f.value for f in FIGURES if f.statistic == "H"}
    assert {132.46, 65.29, 133.39, 99.87, 231.92, 364.20, 16.12} <= h
    assert 116.42 in {f.value for f in FIGURES if f.statistic == "chi2"}
    assert printed(algorithm="sda", robots=(1000,), compositions=((10, 5),), statistic="min")
    assert "~ 2x" in printed(statistic="median ratio", algorithm="grape-s")
    ranges = {(f.statistic, f.value) for f in figures(algorithm="rachna-dt", measure="runtime_s")}
    assert ("max", 3300.0) in ranges and ("median", 300.0) in ranges
    assert ("max", 3420.0) in {(f.statistic, f.value) for f in figures(algorithm="sda")}
    rachna_mb = figures(evaluation="centralized", algorithm="rachna-dt", measure="communication_mb")
    assert len(rachna_mb) == 12  # 5:1: < 100, < 400, > 1,800, < 200, > 1,200; 5:5: 4; 10:5: 3
    assert printed(algorithm="sda", measure="communication_mb", statistic="median") == [
        "<500 MB for most"
    ]
    assert "96.07%" in printed(statistic="second lowest")
    assert {"<= 110 MB", "45-110 GB"} <= set(printed(evaluation="distributed",
                                                     algorithm="pair-grape-s"))  # fmt: skip
    assert printed(statistic="count", threshold=(180.0, 240.0)) == ["three trials had 3-4 min"]
    assert printed(measure="completed_trials") == ["no trial"]
    tests = Counter(f.test for f in FIGURES if f.test)
    assert tests["conover"] >= 20 and tests["mann-whitney"] >= 30 and tests["wilcoxon"] == 3


def test_the_paper_disagrees_with_itself_three_times() -> None:
    assert [d.figure.printed for d in DISAGREEMENTS] == ["8 min 17 s", "O(n^3)", "364.2"]
    sizes = [f for f in FIGURES if f.curve]
    slope = math.log(sizes[-1].value / sizes[0].value) / math.log(10)
    assert round(slope, 2) == 2.0  # 30 -> 3,000 MB over 100 -> 1000 robots: n^2, not n^3
    # the Kruskal-Wallis H cannot exceed N - 1: of all the paper's H, only 364.20 does
    over = []
    for f in FIGURES:
        if f.statistic == "H":
            grid = paper_grid() if f.evaluation == "centralized" else distributed_grid()
            trials = 25 * sum(f.covers(c.robots, c.percent_tasks, c.service_types,
                                       c.services_per_robot) for c in grid)  # fmt: skip
            if f.value > trials - 1:
                over.append(f.value)
    assert over == [364.20]


def test_figures_rejects_unknown_fields() -> None:
    with pytest.raises(TypeError, match="no field 'colour'"):
        figures(colour="red")
