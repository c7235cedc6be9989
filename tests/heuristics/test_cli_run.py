"""``cfopt run ALGORITHM MISSION``."""

from __future__ import annotations

import json

import pytest

from cfopt import Assignment, Mission, generate_mission
from cfopt.cli import main
from heuristics import grape_s, pair_grape_s
from heuristics.registry import algorithm_names


@pytest.fixture
def mission_file(tmp_path):
    m = generate_mission(
        robots=30, percent_tasks=10, service_types=10, services_per_robot=5, seed=4
    )
    path = tmp_path / "m.json"
    m.to_json(path)
    return m, str(path)


@pytest.mark.parametrize(
    ("name", "function"), [("grape-s", grape_s), ("pair-grape-s", pair_grape_s)]
)
def test_run_json_has_the_interface_keys(mission_file, capsys, name, function) -> None:
    m, path = mission_file
    assert main(["run", name, path, "--seed", "5", "--order", "random", "--json"]) == 0
    out, _ = capsys.readouterr()
    data = json.loads(out)
    for key in (
        "algorithm",
        "seed",
        "utility",
        "total_utility",
        "percent_utility",
        "iterations",
        "messages",
        "bytes",
        "seconds",
        "nash_stable",
        "pairwise_stable",
        "assignment",
    ):
        assert key in data
    expected = function(m, seed=5, order="random")
    assert data["algorithm"] == name and data["seed"] == 5
    assert data["iterations"] == expected.iterations and data["bytes"] == expected.bytes
    got = Assignment.from_dict(m, {"assignment": data["assignment"]})
    assert got == expected.assignment
    assert data["utility"] == expected.assignment.utility(m)
    assert isinstance(data["nash_stable"], bool) and isinstance(data["pairwise_stable"], bool)


def test_run_text_output(mission_file, capsys) -> None:
    m, path = mission_file
    assert main(["run", "grape-s", path]) == 0
    out, _ = capsys.readouterr()
    first, second, third, rest = out.split("\n", 3)
    assert first.startswith("grape-s: utility ")
    assert second.startswith("stability under the seed's reward: Nash yes, pairwise (strict)")
    assert "pareto" in second
    assert third == ("stability under its own rule (Nash stable under the seed's reward): yes")
    assert Assignment.from_dict(m, json.loads(rest)) == grape_s(m).assignment


def test_unknown_algorithm_is_one_error_line(mission_file, capsys) -> None:
    _, path = mission_file
    assert main(["run", "grape", path]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    known = ", ".join(algorithm_names())
    assert err == f"error: unknown algorithm 'grape' (known: {known})\n"
    assert "grape-s, pair-grape-s" in known


def test_bad_mission_and_bad_order(tmp_path, capsys) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text('{"services": [], "robots": [], "tasks": []}')
    assert main(["run", "grape-s", str(bad)]) == 2
    _, err = capsys.readouterr()
    assert err.startswith(f"error: {bad}: services") and err.count("\n") == 1
    with pytest.raises(SystemExit) as exc:
        main(["run", "grape-s", str(bad), "--order", "reverse"])
    assert exc.value.code == 2


def test_run_reads_stdin(monkeypatch, capsys) -> None:
    import io

    m = Mission.from_arrays([[1], [1]], [[2]], [3])
    monkeypatch.setattr("sys.stdin", io.StringIO(m.to_json()))
    assert main(["run", "pair-grape-s", "-", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["percent_utility"] == 100.0 and data["pairwise_stable"] is True
