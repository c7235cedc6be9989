"""The ``cfopt_audit`` pytest plugin, run in a child pytest with ``pytester``."""

from __future__ import annotations

import json
import re

import pytest

import cfopt
from cfopt.cli import main

USER_TESTS = """
import cfopt
from hypothesis import strategies as st
from proofs._dynamics import best_response
from proofs.strategies import missions


def stable(mission):
    return best_response(mission)


def capped_stable(mission):
    return best_response(mission, capped=True)


def nobody(mission):
    return cfopt.Assignment.empty(mission)


def not_an_assignment(mission):
    return {"assignment": []}


def test_stable_passes(cfopt_audit):
    cfopt_audit(stable, max_examples=25)


def test_stable_passes_pairwise_strict(cfopt_audit):
    cfopt_audit(stable, max_examples=25, pairwise=True)


def test_broken_fails(cfopt_audit):
    cfopt_audit(nobody, max_examples=50)


def test_capped_fails_pareto(cfopt_audit):
    # capped best response leaves r3 out; r0 could move to t1 at the same load and let r3
    # take its place: a Pareto (not strict) pairwise deviation
    m = cfopt.Mission.from_arrays([[1, 1], [0, 1], [1, 0], [1, 0]], [[2, 0], [0, 2]], [1, 1])
    cfopt_audit(capped_stable, capped=True, pairwise=True, mode="strict", missions=st.just(m))
    cfopt_audit(capped_stable, capped=True, pairwise=True, mode="pareto", missions=st.just(m))


def test_wrong_type_fails(cfopt_audit):
    cfopt_audit(not_an_assignment, max_examples=5)


def test_idle_robots_pass_without_nash(cfopt_audit):
    cfopt_audit(nobody, max_examples=10, nash=False)
"""


def _section(text: str, test: str) -> str:
    start = text.index(f"_ {test} _")
    rest = text[start + 1 :]
    end = re.search(r"\n_{3,} test_\w+ _{3,}|\n=+ short test summary", rest)
    return rest[: end.start()] if end else rest


def _replay(capsys, text, *flags):
    (paths,) = set(
        re.findall(r"replay: cfopt check (\S+mission\.json) (\S+assignment\.json)", text)
    )
    capsys.readouterr()
    assert main(["check", *paths, *flags, "--json"]) == 0
    return paths, json.loads(capsys.readouterr().out)


def test_plugin_passes_stable_and_fails_broken_heuristics(pytester, capsys):
    pytester.makepyfile(test_user=USER_TESTS)
    outcome = pytester.runpytest("-p", "no:cacheprovider")
    outcome.assert_outcomes(passed=3, failed=3)
    text = outcome.stdout.str()

    # the broken heuristic: shrunk to one robot, one service, one task needing one robot
    broken = _section(text, "test_broken_fails")
    assert "cfopt_audit: nobody: the partition is not Nash stable" in broken
    # the report shows the user's call, then the failure: none of the plugin's own source
    assert "self._fail(" not in broken and "def _check" not in broken
    errors = [line for line in broken.splitlines() if line.startswith("E ")]
    assert "the partition is not Nash stable" in errors[0]
    assert "replay: cfopt check" in errors[2]
    assert "r0: - -> t0/s0" in broken
    assert '"requires": {"s0": 1}' in broken
    (mission_path, _), report = _replay(capsys, broken)
    mission = cfopt.Mission.from_json(mission_path)
    assert (mission.n_robots, mission.n_tasks, mission.n_services) == (1, 1, 1)
    assert mission.requirements.tolist() == [[1]] and mission.capabilities.tolist() == [[True]]
    assert report["nash_stable"] is False
    assert report["nash_violations"] == [
        {"robot": "r0", "from": None, "to": {"task": "t0", "service": "s0"}}
    ]

    # strict passes, pareto fails with a joint deviation that `cfopt check` replays
    pareto = _section(text, "test_capped_fails_pareto")
    assert "is not pairwise stable (pareto) (capped moves)" in pareto
    assert "r0: t0/s0 -> t1/s1 & r3: - -> t0/s0" in pareto
    _, report = _replay(capsys, pareto, "--capped")
    assert report["nash_stable"] is True and report["pairwise_stable"] is True
    assert report["pareto_stable"] is False

    wrong = _section(text, "test_wrong_type_fails")
    assert "returned dict, not a cfopt.Assignment" in wrong


