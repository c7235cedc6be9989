"""``cfopt solve``: output keys, human output, and the exit-code convention."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import pytest

import cfopt
from cfopt import Assignment, Mission
from cfopt.cli import main
from tests.cfopt.test_exact import brute_force_optimum, independent_utility

SOLVE_KEYS = {"status", "utility", "bound", "gap", "total_utility", "seconds", "assignment"}


@pytest.fixture
def mission_file(tmp_path: Path) -> tuple[Mission, str]:
    mission = cfopt.generate_mission(12, 30, 4, 2, load=1.5, seed=2)
    path = tmp_path / "mission.json"
    mission.to_json(path)
    return mission, str(path)


@pytest.mark.parametrize("formulation", ["aggregated", "assignment"])
def test_solve_json_prints_one_object_with_the_interface_keys(
    mission_file: tuple[Mission, str], capsys: pytest.CaptureFixture[str], formulation: str
) -> None:
    mission, path = mission_file
    assert main(["solve", path, "--json", "--formulation", formulation]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert out.count("\n") == 1
    data = json.loads(out)
    assert set(data) >= SOLVE_KEYS
    assert data["status"] == "optimal"
    assert data["utility"] == pytest.approx(brute_force_optimum(mission))
    assert data["bound"] == pytest.approx(data["utility"])
    assert data["total_utility"] == pytest.approx(mission.total_utility)
    assert all(set(row) == {"robot", "task", "service"} for row in data["assignment"])
    robots = [row["robot"] for row in data["assignment"]]
    assert robots == sorted(robots, key=mission.robot_ids.index)  # mission order
    chosen = Assignment.from_dict(mission, {"assignment": data["assignment"]})
    assert independent_utility(mission, chosen) == pytest.approx(data["utility"])


def test_solve_human_output_is_a_summary_then_the_assignment_file(
    mission_file: tuple[Mission, str], capsys: pytest.CaptureFixture[str]
) -> None:
    mission, path = mission_file
    assert main(["solve", path, "--time-limit", "30"]) == 0
    out, _ = capsys.readouterr()
    summary, _, rest = out.partition("\n")
    assert summary.startswith("optimal: utility ")
    for word in ("bound", "gap", " s "):
        assert word in summary
    document = json.loads(rest)
    assert document["format"] == "cfopt.assignment/1"
    chosen = Assignment.from_dict(mission, document)
    assert independent_utility(mission, chosen) == pytest.approx(brute_force_optimum(mission))


def test_solve_reads_stdin(
    mission_file: tuple[Mission, str],
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    _, path = mission_file
    monkeypatch.setattr(sys, "stdin", io.StringIO(Path(path).read_text(encoding="utf-8")))
    assert main(["solve", "-", "--json"]) == 0
    assert set(json.loads(capsys.readouterr().out)) >= SOLVE_KEYS


_EMPTY = '{"services": ["a"], "robots": [], "tasks": []}'
BAD_INPUT = [
    pytest.param("{", [], "not valid JSON", id="bad-json"),
    pytest.param(
        '{"services": ["a"], "robots": [], "tasks": [{"id": "t0", "utility": -1, '
        '"requires": {"a": 1}}]}',
        [],
        "tasks[0].utility: must be a finite number >= 0",
        id="bad-utility",
    ),
    pytest.param(None, [], "no such file", id="missing-file"),
    pytest.param(_EMPTY, ["--time-limit", "0"], "--time-limit", id="zero-time-limit"),
    pytest.param(_EMPTY, ["--time-limit", "soon"], "--time-limit", id="word-time-limit"),
    pytest.param(_EMPTY, ["--formulation", "x"], "--formulation", id="bad-formulation"),
]


@pytest.mark.parametrize(("content", "extra", "fragment"), BAD_INPUT)
def test_solve_bad_input_exits_2_with_one_error_line(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    content: str | None,
    extra: list[str],
    fragment: str,
) -> None:
    path = tmp_path / "m.json"
    if content is not None:
        path.write_text(content, encoding="utf-8")
    try:
        code = main(["solve", str(path), "--json", *extra])
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    out, err = capsys.readouterr()
    assert code == 2
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert fragment in lines[0]
    assert out == ""


def test_solve_bad_file_in_a_real_process_has_no_traceback(tmp_path: Path) -> None:
    path = tmp_path / "m.json"
    path.write_text('{"services": ["a"], "robots": [{"id": "r0"}], "tasks": []}', "utf-8")
    result = subprocess.run(
        [sys.executable, "-m", "cfopt", "solve", str(path), "--json"],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2, result.stderr
    assert result.stderr.startswith(f"error: {path}: robots[0]")
    assert result.stderr.count("\n") == 1
    assert "Traceback" not in result.stderr
    assert result.stdout == ""
