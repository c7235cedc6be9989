"""``cfopt check MISSION ASSIGNMENT [--capped] [--json]``."""

from __future__ import annotations

import json
import re

import pytest

import cfopt
from cfopt.cli import main

KEYS = {
    "valid",
    "utility",
    "total_utility",
    "nash_stable",
    "nash_violations",
    "pairwise_stable",
    "pairwise_violations",
}


@pytest.fixture
def files(tmp_path):
    # the Pair-GRAPE-S situation (see test_stability.test_capped_and_uncapped_differ)
    m = cfopt.Mission.from_arrays([[1, 0], [1, 1], [0, 1]], [[1, 0], [0, 2]], [5.0, 7.0])
    a = cfopt.Assignment(task=[-1, 0, 1], service=[-1, 0, 1])
    mp, ap = tmp_path / "m.json", tmp_path / "a.json"
    m.to_json(mp)
    a.to_json(m, ap)
    return str(mp), str(ap)


def _json(capsys, *argv):
    assert main(["check", *argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_json_keys_and_values(files, capsys):
    out = _json(capsys, *files)
    assert set(out) >= KEYS
    assert out["valid"] is True
    assert (out["utility"], out["total_utility"]) == (5.0, 12.0)
    assert out["nash_stable"] is False  # uncapped: r0 can crowd t0
    assert out["nash_violations"] == [
        {"robot": "r0", "from": None, "to": {"task": "t0", "service": "s0"}}
    ]
    assert out["pairwise_stable"] is False
    assert out["pairwise_violations"][0] == {
        "robots": ["r0"],
        "moves": out["nash_violations"],
        "kind": "individual",
    }


def test_capped(files, capsys):
    out = _json(capsys, *files, "--capped")
    assert out["nash_stable"] is True and out["nash_violations"] == []
    assert out["pairwise_stable"] is True and out["pairwise_violations"] == []
    assert out["pareto_stable"] is False
    assert out["pareto_violations"][0] == {
        "robots": ["r0", "r1"],
        "moves": [
            {"robot": "r0", "from": None, "to": {"task": "t0", "service": "s0"}},
            {"robot": "r1", "from": {"task": "t0", "service": "s0"},
             "to": {"task": "t1", "service": "s1"}},
        ],
        "kind": "joint",
    }  # fmt: skip


def test_human_output(files, capsys):
    assert main(["check", *files, "--capped"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out == [
        "valid: 2 of 3 robots assigned, utility 5 of 12 (41.67%), capped moves",
        "nash stable: yes",
        "pairwise stable (strict): yes",
        "pairwise stable (pareto): no, 2 violations",
        "  r0: - -> t0/s0 & r1: t0/s0 -> t1/s1",
        "  r1: t0/s0 -> t1/s1 & r0: - -> t0/s0",
    ]


def test_long_lists_are_cut_in_human_output(tmp_path, capsys):
    m = cfopt.generate_mission(30, 10, 3, 2, seed=2)
    mp, ap = tmp_path / "m.json", tmp_path / "a.json"
    m.to_json(mp)
    cfopt.Assignment.empty(m).to_json(m, ap)
    assert main(["check", str(mp), str(ap)]) == 0
    out = capsys.readouterr().out
    assert "nash stable: no, 30 violations" in out
    assert "  ... and 20 more (--json lists them all)" in out


@pytest.mark.parametrize(
    ("assignment", "match"),
    [
        pytest.param('{"assignment": [{"robot": "r9", "task": "t0", "service": "s0"}]}',
                     r'assignment\[0\]\.robot: unknown robot "r9"', id="unknown-robot"),
        pytest.param('{"assignment": [{"robot": "r2", "task": "t0", "service": "s0"}]}',
                     "cannot perform", id="incapable"),
        pytest.param("[1, 2", "", id="not-json"),
    ],
)  # fmt: skip
def test_bad_assignment_exits_2(files, tmp_path, capsys, assignment, match):
    bad = tmp_path / "bad.json"
    bad.write_text(assignment)
    assert main(["check", files[0], str(bad)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    (line,) = captured.err.splitlines()
    assert line.startswith(f"error: {bad}: ")
    assert re.search(match, line)


def test_both_from_stdin_is_usage_error(capsys):
    assert main(["check", "-", "-"]) == 2
    assert capsys.readouterr().err.startswith("error: MISSION and ASSIGNMENT cannot both")


def test_missing_argument_is_usage_error(files, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["check", files[0]])
    assert exc.value.code == 2
    assert capsys.readouterr().err.startswith("error:")
