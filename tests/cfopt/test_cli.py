"""The ``cfopt`` command line: generate, validate, help, and the error convention."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from cfopt import Mission
from cfopt.cli import build_parser, main
from tests.cfopt.test_mission import MALFORMED, write_case


def cfopt(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "cfopt", *args], capture_output=True, text=True, input=stdin
    )


def assert_one_error_line(result: subprocess.CompletedProcess, fragment: str) -> None:
    assert result.returncode == 2, result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("error: ")
    assert fragment in lines[0]
    assert "Traceback" not in result.stderr
    assert result.stdout == ""


@pytest.mark.parametrize(("content", "fragment"), MALFORMED)
def test_validate_rejects_malformed_missions_with_one_error_line(
    tmp_path, capsys, content, fragment
) -> None:
    path = write_case(tmp_path, content)
    assert main(["validate", path]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and err.startswith(f"error: {path}: ")
    assert fragment in err


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        pytest.param(
            ["validate", "/nonexistent/m.json"],
            "/nonexistent/m.json: no such file",
            id="missing-file",
        ),
        pytest.param(["validate", "."], ".: is a directory", id="directory"),
        pytest.param(
            [
                "generate",
                "--robots",
                "x",
                "--percent-tasks",
                "1",
                "--service-types",
                "1",
                "--services-per-robot",
                "1",
            ],
            "argument --robots: must be a whole number",
            id="bad-number",
        ),
        pytest.param(
            ["generate", "--robots", "10"],
            "the following arguments are required",
            id="missing-options",
        ),
        pytest.param(
            [
                "generate",
                "--robots",
                "10",
                "--percent-tasks",
                "10",
                "--service-types",
                "2",
                "--services-per-robot",
                "3",
            ],
            "--services-per-robot: must be",
            id="k-over-s",
        ),
        pytest.param(["frobnicate"], "invalid choice: 'frobnicate'", id="unknown-command"),
        pytest.param([], "the following arguments are required: COMMAND", id="no-command"),
    ],
)
def test_usage_and_file_errors_exit_2_without_traceback(args, fragment) -> None:
    assert_one_error_line(cfopt(*args), fragment)


def test_validate_from_stdin_through_a_real_process(tmp_path) -> None:
    text = Mission.from_arrays([[1]], [[1]], [3.0]).to_json()
    result = cfopt("validate", "-", stdin=text)
    assert result.returncode == 0
    assert result.stdout == "ok: 1 robot, 1 task, 1 service\n"
    broken = cfopt("validate", "-", stdin=text.replace('"utility": 3', '"utility": -3'))
    assert_one_error_line(broken, "<stdin>: tasks[0].utility: must be a finite number >= 0, got -3")


def test_validate_json_output(tmp_path, capsys) -> None:
    path = tmp_path / "m.json"
    Mission.from_arrays([[1, 0], [0, 1]], [[1, 1]], [4.5]).to_json(path)
    assert main(["validate", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out == {"valid": True, "robots": 2, "tasks": 1, "services": 2, "total_utility": 4.5}


def test_generate_writes_a_file_and_never_overwrites_without_force(tmp_path, capsys) -> None:
    path = tmp_path / "m.json"
    args = [
        "generate",
        "--robots",
        "30",
        "--percent-tasks",
        "10",
        "--service-types",
        "5",
        "--services-per-robot",
        "2",
        "--seed",
        "3",
        "-o",
        str(path),
    ]
    assert main(args) == 0
    first = path.read_text()
    assert Mission.from_json(path).n_robots == 30
    path.write_text("precious")
    assert main(args) == 2
    assert "already exists" in capsys.readouterr().err
    assert path.read_text() == "precious"
    assert main([*args, "--force"]) == 0
    assert path.read_text() == first


def test_generate_to_stdout_then_validate(capsys) -> None:
    assert (
        main(
            [
                "generate",
                "--robots",
                "100",
                "--percent-tasks",
                "50",
                "--service-types",
                "10",
                "--services-per-robot",
                "5",
                "--seed",
                "0",
            ]
        )
        == 0
    )
    mission = Mission.from_dict(json.loads(capsys.readouterr().out))
    assert (mission.n_robots, mission.n_tasks, mission.n_services) == (100, 50, 10)


def test_help_describes_every_option() -> None:
    parser = build_parser()
    top = parser.format_help()
    subparsers = next(a for a in parser._actions if a.dest == "command")
    for name, sub in subparsers.choices.items():
        assert name in top
        text = sub.format_help()
        for action in sub._actions:
            if action.option_strings and action.dest != "help":
                assert action.help, f"cfopt {name} {action.option_strings[0]} has no help text"
                assert action.option_strings[-1] in text
    result = cfopt("generate", "--help")
    assert result.returncode == 0 and "--services-per-robot" in result.stdout


def test_version() -> None:
    result = cfopt("--version")
    assert result.returncode == 0 and result.stdout.startswith("cfopt ")