GAP_TESTS = """
import cfopt
from hypothesis import strategies as st

ONE = cfopt.Mission.from_arrays([[1]], [[1]], [10.0])  # the first task only: 100 %
EVEN = cfopt.Mission.from_arrays([[1], [1]], [[1], [1]], [10.0, 10.0])  # 50 %
WORST = cfopt.Mission.from_arrays([[1], [1]], [[1], [1]], [10.0, 30.0])  # 25 %


def optimum(mission):
    return cfopt.solve_exact(mission).assignment


def first_task_only(mission):
    best = optimum(mission)
    keep = best.task == 0
    return cfopt.Assignment(task=best.task * keep - ~keep, service=best.service * keep - ~keep)


def test_the_optimum_passes(cfopt_audit):
    cfopt_audit(optimum, nash=False, min_percent=95, max_examples=20)


def test_the_worst_mission_is_shown(cfopt_audit):
    missions = st.sampled_from([ONE, EVEN, WORST])
    cfopt_audit(first_task_only, nash=False, min_percent=95, missions=missions)


def test_a_lower_bar_passes(cfopt_audit):
    missions = st.sampled_from([ONE, EVEN, WORST])
    cfopt_audit(first_task_only, nash=False, min_percent=25, missions=missions)


def test_without_min_percent_no_gap_is_measured(cfopt_audit):
    cfopt_audit(first_task_only, nash=False, missions=st.sampled_from([EVEN, WORST]))
"""


def test_plugin_measures_the_gap_to_the_optimum(pytester, capsys):
    pytester.makepyfile(test_gap=GAP_TESTS)
    outcome = pytester.runpytest("-p", "no:cacheprovider")
    outcome.assert_outcomes(passed=3, failed=1)
    text = _section(outcome.stdout.str(), "test_the_worst_mission_is_shown")
    found = re.search(
        r"cfopt_audit: first_task_only: the partition earns (\S+) of the optimum (\S+) "
        r"\(([\d.]+) % < 95 %\) on the worst of the missions drawn",
        text,
    )
    assert found, text
    (mission_path, assignment_path), report = _replay(capsys, text)
    mission = cfopt.Mission.from_json(mission_path)
    assert mission.utilities.tolist() == [10.0, 30.0]  # the worst of the three
    assignment = cfopt.Assignment.from_json(mission, assignment_path)
    optimum = cfopt.solve_exact(mission).utility
    percent = 100 * assignment.utility(mission) / optimum
    assert percent == pytest.approx(float(found.group(3))) == pytest.approx(25.0)
    assert float(found.group(1)) == report["utility"] == 10.0 and float(found.group(2)) == 40.0
    assert f"optimum: cfopt solve {mission_path}" in text
    assert main(["solve", mission_path, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["utility"] == optimum


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        pytest.param({"heuristic": 3}, TypeError, "heuristic: must be callable", id="heuristic"),
        pytest.param({"mode": "weak"}, ValueError, "mode: must be one of", id="mode"),
        pytest.param({"max_examples": 0}, ValueError, "max_examples: must be", id="examples"),
        pytest.param({"capped": "yes"}, TypeError, "capped: must be a bool", id="capped"),
        pytest.param({"nash": 1}, TypeError, "nash: must be a bool", id="nash"),
        pytest.param({"seed": 1.5}, TypeError, "seed: must be a whole number", id="seed"),
        pytest.param({"min_percent": 0}, ValueError, "min_percent: must be", id="percent"),
        pytest.param({"min_percent": 101}, ValueError, "min_percent: must be", id="above"),
        pytest.param({"min_percent": "95"}, TypeError, "min_percent: must be", id="text"),
    ],
)
def test_bad_arguments(cfopt_audit, kwargs, error, match):
    heuristic = kwargs.pop("heuristic", cfopt.Assignment.empty)
    with pytest.raises(error, match=match):
        cfopt_audit(heuristic, **kwargs)
