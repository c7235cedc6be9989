"""The report's first screen, its figures' styles and its pooling warning (issue 24)."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import matplotlib
import pytest
from matplotlib.colors import to_hex

from cfopt import Assignment, generate_mission
from cfopt.cli import main
from cfopt.report import (
    HEADLINE_FIGURE,
    algorithm_styles,
    cell_table,
    figures,
    label_variants,
    plain_markup,
    summary_text,
    write_report,
)
from cfopt.store import Trial
from heuristics.registry import ALGORITHMS
from proofs.claimkit import Counterexample, Scope, Verdict, VerdictKind
from proofs.claims import write_counterexamples

matplotlib.use("Agg")


def _trial(**values) -> Trial:
    base = dict(
        cell="c", robots=20, percent_tasks=10.0, service_types=5, services_per_robot=1,
        load=1.0, mission_index=0, base_seed=0, mission_seed=0, tasks=10, total_utility=100.0,
        algorithm="grape-s", code_version="v", utility=90.0, optimum=100.0,
        optimum_bound=100.0, optimum_status="optimal", percent_optimum=90.0,
        percent_total=90.0, iterations=1, rounds=2, messages=10, bytes=1000, work=5,
        seconds=0.1, nash_stable=True, nash_stable_capped=True, pairwise_stable=True,
        pairwise_stable_capped=True, pareto_stable=False, pairwise_step_ran=None,
        algorithm_seed=0, finished=0.0,
    )  # fmt: skip
    base.update(values)
    return Trial(**base)


ALL = [*ALGORITHMS, "my-algorithm"]
NET = "complete,latency=0.001"


def _grid(per_algorithm: dict[str, int] | None = None) -> list[Trial]:
    """Every registered algorithm, a user's, and three distributed variants, on two loads
    and two compositions (``per_algorithm``: trials per mission count override)."""
    out = []
    for load, robots in ((1.0, 20), (1.25, 24)):
        for s, k in ((5, 1), (10, 2)):
            cell = f"n={robots} {s}:{k} load={load:g}"
            for i in range(3):
                common = dict(cell=cell, robots=robots, service_types=s, load=load)
                common.update(services_per_robot=k, mission_seed=i)
                out.append(_trial(algorithm="exact", percent_optimum=100.0, **common))
                for j, a in enumerate(ALL):
                    if per_algorithm is not None and i >= per_algorithm.get(a, 3):
                        continue
                    value = 60.0 + 3 * j + i
                    out.append(_trial(algorithm=a, percent_optimum=value, **common))
                    if a in ("grape-s", "pair-grape-s", "sda"):
                        out.append(
                            _trial(algorithm=a, network=NET, percent_optimum=value - 5,
                                   sim_seconds=0.5, **common)
                        )  # fmt: skip
    return label_variants(out)


# ------------------------------------------------------------------------- styles
def test_every_series_has_its_own_style_from_one_rule() -> None:
    names = [*ALL, *(f"{a} (distributed)" for a in ALL), *(f"user-{i}" for i in range(30))]
    styles = algorithm_styles(names)
    assert set(names) <= set(styles)
    pairs = [(s.colour.lower(), s.hatch) for s in styles.values()]
    assert len(set(pairs)) == len(pairs)
    # fixed by the registry: what else is drawn does not move an algorithm's style
    assert algorithm_styles()["grape-s"] == styles["grape-s"]
    assert algorithm_styles(["zzz"])["sda"] == styles["sda"]
    # a distributed variant is a lighter shade of its algorithm's colour, with a hatch
    own, variant = styles["sda"], styles["sda (distributed)"]
    assert variant.edge == own.edge and variant.hatch and variant.colour != own.colour


def _legend_entries(fig) -> list[tuple[str, tuple[str, str]]]:
    (legend,) = fig.legends
    texts = [t.get_text() for t in legend.get_texts()]
    handles = legend.legend_handles
    assert len(texts) == len(handles)
    return [
        (t, (to_hex(h.get_facecolor()), h.get_hatch() or ""))
        for t, h in zip(texts, handles, strict=True)
    ]


def test_every_figure_has_distinct_labelled_styles_and_a_whole_legend() -> None:
    import matplotlib.pyplot as plt

    trials = _grid()
    styles = algorithm_styles(t.algorithm for t in trials)
    seen: dict[str, tuple[str, str]] = {}
    names = []
    for name, fig in figures(trials):
        names.append(name)
        entries = _legend_entries(fig)
        assert entries and all(label.strip() for label, _ in entries), name
        drawn = [style for _, style in entries]
        assert len(set(drawn)) == len(drawn), name  # no two series share a style
        for label, style in entries:
            assert seen.setdefault(label, style) == style, (name, label)  # same in every figure
            assert style == (to_hex(styles[label].colour), styles[label].hatch)
        boxes = {
            (to_hex(p.get_facecolor()), p.get_hatch() or "") for ax in fig.axes for p in ax.patches
        }
        assert boxes and boxes <= set(drawn), name  # every box is drawn in a legend style
        fig.canvas.draw()
        box, whole = fig.legends[0].get_window_extent(), fig.bbox
        assert box.x0 >= whole.x0 - 1 and box.x1 <= whole.x1 + 1, name  # never clipped
        assert box.y0 >= whole.y0 - 1, name
        plt.close(fig)
    assert names[0] == HEADLINE_FIGURE and "fig_sim_seconds_load1.png" in names
    assert "my-algorithm" in seen and "sda (distributed)" in seen


# ------------------------------------------------------------------------ pooling
def test_pooled_trial_counts_are_labelled_and_warned() -> None:
    trials = _grid({"pair-grape-s": 1})
    text = summary_text(trials)
    assert "warning: the algorithms ran on different numbers of trials" in text
    assert "pair-grape-s: 2" in text and "grape-s: 6" in text
    assert max(len(line) for line in text.splitlines()) <= 100
    _, rows = cell_table(trials, "percent_optimum")
    assert all("(n=1)" in r[4:][sorted({t.algorithm for t in trials} - {"exact"}).index(
        "pair-grape-s")] for r in rows)  # fmt: skip
    assert "warning" not in summary_text(_grid())
    assert not any("(n=" in c for r in cell_table(_grid(), "percent_optimum")[1] for c in r)


# ---------------------------------------------------------------- the first screen
def _verdicts() -> list[Verdict]:
    m = generate_mission(4, 50, 2, 1, seed=0)
    holds = Verdict(
        "ZZ9", "a user's claim about :func:`heuristics.sda`", VerdictKind.HOLDS, 5, None, 0.1,
        scope=Scope.PAPER_SIZES,
    )  # fmt: skip
    fails = Verdict(
        "L1", "GRAPE-S ends ``Nash stable``", VerdictKind.FAILS, 5,
        Counterexample(m, Assignment.empty(m), "grape-s", "r2: t1/s1 -> t2/s2"), 0.1, "fake",
    )  # fmt: skip
    return [holds, fails]


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("layout") / "report"
    out.mkdir()
    verdicts = _verdicts()
    files = write_counterexamples(verdicts, out / "counterexamples")
    write_report(_grid({"pair-grape-s": 1}), out, claims=verdicts, claim_files=files)
    return out


def test_first_screen_is_the_verdicts_then_the_headline(report_dir: Path) -> None:
    md = (report_dir / "report.md").read_text(encoding="utf-8")
    order = [md.index(s) for s in ("## Claims: verdicts", HEADLINE_FIGURE, "## Summary")]
    assert order == sorted(order)
    assert md.index("| L1 | fails |") < md.index("| ZZ9 | holds |")  # failures first
    assert "L1 is the seed paper's" in md and "ZZ9 is yours" in md
    assert "Claims of the seed paper" not in md
    assert "r2: t1/s1 -> t2/s2" in md
    assert "[L1.mission.json](counterexamples/L1.mission.json)" in md
    assert "`cfopt check counterexamples/L1.mission.json counterexamples/L1.assignment.json`" in md
    assert ":func:" not in md and "``" not in md and "`heuristics.sda`" in md
    page = (report_dir / "report.html").read_text(encoding="utf-8")
    assert '<a href="counterexamples/L1.mission.json">L1.mission.json</a>' in page
    assert '<td class="fails">fails</td>' in page and ":func:" not in page
    assert page.index("Claims: verdicts") < page.index("<h2>Summary</h2>")
    with (report_dir / "claims.csv").open(encoding="utf-8") as handle:
        rows = {r["id"]: r for r in csv.DictReader(handle)}
    assert rows["L1"]["violation"] == "r2: t1/s1 -> t2/s2" and rows["L1"]["source"] == "seed paper"
    assert rows["L1"]["replay"].startswith("cfopt check counterexamples/L1.mission.json ")
    assert ":func:" not in rows["ZZ9"]["statement"]


def test_the_replay_line_runs_where_the_report_is(
    report_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    md = (report_dir / "report.md").read_text(encoding="utf-8")
    line = re.search(r"`(cfopt check [^`]+)`", md).group(1)
    monkeypatch.chdir(report_dir)
    assert main(line.split()[1:]) == 0


def test_tables_fit_and_say_what_mb_is(report_dir: Path) -> None:
    page = (report_dir / "report.html").read_text(encoding="utf-8")
    assert 'name="viewport"' in page
    assert page.count("<table>") == page.count('<div class="wrap"><table>')  # scroll inside only
    assert "overflow-wrap:anywhere" in page
    summary = page[page.index("<h2>Summary</h2>") :]
    head = re.search(r"<thead><tr>(.*?)</tr></thead>", summary).group(1)
    columns = re.findall(r"<th>(.*?)</th>", head)
    assert "missions" not in columns  # one table per load, under its heading
    assert columns.index("Nash stable") == columns.index("optimal") + 1  # seen early
    assert "communication (MB): median (max)" in columns
    assert '<p class="warning">warning: the algorithms ran on different numbers' in page


def test_plain_markup() -> None:
    assert plain_markup(":func:`heuristics.sda` and :class:`~cfopt.Mission`") == (
        "`heuristics.sda` and `cfopt.Mission`"
    )
